"""Settings of the particle filter SLAM, one dataclass per part; all in SI units."""

from __future__ import annotations

import json
import math
import typing
from dataclasses import asdict, dataclass, field, fields, is_dataclass
from pathlib import Path

import numpy as np

from slam_core.graph.config import LoopClosureConfig
from slam_core.motion_model import OdometryMotionModel
from slam_core.occupancy_grid import SensorModel, logit


@dataclass(frozen=True)
class MatcherParams:
    """Scan matching and observation likelihood (GMapping's names in brackets).

    ``lsigma`` (lsigma): spread of a beam's likelihood; ``max_distance``: a beam
    with no surface within reach counts as this far off; ``iterations`` /
    ``wide_iterations``: Gauss-Newton steps, the first ones searching
    correspondences two cells wide; ``huber``: residual (m) beyond which a beam's
    pull stops growing; ``start_sigma_xy`` / ``start_sigma_th``: the weak prior
    on the start pose that settles directions the scan leaves open;
    ``max_beams``: beams used (evenly spread) up to ``max_range``;
    ``min_matched``: the fraction of them that must match, and
    ``min_matched_beams`` the number (fewer cannot pin a pose down), else the particle
    falls back to the motion model; ``good_match``: the matched fraction above
    which the leading particle's match is trusted without the coarse search;
    ``lead_rotations`` / ``lead_rotation_step``: the leading particle is matched
    from its prediction turned by ``k * lead_rotation_step`` for
    ``|k| <= lead_rotations`` and keeps the likeliest result (the odometry's
    worst errors are in heading); ``check_beams`` / ``mismatch_drop``: between
    updates, each scan is checked with that many beams against the leading
    map from the odometry's prediction, and forces an update when the fraction
    of them that match is more than ``mismatch_drop`` below the last update's;
    ``motion_floor_xy`` / ``motion_floor_th``: the least spread (m, rad) of the
    motion model's prediction in the proposal.
    ``gain`` tempers the weights: a particle's weight is multiplied by
    ``eta ** (1 / gain)``, because beams are far from independent (GMapping
    divides by ogain times the particle count).

    ``coarse_*``: the correlative search for the odometry's error on the best
    particle's map (:mod:`slam_core.rbpf.correlative`): beams up to
    ``coarse_range``, at most ``coarse_beams`` of them, +-``coarse_linear_cells``
    cells and +-``coarse_angular`` rad in steps of ``coarse_angular_step`` (both
    widened with the odometry's motion), a
    likelihood field of spread ``coarse_sigma`` reaching ``coarse_reach_cells``,
    and a Gaussian prior of ``coarse_prior_linear`` m / ``coarse_prior_angular``
    rad around the prediction. Its result replaces the fine match only when it is
    likelier and at least ``good_match`` of the beams fit there.
    """

    lsigma: float = 0.075
    gain: float = 50.0
    max_distance: float = 0.15
    iterations: int = 10
    wide_iterations: int = 3
    huber: float = 0.05
    start_sigma_xy: float = 0.3
    start_sigma_th: float = 0.3
    max_beams: int = 180
    max_range: float = 20.0
    min_matched: float = 0.25
    min_matched_beams: int = 20
    good_match: float = 0.6
    lead_rotations: int = 3
    check_beams: int = 60
    mismatch_drop: float = 0.15
    lead_rotation_step: float = 0.04
    motion_floor_xy: float = 0.01
    motion_floor_th: float = 0.005
    occupied_prob: float = 0.6
    free_prob: float = 0.45
    coarse_range: float = 10.0
    coarse_beams: int = 90
    coarse_linear_cells: int = 20
    coarse_angular: float = 0.2
    coarse_angular_step: float = 0.005
    coarse_sigma: float = 0.05
    coarse_reach_cells: int = 3
    coarse_prior_linear: float = 1.0
    coarse_prior_angular: float = 0.2

    def packed(self) -> np.ndarray:
        """The numbers the compiled kernels read, in their order (see ``scan_matcher.P_*``)."""
        return np.array([self.lsigma ** 2, self.max_distance ** 2, logit(self.occupied_prob),
                         logit(self.free_prob), self.huber, self.start_sigma_xy ** 2,
                         self.start_sigma_th ** 2])

    def motion_floor(self) -> np.ndarray:
        """Variance floor of the motion model's prediction (m^2, m^2, rad^2)."""
        return np.array([self.motion_floor_xy ** 2, self.motion_floor_xy ** 2, self.motion_floor_th ** 2])


@dataclass(frozen=True)
class RBPFConfig:
    """The whole filter. ``linear_update`` / ``angular_update``: travel since the last
    update that triggers the next one (GMapping uses 1.0 m / 0.5 rad); between them a scan
    that fits the leading map much worse from the odometry's prediction forces an update
    (``MatcherParams.mismatch_drop``), so updating more often costs time and buys little;
    ``resample_threshold``: resample when ``N_eff < resample_threshold * N``;
    ``calibration_*``: the odometry's errors measured by the last ``calibration_window`` good
    matches calibrate the draws of particles that do not match, once there are
    ``calibration_min_samples`` of them, their noise at least ``calibration_min_scale`` of the
    motion model's (:mod:`slam_core.odometry_calibration`);
    ``loop_closure``: the back end that closes loops on the best particle's trajectory
    after a log (:mod:`slam_core.graph.loop_closure`)."""

    particles: int = 30
    resolution: float = 0.05
    linear_update: float = 0.5
    angular_update: float = 0.25
    resample_threshold: float = 0.5
    calibration_window: int = 200
    calibration_min_samples: int = 20
    calibration_min_scale: float = 0.05
    motion: OdometryMotionModel = field(default_factory=OdometryMotionModel)
    sensor: SensorModel = field(default_factory=SensorModel)
    matcher: MatcherParams = field(default_factory=MatcherParams)
    loop_closure: LoopClosureConfig = field(default_factory=LoopClosureConfig)

    def to_dict(self) -> dict:
        return asdict(self)

    @classmethod
    def from_dict(cls, data: dict) -> RBPFConfig:
        """The config of ``to_dict``'s shape (keys left out keep their defaults); ``ValueError``
        naming the key for an unknown key, a wrong type, or a number out of bounds."""
        config = _checked(cls, data, "")
        if config.particles < 1 or not MIN_RESOLUTION <= config.resolution <= MAX_RESOLUTION:
            raise ValueError(f"need particles >= 1 and resolution in {MIN_RESOLUTION:g}.."
                             f"{MAX_RESOLUTION:g} m, got {config.particles} and {config.resolution:g}")
        return config

    @classmethod
    def from_file(cls, path) -> RBPFConfig:
        """A ``config.json`` as ``homebot slam`` writes it; ``ValueError`` naming the file."""
        try:
            return cls.from_dict(json.loads(Path(path).read_bytes().decode("utf-8")))
        except (UnicodeDecodeError, json.JSONDecodeError, ValueError) as exc:
            raise ValueError(f"{path}: not a SLAM config ({exc})") from None


#: Bounds of the settings' numbers: none is negative, none larger than these.
MAX_SETTING_INT = 100_000
MAX_SETTING_FLOAT = 1e4
MIN_RESOLUTION, MAX_RESOLUTION = 0.005, 1.0


def _checked(kind: type, data, prefix: str):
    """An instance of the settings dataclass ``kind`` from ``data``, every value checked."""
    if not isinstance(data, dict):
        raise ValueError(f"{prefix.rstrip('.') or 'the config'} must be a JSON object")
    hints = typing.get_type_hints(kind)
    names = {f.name for f in fields(kind)}
    unknown = sorted(set(data) - names, key=str)
    if unknown:
        raise ValueError(f"unknown key {prefix}{unknown[0]}")
    values = {}
    for name, value in data.items():
        key, expected = prefix + name, hints[name]
        if is_dataclass(expected):
            values[name] = _checked(expected, value, key + ".")
        elif expected is bool:
            if not isinstance(value, bool):
                raise ValueError(f"{key} must be true or false, got {value!r}")
            values[name] = value
        else:
            integral = expected is int
            if isinstance(value, bool) or not isinstance(value, int if integral else int | float):
                raise ValueError(f"{key} must be {'an integer' if integral else 'a number'}, got {value!r}")
            limit = MAX_SETTING_INT if integral else MAX_SETTING_FLOAT
            if not (math.isfinite(value) and 0 <= value <= limit):
                raise ValueError(f"{key} must be a number in 0..{limit:g}, got {value!r}")
            values[name] = expected(value)
    return kind(**values)
