"""``homebot eval TRAJECTORY RELATIONS``: the relation error of Kümmerle et al. 2009."""

from __future__ import annotations

import json
from pathlib import Path

from slam_core.datasets import resolve_relations
from slam_core.evaluation import MAX_DT, evaluate_files


def register(sub) -> None:
    p = sub.add_parser("eval", help="score a trajectory against ground-truth relations",
                       description="Relation error (Kümmerle et al. 2009) of a per-scan trajectory "
                                   "file ('ipc_timestamp x y theta' lines).")
    p.add_argument("trajectory", type=Path, help="trajectory file written by homebot slam/map")
    p.add_argument("relations", help="relations file, or a bundled log's name (intel, mit-csail)")
    p.add_argument("--json", action="store_true", help="print the figures as JSON")
    p.set_defaults(run=run)


def run(args) -> int:
    result = evaluate_files(args.trajectory, resolve_relations(args.relations))
    if args.json:
        print(json.dumps(result.summary(), indent=2))
    else:
        print(result.report())
        print(f"(poses matched to relation times within {MAX_DT} s)")
    return 0
