import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays
from scipy.ndimage import distance_transform_edt

from slam_core.distance_transform import distance_to_features

grids = st.tuples(st.integers(1, 40), st.integers(1, 40)).flatmap(
    lambda shape: arrays(np.bool_, shape, elements=st.booleans() | st.just(False)))


@settings(max_examples=150, deadline=None)
@given(grids)
def test_edt_equals_scipy(features):
    if not features.any():
        features = features.copy()
        features.flat[len(features.flat) // 2] = True
    np.testing.assert_allclose(distance_to_features(features), distance_transform_edt(~features), rtol=1e-12)


def test_sparse_large_grid_equals_scipy():
    rng = np.random.default_rng(3)
    features = rng.random((300, 257)) < 0.002
    np.testing.assert_allclose(distance_to_features(features), distance_transform_edt(~features))


def test_no_features_is_infinite():
    assert np.all(np.isinf(distance_to_features(np.zeros((4, 5), bool))))


def test_rejects_non_2d():
    with pytest.raises(ValueError, match="2-D"):
        distance_to_features(np.zeros(5, bool))
