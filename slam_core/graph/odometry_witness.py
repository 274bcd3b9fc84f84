"""Where the filter's step and the wheel odometry's disagree, the chain's step is that uncertain,
and the odometry's step is heard.

The back end's chain trusts each filter step to a few centimetres. Where a scan match went wrong
(few walls in range, look-alike places) a filter step can be off by decimetres while the
odometry, an independent witness, read it right; a pose graph that trusts the wrong step cannot
bend there when the loop edges around it disagree. So each step's position variance gains the
square of the disagreement beyond a tolerance (the odometry's own noise, and the stale readings
of real wheels). Where the odometry is no witness, nothing is added: it froze (read less than
``STALL_XY`` while the filter moved) or caught up after freezing (the first step it reads after
freezing, whatever its length, or a step more than ``CATCH_UP`` times its running mean step,
rate ``SPEED_RATE``), the faults the odometry of intel and mit-csail shows. The filter's updates
are not evenly spaced (a poor fit forces one at every scan), so a catch-up over a few short
steps can be shorter than the mean step: mit-csail's odometry read nothing for two 0.22 m steps,
then 0.83 m in one against a mean of about 0.6 m, and the chain's step, loosened by the 0.6 m
difference, let the loops pull the trajectory 0.37 m apart within one scan.

A loosened step is not left where the filter put it either: the odometry saw that step too, so the
chain's step is the product of the two Gaussians in position (:func:`witnessed_steps`). Where the
filter slid along a road of few walls in range (freiburg-campus: 0.65-0.9 m short at each of
three scans while the odometry read the robot's 1.1 m), the chain follows the odometry; where the two
disagree by little more than the tolerance, the step moves a little.
"""

from __future__ import annotations

import numpy as np

from slam_core.geometry import relative

STALL_XY = 0.01
CATCH_UP = 2.0
SPEED_RATE = 0.2


def step_disagreement(poses: np.ndarray, odometry: np.ndarray, tolerance: float) -> np.ndarray:
    """``(n - 1,)`` metres: how far each step of ``poses`` (n, 3) lands from the odometry's step
    (``odometry`` (n, 3) at the same instants, both in the robot frame), beyond ``tolerance``;
    0 where the odometry froze or caught up."""
    poses = np.asarray(poses, dtype=np.float64).reshape(-1, 3)
    odometry = np.asarray(odometry, dtype=np.float64).reshape(-1, 3)
    if poses.shape != odometry.shape:
        raise ValueError(f"need an odometry pose per pose, got {odometry.shape} for {poses.shape}")
    if len(poses) < 2:
        return np.zeros(0)
    ours = relative(poses[:-1], poses[1:])
    theirs = relative(odometry[:-1], odometry[1:])
    apart = np.hypot(ours[:, 0] - theirs[:, 0], ours[:, 1] - theirs[:, 1])
    read = np.hypot(theirs[:, 0], theirs[:, 1])
    moved = np.hypot(ours[:, 0], ours[:, 1])
    witness = read >= STALL_XY
    mean = None
    froze = False  # since the last step the odometry read, it read nothing while the filter moved
    for k in range(len(read)):
        if not witness[k]:
            froze = froze or moved[k] >= STALL_XY
            continue
        if froze or (mean is not None and read[k] > CATCH_UP * mean):
            witness[k] = False
        froze = False
        mean = read[k] if mean is None else mean + SPEED_RATE * (read[k] - mean)
    return np.where(witness, np.maximum(apart - tolerance, 0.0), 0.0)


def witnessed_steps(steps: np.ndarray, variances: np.ndarray, odometry_steps: np.ndarray, loosen: np.ndarray,
                    sigma: float) -> tuple[np.ndarray, np.ndarray]:
    """The chain's ``steps`` (n, 3) with their position ``variances`` (n,) where ``loosen`` (n,) says
    the odometry witnessed a disagreement: there the product of the step and the odometry's
    ``odometry_steps`` (n, 3) in position (the odometry's standard error ``sigma``), its mean and
    variance; the heading and every other step as they were."""
    steps = np.array(steps, dtype=np.float64).reshape(-1, 3)
    variances = np.array(variances, dtype=np.float64).reshape(-1)
    heard = np.asarray(loosen) > 0.0
    share = variances[heard] / (variances[heard] + sigma * sigma)
    odometry_steps = np.asarray(odometry_steps, dtype=np.float64).reshape(-1, 3)
    steps[heard, :2] += share[:, None] * (odometry_steps[heard, :2] - steps[heard, :2])
    variances[heard] *= 1.0 - share
    return steps, variances
