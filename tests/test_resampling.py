import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from slam_core.resampling import effective_sample_size, low_variance_resample, normalized

weight_lists = st.lists(st.floats(0.0, 10.0, allow_nan=False), min_size=1, max_size=40).filter(
    lambda w: sum(w) > 1e-6)


@settings(max_examples=200, deadline=None)
@given(weight_lists, st.integers(0, 2**32 - 1))
def test_systematic_counts_are_floor_or_ceil_of_expected(weights, seed):
    w = np.array(weights) / np.sum(weights)
    n = len(w)
    idx = low_variance_resample(w, np.random.default_rng(seed))
    counts = np.bincount(idx, minlength=n)
    expected = n * w
    assert counts.sum() == n
    assert np.all(counts >= np.floor(expected - 1e-9))
    assert np.all(counts <= np.ceil(expected + 1e-9))
    assert np.all(counts[w == 0] == 0)


@settings(max_examples=15, deadline=None)
@given(weight_lists, st.integers(1, 60))
def test_systematic_is_unbiased(weights, n):
    w = np.array(weights) / np.sum(weights)
    rng = np.random.default_rng(1)
    trials = 2000
    counts = np.zeros(len(w))
    for _ in range(trials):
        counts += np.bincount(low_variance_resample(w, rng, n), minlength=len(w))
    # each count lies within one of n*w, so the mean's standard error is <= 0.5/sqrt(trials)
    assert np.allclose(counts / trials, n * w, atol=6 * 0.5 / np.sqrt(trials))


def test_neff_uniform_and_degenerate():
    assert effective_sample_size(np.ones(250)) == pytest.approx(250)
    assert effective_sample_size([0, 0, 3.0, 0]) == pytest.approx(1)
    assert effective_sample_size([1, 1, 0, 0]) == pytest.approx(2)


@settings(max_examples=100, deadline=None)
@given(weight_lists)
def test_neff_between_one_and_n(weights):
    w = np.array(weights)
    neff = effective_sample_size(w)
    assert 1 - 1e-9 <= neff <= np.count_nonzero(w) + 1e-9


def test_bad_weights_are_refused_with_reason():
    with pytest.raises(ValueError, match="sum to zero"):
        effective_sample_size([0.0, 0.0])
    with pytest.raises(ValueError, match="weight 1"):
        low_variance_resample([1.0, np.nan], np.random.default_rng(0))
    with pytest.raises(ValueError, match="count=0"):
        low_variance_resample([1.0], np.random.default_rng(0), 0)


def test_normalized_survive_huge_log_weights():
    w = normalized([-1e4, -1e4 + np.log(3.0)])
    assert np.allclose(w, [0.25, 0.75])
