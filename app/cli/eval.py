"""``homebot eval TRAJECTORY RELATIONS``: the relation error of Kümmerle et al. 2009."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from app.cli.inputs import text_file
from slam_core.datasets import resolve_relations
from slam_core.evaluation import MAX_DT, load_relations, relation_error
from slam_core.io.carmen import MAX_POSE_VALUE
from slam_core.io.trajectory import Trajectory


def register(sub) -> None:
    p = sub.add_parser("eval", help="score a trajectory against ground-truth relations",
                       description="Relation error (Kümmerle et al. 2009) of a per-scan trajectory "
                                   "file ('ipc_timestamp x y theta' lines).")
    p.add_argument("trajectory", type=Path, help="trajectory file written by homebot slam/map")
    p.add_argument("relations", help="relations file, or a bundled log's name (intel, mit-csail)")
    p.add_argument("--json", action="store_true", help="print the figures as JSON")
    p.set_defaults(run=run)


def _sane(values: np.ndarray) -> bool:
    """Finite and no farther than any robot travels (as a log's poses must be)."""
    return bool(np.isfinite(values).all() and (np.abs(values) <= MAX_POSE_VALUE).all())


def run(args) -> int:
    trajectory = Trajectory.load(text_file(args.trajectory))
    if len(trajectory.poses) < 2 or not _sane(trajectory.poses):
        raise ValueError(f"{args.trajectory}: need at least two poses, all finite and within "
                         f"±{MAX_POSE_VALUE:g}")
    relations_path = text_file(resolve_relations(args.relations))
    relations = load_relations(relations_path)
    if not (np.isfinite(relations).all() and _sane(relations[:, 2:])):
        raise ValueError(f"{relations_path}: relations must be finite, their motions within "
                         f"±{MAX_POSE_VALUE:g}")
    result = relation_error(trajectory.times, trajectory.poses, relations)
    if result.count == 0:
        raise ValueError(f"{relations_path}: no relation matches a pose of {args.trajectory}")
    if args.json:
        print(json.dumps(result.summary(), indent=2))
    else:
        print(result.report())
        print(f"(poses matched to relation times within {MAX_DT} s)")
    return 0
