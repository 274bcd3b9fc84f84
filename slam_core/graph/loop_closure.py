"""Loop closing for a particle filter's trajectory: submap matching and a pose graph.

A particle filter closes a loop only if one of its particles happens to lie near
the true pose when the robot re-enters known ground; after a long loop the
cloud is far narrower than the drift, so the loop may stay open (the map
doubles) or close with a jump. This back end takes the best particle's
trajectory at its filter updates and

1. cuts it into *submaps*: runs of consecutive updates whose scans are rendered,
   at the filter's poses, into a small map of their own (locally the filter is
   accurate, so a submap is rigid; it is anchored at its middle update);
2. matches the scan of every update against the submaps the robot passed long
   before (by path length) that one of their updates lies near (a submap of sparse
   scans spans tens of metres, its anchor far from its ends): a correlative search over
   a window wide enough for the drift (a best pose on the window's rim is a false
   peak and is dropped), then the filter's Gauss-Newton point-to-line matcher; a
   match that explains enough beams becomes a loop edge from the submap's anchor
   to that update, weighted with the matcher's information (:func:`loop_edge`; a match of the wide
   search that explains fewer is kept if the updates around it match where it
   puts them; a narrow search where the chain may have drifted farther than its
   window since the last loop edge must pass the wide search's test: a look-alike
   place may lie within its reach; and a match of either, where that drift is large,
   is dropped if a pose a metre or more away within the drift's reach scores clearly
   higher: :func:`_look_alike`);
3. drops loop edges that imply a motion, against the edges of nearby updates into the
   same submap, that neither the filter nor the odometry saw
   (:mod:`slam_core.graph.edge_consistency`); optimises the pose graph of the loop edges
   and the chain of the filter's own steps (heard against the odometry's where the two
   disagree: :mod:`slam_core.graph.odometry_witness`; :mod:`slam_core.graph.pose_graph`,
   Huber-robust on loop edges), drops loop edges that still disagree, optimises
   again; the next round searches
   again from the optimised poses, which finds the closures the drift hid (a pair
   whose search found nothing is searched again only if the optimisation moved
   it by a cell or an angular step).

A trajectory that keeps growing (the live back end) is solved again with the
:class:`LoopMemory` of its last solve: the loop edges found stay, only the new
updates are searched, and the graph starts from the edges kept.

Every scan then gets its update's optimised pose moved by the odometry since, and
is matched against its update's submap (:func:`scan_poses`). Matching runs
on every core (the kernels release the GIL), one submap per task.
"""

from __future__ import annotations

import os
import threading
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from functools import cached_property

import numpy as np

from slam_core.geometry import compose, paced_pose, relative, wrap_angle
from slam_core.graph.config import LoopClosureConfig
from slam_core.graph.edge_consistency import inconsistent_edges
from slam_core.graph.odometry_witness import step_disagreement, witnessed_steps
from slam_core.graph.pose_graph import PoseGraph, chain_edges, optimize
from slam_core.graph.wide_search import LEVELS, field_pyramid, wide_search
from slam_core.occupancy_grid import SensorModel
from slam_core.rbpf.config import MatcherParams
from slam_core.rbpf.correlative import NO_SKIP, bound_levels, bounded_search, likelihood_window
from slam_core.rbpf.laser_mount import LaserMount
from slam_core.rbpf.scan_matcher import P_OCCUPIED, beam_rows, match
from slam_core.rbpf.tiled_map import TiledMaps
from slam_core.scan import Scan

#: Bytes of built submap maps kept for the later searches and the scans' re-match; those built after
#: the budget is spent are rebuilt when asked for again (each pass visits the submaps in order, so
#: a recently-used cache would keep none of them until the next pass needs it).
KEPT_SUBMAP_BYTES = 64 << 20
#: Side (cells) of the blocks whose bounds the branch and bound search scores first.
BLOCK_CELLS = 4
#: A scan between updates is also matched from where the robot's pace puts it when that start lies
#: more than these (m, rad) from the odometry's (a wheel reading that froze or lagged), and that
#: match is taken when it fits at least this fraction more of the scan's beams.
PACE_GAP_XY = 0.05
PACE_GAP_THETA = 0.035
PACE_GAIN = 0.05


@dataclass
class LoopMemory:
    """What one solve leaves for the next solve of the same trajectory grown longer: the laser
    poses it searched from, how many of its submaps were complete, the loop edges it kept
    ``{(anchor, update): (z, information)}``, the wide searches it tried ``{(submap, update)}``
    and the laser poses it optimised (where the next solve starts from)."""

    poses: np.ndarray
    submaps: int
    edges: dict[tuple[int, int], tuple[np.ndarray, np.ndarray]]
    tried_wide: set[tuple[int, int]]
    optimised: np.ndarray

    def reusable(self, poses: np.ndarray, submap_updates: int
                 ) -> tuple[int, dict[tuple[int, int], tuple[np.ndarray, np.ndarray]], set[tuple[int, int]]]:
        """For laser ``poses`` now: the first update to search again (those before it are where
        they were, so their submaps and searches still hold), the edges and wide searches kept."""
        same = self._unchanged(poses)
        whole = min(self.submaps, same // submap_updates)  # submaps built of unchanged updates only
        edges = {(a, q): e for (a, q), e in self.edges.items() if q < same and a // submap_updates < whole}
        tried = {(sub, q) for sub, q in self.tried_wide if q < same and sub < whole}
        return same, edges, tried

    def warm_start(self, poses: np.ndarray) -> np.ndarray:
        """Where a solve of laser ``poses`` starts: the unchanged updates at their optimised poses,
        the others carried along by the filter's motion since the last of them."""
        same = self._unchanged(poses)
        if same == 0:
            return poses.copy()
        start = poses.copy()
        start[:same] = self.optimised[:same]
        start[same:] = compose(start[same - 1], relative(poses[same - 1], poses[same:])).reshape(-1, 3)
        return start

    def _unchanged(self, poses: np.ndarray) -> int:
        """How many leading updates have the laser pose they had in the last solve."""
        m = min(len(self.poses), len(poses))
        differs = np.flatnonzero(np.any(self.poses[:m] != poses[:m], axis=1))
        return int(differs[0]) if len(differs) else m


@dataclass
class LoopClosureResult:
    """The optimised poses of the updates and what the search did; ``loop_pairs`` are the
    kept loop edges as ``(submap anchor, update)``; ``rejected_edges`` counts the pairs whose
    edge was dropped (inconsistent or an outlier) and not found again and kept, each once."""

    poses: np.ndarray
    loop_edges: int = 0
    rejected_edges: int = 0
    candidates_tried: int = 0
    loop_pairs: list[tuple[int, int]] = field(default_factory=list)
    memory: LoopMemory | None = None  # for the next solve of this trajectory grown longer

    def stats(self) -> dict:
        return {"loop_edges": self.loop_edges, "rejected_loop_edges": self.rejected_edges,
                "loop_candidates_tried": self.candidates_tried}


class Submap:
    """Scans of consecutive updates rendered at their poses into one small map, with the
    likelihood field of the correlative search as far around its updates' poses as the endpoints
    of a query near one of them can land."""

    def __init__(self, updates: np.ndarray, poses: np.ndarray, scans: list[Scan], resolution: float,
                 model: SensorModel, matcher: MatcherParams, params: np.ndarray, reach: float):
        self.anchor = int(updates[len(updates) // 2])
        self.anchor_pose = poses[self.anchor].copy()
        self.maps = TiledMaps(1, resolution, model, capacity=512)
        for u in updates:
            self.maps.integrate(poses[u][None, :], scans[u])
        m = self.maps
        lo, hi = poses[updates, :2].min(axis=0), poses[updates, :2].max(axis=0)
        half = int(np.ceil((0.5 * np.max(hi - lo) + reach) / resolution))  # where a query's endpoints land
        self._centre = np.floor((0.5 * (lo + hi) - m.origin) / resolution).astype(int)
        self._half = half
        self._field_args = (params[P_OCCUPIED], matcher.coarse_sigma, matcher.coarse_reach_cells)
        self.field_corner = m.origin + (self._centre - half) * resolution
        self._pyramid: np.ndarray | None = None

    @cached_property
    def field(self) -> np.ndarray:
        """The likelihood field (built when first asked for: the final re-match needs none)."""
        m = self.maps
        return likelihood_window(m.tables[0], m.lo, m.origin[0], m.origin[1], m.resolution, self._centre[0],
                                 self._centre[1], self._half, *self._field_args)

    @cached_property
    def pooled(self) -> tuple[np.ndarray, np.ndarray]:
        """The field max-pooled over blocks of ``BLOCK_CELLS`` and of twice that (the bounds of the
        narrow search)."""
        return bound_levels(self.field, BLOCK_CELLS)

    def pyramid(self) -> np.ndarray:
        """The field max-pooled at every level of the wide search (built when first asked for)."""
        if self._pyramid is None:
            self._pyramid = field_pyramid(self.field, LEVELS)
        return self._pyramid

    def release_fields(self) -> None:
        """Let the field, its pooled copies and the pyramid go (a search batch holds all of a submap's
        queries, so the next one needing them is a later round; the maps stay)."""
        self.__dict__.pop("field", None)
        self.__dict__.pop("pooled", None)
        self._pyramid = None

    def fine(self) -> tuple:
        m = self.maps
        return m.tables[0], m.lo, m.hits, m.origin[0], m.origin[1], m.resolution

    def in_frame(self, estimate: np.ndarray, pose: np.ndarray) -> np.ndarray:
        """``pose`` (in the frame of ``estimate``, the anchor's current pose) in the submap's frame."""
        return compose(self.anchor_pose, relative(estimate, pose))


class Submaps:
    """The trajectory's submaps, built when first asked for; their maps are kept while they take at
    most ``KEPT_SUBMAP_BYTES`` (the first ones built), the others are rebuilt when asked for again."""

    def __init__(self, poses: np.ndarray, scans: list[Scan], config: LoopClosureConfig, resolution: float,
                 model: SensorModel, matcher: MatcherParams, params: np.ndarray):
        n = len(poses)
        size = config.submap_updates
        self.ranges = [np.arange(a, min(a + size, n)) for a in range(0, n, size)]
        self.anchors = np.array([r[len(r) // 2] for r in self.ranges], np.int64)
        self.starts = np.array([r[0] for r in self.ranges], np.int64)
        self.ends = np.array([r[-1] for r in self.ranges], np.int64)
        reach = (config.search_radius + config.linear_window + matcher.coarse_range
                 + matcher.coarse_reach_cells * resolution)
        self._args = (poses, scans, resolution, model, matcher, params, reach)
        self._kept: dict[int, Submap] = {}
        self._kept_bytes = 0
        self._lock = threading.Lock()

    def __len__(self) -> int:
        return len(self.ranges)

    def __getitem__(self, s: int) -> Submap:
        with self._lock:
            if s in self._kept:
                return self._kept[s]
        sub = Submap(self.ranges[s], *self._args)
        size = sub.maps.nbytes()
        with self._lock:  # (another thread may have built it too: the one kept is returned from then on)
            if s not in self._kept and self._kept_bytes + size <= KEPT_SUBMAP_BYTES:
                self._kept[s] = sub
                self._kept_bytes += size
        return sub

    def of_update(self, u: int) -> int:
        return int(np.searchsorted(self.ends, u))

    def distances(self, subs: np.ndarray, estimate: np.ndarray, q: int) -> np.ndarray:
        """How far (m) update ``q`` lies from the nearest update of each submap in ``subs``, by
        ``estimate`` (the updates' poses)."""
        d = np.hypot(estimate[:, 0] - estimate[q, 0], estimate[:, 1] - estimate[q, 1])
        return np.minimum.reduceat(d, self.starts)[subs]


@dataclass(frozen=True)
class Match:
    """One scan matched in a submap (its frame): the matcher's ``pose``, ``info`` and ``fit``
    (the fraction of beams that found a surface), and the correlative search's best pose
    ``peak`` with its ``score``."""

    pose: np.ndarray
    info: np.ndarray
    fit: float
    peak: np.ndarray
    score: float


def _match(sub: Submap, start: np.ndarray, beams: np.ndarray, points: np.ndarray,
           config: LoopClosureConfig, matcher: MatcherParams, params: np.ndarray,
           linear: float, angular: float) -> Match | None:
    """One scan in the submap's frame, searched within ``+-linear`` m and ``+-angular`` rad of
    ``start``; ``None`` when the correlative search's best pose lies on its window's rim, or (a
    window wider than the narrow one) no pose scores well."""
    res = sub.maps.resolution
    if linear <= config.linear_window:
        linear_cells = int(np.ceil(linear / res))
        sx, sy, sth, score = bounded_search(sub.field, *sub.pooled, BLOCK_CELLS, res, sub.field_corner[0],
                                            sub.field_corner[1], start[0], start[1], start[2], points,
                                            angular, matcher.coarse_angular_step, linear_cells, *NO_SKIP)
    else:
        start = _within_reach(sub, start, linear, matcher.coarse_range)
        if start is None:
            return None
        start, linear = start
        linear_cells = int(np.ceil(linear / res))
        sx, sy, sth, score = wide_search(sub.pyramid(), res, sub.field_corner[0], sub.field_corner[1],
                                         start[0], start[1], start[2], points, angular,
                                         matcher.coarse_angular_step, linear_cells,
                                         config.wide_min_score * len(points), 0.0, 0.0, 0.0)
        if score < 0:
            return None
    rim = (max(abs(sx - start[0]), abs(sy - start[1])) >= (linear_cells - 0.5) * res
           or abs(sth - start[2]) >= angular - 0.5 * matcher.coarse_angular_step)
    if rim:
        return None
    fine = sub.fine()
    x, y, th, info, _, _, fitting = match(*fine, sx, sy, sth, beams, params, matcher.iterations,
                                          matcher.wide_iterations)
    return Match(np.array([x, y, th]), info, fitting / max(len(beams), 1), np.array([sx, sy, sth]),
                 float(score))


def _look_alike(sub: Submap, found: Match, points: np.ndarray, config: LoopClosureConfig,
                matcher: MatcherParams, linear: float, angular: float) -> bool:
    """Whether a pose at least ``lookalike_separation`` from the match's correlative peak, within
    ``+-linear`` m and ``+-angular`` rad of it, scores ``lookalike_ratio`` times the peak's score: a
    place that looks the same, and fits clearly better, where the drift could as well have put the
    robot."""
    window = _within_reach(sub, found.peak, linear, matcher.coarse_range)
    if window is None:
        return False
    (centre, half), res = window, sub.maps.resolution
    skip_x, skip_y = (found.peak[:2] - centre[:2]) / res
    score = wide_search(sub.pyramid(), res, sub.field_corner[0], sub.field_corner[1], *centre, points,
                        angular, config.lookalike_angular_step, int(np.ceil(half / res)),
                        config.lookalike_ratio * found.score, skip_x, skip_y,
                        config.lookalike_separation / res)[3]
    return score >= 0.0


def _within_reach(sub: Submap, start: np.ndarray, linear: float, reach: float
                  ) -> tuple[np.ndarray, float] | None:
    """A square on the window's cells holding the part of the window ``+-linear`` around ``start``
    (submap frame) from which points at most ``reach`` from the pose can land on the submap's
    field, as ``(centre with start's heading, half width)``; ``None`` when there is no such part.
    Elsewhere every pose scores 0, so a window metres wider than the field loses nothing by
    being searched there alone."""
    size = sub.field.shape[1] * sub.maps.resolution
    lo = np.maximum(start[:2] - linear, sub.field_corner - reach)
    hi = np.minimum(start[:2] + linear, sub.field_corner + size + reach)
    if np.any(lo > hi):
        return None
    res = sub.maps.resolution
    centre = start[:2] + np.round((0.5 * (lo + hi) - start[:2]) / res) * res  # on the window's own cells
    return np.array([centre[0], centre[1], start[2]]), float(0.5 * np.max(hi - lo)) + res


def close_loops(poses: np.ndarray, scans: list[Scan], config: LoopClosureConfig | None = None,
                matcher: MatcherParams | None = None, resolution: float = 0.05,
                model: SensorModel | None = None, laser_mount=None, memory: LoopMemory | None = None,
                odometry: np.ndarray | None = None) -> tuple[LoopClosureResult, Submaps]:
    """Loop-closed robot poses for the filter's robot poses at its updates with their scans
    (taken by a laser at ``laser_mount`` in the robot frame); also the submaps (for
    :func:`scan_poses`), which hold the laser's poses. With the ``memory`` of a solve of the
    first part of this trajectory, only the updates since are searched. With the ``odometry``
    at the updates, the chain's steps are loosened where the two disagree (:mod:`odometry_witness
    <slam_core.graph.odometry_witness>`)."""
    config = config or LoopClosureConfig()
    matcher = matcher or MatcherParams()
    model = model or SensorModel()
    mount = LaserMount.of(laser_mount)
    result = LoopClosureResult(np.array(poses, dtype=float))
    poses = mount.laser_poses(result.poses)
    params = matcher.packed()
    submaps = Submaps(poses, scans, config, resolution, model, matcher, params)
    n = len(poses)
    if not config.enabled or n < 2:
        return result, submaps
    path = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(poses[:, :2], axis=0).T))])
    reach = min(matcher.max_range, model.usable_range)
    loosen = None if odometry is None else step_disagreement(result.poses, odometry, config.witness_tolerance)
    witnessed = None if odometry is None else mount.laser_poses(np.asarray(odometry, dtype=float))
    chain_poses, chain = _witnessed_chain(poses, config, loosen, witnessed)
    drift = ChainDrift(poses, path, config, sparse_step_scales(scans, reach, matcher), loosen)
    estimate = poses.copy()
    first = 0  # the first update searched
    edges: dict[tuple[int, int], tuple[np.ndarray, np.ndarray]] = {}  # (anchor, update): (z, info)
    tried_wide: set[tuple[int, int]] = set()
    dropped: set[tuple[int, int]] = set()  # edges dropped (a later round's search may find one again)
    if memory is not None:
        first, edges, tried_wide = memory.reusable(poses, config.submap_updates)
        estimate = memory.warm_start(poses)
    narrow = (config.linear_window, config.angular_window)

    rows: dict[int, tuple[np.ndarray, np.ndarray]] = {}  # update: (beams, points), each made once

    def query_rows(q: int) -> tuple[np.ndarray, np.ndarray]:
        if q not in rows:
            rows[q] = (beam_rows(scans[q], model.beam_reach(scans[q], matcher.max_range), matcher.max_beams),
                       beam_rows(scans[q], min(matcher.coarse_range, reach), matcher.coarse_beams)[:, :2])
        return rows[q]

    failed: dict[tuple[int, int], np.ndarray] = {}  # (submap, update): where a narrow search found nothing
    # the narrow test takes (a match held to the wide test while the drift was large may pass it later)

    def failed_before(s: int, q: int, estimate: np.ndarray) -> bool:
        """Whether a narrow search of update ``q`` in submap ``s`` found nothing from within a cell and
        an angular step of where the estimate now puts it (it would score nearly the same poses)."""
        before = failed.get((s, q))
        if before is None:
            return False
        now = relative(estimate[submaps.anchors[s]], estimate[q])
        return bool(np.hypot(now[0] - before[0], now[1] - before[1]) < resolution
                    and abs(now[2] - before[2]) < matcher.coarse_angular_step)

    def try_submap(s: int, queries: list[tuple[int, float, float, float]], estimate: np.ndarray):
        sub = submaps[s]
        found = []
        for q, linear, angular, drifted in queries:
            beams, points = query_rows(q)
            if len(points) == 0:
                continue
            hit = _match(sub, sub.in_frame(estimate[sub.anchor], estimate[q]), beams, points,
                         config, matcher, params, linear, angular)
            wide, strict = linear > config.linear_window, drifted > 0.0
            if hit is not None and (hit.fit >= (config.wide_accept_fit if strict else config.accept_fit) or (
                    strict and hit.fit >= config.wide_confirm_fit and confirmed(sub, q, hit.pose, estimate))
                    ) and not (strict and _look_alike(sub, hit, points, config, matcher, drifted, angular)):
                found.append((q, *loop_edge(sub.anchor_pose, hit.pose, hit.info * config.information_scale)))
            elif not wide and (hit is None or hit.fit < config.accept_fit):  # nothing a narrow test takes
                failed[(s, q)] = relative(estimate[sub.anchor], estimate[q])
        sub.release_fields()
        return s, found

    def confirmed(sub: Submap, q: int, pose: np.ndarray, estimate: np.ndarray) -> bool:
        """Whether enough of the updates around ``q`` match ``sub`` where its match ``pose`` (in the
        submap's frame) puts them, by the estimate's steps between them."""
        agree = 0
        for k in (q - 2, q - 1, q + 1, q + 2):
            if not 0 <= k < n:
                continue
            beams, points = query_rows(k)
            start = compose(pose, relative(estimate[q], estimate[k]))
            hit = None if len(points) == 0 else _match(sub, start, beams, points, config, matcher, params,
                                                       *narrow)
            agree += bool(hit is not None and hit.fit >= config.accept_fit
                          and np.hypot(*(hit.pose[:2] - start[:2])) <= narrow[0] / 2
                          and abs(wrap_angle(hit.pose[2] - start[2])) <= narrow[1] / 2)
        return agree >= config.wide_confirmations

    def search_and_solve(pairs: dict[int, list[tuple[int, float, float, float]]], estimate: np.ndarray):
        if not pairs:
            return estimate
        result.candidates_tried += sum(len(v) for v in pairs.values())
        with ThreadPoolExecutor(os.cpu_count() or 1) as pool:
            for s, found in pool.map(lambda item: try_submap(*item, estimate), sorted(pairs.items())):
                for q, z, info in found:
                    edges[(int(submaps.anchors[s]), q)] = (z, info)
        drop_inconsistent()
        return solve(estimate)

    def drop_inconsistent() -> None:
        for key in inconsistent_edges(edges, poses, witnessed, config.consistency_tolerance):
            del edges[key]
            dropped.add(key)

    settled: list[set] = []  # the edges of the last solve, if it dropped none

    solved = [False]

    def solve(estimate: np.ndarray):
        if settled and settled[0] == edges.keys():
            return estimate  # the same graph (it depends on nothing else): the same optimum, no drop
        estimate, outliers = robust_solve(chain_poses, chain, edges, config.outlier_chi2, start=estimate)
        for key in outliers:
            del edges[key]
        dropped.update(outliers)
        settled[:] = [] if outliers else [set(edges)]
        solved[0] = True
        return estimate

    if edges:
        estimate = solve(estimate)  # the searches start where the edges kept put the poses
    for _ in range(config.rounds):
        # (submap: [(update, linear window, angular window, how far the chain may have drifted: where
        # beyond the narrow window, only a wide search's fit and no look-alike in that reach will do)])
        pairs: dict[int, list[tuple[int, float, float, float]]] = {}
        loops = np.array(list(edges), np.int64).reshape(-1, 2)
        for q in range(first, n):
            near = [s for s in _candidates(q, estimate, path, submaps, config)
                    if (int(submaps.anchors[s]), q) not in edges and not failed_before(s, q, estimate)]
            if near:  # where the chain may have drifted beyond the window, a look-alike could be there
                spread = _drift_reach(drift.since_loops(submaps.anchors[near], q, loops), config)
                for s, drifted in zip(near, np.where(spread > narrow[0], spread, 0.0), strict=True):
                    pairs.setdefault(s, []).append((q, *narrow, float(drifted)))
        estimate = search_and_solve(pairs, estimate)
        linked = {q for _, q in edges}
        loops = np.array(list(edges), np.int64).reshape(-1, 2)
        pairs = {}
        for q in range(first + (-first) % config.wide_every, n, config.wide_every):
            if q in linked:
                continue
            for s, linear, angular in _wide_candidates(q, estimate, path, submaps, drift, loops, config):
                if (s, q) not in tried_wide:
                    tried_wide.add((s, q))
                    pairs.setdefault(s, []).append((q, linear, angular, linear))
        estimate = search_and_solve(pairs, estimate)
    if not solved[0] and chain_poses is not poses:  # nothing searched: the chain as the odometry heard it
        estimate = solve(estimate)
    result.poses = mount.robot_poses(estimate)
    result.loop_edges = len(edges)
    result.rejected_edges = len(dropped - edges.keys())
    result.loop_pairs = list(edges)
    result.memory = LoopMemory(poses.copy(), n // config.submap_updates, dict(edges), set(tried_wide),
                               estimate.copy())
    return result, submaps


def per_scan_poses(update_of_scan: np.ndarray, scan_odometry: np.ndarray,
                   update_odometry: np.ndarray, update_poses: np.ndarray) -> np.ndarray:
    """A pose for every scan: the pose of its last filter update moved by the odometry since."""
    base_pose = update_poses[update_of_scan]
    base_odom = update_odometry[update_of_scan]
    return compose(base_pose, relative(base_odom, scan_odometry))


def scan_poses(submaps: Submaps, update_poses: np.ndarray, update_of_scan: np.ndarray,
               scan_odometry: np.ndarray, update_odometry: np.ndarray, scans: list[Scan],
               config: LoopClosureConfig | None = None, matcher: MatcherParams | None = None,
               model: SensorModel | None = None, laser_mount=None) -> np.ndarray:
    """A robot pose for every scan: its update's optimised pose moved by the odometry since,
    then matched finely against that update's submap where it fits well (poses and
    odometry are the robot's, the laser sits at ``laser_mount``).

    The filter's own poses are draws from its proposal, each a little off the likeliest
    pose; the match takes the likeliest pose given the submap's other scans, and gives
    the scans between updates a pose of their own instead of the odometry's. Where the
    odometry froze or lagged between updates (mit-csail's wheels), its start is too far
    for the fine match; such a scan is also matched from the robot's pace: that of the two
    scans before it when this submap holds them, else that of its update's step
    (:func:`steady_starts`)."""
    config = config or LoopClosureConfig()
    matcher = matcher or MatcherParams()
    model = model or SensorModel()
    mount = LaserMount.of(laser_mount)
    params = matcher.packed()
    out = per_scan_poses(update_of_scan, scan_odometry, update_odometry, update_poses)
    if not config.enabled:
        return out
    out = mount.laser_poses(out)
    update_poses = mount.laser_poses(update_poses)
    times = np.array([s.timestamp for s in scans], float)
    steady = steady_starts(update_poses, update_of_scan, times)
    first_of_update = np.diff(update_of_scan, prepend=-1) != 0
    submap_of = np.array([submaps.of_update(int(u)) for u in update_of_scan])
    by_submap: dict[int, list[int]] = {}
    for k, s in enumerate(submap_of):
        by_submap.setdefault(int(s), []).append(k)

    def refine(s: int, ks: list[int]) -> None:
        sub = submaps[s]
        fine = sub.fine()
        anchor = update_poses[sub.anchor]

        def fitted(start: np.ndarray, beams: np.ndarray) -> tuple[np.ndarray, int]:
            """The fine match from ``start`` (the anchor's frame) and how many beams it fits."""
            x, y, th, _, _, _, fitting = match(*fine, *sub.in_frame(anchor, start), beams, params,
                                               matcher.iterations, matcher.wide_iterations)
            return np.array([x, y, th]), fitting

        for k in ks:  # in order: the scans before k in this submap are matched already
            beams = beam_rows(scans[k], model.beam_reach(scans[k], matcher.max_range), config.refine_beams)
            if len(beams) == 0:
                continue
            best, best_fit = fitted(out[k], beams)
            gain = PACE_GAIN * len(beams)  # the paced start must fit clearly more beams to win,
            if best_fit + gain <= len(beams):  # which it cannot where the odometry's fits nearly all
                paced = None
                if k >= 2 and not first_of_update[k] and submap_of[k - 2] == s:
                    paced = paced_pose(out[k - 2], out[k - 1], *times[k - 2:k + 1])
                paced = steady[k] if paced is None else paced
                gap = relative(out[k], paced)
                if np.hypot(gap[0], gap[1]) > PACE_GAP_XY or abs(gap[2]) > PACE_GAP_THETA:
                    pose, fitting = fitted(paced, beams)
                    if fitting >= best_fit + gain:
                        best, best_fit = pose, fitting
            if best_fit >= config.refine_fit * len(beams):
                out[k] = compose(anchor, relative(sub.anchor_pose, best))

    with ThreadPoolExecutor(os.cpu_count() or 1) as pool:
        list(pool.map(lambda item: refine(*item), sorted(by_submap.items())))
    return mount.robot_poses(out)


def steady_starts(update_poses: np.ndarray, update_of_scan: np.ndarray, times: np.ndarray) -> np.ndarray:
    """``(n, 3)``: where each scan between updates would be had the robot kept the pace of its last
    update step (that step scaled by the time since over the step's time); NaN for update scans and
    where that step's time is unknown or not positive."""
    out = np.full((len(update_of_scan), 3), np.nan)
    first = np.flatnonzero(np.diff(update_of_scan, prepend=-1) != 0)  # the update scans
    at = np.full(len(update_poses), -1)
    at[update_of_scan[first]] = first
    u = update_of_scan
    ok = (u >= 1) & (at[u] != np.arange(len(u)))
    ok[ok] &= at[u[ok] - 1] >= 0
    k = np.flatnonzero(ok)
    t_prev, t_now = times[at[u[k] - 1]], times[at[u[k]]]
    span = t_now - t_prev
    k, span, t_now = k[span > 0], span[span > 0], t_now[span > 0]
    step = relative(update_poses[u[k] - 1], update_poses[u[k]])
    out[k] = compose(update_poses[u[k]], step * ((times[k] - t_now) / span)[:, None])
    return out


def sparse_step_scales(scans: list[Scan], reach: float, matcher: MatcherParams) -> np.ndarray:
    """How much less than a full scan each filter step's scan could pin its heading down, as a
    factor on the step's heading standard error: ``sqrt(max_beams / n)`` for a scan with ``n``
    echoes within ``reach`` (a match's information grows with its beams), 1 for ``max_beams`` or
    more, and at most ``sqrt(max_beams / min_matched_beams)``: with fewer echoes than a match
    needs, the step was the calibrated odometry's. One factor per step (the scan it ends at).

    Checked against freiburg-campus's ground truth (``benchmarks/RESULTS.md``): with this factor
    the filter's heading errors over the model's sigma have about the same median at every echo
    count; its position errors need none."""
    echoes = np.array([np.count_nonzero(s.valid & (s.ranges <= reach)) for s in scans[1:]], dtype=float)
    full = float(matcher.max_beams)
    return np.sqrt(full / np.clip(echoes, matcher.min_matched_beams, full))


def _chain_variances(poses: np.ndarray, config: LoopClosureConfig, scales: np.ndarray | None = None,
                     loosen: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Position and heading variances (m^2, rad^2) of each filter step: the standard error is a
    floor plus noise growing with its motion, the heading's times the step's ``scales``
    (:func:`sparse_step_scales`) and the position's widened by ``loosen`` (metres, per step:
    :mod:`odometry_witness <slam_core.graph.odometry_witness>`) when given."""
    rel = relative(poses[:-1], poses[1:])
    dist = np.hypot(rel[:, 0], rel[:, 1])
    sxy = config.chain_sigma_xy + config.chain_sigma_per_metre * dist
    sth = (config.chain_sigma_th + config.chain_sigma_per_radian * np.abs(rel[:, 2])
           + config.chain_sigma_th_per_metre * dist)
    if scales is not None:
        sth = sth * scales
    vxy = sxy ** 2 if loosen is None else sxy ** 2 + np.asarray(loosen) ** 2
    return vxy, sth ** 2


class ChainDrift:
    """How far the chain of filter steps alone may have drifted between two updates: its
    steps' translation noise (widened by ``loosen``: the filter's step may be that far off) plus
    each step's heading noise (times its ``scales``, when given) swung over the path after it
    (:func:`_chain_variances`); and how far at most once the loop edges found so far tie parts
    of the chain together."""

    def __init__(self, poses: np.ndarray, path: np.ndarray, config: LoopClosureConfig,
                 scales: np.ndarray | None = None, loosen: np.ndarray | None = None):
        vxy, vth = _chain_variances(poses, config, scales, loosen)
        at = path[:-1]  # where each step's heading error starts to swing the path
        self._cum = [np.concatenate([[0.0], np.cumsum(v)]) for v in (vxy, vth, vth * at, vth * at ** 2)]
        self._path = path
        self._xy = poses[:, :2]

    def _variances(self, a, b) -> tuple[np.ndarray, np.ndarray]:
        """Position and heading variances of the later of updates ``a``, ``b`` (arrays broadcast)
        relative to the earlier, along the chain."""
        lo, hi = np.minimum(a, b), np.maximum(a, b)
        xy, th, th_p, th_pp = (c[hi] - c[lo] for c in self._cum)
        p = self._path[hi]
        return xy + np.maximum(p * p * th - 2.0 * p * th_p + th_pp, 0.0), th

    def sigmas(self, a: np.ndarray | int, b: int) -> tuple[np.ndarray, np.ndarray]:
        """``(linear, angular)`` standard errors of update ``b`` relative to update(s) ``a < b``."""
        vxy, vth = self._variances(a, b)
        return np.sqrt(vxy), np.sqrt(vth)

    def since_loops(self, a: np.ndarray, b: int, loops: np.ndarray) -> np.ndarray:
        """The linear standard errors of :meth:`sigmas`, or less where a loop edge ``(i, j)`` of
        ``loops`` (rows) makes a shorter way: the chain from ``a`` to ``i``, the edge (taken as
        exact), the chain from ``j`` to ``b``, the heading error of the first part swinging the
        edge and the last part (over the edge's length plus the path from ``j`` to ``b``). Of
        the edges with one older end, the one whose newer end lies nearest ``b`` along the path
        is taken."""
        vxy, _ = self._variances(a, b)
        if len(loops) == 0:
            return np.sqrt(vxy)
        i, j = loops[:, 0], loops[:, 1]
        gap = np.abs(self._path[j] - self._path[b])
        order = np.lexsort((gap, i))
        keep = order[np.concatenate([[True], np.diff(i[order]) != 0])]
        i, j = i[keep], j[keep]
        lever = gap[keep] + np.hypot(*(self._xy[j] - self._xy[i]).T)
        first_xy, first_th = self._variances(a[:, None], i[None, :])
        last_xy, _ = self._variances(j, b)
        return np.sqrt(np.minimum(vxy, (first_xy + last_xy + first_th * lever * lever).min(axis=1)))


def _witnessed_chain(poses: np.ndarray, config: LoopClosureConfig, loosen: np.ndarray | None = None,
                     witnessed: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """The chain the solve optimises: poses whose steps are the filter's, heard against the steps
    of the odometry's poses ``witnessed`` where ``loosen`` (metres, per step) says the two disagree
    (:func:`witnessed_steps <slam_core.graph.odometry_witness.witnessed_steps>`; ``poses`` itself
    where nothing was heard), and each step's information (:func:`_chain_variances`, its position's
    standard error widened by ``loosen``)."""
    vxy, vth = _chain_variances(poses, config, loosen=loosen)
    if witnessed is None or not np.any(loosen > 0.0):
        return poses, _information(vxy, vth)
    steps, vxy = witnessed_steps(relative(poses[:-1], poses[1:]), vxy,
                                 relative(witnessed[:-1], witnessed[1:]), loosen, config.witness_sigma)
    chain = np.empty_like(poses)
    chain[0] = poses[0]
    for k, step in enumerate(steps):
        chain[k + 1] = compose(chain[k], step)
    return chain, _information(vxy, vth)


def _information(vxy: np.ndarray, vth: np.ndarray) -> np.ndarray:
    """``(n, 3, 3)`` information of steps of position and heading variances ``vxy``, ``vth``."""
    info = np.zeros((len(vxy), 3, 3))
    info[:, 0, 0] = info[:, 1, 1] = 1.0 / vxy
    info[:, 2, 2] = 1.0 / vth
    return info


def loop_edge(anchor: np.ndarray, pose: np.ndarray, information: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The edge ``(z, information)`` from ``anchor`` to a matched ``pose``, both in one map's
    frame, whose ``information`` is the matcher's, on the pose's position in that frame's axes:
    the pose graph's error is in the frame of the measured pose, so the position's block is
    turned into it (a corridor's match knows across the corridor, whichever way it runs)."""
    c, s = np.cos(pose[2]), np.sin(pose[2])
    turn = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])  # the error's axes in the map's
    return relative(anchor, pose), turn.T @ information @ turn


def robust_solve(poses: np.ndarray, chain: np.ndarray, edges: dict, outlier_chi2: float,
                 start: np.ndarray | None = None) -> tuple[np.ndarray, list[tuple[int, int]]]:
    """Optimise the chain of ``poses`` (information ``chain`` per step) with the loop
    ``edges`` ``{(i, j): (z, information)}`` (pose ``j`` seen from pose ``i``, Huber-robust),
    drop the loop edges whose error then exceeds ``outlier_chi2`` and optimise again, each
    time from ``start`` (default: ``poses``; a solve warm-started from an earlier optimum
    converges in fewer steps). Returns the poses and the dropped edges' keys."""
    start = poses if start is None else start
    graph = _graph(poses, chain, edges, start)
    estimate = optimize(graph)
    n = len(poses)
    loops = np.arange(n - 1, graph.n_edges)
    keys = list(edges)
    dropped = [keys[k - (n - 1)] for k in loops[graph.chi2(estimate)[loops] > outlier_chi2]]
    if dropped:
        estimate = optimize(_graph(poses, chain, {k: v for k, v in edges.items() if k not in dropped}, start))
    return estimate, dropped


def _graph(poses, chain, edges, start) -> PoseGraph:
    """The chain of ``poses`` and the loop ``edges``, its nodes at ``start``."""
    graph = PoseGraph(start)
    chain_edges(graph, poses, chain)
    for (i, j), (z, info) in edges.items():
        graph.add_edge(i, j, z, info, robust=True)
    return graph


def _candidates(q: int, estimate: np.ndarray, path: np.ndarray, submaps: Submaps,
                config: LoopClosureConfig) -> list[int]:
    """The nearest submaps (at most ``candidates``) passed long before update ``q``."""
    old = np.flatnonzero(path[q] - path[submaps.ends] >= config.min_loop_path)
    if len(old) == 0:
        return []
    d = submaps.distances(old, estimate, q)
    near = np.argsort(d)[:config.candidates]
    return [int(old[k]) for k in near if d[k] < config.search_radius]


def _drift_reach(sxy: np.ndarray, config: LoopClosureConfig) -> np.ndarray:
    """How far (m) a look-alike may lie, and a wide search looks, for the chain's drift of linear
    standard errors ``sxy``: ``window_sigmas`` of it, within the narrow and the widest windows."""
    return np.clip(config.window_sigmas * sxy, config.linear_window, config.max_linear_window)


def _wide_candidates(q: int, estimate: np.ndarray, path: np.ndarray, submaps: Submaps, drift: ChainDrift,
                     loops: np.ndarray, config: LoopClosureConfig) -> list[tuple[int, float, float]]:
    """``(submap, linear, angular)``: submaps passed long before update ``q`` that the drift
    between them since the ``loops`` found (rows ``(anchor, update)``) may have moved within
    ``search_radius`` of it, with the window that drift asks for: the ``wide_candidates``
    likeliest (where the drift's density is highest) and ``wide_others`` of the rest in turn,
    the next few for each query, so that over a stretch of queries a window wider than the
    submaps' spacing tries every submap in it, not only those the drifted estimate lies near."""
    old = np.flatnonzero(path[q] - path[submaps.ends] >= config.min_loop_path)
    if len(old) == 0:
        return []
    sxy = drift.since_loops(submaps.anchors[old], q, loops)
    _, sth = drift.sigmas(submaps.anchors[old], q)  # the chain's heading drift: loops close it less surely
    linear = _drift_reach(sxy, config)
    angular = np.clip(config.heading_window_sigmas * sth, config.angular_window, config.max_angular_window)
    d = np.hypot(*(estimate[submaps.anchors[old], :2] - estimate[q, :2]).T)
    reachable = np.flatnonzero((d < config.search_radius + linear) & (linear > config.linear_window))
    sigma = np.maximum(sxy[reachable], 1e-9)
    likeliest = reachable[np.argsort(2.0 * np.log(sigma) + 0.5 * (d[reachable] / sigma) ** 2)]
    others = likeliest[config.wide_candidates:]
    if len(others) > config.wide_others:  # more than a query's share: each takes the next few
        others = np.roll(others, -((q // config.wide_every) * config.wide_others % len(others)))
    near = np.concatenate([likeliest[:config.wide_candidates], others[:config.wide_others]])
    return [(int(old[k]), float(linear[k]), float(angular[k])) for k in near]
