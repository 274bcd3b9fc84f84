"""PNG picture of a landmark map: landmarks with covariance ellipses, the trajectory, optional scan points."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from PIL import Image, ImageDraw

from slam_core.io.caption import draw_caption

#: Ellipses are drawn at this many standard deviations (chi-square 2 dof: 3 sigma ~ 98.9 %).
ELLIPSE_SIGMAS = 3.0
ELLIPSE_POINTS = 36
#: With a trajectory, the picture shows what lies at most this far (m) beyond it.
REACH_M = 5.0


def ellipse_outline(mean, cov, sigmas: float = ELLIPSE_SIGMAS, n: int = ELLIPSE_POINTS) -> np.ndarray:
    """``(n, 2)`` points of the ``sigmas``-sigma ellipse of a 2D Gaussian."""
    vals, vecs = np.linalg.eigh(np.asarray(cov, float))
    t = np.linspace(0.0, 2.0 * np.pi, n)
    circle = np.column_stack([np.cos(t), np.sin(t)]) * (sigmas * np.sqrt(np.maximum(vals, 0.0)))
    return np.asarray(mean, float) + circle @ vecs.T


def drawn_extent(trajectory, others, margin: float, reach: float = REACH_M) -> tuple[np.ndarray, np.ndarray]:
    """``(lo, hi)`` corners of the picture: all points ``(m, 2)`` plus ``margin``, but with a
    trajectory ``(n, 2)`` no more than ``reach`` beyond it, so far landmarks do not shrink the rest."""
    trajectory = np.asarray(trajectory, float).reshape(-1, 2)
    everything = np.vstack([trajectory, np.asarray(others, float).reshape(-1, 2)])
    if not len(everything):
        everything = np.zeros((1, 2))
    lo, hi = everything.min(axis=0) - margin, everything.max(axis=0) + margin
    if len(trajectory):
        lo = np.maximum(lo, trajectory.min(axis=0) - reach)
        hi = np.minimum(hi, trajectory.max(axis=0) + reach)
    return lo, hi


def save_landmark_png(path, landmarks, covariances, trajectory=None, points=None,
                      resolution: float = 0.05, margin: float = 2.0, caption: str | None = None,
                      segments=None) -> Path:
    """Draw landmarks ``(k, 2)`` with their ellipses, a trajectory ``(n, 2+)``, grey points ``(p, 2)``
    and wall segments ``(l, 2, 2)`` (end points), within :func:`drawn_extent`."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    landmarks = np.asarray(landmarks, float).reshape(-1, 2)
    parts = [landmarks]
    if points is not None:
        parts.append(np.asarray(points, float).reshape(-1, 2))
    segments = np.zeros((0, 2, 2)) if segments is None else np.asarray(segments, float).reshape(-1, 2, 2)
    parts.append(segments.reshape(-1, 2))
    path_xy = np.zeros((0, 2)) if trajectory is None else np.asarray(trajectory, float)[:, :2]
    lo, hi = drawn_extent(path_xy, np.vstack(parts), margin)
    width, height = (np.ceil((hi - lo) / resolution).astype(int) + 1).tolist()
    img = Image.new("RGB", (width, height), (255, 255, 255))
    draw = ImageDraw.Draw(img)

    def px(xy):
        xy = np.atleast_2d(xy)
        return [(float((p[0] - lo[0]) / resolution), float(height - 1 - (p[1] - lo[1]) / resolution))
                for p in xy]

    if points is not None:
        for p in px(points):
            draw.point(p, fill=(150, 150, 150))
    for ends in segments:
        draw.line(px(ends), fill=(20, 130, 20), width=2)
    if trajectory is not None and len(trajectory) > 1:
        draw.line(px(np.asarray(trajectory)[:, :2]), fill=(220, 30, 30), width=1)
    for mean, cov in zip(landmarks, np.asarray(covariances, float).reshape(-1, 2, 2), strict=True):
        draw.line(px(ellipse_outline(mean, cov)), fill=(30, 60, 200), width=1)
        (cx, cy), = px(mean)
        draw.rectangle((cx - 1, cy - 1, cx + 1, cy + 1), fill=(0, 0, 120))
    if caption:
        draw_caption(draw, (4, 4), caption, (20, 20, 160))
    img.save(path)
    return path
