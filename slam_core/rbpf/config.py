"""Settings of the particle filter SLAM, one dataclass per part; all in SI units."""

from __future__ import annotations

from dataclasses import asdict, dataclass, field

import numpy as np

from slam_core.motion_model import OdometryMotionModel
from slam_core.occupancy_grid import SensorModel, logit


@dataclass(frozen=True)
class MatcherParams:
    """Scan matching and observation likelihood (GMapping's names in brackets).

    ``sigma`` (sigma): spread of the matching score; ``lsigma`` (lsigma): the
    observation likelihood; ``max_distance``: a beam with no surface within the
    kernel counts as this far off; ``linear_step`` / ``angular_step`` (lstep /
    astep) and ``refinements`` (iterations): hill climbing; ``max_beams``: beams
    used (evenly spread) per evaluation; ``min_matched``: the fraction of beams
    that must match, else the particle falls back to the motion model;
    ``sample_*``: spacing of the poses around the match at which the proposal is
    evaluated. ``gain`` tempers the weights: a particle's weight is multiplied
    by ``eta ** (1 / gain)``, because beams are far from independent (GMapping
    divides by ogain times the particle count).

    ``coarse_*``: the correlative search for the odometry's error on the best
    particle's map (:mod:`slam_core.rbpf.correlative`): beams up to
    ``coarse_range``, at most ``coarse_beams`` of them, +-``coarse_linear_cells``
    cells and +-``coarse_angular`` rad in steps of ``coarse_angular_step`` (both
    widened with the odometry's motion), a
    likelihood field of spread ``coarse_sigma`` reaching ``coarse_reach_cells``,
    and a Gaussian prior of ``coarse_prior_linear`` m / ``coarse_prior_angular``
    rad around the prediction.
    """

    sigma: float = 0.05
    lsigma: float = 0.075
    gain: float = 50.0
    max_distance: float = 0.15
    linear_step: float = 0.025
    angular_step: float = 0.0125
    refinements: int = 5
    max_beams: int = 120
    max_range: float = 20.0
    min_matched: float = 0.25
    occupied_prob: float = 0.6
    free_prob: float = 0.45
    sample_linear: float = 0.02
    sample_angular: float = 0.01
    coarse_range: float = 10.0
    coarse_beams: int = 90
    coarse_linear_cells: int = 6
    coarse_angular: float = 0.1
    coarse_angular_step: float = 0.005
    coarse_sigma: float = 0.05
    coarse_reach_cells: int = 3
    coarse_prior_linear: float = 0.3
    coarse_prior_angular: float = 0.2

    def packed(self) -> np.ndarray:
        """The numbers the compiled kernels read, in their order."""
        return np.array([self.sigma ** 2, self.lsigma ** 2, self.max_distance ** 2,
                         logit(self.occupied_prob), logit(self.free_prob)])


@dataclass(frozen=True)
class RBPFConfig:
    """The whole filter. ``linear_update`` / ``angular_update``: travel since the last
    update that triggers the next one; ``resample_threshold``: resample when
    ``N_eff < resample_threshold * N``."""

    particles: int = 30
    resolution: float = 0.05
    linear_update: float = 0.5
    angular_update: float = 0.25
    resample_threshold: float = 0.5
    motion: OdometryMotionModel = field(default_factory=OdometryMotionModel)
    sensor: SensorModel = field(default_factory=SensorModel)
    matcher: MatcherParams = field(default_factory=MatcherParams)

    def to_dict(self) -> dict:
        return asdict(self)

    @classmethod
    def from_dict(cls, data: dict) -> RBPFConfig:
        data = dict(data)
        parts = {"motion": OdometryMotionModel, "sensor": SensorModel, "matcher": MatcherParams}
        for key, kind in parts.items():
            if key in data and isinstance(data[key], dict):
                data[key] = kind(**data[key])
        return cls(**data)
