"""The SE(2) pose graph optimiser: exact recovery, loop closing, robust edges, Jacobians."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from slam_core.geometry import compose, relative, wrap_angle
from slam_core.graph.pose_graph import PoseGraph, _errors, chain_edges, optimize


def random_path(rng, n):
    steps = np.column_stack([rng.uniform(0.2, 0.5, n - 1), rng.normal(0, 0.05, n - 1),
                             rng.normal(0, 0.3, n - 1)])
    poses = [np.zeros(3)]
    for s in steps:
        poses.append(compose(poses[-1], s))
    return np.array(poses)


def pose_error(a, b):
    d = a - b
    d[:, 2] = wrap_angle(d[:, 2])
    return np.abs(d).max()


def test_exact_edges_recover_the_true_poses_from_a_bad_start():
    rng = np.random.default_rng(0)
    truth = random_path(rng, 40)
    start = truth + np.vstack([np.zeros(3), rng.normal(0, [0.3, 0.3, 0.2], (39, 3))])
    graph = PoseGraph(start)
    chain_edges(graph, truth, np.eye(3))
    for a, b in [(0, 20), (5, 35), (10, 39)]:
        graph.add_edge(a, b, relative(truth[a], truth[b]), np.eye(3))
    assert pose_error(optimize(graph), truth) < 1e-8
    assert np.all(graph.chi2(truth) < 1e-20)
    assert pose_error(graph.poses, start) == 0.0  # the input is left alone


def test_a_loop_edge_removes_the_drift_of_a_biased_chain():
    # a square loop driven with a heading bias of 1 degree per step: the chain alone
    # ends far from the start; a loop edge saying "back at the start" closes it
    truth = [np.zeros(3)]
    for k in range(40):
        truth.append(compose(truth[-1], [0.5, 0.0, np.pi / 2 if k % 10 == 9 else 0.0]))
    truth = np.array(truth)
    rel = relative(truth[:-1], truth[1:])
    rel[:, 2] += np.radians(1.0)
    drifted = [np.zeros(3)]
    for r in rel:
        drifted.append(compose(drifted[-1], r))
    drifted = np.array(drifted)
    graph = PoseGraph(drifted)
    chain_edges(graph, drifted, np.diag([1e4, 1e4, 1e3]))
    graph.add_edge(0, 40, relative(truth[0], truth[40]), np.diag([1e6, 1e6, 1e6]))
    fixed = optimize(graph)
    assert np.hypot(*(drifted[40, :2] - truth[40, :2])) > 2.0
    assert np.hypot(*(fixed[40, :2] - truth[40, :2])) < 0.01
    err_before = np.hypot(*(drifted[:, :2] - truth[:, :2]).T).mean()
    err_after = np.hypot(*(fixed[:, :2] - truth[:, :2]).T).mean()
    assert err_after < 0.3 * err_before


def test_a_robust_false_edge_bends_the_path_far_less_than_a_plain_one():
    rng = np.random.default_rng(1)
    truth = random_path(rng, 30)
    wrong = compose(relative(truth[3], truth[25]), [1.5, -1.0, 0.6])
    errors = {}
    for robust in (False, True):
        graph = PoseGraph(truth)
        chain_edges(graph, truth, np.diag([400.0, 400.0, 2500.0]))
        for a, b in [(2, 24), (4, 26)]:
            graph.add_edge(a, b, relative(truth[a], truth[b]), np.diag([400.0, 400.0, 2500.0]), robust=True)
        graph.add_edge(3, 25, wrong, np.diag([400.0, 400.0, 2500.0]), robust=robust)
        errors[robust] = pose_error(optimize(graph, iterations=50), truth)
    assert errors[True] < 0.25 * errors[False]


def test_an_edge_must_join_two_existing_nodes():
    graph = PoseGraph(np.zeros((3, 3)))
    with pytest.raises(ValueError, match="does not join"):
        graph.add_edge(0, 3, np.zeros(3), np.eye(3))
    with pytest.raises(ValueError, match="does not join"):
        graph.add_edge(1, 1, np.zeros(3), np.eye(3))


@settings(max_examples=50, deadline=None)
@given(st.lists(st.floats(-3.0, 3.0), min_size=9, max_size=9))
def test_jacobians_match_finite_differences(values):
    x = np.array(values[:6]).reshape(2, 3)
    z = np.array(values[6:]).reshape(1, 3)
    i, j = np.array([0]), np.array([1])
    _, a, b = _errors(x, i, j, z)
    h = 1e-6
    for node, jac in ((0, a), (1, b)):
        for k in range(3):
            d = np.zeros_like(x)
            d[node, k] = h
            numeric = (_errors(x + d, i, j, z)[0] - _errors(x - d, i, j, z)[0]) / (2 * h)
            numeric[:, 2] = wrap_angle(numeric[:, 2] * 2 * h) / (2 * h)
            assert np.allclose(numeric, jac[:, :, k], atol=1e-5)


@settings(max_examples=20, deadline=None)
@given(st.integers(0, 10_000))
def test_a_step_solves_the_dense_normal_equations(seed):
    # oracle for the sparse solve (and its fill-reducing ordering): one Gauss-Newton step
    # equals the dense solution of H dx = -g over the free nodes
    rng = np.random.default_rng(seed)
    truth = random_path(rng, 30)
    start = truth + np.vstack([np.zeros(3), rng.normal(0, [0.1, 0.1, 0.05], (29, 3))])
    graph = PoseGraph(start)
    chain_edges(graph, truth, np.diag([50.0, 80.0, 200.0]))
    for _ in range(8):
        a, b = sorted(rng.choice(30, 2, replace=False))
        z = relative(truth[a], truth[b]) + rng.normal(0, 0.02, 3)
        graph.add_edge(a, b, z, np.diag([30.0, 30.0, 90.0]))
    i, j, z, info, _ = graph._arrays()
    e, ja, jb = _errors(start, i, j, z)
    h = np.zeros((90, 90))
    g = np.zeros(90)
    for k in range(len(i)):
        for (r, jr) in ((i[k], ja[k]), (j[k], jb[k])):
            g[3 * r:3 * r + 3] += jr.T @ info[k] @ e[k]
            for (c, jc) in ((i[k], ja[k]), (j[k], jb[k])):
                h[3 * r:3 * r + 3, 3 * c:3 * c + 3] += jr.T @ info[k] @ jc
    expected = start.copy()
    expected[1:] += np.linalg.solve(h[3:, 3:], -g[3:]).reshape(-1, 3)
    expected[:, 2] = wrap_angle(expected[:, 2])
    assert pose_error(optimize(graph, iterations=1), expected) < 1e-9
