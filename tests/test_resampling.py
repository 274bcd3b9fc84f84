"""N_eff and low-variance resampling."""

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from slam_core.resampling import effective_sample_size, low_variance_resample, normalized


def test_neff_of_uniform_and_degenerate_weights():
    assert effective_sample_size(np.full(30, 1 / 30)) == 30
    w = np.zeros(30)
    w[4] = 1.0
    assert effective_sample_size(w) == 1


def test_normalized_handles_huge_log_weights():
    w = normalized([-1000.0, -1000.0 + np.log(3.0)])
    np.testing.assert_allclose(w, [0.25, 0.75])


@settings(max_examples=200, deadline=None)
@given(st.lists(st.floats(0.0, 1.0), min_size=1, max_size=60).filter(lambda w: sum(w) > 1e-6),
       st.integers(0, 2**32 - 1))
def test_low_variance_copies_each_particle_floor_or_ceil_times(weights, seed):
    w = np.array(weights) / np.sum(weights)
    idx = low_variance_resample(w, np.random.default_rng(seed))
    counts = np.bincount(idx, minlength=len(w))
    expected = len(w) * w
    assert len(idx) == len(w)
    assert np.all(counts >= np.floor(expected - 1e-9))
    assert np.all(counts <= np.ceil(expected + 1e-9))
    assert np.all(np.diff(idx) >= 0)
