"""Sweep of the cantilever on a LocalCluster: 2 workers against 1 worker, and per-task overhead.

Run: ``PYTHONPATH=src python benchmarks/sweep.py [--samples 200] [--tolerance 0.005]``.
Prints the wall time of the task phase (cluster start-up excluded) for 1 and 2 workers, the
speed-up (target >= 1.6x), the machine load, and the per-task overhead: the time a sample
spends building its problem and compiling its CasADi solver (the measured frequencies enter
the NLP as constants, so a compiled solver cannot be reused across samples), and the Dask
overhead per task (wall x workers minus the time inside the tasks, per task).
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import tempfile
import time
from pathlib import Path

import numpy as np

CASE = Path(__file__).resolve().parents[1] / "examples" / "cantilever" / "case.toml"


def build_overhead(tolerance: float, repeats: int = 3) -> dict:
    """Seconds to formulate a sample and compile its solver, against a whole sample."""
    from vibupdate.io.case import load_case
    from vibupdate.study.multistart import build_solver
    from vibupdate.study.sampling import SamplingOptions
    from vibupdate.study.sweep import run_sample

    case = load_case(CASE)
    from dataclasses import replace

    case = replace(case, frequency_tolerance=tolerance)
    sampling = SamplingOptions()
    build, whole = [], []
    for i in range(repeats):
        t = time.perf_counter()
        build_solver(case.configurations, case.formulation, case.solver)
        build.append(time.perf_counter() - t)
        whole.append(run_sample(case, i, 0, sampling)["seconds"])
    # one sample builds twice: the homotopy's solver and the random start's solver
    return {"build_seconds": float(np.median(build)), "sample_seconds": float(np.median(whole)),
            "build_share": float(2 * np.median(build) / np.median(whole))}


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
