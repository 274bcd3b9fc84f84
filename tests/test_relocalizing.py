"""The relocalization step's guesses: the start pose moved by the odometry; after a restart, map -> odom."""

from __future__ import annotations

import math

import numpy as np

from app.worker.relocalizing import Relocalizing


class NeverFound:
    """A relocalizer that records the guesses it is asked about and finds nothing."""

    def __init__(self):
        self.guesses = []

    def locate(self, scan, guess):
        self.guesses.append(np.asarray(guess, float))


def test_the_guess_is_the_worker_pose_moved_by_the_odometry_since_the_search_began():
    search = Relocalizing(NeverFound())
    pose = np.array([2.0, 1.0, math.pi / 2])
    fix, guess = search.locate((5.0, 5.0, 0.0), None, pose)
    assert fix is None and np.allclose(guess, pose)
    _, guess = search.locate((6.0, 5.0, 0.0), None, np.zeros(3))  # 1 m on; the worker pose no longer counts
    assert np.allclose(guess, (2.0, 2.0, math.pi / 2))


def test_after_a_restart_the_search_begins_at_the_correction_composed_with_the_odometry():
    correction = np.array([1.0, 0.0, math.pi / 2])  # odom frame turned by 90° and moved 1 m along x
    search = Relocalizing(NeverFound(), correction)
    _, guess = search.locate((3.0, 0.0, 0.0), None, np.array([9.0, 9.0, 0.0]))  # a stale checkpoint pose
    assert np.allclose(guess, (1.0, 3.0, math.pi / 2))
    search.restart()  # a person's pose: the search begins again there, the correction forgotten
    person = np.array([4.0, 4.0, 0.0])
    _, guess = search.locate((3.0, 0.0, 0.0), None, person)
    assert np.allclose(guess, person)
