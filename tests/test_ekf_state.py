"""The EKF state: prediction, joint update and landmark augmentation against dense references."""

import numpy as np
import pytest
from naive_ekf import dense_add, dense_update

from slam_core.ekf.association import (
    CHI2_2_99,
    associate,
    mahalanobis_table,
    predicted_innovation_covariances,
)
from slam_core.ekf.models import motion_jacobians, observe
from slam_core.ekf.state import EkfState


def random_state(rng, k=6):
    state = EkfState(rng.normal(size=3), np.diag([0.05, 0.05, 0.01]))
    r = np.diag([0.02 ** 2, 0.01 ** 2])
    for _ in range(k):
        state.add_landmark(np.array([rng.uniform(1, 6), rng.uniform(-np.pi, np.pi)]), r)
    state.predict(np.array([0.3, 0.05, 0.1]), np.diag([1e-3, 1e-3, 1e-3]))
    return state, r


def test_state_rejects_bad_pose():
    with pytest.raises(ValueError, match="pose"):
        EkfState((0.0, np.nan, 0.0))
    with pytest.raises(ValueError, match="3 x 3"):
        EkfState((0.0, 0.0, 0.0), np.eye(2))


def test_predict_is_the_linearised_propagation_and_leaves_landmarks_alone():
    rng = np.random.default_rng(1)
    state, _ = random_state(rng)
    mean0, cov0 = state.mean.copy(), state.cov.copy()
    u, q = np.array([0.2, -0.1, 0.3]), np.diag([1e-3, 2e-3, 3e-3])
    state.predict(u, q)
    f, g = motion_jacobians(mean0[:3], u)
    big_f = np.eye(len(mean0))
    big_f[:3, :3] = f
    expected = big_f @ cov0 @ big_f.T
    expected[:3, :3] += g @ q @ g.T
    np.testing.assert_allclose(state.cov, expected, atol=1e-12)
    np.testing.assert_array_equal(state.mean[3:], mean0[3:])


def test_add_landmark_matches_the_dense_augmentation():
    rng = np.random.default_rng(2)
    state, r = random_state(rng)
    mean, cov = dense_add(state.mean, state.cov, np.array([3.0, 0.4]), r)
    index = state.add_landmark(np.array([3.0, 0.4]), r)
    assert index == state.n_landmarks - 1
    np.testing.assert_allclose(state.mean, mean, atol=1e-12)
    np.testing.assert_allclose(state.cov, cov, atol=1e-12)


def test_joint_update_matches_the_dense_textbook_update():
    rng = np.random.default_rng(3)
    state, r = random_state(rng)
    idx = np.array([4, 0, 2])
    z = np.array([observe(state.mean[:3], state.mean[3 + 2 * j:5 + 2 * j])[0] for j in idx])
    z += rng.normal(scale=[0.03, 0.02], size=z.shape)
    rs = np.repeat(r[None], len(idx), axis=0)
    mean, cov = dense_update(state.mean, state.cov, idx, z, rs)
    state.update(idx, z, rs)
    np.testing.assert_allclose(state.mean, mean, atol=1e-9)
    np.testing.assert_allclose(state.cov, cov, atol=1e-9)
    assert np.all(np.linalg.eigvalsh(state.cov) > -1e-12)


def test_innovation_covariance_table_matches_per_landmark_formula():
    rng = np.random.default_rng(4)
    state, r = random_state(rng)
    z_pred, s_pred = predicted_innovation_covariances(state)
    for j in range(state.n_landmarks):
        nu, s = state.innovation(j, z_pred[j], r)
        np.testing.assert_allclose(nu, 0.0, atol=1e-12)
        np.testing.assert_allclose(s_pred[j] + r, s, atol=1e-12)
    z_obs = z_pred[:2] + np.array([[0.05, 0.01], [-0.02, 0.0]])
    d2 = mahalanobis_table(z_obs, np.repeat(r[None], 2, axis=0), z_pred, s_pred)
    for i in range(2):
        for j in range(state.n_landmarks):
            nu, s = state.innovation(j, z_obs[i], r)
            assert d2[i, j] == pytest.approx(nu @ np.linalg.solve(s, nu), rel=1e-9)


def test_association_gates_matches_nearest_and_flags_new():
    state = EkfState((0.0, 0.0, 0.0), np.diag([1e-4, 1e-4, 1e-5]))
    r = np.diag([0.05 ** 2, 0.01 ** 2])
    state.add_landmark(np.array([2.0, 0.0]), r)
    state.add_landmark(np.array([3.0, 1.0]), r)
    z = np.array([[2.02, 0.005],  # landmark 0
                  [3.0, 1.0],  # landmark 1
                  [5.0, -1.0]])  # nothing there: new
    rs = np.repeat(r[None], 3, axis=0)
    a = associate(state, z, rs)
    assert sorted(map(tuple, a.matches)) == [(0, 0), (1, 1)]
    assert list(a.new) == [2]
    assert np.all(a.distances[a.matches[:, 0], a.matches[:, 1]] < CHI2_2_99)
    # incompatible appearance forbids the match, and keeps the observation from being "new"
    a = associate(state, z[:1], rs[:1], compatible=np.array([[False, True]]))
    assert len(a.matches) == 0 and list(a.new) == [0]


def test_ambiguous_observation_is_dropped_not_added():
    state = EkfState((0.0, 0.0, 0.0), np.diag([0.25, 0.25, 0.01]))
    r = np.diag([0.05 ** 2, 0.01 ** 2])
    state.add_landmark(np.array([3.0, 0.0]), r)
    state.add_landmark(np.array([3.0, 0.03]), r)  # 9 cm apart
    z = np.array([[3.0, 0.015]])  # half-way: both inside the gate
    a = associate(state, z, r[None])
    assert len(a.matches) == 0 and len(a.new) == 0
    a = associate(state, z, r[None], reject_ambiguous=False)
    assert len(a.matches) == 1
