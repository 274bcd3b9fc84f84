"""The EKF landmark picture is framed on the trajectory, not on wall lines tens of metres away."""

import numpy as np
import pytest
from PIL import Image

from slam_core.ekf.render import REACH_M, drawn_extent, save_landmark_png

TRAJECTORY = np.array([[0.0, 0.0], [4.0, 0.0], [4.0, 3.0]])


def test_far_landmarks_do_not_widen_the_extent():
    far = np.array([[-60.0, 1.0], [80.0, 2.0], [1.0, 1.0]])
    lo, hi = drawn_extent(TRAJECTORY, far, margin=2.0)
    assert lo == pytest.approx([-REACH_M, -2.0]) and hi == pytest.approx([4.0 + REACH_M, 5.0])


def test_near_landmarks_and_no_trajectory_keep_the_margin():
    near = np.array([[-1.0, 4.0], [5.0, -1.0]])
    lo, hi = drawn_extent(TRAJECTORY, near, margin=0.5)
    assert lo == pytest.approx([-1.5, -1.5]) and hi == pytest.approx([5.5, 4.5])
    lo, hi = drawn_extent(np.zeros((0, 2)), near, margin=0.5)
    assert lo == pytest.approx([-1.5, -1.5]) and hi == pytest.approx([5.5, 4.5])


def test_a_wall_line_80_m_away_leaves_the_picture_its_size(tmp_path):
    wall = np.array([[[-30.0, 6.0], [80.0, 6.0]]])
    png = save_landmark_png(tmp_path / "l.png", [[1.0, 1.0]], [np.eye(2) * 0.01], TRAJECTORY,
                            resolution=0.1, segments=wall)
    with Image.open(png) as img:
        assert img.size[0] <= (4.0 + 2 * REACH_M) / 0.1 + 1
