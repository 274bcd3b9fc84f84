"""The relation error of Kümmerle et al. 2009, "On measuring the accuracy of SLAM algorithms".

A relation ``(t1, t2, dx, dy, dtheta)`` states the true pose at ``t2`` in the frame
of the true pose at ``t1``. For each relation the estimated poses nearest in time
to ``t1`` and ``t2`` (within ``max_dt`` seconds) give ``delta = X(t1)^-1 * X(t2)``;
the translational error is ``|t - t*|`` in metres and the rotational error
``|wrap(theta - theta*)|`` in degrees.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from slam_core.geometry import relative, wrap_angle

#: The benchmark's tolerance when matching relation times to trajectory times.
MAX_DT = 0.1


def load_relations(path) -> np.ndarray:
    """Relations ``(n, 5)``: ``t1 t2 x y yaw`` from lines ``t1 t2 x y z roll pitch yaw``."""
    rows = []
    with open(path) as f:
        for number, line in enumerate(f, 1):
            fields = line.split()
            if not fields or fields[0].startswith("#"):
                continue
            if len(fields) != 8:
                raise ValueError(f"{path}:{number}: expected 8 fields "
                                 f"(t1 t2 x y z roll pitch yaw), got {len(fields)}")
            try:
                v = [float(x) for x in fields]
            except ValueError as exc:
                raise ValueError(f"{path}:{number}: {exc}") from exc
            rows.append([v[0], v[1], v[2], v[3], v[7]])
    return np.array(rows, dtype=float).reshape(-1, 5)


@dataclass(frozen=True)
class RelationError:
    trans: np.ndarray  # metres, one per matched relation
    rot: np.ndarray  # degrees
    unmatched: int

    @property
    def count(self) -> int:
        return len(self.trans)

    def summary(self) -> dict:
        def stats(v):
            std = float(np.std(v, ddof=1)) if len(v) > 1 else 0.0
            return float(np.mean(v)), std, float(np.mean(v ** 2))

        tm, ts, tsq = stats(self.trans)
        rm, rs, rsq = stats(self.rot)
        return {"relations": self.count, "unmatched": self.unmatched,
                "trans_mean_m": tm, "trans_std_m": ts, "trans_sq_m2": tsq,
                "rot_mean_deg": rm, "rot_std_deg": rs, "rot_sq_deg2": rsq}

    def report(self) -> str:
        s = self.summary()
        return (f"relations: {s['relations']} matched, {s['unmatched']} unmatched\n"
                f"translational: {s['trans_mean_m']:.4f} ± {s['trans_std_m']:.4f} m "
                f"(squared {s['trans_sq_m2']:.4f} m²)\n"
                f"rotational:    {s['rot_mean_deg']:.3f} ± {s['rot_std_deg']:.3f} deg "
                f"(squared {s['rot_sq_deg2']:.3f} deg²)")


def nearest_indices(times: np.ndarray, queries: np.ndarray, max_dt: float = MAX_DT) -> np.ndarray:
    """Index of the time nearest each query, or -1 where none is within ``max_dt``."""
    order = np.argsort(times, kind="stable")
    sorted_t = times[order]
    pos = np.clip(np.searchsorted(sorted_t, queries), 1, len(sorted_t) - 1)
    left, right = sorted_t[pos - 1], sorted_t[pos]
    pick = np.where(np.abs(queries - left) <= np.abs(right - queries), pos - 1, pos)
    best = order[pick]
    return np.where(np.abs(times[best] - queries) <= max_dt, best, -1)


def relation_error(times, poses, relations, max_dt: float = MAX_DT) -> RelationError:
    """Score a trajectory (``times (n,)``, ``poses (n, 3)``) against relations ``(m, 5)``."""
    times = np.asarray(times, dtype=float)
    poses = np.asarray(poses, dtype=float)
    if len(times) < 2:
        raise ValueError("trajectory needs at least two poses")
    i1 = nearest_indices(times, relations[:, 0], max_dt)
    i2 = nearest_indices(times, relations[:, 1], max_dt)
    ok = (i1 >= 0) & (i2 >= 0)
    delta = relative(poses[i1[ok]], poses[i2[ok]])
    rel = relations[ok]
    trans = np.hypot(delta[:, 0] - rel[:, 2], delta[:, 1] - rel[:, 3])
    rot = np.degrees(np.abs(wrap_angle(delta[:, 2] - rel[:, 4])))
    return RelationError(trans, rot, int((~ok).sum()))


def evaluate_files(trajectory_path, relations_path) -> RelationError:
    from slam_core.io.trajectory import Trajectory

    traj = Trajectory.load(trajectory_path)
    return relation_error(traj.times, traj.poses, load_relations(Path(relations_path)))
