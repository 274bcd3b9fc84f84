"""Rao-Blackwellized particle filter SLAM (GMapping-class) with shared, tiled maps."""

from slam_core.rbpf.config import MatcherParams, RBPFConfig
from slam_core.rbpf.filter import RBPFSlam, RBPFStats

__all__ = ["MatcherParams", "RBPFConfig", "RBPFSlam", "RBPFStats"]
