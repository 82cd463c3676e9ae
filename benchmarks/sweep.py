"""Sweep of the cantilever on a LocalCluster: 2 workers against 1 worker, and per-task overhead.

Run: ``PYTHONPATH=src python benchmarks/sweep.py [--samples 200] [--tolerance 0.005]``.
Prints the wall time of the task phase (cluster start-up excluded) for 1 and 2 workers, the
speed-up (target >= 1.6x), the machine load, and the per-task overhead: the time a sample
spends compiling its CasADi solver (a sample with the process's solver cache empty against the
same sample with it warm: the data are NLP parameters, so a worker compiles once), and the Dask
overhead per task (wall x workers minus the time inside the tasks, per task).
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import tempfile
from pathlib import Path

import numpy as np

CASE = Path(__file__).resolve().parents[1] / "examples" / "cantilever" / "case.toml"


def build_overhead(tolerance: float, repeats: int = 3) -> dict:
    """Seconds of one sample with the process's solver cache empty (the sample compiles its
    CasADi solver, as every task did before the cache) and of the same sample with the cache
    warm (what every later task of a worker costs), medians of ``repeats``."""
    from dataclasses import replace

    from vibupdate.inverse.backends.casadi_ipopt import CACHE
    from vibupdate.io.case import load_case
    from vibupdate.study.sampling import SamplingOptions
    from vibupdate.study.sweep import run_sample

    case = replace(load_case(CASE), frequency_tolerance=tolerance)
    sampling = SamplingOptions()
    run_sample(case, 0, 0, sampling)  # imports and first-call costs out of the way
    cold, warm = [], []
    for i in range(repeats):
        CACHE.clear()
        cold.append(run_sample(case, i, 0, sampling)["seconds"])
        builds = CACHE.builds
        warm.append(run_sample(case, i, 0, sampling)["seconds"])
        assert CACHE.builds == builds
    cold_s, warm_s = float(np.median(cold)), float(np.median(warm))
    return {"sample_cold_cache_seconds": cold_s, "sample_warm_cache_seconds": warm_s,
            "build_share_of_cold_sample": (cold_s - warm_s) / cold_s}


def timed_sweep(samples: int, workers: int, tolerance: float) -> dict:
    from vibupdate.study.sampling import SamplingOptions
    from vibupdate.study.sweep import run_sweep

    out = Path(tempfile.mkdtemp(prefix="vibupdate-bench-")) / "s"
    try:
        summary = run_sweep(str(CASE), out, samples, seed=0, workers=workers, plots=False,
                            sampling=SamplingOptions(frequency_tolerance=tolerance))
        return {**summary.document["timing"], "verified": summary.verified, "failed": summary.failed}
    finally:
        shutil.rmtree(out.parent, ignore_errors=True)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--samples", type=int, default=200)
    parser.add_argument("--tolerance", type=float, default=0.005)
    args = parser.parse_args()
    load_before = os.getloadavg()
    overhead = build_overhead(args.tolerance)
    print("build:", json.dumps(overhead), flush=True)
    one = timed_sweep(args.samples, 1, args.tolerance)
    print("1 worker:", json.dumps(one), "load", os.getloadavg(), flush=True)
    two = timed_sweep(args.samples, 2, args.tolerance)
    print("2 workers:", json.dumps(two), "load", os.getloadavg(), flush=True)
    load_after = os.getloadavg()
    speedup = one["task_phase_wall_seconds"] / two["task_phase_wall_seconds"]
    report = {"samples": args.samples, "cores": os.cpu_count(), "load_before": load_before,
              "load_after": load_after, "one_worker": one, "two_workers": two, "speedup": speedup,
              "build": overhead}
    print(json.dumps(report, indent=2))
    print(f"speed-up 2 workers vs 1: {speedup:.2f}x (target >= 1.6x); load average {load_before[0]:.1f} -> "
          f"{load_after[0]:.1f} on {os.cpu_count()} cores")


if __name__ == "__main__":
    main()
