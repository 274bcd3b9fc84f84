"""Wall-line landmarks: the (ρ, α) models against finite differences, the fit's covariance against
sampling, extraction in the analytic room, the mixed point + line update against a dense reference,
and the EKF mapping each wall once."""

import numpy as np
from ekf_world import ROOM, cast
from hypothesis import given, settings
from hypothesis import strategies as st
from test_ekf_models import numeric_jacobian

from slam_core.ekf.ekf_slam import EkfConfig, EkfSlam
from slam_core.ekf.landmarks import LINE, ExtractorConfig, fit_lines, line_segments
from slam_core.ekf.models import (
    inverse_line_observation,
    inverse_observation,
    observe,
    observe_line,
    observe_lines_many,
)
from slam_core.ekf.state import EkfState
from slam_core.geometry import wrap_angle

coord = st.floats(-20, 20)
angle = st.floats(-np.pi, np.pi)


@settings(max_examples=80, deadline=None)
@given(coord, coord, angle, st.floats(-15, 15), angle, coord, coord)
def test_line_observation_jacobians_match_finite_differences(x, y, th, rho, alpha, ax, ay):
    pose, line, anchor = np.array([x, y, th]), np.array([rho, alpha]), np.array([ax, ay])
    z, h_pose, h_line = observe_line(pose, line, anchor)
    if abs(z[0]) < 0.1:  # the robot on the line: ρ_r's sign flips there
        return
    assert z[0] >= 0
    by_pose = numeric_jacobian(lambda p: observe_line(p, line, anchor)[0], pose, [1])
    by_line = numeric_jacobian(lambda q: observe_line(pose, q, anchor)[0], line, [1])
    np.testing.assert_allclose(h_pose, by_pose, atol=1e-5)
    np.testing.assert_allclose(h_line, by_line, atol=1e-5)
    zs, hps, hls = observe_lines_many(pose, line[None], anchor[None])
    np.testing.assert_allclose(zs[0], z, atol=1e-12)
    np.testing.assert_allclose(hps[0], h_pose, atol=1e-12)
    np.testing.assert_allclose(hls[0], h_line, atol=1e-12)


@settings(max_examples=60, deadline=None)
@given(coord, coord, angle, st.floats(0.2, 15), angle, coord, coord)
def test_inverse_line_observation_inverts_and_its_jacobians_match(x, y, th, rho_r, alpha_r, ax, ay):
    pose, z, anchor = np.array([x, y, th]), np.array([rho_r, alpha_r]), np.array([ax, ay])
    line, g_pose, g_z = inverse_line_observation(pose, z, anchor)
    back = observe_line(pose, line, anchor)[0]
    assert abs(back[0] - rho_r) < 1e-9 and abs(wrap_angle(back[1] - alpha_r)) < 1e-9
    np.testing.assert_allclose(g_pose, numeric_jacobian(lambda p: inverse_line_observation(p, z, anchor)[0],
                                                        pose, [1]), atol=1e-5)
    np.testing.assert_allclose(g_z, numeric_jacobian(lambda v: inverse_line_observation(pose, v, anchor)[0],
                                                     z, [1]), atol=1e-5)


def test_a_line_seen_from_its_far_side_flips_to_positive_distance():
    line = np.array([2.0, 0.0])  # x = 2
    near = observe_line(np.array([0.0, 0.0, 0.0]), line)[0]
    far = observe_line(np.array([3.0, 0.0, 0.0]), line)[0]
    np.testing.assert_allclose(near, [2.0, 0.0], atol=1e-12)
    np.testing.assert_allclose([far[0], abs(wrap_angle(far[1]))], [1.0, np.pi], atol=1e-12)


def wall_points(rho, alpha, t, sigma, rng):
    n = np.array([np.cos(alpha), np.sin(alpha)])
    d = np.array([-n[1], n[0]])
    return rho * n + t[:, None] * d + sigma * rng.standard_normal(len(t))[:, None] * n


def test_line_fit_is_exact_on_a_clean_wall_and_its_covariance_matches_sampling():
    rng = np.random.default_rng(0)
    rho, alpha, sigma = 3.0, 0.7, 0.01
    t = np.linspace(0.5, 3.0, 60)  # off-centre: ρ and α are correlated
    exact = fit_lines([wall_points(rho, alpha, t, 0.0, rng)])
    np.testing.assert_allclose(exact.params[0], [rho, alpha], atol=1e-12)
    samples = np.array([fit_lines([wall_points(rho, alpha, t, sigma, rng)]).params[0] for _ in range(4000)])
    predicted = fit_lines([wall_points(rho, alpha, t, 0.0, rng)], sigma_floor=sigma).covariances[0]
    np.testing.assert_allclose(samples.mean(axis=0), [rho, alpha], atol=3e-4)
    np.testing.assert_allclose(np.cov(samples.T), predicted, rtol=0.1)
    # fewer effective points: a larger covariance
    assert np.all(np.diag(fit_lines([wall_points(rho, alpha, t, 0.0, rng)], sigma, 10).covariances[0])
                  > np.diag(predicted))


def test_the_room_walls_are_found_as_lines():
    pose = np.array([1.0, -0.5, 0.4])
    scan = cast(pose, [], n_beams=720)
    cfg = ExtractorConfig(line_max_range=11.9)
    segments = line_segments(scan, cfg)
    lines = fit_lines(segments)
    # the four walls x = ±ROOM, y = ±ROOM in the sensor frame
    truth = np.array([observe_line(pose, w)[0] for w in
                      ([ROOM, 0.0], [ROOM, np.pi / 2], [ROOM, np.pi], [ROOM, -np.pi / 2])])
    assert len(lines) == 4  # the wall behind, cut by the scan's seam, is merged into one
    for z in lines.params:
        err = np.abs(truth[:, 0] - z[0]) + np.abs(wrap_angle(truth[:, 1] - z[1]))
        assert err.min() < 1e-6
    assert all(np.hypot(*(s[-1] - s[0])) >= cfg.line_min_length for s in segments)


def dense_mixed_update(mean, cov, lines, anchors, indices, z, r):
    """Textbook EKF update with the full stacked Jacobian, points or lines per landmark."""
    n, m = len(mean), len(indices)
    h = np.zeros((2 * m, n))
    nu = np.zeros(2 * m)
    rr = np.zeros((2 * m, 2 * m))
    for i, j in enumerate(indices):
        a = 3 + 2 * j
        if lines[j]:
            zhat, hp, hl = observe_line(mean[:3], mean[a:a + 2], anchors[j])
        else:
            zhat, hp, hl = observe(mean[:3], mean[a:a + 2])
        h[2 * i:2 * i + 2, :3] = hp
        h[2 * i:2 * i + 2, a:a + 2] = hl
        nu[2 * i:2 * i + 2] = [z[i][0] - zhat[0], wrap_angle(z[i][1] - zhat[1])]
        rr[2 * i:2 * i + 2, 2 * i:2 * i + 2] = r[i]
    k = cov @ h.T @ np.linalg.inv(h @ cov @ h.T + rr)
    return mean + k @ nu, (np.eye(n) - k @ h) @ cov


def test_mixed_point_and_line_state_matches_the_dense_reference():
    rng = np.random.default_rng(1)
    state = EkfState(np.array([2.0, -1.0, 0.3]), np.diag([0.05, 0.05, 0.01]))
    r = np.diag([0.02 ** 2, 0.01 ** 2])
    state.add_landmark(np.array([3.0, 0.5]), r)
    mean0, cov0 = state.mean.copy(), state.cov.copy()
    state.add_landmark(np.array([2.5, -1.2]), r, line=True)
    # augmentation of a line: the dense Jacobian of [x; g(x, z)]
    line, gp, gz = inverse_line_observation(mean0[:3], np.array([2.5, -1.2]), mean0[:2])
    np.testing.assert_allclose(state.mean[-2:], line, atol=1e-12)
    np.testing.assert_allclose(state.anchors[-1], mean0[:2])
    np.testing.assert_allclose(state.cov[-2:, -2:], gp @ cov0[:3, :3] @ gp.T + gz @ r @ gz.T, atol=1e-12)
    np.testing.assert_allclose(state.cov[-2:, :5], gp @ cov0[:3, :5], atol=1e-12)
    state.add_landmark(np.array([4.0, 1.5]), r, line=True)
    state.add_landmark(np.array([5.0, -0.5]), r)
    state.predict(np.array([0.4, 0.1, 0.2]), np.diag([1e-3, 1e-3, 2e-3]))
    idx = np.array([1, 3, 0, 2])
    z = np.array([state.observe(j)[0] for j in idx]) + rng.normal(scale=[0.03, 0.02], size=(4, 2))
    rs = np.repeat(r[None], 4, axis=0)
    mean, cov = dense_mixed_update(state.mean, state.cov, state.lines, state.anchors, idx, z, rs)
    state.update(idx, z, rs)
    linear = [0, 1, 3, 4, 5, 7, 9, 10]  # all but the headings and the lines' angles
    np.testing.assert_allclose(state.mean[linear], mean[linear], atol=1e-9)
    np.testing.assert_allclose(wrap_angle(state.mean[[2, 6, 8]] - mean[[2, 6, 8]]), 0.0, atol=1e-9)
    np.testing.assert_allclose(state.cov, cov, atol=1e-9)
    assert list(state.lines) == [False, True, True, False]
    # inverse_observation for points is untouched by the line machinery
    np.testing.assert_allclose(inverse_observation(mean0[:3], np.array([3.0, 0.5]))[0], mean0[3:5])


def test_the_ekf_maps_each_room_wall_once_and_where_it_is():
    """Drive across the empty analytic room: four walls, each one line landmark, in place."""
    ekf = EkfSlam(EkfConfig(extractor=ExtractorConfig(line_max_range=11.9)), (-4.0, 0.0, 0.0))
    rng = np.random.default_rng(5)
    for k in range(60):
        pose = np.array([-4.0 + 0.1 * k, 0.3 * np.sin(0.1 * k), 0.05 * k])
        ekf.step(pose, cast(pose, [], sigma=0.005, rng=rng))
    lines = ekf.state.landmarks[ekf.state.lines]
    anchors = ekf.state.anchors[ekf.state.lines]
    assert np.all(ekf.landmark_kinds[ekf.state.lines] == LINE)
    assert len(lines) == 4, lines
    # each mapped line, moved to the world origin's normal form, is one of the walls
    unit = np.column_stack([np.cos(lines[:, 1]), np.sin(lines[:, 1])])
    rho0 = lines[:, 0] + np.einsum("ij,ij->i", anchors, unit)
    normal = np.where(rho0[:, None] < 0, -1.0, 1.0) * unit
    np.testing.assert_allclose(np.abs(rho0), ROOM, atol=0.05)
    walls = np.array([[1, 0], [0, 1], [-1, 0], [0, -1]])
    assert sorted(np.argmax(normal @ walls.T, axis=1)) == [0, 1, 2, 3]
    np.testing.assert_allclose(np.max(np.abs(normal), axis=1), 1.0, atol=0.01)
    segments = ekf.line_segments()
    assert segments.shape == (4, 2, 2)
    assert np.all(np.hypot(*(segments[:, 1] - segments[:, 0]).T) > 5.0)
    assert len(ekf.estimate().landmarks) == ekf.state.n_landmarks - 4  # lines are not points
