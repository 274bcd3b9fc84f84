"""Point landmarks extracted from one 2D scan: "spikes" and corners.

1. The valid beams are cut into clusters of contiguous points with the adaptive
   breakpoint detector of Borges & Aldon (2004): consecutive points further apart
   than ``r·sin(Δφ)/sin(λ-Δφ) + 3σ`` start a new cluster.
2. Spikes: a small cluster (table leg, door post, chair leg) standing clearly in
   front of both its neighbours with no other scan point nearby; the landmark
   is the post's centre, estimated from the mean point and the post's radius.
3. Corners: each cluster is split into line segments by iterative end-point fit
   (split-and-merge, Nguyen et al. 2005); two consecutive segments that are long
   enough, meet at a clear angle and are at most a few beams apart give a
   corner at the intersection of their total-least-squares lines.
4. Lines: the long segments of step 3 themselves, as infinite lines in normal
   form ``(ρ, α)`` fitted by total least squares, with the covariance of the fit
   and the segment's end points (for the overlap check of the association).
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass

import numpy as np

from slam_core.jit import njit
from slam_core.scan import Scan

SPIKE = 0
CORNER = 1
LINE = 2


@dataclass(frozen=True)
class ExtractorConfig:
    """Tunables of the extractor (metres, radians)."""

    max_range: float = 8.0  # features further away are too uncertain
    breakpoint_lambda: float = np.radians(10.0)  # Borges & Aldon's worst incidence angle
    range_sigma: float = 0.01  # sensor range noise, for the breakpoint threshold
    spike_max_width: float = 0.25  # widest object still read as a spike
    spike_min_depth: float = 0.3  # both neighbours must be this much further away
    spike_min_beams: int = 3  # real 0.5-degree scans; a coarse (1-degree) lidar needs 1
    spike_clearance: float = 0.4  # no other scan point this close (rejects dotted grazing walls)
    spike_radius: float = 0.0  # expected radius of posts (m), when the scan is too coarse to tell
    spikes: bool = True
    corners: bool = True
    split_threshold: float = 0.04  # max point-to-line distance inside one segment
    segment_min_points: int = 4
    segment_min_length: float = 0.15
    corner_min_angle: float = np.radians(50.0)  # smallest acute angle between the two walls
    corner_max_gap: float = 0.15  # intersection to the segments' facing end points
    corner_max_skip: int = 4  # beams of rounded corner allowed between the two segments
    lines: bool = True
    line_min_points: int = 12
    line_min_length: float = 1.0  # shorter segments constrain the heading too little
    line_max_range: float = 10.0  # points further away are left out of the lines
    line_merge_angle: float = np.radians(3.0)  # segments of one scan this close in angle ...
    line_merge_distance: float = 0.1  # ... and distance (m) are one wall (split by a door, the seam)


@dataclass(frozen=True)
class Features:
    """Landmarks seen in one scan: sensor-frame points ``(k, 2)``, kinds (SPIKE / CORNER) and,
    for corners, the sensor-frame bearing of the bisector between the two walls (NaN for spikes)."""

    points: np.ndarray
    kinds: np.ndarray
    directions: np.ndarray

    def __len__(self) -> int:
        return len(self.points)


@njit
def _cluster_labels(ranges, angles, valid, sin_lambda_rad, lambda_rad, three_sigma, labels):
    label = -1
    last = -1
    for i in range(ranges.shape[0]):
        if not valid[i]:
            labels[i] = -1
            last = -1
            continue
        if last < 0:
            label += 1
        else:
            dphi = abs(angles[i] - angles[last])
            limit = ranges[last] * np.sin(dphi) / max(np.sin(lambda_rad - dphi), 1e-3 * sin_lambda_rad)
            dx = ranges[i] * np.cos(angles[i]) - ranges[last] * np.cos(angles[last])
            dy = ranges[i] * np.sin(angles[i]) - ranges[last] * np.sin(angles[last])
            if np.sqrt(dx * dx + dy * dy) > limit + three_sigma:
                label += 1
        labels[i] = label
        last = i


def clusters(scan: Scan, config: ExtractorConfig) -> list[np.ndarray]:
    """Beam indices of runs of contiguous valid points (adaptive breakpoints)."""
    labels = np.empty(len(scan), dtype=np.int64)
    lam = float(config.breakpoint_lambda)
    _cluster_labels(scan.ranges, scan.angles, scan.valid, np.sin(lam), lam, 3.0 * config.range_sigma, labels)
    idx = np.flatnonzero(labels >= 0)
    if len(idx) == 0:
        return []
    cuts = np.flatnonzero(np.diff(labels[idx]) != 0) + 1
    return np.split(idx, cuts)


def spikes(scan: Scan, runs: list[np.ndarray], config: ExtractorConfig) -> np.ndarray:
    """Mean points ``(k, 2)`` of small clusters standing in front of both neighbours."""
    r, a = scan.ranges, scan.angles
    valid = scan.valid
    n = len(r)
    out = []
    for run in runs:
        first, last = run[0], run[-1]
        if len(run) < config.spike_min_beams or first == 0 or last == n - 1:
            continue
        pts = np.column_stack([r[run] * np.cos(a[run]), r[run] * np.sin(a[run])])
        if np.hypot(*(pts[-1] - pts[0])) > config.spike_max_width:
            continue
        near = r[run].max()
        if near > config.max_range:
            continue
        behind = [not valid[k] or r[k] > near + config.spike_min_depth for k in (first - 1, last + 1)]
        # the visible arc of a round post: its mean lies (1 - π/4)·radius behind the front, the
        # centre a full radius behind it, so push the mean back by π/4·radius along the beam
        mean = pts.mean(axis=0)
        radius = max(0.5 * np.hypot(*(pts[-1] - pts[0])), config.spike_radius)
        centre = mean + (np.pi / 4) * radius * mean / max(np.hypot(*mean), 1e-12)
        others = np.ones(n, dtype=bool)
        others[run] = False
        others &= valid
        gaps = np.hypot(r[others] * np.cos(a[others]) - centre[0], r[others] * np.sin(a[others]) - centre[1])
        if all(behind) and (len(gaps) == 0 or gaps.min() > config.spike_clearance):
            out.append(centre)
    return np.array(out).reshape(-1, 2)


def split_segments(points: np.ndarray, threshold: float) -> list[tuple[int, int]]:
    """Iterative end-point fit: index ranges ``[a, b]`` (inclusive, sharing split points)."""
    out = []
    stack = [(0, len(points) - 1)]
    while stack:
        a, b = stack.pop()
        if b - a < 2:
            out.append((a, b))
            continue
        p, q = points[a], points[b]
        d = q - p
        norm = np.hypot(*d)
        seg = points[a + 1:b] - p
        dist = np.abs(seg[:, 0] * d[1] - seg[:, 1] * d[0]) / max(norm, 1e-12)
        k = int(np.argmax(dist))
        if dist[k] > threshold:
            split = a + 1 + k
            stack.append((split, b))
            stack.append((a, split))
        else:
            out.append((a, b))
    return sorted(out)


def fit_line(points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Total least squares line: ``(centroid, unit direction)``."""
    c = points.mean(axis=0)
    d = points - c
    sxx, syy, sxy = d[:, 0] @ d[:, 0], d[:, 1] @ d[:, 1], d[:, 0] @ d[:, 1]
    angle = 0.5 * np.arctan2(2.0 * sxy, sxx - syy)  # principal axis of the scatter
    return c, np.array([np.cos(angle), np.sin(angle)])


def corners(scan: Scan, runs: list[np.ndarray], config: ExtractorConfig) -> tuple[np.ndarray, np.ndarray]:
    """Intersections ``(k, 2)`` of consecutive wall segments meeting at a clear angle, and the
    direction ``(k,)`` of the bisector from the corner between the two walls."""
    r, a = scan.ranges, scan.angles
    out, directions = [], []
    for run in runs:
        if len(run) < 2 * config.segment_min_points - 1:
            continue
        pts = np.column_stack([r[run] * np.cos(a[run]), r[run] * np.sin(a[run])])
        segs = [(a0, b0) for a0, b0 in split_segments(pts, config.split_threshold)
                if _long_enough(pts[a0:b0 + 1], config)]
        for (a0, b0), (a1, b1) in itertools.pairwise(segs):
            if a1 - b0 > config.corner_max_skip:
                continue
            first, second = pts[a0:b0 + 1], pts[a1:b1 + 1]
            c0, d0 = fit_line(first)
            c1, d1 = fit_line(second)
            cross = d0[0] * d1[1] - d0[1] * d1[0]
            angle = np.arccos(np.clip(abs(d0 @ d1), 0.0, 1.0))  # 0..90 deg between the lines
            if angle < config.corner_min_angle:
                continue
            t = ((c1 - c0)[0] * d1[1] - (c1 - c0)[1] * d1[0]) / cross
            corner = c0 + t * d0
            if max(np.hypot(*(corner - pts[b0])), np.hypot(*(corner - pts[a1]))) > config.corner_max_gap:
                continue
            if np.hypot(*corner) <= config.max_range:
                out.append(corner)
                wall0 = _unit(first[0] - corner)
                wall1 = _unit(second[-1] - corner)
                bisector = wall0 + wall1
                directions.append(np.arctan2(bisector[1], bisector[0]))
    return np.array(out).reshape(-1, 2), np.array(directions)


@dataclass(frozen=True)
class Lines:
    """Lines seen in one scan, in the frame of their points: normal form ``(ρ >= 0, α)`` ``(k, 2)``,
    covariances ``(k, 2, 2)`` and the segments' end points ``(k, 2, 2)``."""

    params: np.ndarray
    covariances: np.ndarray
    ends: np.ndarray

    def __len__(self) -> int:
        return len(self.params)

    @classmethod
    def empty(cls) -> Lines:
        return cls(np.zeros((0, 2)), np.zeros((0, 2, 2)), np.zeros((0, 2, 2)))


def line_segments(scan: Scan, config: ExtractorConfig | None = None,
                  runs: list[np.ndarray] | None = None) -> list[np.ndarray]:
    """Sensor-frame points ``(n, 2)`` of each long straight segment of the scan (split-and-merge),
    from the points within ``line_max_range`` (a run is cut where it leaves that range)."""
    config = config or ExtractorConfig()
    runs = clusters(scan, config) if runs is None else runs
    r, a = scan.ranges, scan.angles
    out = []
    for run in runs:
        near = run[r[run] <= config.line_max_range]
        for piece in np.split(near, np.flatnonzero(np.diff(near) > 1) + 1):
            if len(piece) < config.line_min_points:
                continue
            pts = np.column_stack([r[piece] * np.cos(a[piece]), r[piece] * np.sin(a[piece])])
            for a0, b0 in split_segments(pts, config.split_threshold):
                seg = pts[a0:b0 + 1]
                long = np.hypot(*(seg[-1] - seg[0])) >= config.line_min_length
                if len(seg) >= config.line_min_points and long:
                    out.append(seg)
    return merge_collinear(out, config.line_merge_angle, config.line_merge_distance)


def merge_collinear(segments: list[np.ndarray], max_angle: float, max_distance: float) -> list[np.ndarray]:
    """Join segments lying on one line (the "merge" of split-and-merge, across gaps as well): two
    segments are joined when their fitted lines differ by less than ``max_angle`` and each one's
    points lie within ``max_distance`` of the other's line on average; repeated until none is."""
    segments = list(segments)
    merged = True
    while merged:
        merged = False
        fits = [fit_line(seg) for seg in segments]
        for i, j in itertools.combinations(range(len(segments)), 2):
            (ci, di), (cj, dj) = fits[i], fits[j]
            if np.arccos(np.clip(abs(di @ dj), 0.0, 1.0)) > max_angle:
                continue
            ni, nj = np.array([-di[1], di[0]]), np.array([-dj[1], dj[0]])
            if (abs((segments[j] - ci) @ ni).mean() < max_distance
                    and abs((segments[i] - cj) @ nj).mean() < max_distance):
                segments[i] = np.vstack([segments[i], segments[j]])
                del segments[j]
                merged = True
                break
    return segments


def fit_lines(segments: list[np.ndarray], sigma_floor: float = 0.0,
              effective_points: int | None = None) -> Lines:
    """Total-least-squares normal form of each segment with the covariance of the fit.

    With ``d`` the line direction and ``tᵢ = pᵢ·d``, a point noise ``σ`` across the line gives
    ``var α = σ² / Σ(tᵢ - t̄)²`` and, since the fit passes through the centroid,
    ``ρ = ρ_c + t̄ δα``: ``var ρ = σ²/n + t̄² var α``, ``cov(ρ, α) = t̄ var α``. ``σ`` is the fit's
    residual std (at least ``sigma_floor``); ``effective_points`` caps ``n`` (scan errors along
    a wall are correlated, so n points carry less than n independent measurements).
    """
    if not segments:
        return Lines.empty()
    params, covs, ends = [], [], []
    for seg in segments:
        c, d = fit_line(seg)
        normal = np.array([d[1], -d[0]])
        rho = float(normal @ c)
        if rho < 0:
            normal, rho = -normal, -rho
        alpha = float(np.arctan2(normal[1], normal[0]))
        direction = np.array([-normal[1], normal[0]])
        t = seg @ direction
        resid = seg @ normal - rho
        n = len(seg)
        dof = max(n - 2, 1)
        sigma2 = max(float(resid @ resid) / dof, sigma_floor ** 2)
        n_eff = n if effective_points is None else min(n, effective_points)
        spread = float(((t - t.mean()) ** 2).sum()) * n_eff / n
        var_a = sigma2 / max(spread, 1e-12)
        t_bar = float(t.mean())
        covs.append([[sigma2 / n_eff + t_bar * t_bar * var_a, t_bar * var_a], [t_bar * var_a, var_a]])
        params.append([rho, alpha])
        ends.append([seg[np.argmin(t)], seg[np.argmax(t)]])
    return Lines(np.array(params), np.array(covs), np.array(ends))


def _unit(v: np.ndarray) -> np.ndarray:
    return v / max(np.hypot(*v), 1e-12)


def _long_enough(points: np.ndarray, config: ExtractorConfig) -> bool:
    return len(points) >= config.segment_min_points and (
        np.hypot(*(points[-1] - points[0])) >= config.segment_min_length)


def extract(scan: Scan, config: ExtractorConfig | None = None) -> Features:
    """All spikes and corners of a scan, in the sensor frame."""
    config = config or ExtractorConfig()
    runs = clusters(scan, config)
    parts, kinds, directions = [np.zeros((0, 2))], [np.zeros(0, dtype=int)], [np.zeros(0)]
    if config.spikes:
        s = spikes(scan, runs, config)
        parts.append(s)
        kinds.append(np.full(len(s), SPIKE))
        directions.append(np.full(len(s), np.nan))
    if config.corners:
        c, d = corners(scan, runs, config)
        parts.append(c)
        kinds.append(np.full(len(c), CORNER))
        directions.append(d)
    return Features(np.vstack(parts), np.concatenate(kinds).astype(int), np.concatenate(directions))
