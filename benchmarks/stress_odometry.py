"""Benchmark: the stress logs again with wheel odometry they were never run with.

Every stress log carries one synthetic odometry (its README's error model, one seed), so a
change can fit that one draw without anyone noticing. This benchmark draws fresh ones from
the same model and runs ``homebot slam`` on each: a systematic heading drift of 0.15-0.3 deg a
metre (random sign), a rotation and a translation scale error (2 % standard deviation), and
random noise per step as large as the log's own odometry shows (its residuals once the
systematic errors are fitted out). ``--faults`` adds what the README says these logs lack:
drift up to 2.5x as large, slips (a step's travel off by 10-40 %) and heading kicks (2-6 deg)
on 1 % of the steps each.

Prints a row per log and draw: the drawn errors, the raw odometry's relation error, the
result's and the best particle's alone, loop edges, wall and CPU seconds, peak RSS.

    python benchmarks/stress_odometry.py [--logs belgioioso fhw ...] [--draws 1 2] [--faults]
        [--seed 0] [--stress-dir ../shared/datasets/stress]
"""

from __future__ import annotations

import argparse
import bz2
import json
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from slam_core.evaluation import load_relations, relation_error  # noqa: E402
from slam_core.geometry import wrap_angle  # noqa: E402

STRESS_LOGS = ("belgioioso", "fhw", "freiburg-101", "freiburg-campus", "orebro", "seattle")
STRESS_DIR = ROOT.parent / "shared" / "datasets" / "stress"
#: Share of steps with a slip, and with a heading kick, when faults are drawn.
FAULT_RATE = 0.01


def robot_steps(poses: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(dx, dy, dtheta)`` of each step in the frame of the pose it starts from."""
    d = np.diff(poses[:, :2], axis=0)
    c, s = np.cos(poses[:-1, 2]), np.sin(poses[:-1, 2])
    return c * d[:, 0] + s * d[:, 1], -s * d[:, 0] + c * d[:, 1], wrap_angle(np.diff(poses[:, 2]))


def chain(dx: np.ndarray, dy: np.ndarray, dth: np.ndarray) -> np.ndarray:
    """Poses from the origin along the steps."""
    out = np.zeros((len(dx) + 1, 3))
    for i in range(len(dx)):
        c, s = np.cos(out[i, 2]), np.sin(out[i, 2])
        out[i + 1] = out[i, 0] + c * dx[i] - s * dy[i], out[i, 1] + s * dx[i] + c * dy[i], \
            wrap_angle(out[i, 2] + dth[i])
    return out


def noise_levels(truth: np.ndarray, odometry: np.ndarray) -> tuple[float, float, float]:
    """Per-step noise of a log's own odometry: heading noise per radian turned and per metre, and
    travel noise per metre (mean absolute residuals once scale and drift are fitted out, as
    standard deviations of a Gaussian)."""
    tx, ty, tth = robot_steps(truth)
    ox, oy, oth = robot_steps(odometry)
    travel = np.hypot(tx, ty)
    turn_err = wrap_angle(oth - tth)
    a = np.column_stack([travel, tth])
    turn_left = turn_err - a @ np.linalg.lstsq(a, turn_err, rcond=None)[0]
    along = np.hypot(ox, oy) - travel
    along_left = along - travel * (along @ travel) / (travel @ travel)
    gauss = np.sqrt(np.pi / 2)  # E|x| = sigma sqrt(2 / pi)
    k_turn, k_metre = np.clip(np.linalg.lstsq(np.column_stack([np.abs(tth), travel]),
                                              np.abs(turn_left) * gauss, rcond=None)[0], 0.0, None)
    k_travel = max(float((np.abs(along_left) * gauss) @ travel / (travel @ travel)), 0.0)
    return float(k_turn), float(k_metre), k_travel


def draw_odometry(truth: np.ndarray, levels, rng: np.random.Generator,
                  faults: bool) -> tuple[np.ndarray, dict]:
    """A fresh odometry along the true poses, and the systematic errors drawn."""
    tx, ty, tth = robot_steps(truth)
    travel = np.hypot(tx, ty)
    n = len(tth)
    k_turn, k_metre, k_travel = levels
    larger = rng.uniform(1.0, 2.5) if faults else 1.0
    drift = np.radians(rng.uniform(0.15, 0.3) * larger) * rng.choice([-1, 1])
    turn_scale, travel_scale = rng.normal(0.0, 0.02, 2)
    dth = tth * (1 + turn_scale) + drift * travel + rng.normal(0, 1, n) * (k_turn * np.abs(tth)
                                                                                  + k_metre * travel)
    scale = 1 + travel_scale + rng.normal(0, 1, n) * k_travel
    if faults:
        slip = rng.random(n) < FAULT_RATE
        scale = np.where(slip, scale * (1 + rng.choice([-1, 1], n) * rng.uniform(0.1, 0.4, n)), scale)
        kick = rng.random(n) < FAULT_RATE
        dth = dth + np.where(kick, np.radians(rng.uniform(2, 6, n)) * rng.choice([-1, 1], n), 0.0)
    drawn = {"drift_deg_per_m": np.degrees(drift), "turn_scale": turn_scale, "travel_scale": travel_scale}
    return chain(tx * scale, ty * scale, dth), drawn


def flaser_poses(lines: list[str]) -> np.ndarray:
    rows = []
    for line in lines:
        if line.startswith("FLASER "):
            f = line.split()
            n = int(f[1])
            rows.append([float(v) for v in f[n + 2:n + 5]])
    return np.array(rows)


def with_odometry(lines: list[str], odometry: np.ndarray) -> list[str]:
    """The log's lines with every FLASER line's laser and odometry poses replaced."""
    out, k = [], 0
    for line in lines:
        if line.startswith("FLASER "):
            f = line.split()
            n = int(f[1])
            f[n + 2:n + 8] = [f"{v:.6f}" for v in (*odometry[k], *odometry[k])]
            line = " ".join(f)
            k += 1
        out.append(line)
    return out


def translational(times: np.ndarray, poses: np.ndarray, relations: np.ndarray) -> float:
    return float(relation_error(times, poses, relations).trans.mean())


def trajectory(path: Path) -> tuple[np.ndarray, np.ndarray]:
    data = np.loadtxt(path, usecols=(0, 1, 2, 3), ndmin=2)
    return data[:, 0], data[:, 1:]


def run(name: str, draw: int, args, workdir: Path) -> str:
    folder = args.stress_dir / name
    with bz2.open(folder / f"{name}.clf.bz2", "rt") as f:
        lines = f.read().splitlines()
    truth = np.loadtxt(folder / f"{name}.gt", comments="#", ndmin=2)
    relations = load_relations(folder / f"{name}.relations")
    rng = np.random.default_rng([draw, STRESS_LOGS.index(name), int(args.faults)])
    odometry, drawn = draw_odometry(truth[:, 1:4], noise_levels(truth[:, 1:4], flaser_poses(lines)), rng,
                                    args.faults)
    log = workdir / f"{name}-{draw}.clf.bz2"
    with bz2.open(log, "wt") as f:
        f.write("\n".join(with_odometry(lines, odometry)) + "\n")
    out = workdir / f"{name}-{draw}"
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    started = time.perf_counter()
    subprocess.run([sys.executable, "-m", "app.cli", "slam", str(log), "--out", str(out), "--seed",
                    str(args.seed)], cwd=ROOT, check=True, capture_output=True, text=True)
    wall = time.perf_counter() - started
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = after.ru_utime + after.ru_stime - before.ru_utime - before.ru_stime
    stats = json.loads((out / "stats.json").read_text())
    result = translational(*trajectory(out / "trajectory.txt"), relations)
    alone = translational(*trajectory(out / "particle_trajectory.txt"), relations)
    raw = translational(truth[:, 0], odometry, relations)
    return (f"| {name} | {draw} | {drawn['drift_deg_per_m']:+.2f} / {drawn['turn_scale']:+.3f} / "
            f"{drawn['travel_scale']:+.3f} | {raw:.3f} | **{result:.4f}** | {alone:.4f} | "
            f"{stats['loop_edges']} ({stats['rejected_loop_edges']}) | {wall:.1f} | {cpu:.1f} | "
            f"{stats['peak_rss_mb']:.0f} |")


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--logs", nargs="+", default=list(STRESS_LOGS), choices=STRESS_LOGS)
    p.add_argument("--draws", nargs="+", type=int, default=[1, 2], help="odometry draws (seeds of the draw)")
    p.add_argument("--faults", action="store_true", help="larger drift, slips and heading kicks")
    p.add_argument("--seed", type=int, default=0, help="the filter's seed")
    p.add_argument("--stress-dir", type=Path, default=STRESS_DIR)
    args = p.parse_args()
    print(f"faults: {'yes' if args.faults else 'no'}; filter seed {args.seed}")
    print("| log | draw | drift deg/m / turn scale / travel scale | raw odometry m | translational m | "
          "best particle alone m | loop edges (rejected) | wall s | CPU s | peak RSS MB |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    with tempfile.TemporaryDirectory() as tmp:
        for name in args.logs:
            for draw in args.draws:
                print(run(name, draw, args, Path(tmp)), flush=True)


if __name__ == "__main__":
    main()
