"""Benchmark: the scan matcher's kernel alone, on particle maps captured from a real log.

Runs the filter over the first updates of a log, keeping a copy of what the improved
proposal was given every ``--every`` updates (the particles' tables, the tile pool, the
hit sums, the start poses, the beams), then times ``scan_matcher.match`` on every particle
of every copy, in process CPU seconds, single-threaded; prints the best and all repeats.
It uses whatever ``slam_core`` is imported, so the same command compares two commits
(``PYTHONPATH=<other checkout>``, run from outside both).

    python benchmarks/match_kernel.py [--log mit-csail] [--every 150] [--copies 8] [--repeats 5]
"""

from __future__ import annotations

import argparse
import copy
import time

import slam_core.rbpf.filter as rbpf_filter
from slam_core.datasets import resolve_log
from slam_core.pipelines.log_slam import slam_from_log
from slam_core.rbpf.scan_matcher import match


class _Enough(Exception):
    """Raised inside the filter once every copy is taken."""


def capture(log: str, every: int, copies: int) -> list[dict]:
    """Copies of the improved proposal's map and matching inputs every ``every`` updates."""
    proposal = rbpf_filter.improved_proposal
    taken: list[dict] = []
    calls = [0]

    def spy(tables, lo, hits, origin_x, origin_y, resolution, prev, starts, motion, alphas, beams, params,
            iterations, wide_iterations, *rest):
        calls[0] += 1
        if calls[0] % every == 0:
            taken.append({"map": copy.deepcopy((tables, lo, hits, origin_x, origin_y, resolution)),
                          "starts": starts.copy(), "beams": beams.copy(), "params": params.copy(),
                          "iterations": iterations, "wide_iterations": wide_iterations})
            if len(taken) == copies:
                raise _Enough
        return proposal(tables, lo, hits, origin_x, origin_y, resolution, prev, starts, motion, alphas, beams,
                        params, iterations, wide_iterations, *rest)

    rbpf_filter.improved_proposal = spy
    try:
        slam_from_log(resolve_log(log))
    except _Enough:
        pass
    finally:
        rbpf_filter.improved_proposal = proposal
    return taken


def match_all(taken: list[dict]) -> list[tuple]:
    """``match`` from every particle's start pose on every copy."""
    out = []
    for c in taken:
        tables, lo, hits, origin_x, origin_y, resolution = c["map"]
        for p, (x, y, th) in enumerate(c["starts"]):
            out.append(match(tables[p], lo, hits, origin_x, origin_y, resolution, x, y, th, c["beams"],
                             c["params"], c["iterations"], c["wide_iterations"]))
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--log", default="mit-csail")
    parser.add_argument("--every", type=int, default=150)
    parser.add_argument("--copies", type=int, default=8)
    parser.add_argument("--repeats", type=int, default=5)
    args = parser.parse_args()
    taken = capture(args.log, args.every, args.copies)
    first = match_all(taken)  # compiled (or loaded from the cache) here
    times = []
    for _ in range(args.repeats):
        started = time.process_time()
        again = match_all(taken)
        times.append(time.process_time() - started)
        assert all(a[:3] == b[:3] for a, b in zip(first, again, strict=True))
    print(f"{rbpf_filter.__file__}: {len(first)} matches on {len(taken)} copies of {args.log} "
          f"(every {args.every} updates): best {min(times):.3f} s CPU, "
          f"repeats {' '.join(f'{t:.3f}' for t in times)}")


if __name__ == "__main__":
    main()
