"""Settings of the loop-closing back end (lengths in metres, angles in radians)."""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class LoopClosureConfig:
    """How the back end finds loop closures and weighs them against the filter's path.

    ``submap_updates``: consecutive filter updates rendered into one submap;
    ``min_loop_path``: path length that must separate an update from a submap
    before the two can close a loop; ``search_radius``: how near (by the current
    estimate) one of a submap's updates must be; ``linear_window`` / ``angular_window``:
    the half-widths of the correlative search around the expected pose;
    ``candidates``: the nearest submaps tried per update; ``accept_fit``: the
    fraction of beams that must find a surface at the match;
    ``information_scale``: the matcher's information is multiplied by it (beams
    are far from independent); ``chain_sigma_*``: the standard error of the
    filter's step between consecutive updates, a floor plus a share of the
    step's travel and turn; ``outlier_chi2``: loop edges whose error, after
    optimising, exceeds this (in ``e^T Omega e``) are dropped; ``rounds``:
    searches, each from the poses the previous one optimised; ``refine_fit``:
    the fraction of beams that must fit for a scan to take its pose matched
    against its submap; ``refine_beams``: how many of a scan's beams (evenly
    spread) that final match uses, more than the filter's ``max_beams``, since it
    runs once per scan.

    Loops after large drift (:mod:`slam_core.graph.wide_search`): an update with no
    loop edge yet (one in ``wide_every``) also searches old submaps in a window of
    ``window_sigmas`` standard errors of the drift the chain's own noise (above) lets
    accumulate between them (the heading's random walk swinging the position, its noise
    widened where a scan held fewer echoes than the matcher uses; in position, only the
    drift since a loop edge found that ties the two stretches together, and each step's
    noise widened as the odometry witness loosens it, below), in heading of
    ``heading_window_sigmas`` (a filter's heading also errs systematically, where an odometry
    bias is left over across open ground, which a random walk does not describe), up to
    ``max_linear_window`` / ``max_angular_window`` (only the part of the window from which
    the query's points can land on the submap is searched): of the submaps whose anchor lies
    within ``search_radius`` plus that window, the ``wide_candidates`` likeliest and
    ``wide_others`` of the rest in turn (:func:`slam_core.graph.loop_closure._wide_candidates`).
    The search keeps only
    poses where the correlative score reaches ``wide_min_score`` of its maximum, and
    the match must explain ``wide_accept_fit`` of the beams; one that explains at least
    ``wide_confirm_fit`` is kept too if ``wide_confirmations`` of the four updates around
    it match the submap where it puts them (a narrow search that explains ``accept_fit``
    within half the narrow window of there). A narrow search is held to the same test where
    ``window_sigmas`` of that drift reach beyond ``linear_window``. Such a match (wide or narrow) is
    dropped where a pose at least ``lookalike_separation`` from it, within that reach of it, scores
    ``lookalike_ratio`` times its score in the correlative search: a road or corridor that looks
    the same a few metres on. The margin is for what sets scores at two poses of one submap apart
    besides the fit: how much of the scan lands where the submap has seen anything (in mit-csail's
    corridors, matches a map needs have look-alikes scoring up to 8 % higher). Its headings are searched in
    steps of ``lookalike_angular_step``, coarser than the search's own, so a look-alike better only
    between them is missed: the test lets a match through rather than drop a true one.

    Where the filter's step and the wheel odometry's disagree by more than
    ``witness_tolerance``, the step's position variance gains the square of the excess
    (:mod:`slam_core.graph.odometry_witness`), so that the loop edges can bend the chain there, and
    the step becomes the product of that and the odometry's step, whose standard error is
    ``witness_sigma``.
    Loop edges into one submap from nearby updates whose implied motion lands more than
    ``consistency_tolerance`` from both the filter's and the odometry's steps, against most
    such neighbours, are dropped before the solve (:mod:`slam_core.graph.edge_consistency`).
    """

    enabled: bool = True
    submap_updates: int = 20
    min_loop_path: float = 8.0
    search_radius: float = 2.5
    linear_window: float = 0.6
    angular_window: float = 0.15
    candidates: int = 2
    accept_fit: float = 0.7
    information_scale: float = 0.02
    chain_sigma_xy: float = 0.01
    chain_sigma_th: float = 0.002
    chain_sigma_per_metre: float = 0.02
    chain_sigma_th_per_metre: float = 0.002
    chain_sigma_per_radian: float = 0.02
    outlier_chi2: float = 16.0
    rounds: int = 2
    refine_fit: float = 0.6
    refine_beams: int = 720
    wide_every: int = 5
    window_sigmas: float = 2.0
    heading_window_sigmas: float = 4.0
    max_linear_window: float = 20.0
    max_angular_window: float = 0.5
    wide_candidates: int = 3
    wide_others: int = 2
    wide_min_score: float = 0.5
    wide_accept_fit: float = 0.8
    wide_confirm_fit: float = 0.7
    wide_confirmations: int = 2
    lookalike_separation: float = 1.0
    lookalike_ratio: float = 1.1
    lookalike_angular_step: float = 0.02
    witness_tolerance: float = 0.1
    witness_sigma: float = 0.2
    consistency_tolerance: float = 0.5
