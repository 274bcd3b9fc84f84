"""Landmark EKF: time per update against the number of landmarks (the O(k²) growth), cold/warm start.

    python benchmarks/ekf.py [--max-landmarks 400] [--repeats 20]

A state with k landmarks (dense, correlated covariance) gets a joint update with OBS observations
of known landmarks; we time the update, the association (gating table) and a prediction.
"""

from __future__ import annotations

import argparse
import platform
import time

import numpy as np

from slam_core.ekf.association import associate
from slam_core.ekf.models import observe
from slam_core.ekf.state import EkfState

OBS = 5
R = np.diag([0.05 ** 2, 0.01 ** 2])


def make_state(k: int, rng) -> EkfState:
    state = EkfState((0.0, 0.0, 0.0), np.diag([0.01, 0.01, 0.001]))
    for _ in range(k):
        state.add_landmark(np.array([rng.uniform(1, 8), rng.uniform(-np.pi, np.pi)]), R)
        state.predict(np.array([0.0, 0.0, 0.0]), np.diag([1e-4, 1e-4, 1e-5]))  # correlate them
    return state


def timed(fn, repeats: int) -> float:
    best = np.inf
    for _ in range(repeats):
        t = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - t)
    return best


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--max-landmarks", type=int, default=400)
    ap.add_argument("--repeats", type=int, default=20)
    args = ap.parse_args()
    rng = np.random.default_rng(0)
    print(f"python {platform.python_version()}, numpy {np.__version__}; best of {args.repeats}")
    print(f"{'landmarks':>9} {'state':>6} {'update ms':>10} {'assoc ms':>9} {'predict ms':>11} "
          f"{'update/k^2 ns':>14}")
    ks = [k for k in (10, 25, 50, 100, 200, 300, 400, 600, 800) if k <= args.max_landmarks]
    for k in ks:
        state = make_state(k, rng)
        idx = rng.choice(k, OBS, replace=False)
        z = np.array([observe(state.mean[:3], state.mean[3 + 2 * j:5 + 2 * j])[0] for j in idx])
        rs = np.repeat(R[None], OBS, axis=0)
        mean, cov = state.mean.copy(), state.cov.copy()

        def update(state=state, idx=idx, z=z, rs=rs, mean=mean, cov=cov):
            state.mean, state.cov = mean.copy(), cov.copy()
            state.update(idx, z, rs)

        copy_only = timed(lambda mean=mean, cov=cov: (mean.copy(), cov.copy()), args.repeats)
        t_update = timed(update, args.repeats) - copy_only
        t_assoc = timed(lambda state=state, z=z, rs=rs: associate(state, z, rs), args.repeats)
        t_pred = timed(lambda state=state: state.predict(np.array([0.1, 0.0, 0.01]),
                                                         np.eye(3) * 1e-4), args.repeats)
        print(f"{k:>9} {3 + 2 * k:>6} {1e3 * t_update:>10.3f} {1e3 * t_assoc:>9.3f} "
              f"{1e3 * t_pred:>11.3f} {1e9 * t_update / k ** 2:>14.1f}")


if __name__ == "__main__":
    main()
