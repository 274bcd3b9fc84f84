"""Monte Carlo localization in a known map (AMCL-class): see :class:`MonteCarloLocalizer`."""

from slam_core.localization.mcl import MclConfig, MclStatus, MonteCarloLocalizer

__all__ = ["MclConfig", "MclStatus", "MonteCarloLocalizer"]
