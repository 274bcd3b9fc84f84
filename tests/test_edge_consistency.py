"""Loop edges into one submap that imply a motion neither the filter nor the odometry saw are
dropped; true edges are kept, also where one of the two witnesses slid or froze."""

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from slam_core.geometry import compose, relative
from slam_core.graph.edge_consistency import inconsistent_edges

TOLERANCE = 0.5


def tour(rng, n):
    steps = np.column_stack([rng.uniform(0.2, 0.9, n - 1), rng.normal(0, 0.05, n - 1),
                             rng.normal(0, 0.2, n - 1)])
    poses = [np.array([rng.normal(0, 10), rng.normal(0, 10), rng.uniform(-np.pi, np.pi)])]
    for step in steps:
        poses.append(compose(poses[-1], step))
    return np.array(poses)


def true_edges(truth, anchor, updates, rng, noise=0.03):
    """Edges from ``anchor`` to each of ``updates``, measured with a few centimetres of noise."""
    scale = np.array([1.0, 1.0, 0.01])
    return {(anchor, q): (relative(truth[anchor], truth[q]) + rng.normal(0, noise, 3) * scale, np.eye(3))
            for q in updates}


@settings(max_examples=60, deadline=None)
@given(seed=st.integers(0, 10 ** 6), wrong=st.floats(1.2, 5.0))
def test_a_false_edge_goes_and_a_true_one_only_if_the_false_one_was_its_only_neighbour(seed, wrong):
    rng = np.random.default_rng(seed)
    truth = tour(rng, 40)
    updates = sorted(rng.choice(np.arange(20, 40), size=rng.integers(3, 9), replace=False).tolist())
    edges = true_edges(truth, 5, updates, rng)
    edges.update(true_edges(truth, 12, updates[:2], rng))  # a second anchor, too few to judge alone
    false_q = int(rng.choice(updates))
    z, info = edges[(5, false_q)]
    angle = rng.uniform(-np.pi, np.pi)
    edges[(5, false_q)] = (z + np.array([wrong * np.cos(angle), wrong * np.sin(angle), 0.0]), info)
    filtered = truth + rng.normal(0, 0.01, truth.shape)
    got = set(inconsistent_edges(edges, filtered, None, TOLERANCE))

    def neighbours(q):
        return [k for k in updates if k != q and abs(k - q) <= 3]

    assert ((5, false_q) in got) == bool(neighbours(false_q))  # alone it is not judged here
    for anchor, q in got - {(5, false_q)}:  # a true edge goes only if the false one was its only neighbour
        assert anchor == 5 and neighbours(q) == [false_q]


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 10 ** 6), k=st.integers(21, 37), slide=st.floats(0.8, 3.0))
def test_true_edges_across_a_slid_filter_step_are_kept_while_the_odometry_saw_it(seed, k, slide):
    rng = np.random.default_rng(seed)
    truth = tour(rng, 40)
    edges = true_edges(truth, 5, range(20, 40), rng)
    filtered = truth.copy()
    filtered[k + 1:, :2] += slide  # every pose after step k moved: the filter's step slid
    odometry = compose(np.array([3.0, -2.0, 0.7]), relative(truth[0], truth))  # its own frame
    assert inconsistent_edges(edges, filtered, odometry, TOLERANCE) == []
    # without the odometry, only the filter speaks: edges across the slide disagree with it, so
    # only an edge next to it can go, where fewer of its neighbours lie on its own side
    alone = inconsistent_edges(edges, filtered, None, TOLERANCE)
    assert all(abs(q - k) <= 3 for _, q in alone)


def test_no_edges_or_one_edge_is_never_judged():
    truth = tour(np.random.default_rng(1), 10)
    assert inconsistent_edges({}, truth, None, TOLERANCE) == []
    one = true_edges(truth, 0, [8], np.random.default_rng(2))
    assert inconsistent_edges(one, truth, None, TOLERANCE) == []
