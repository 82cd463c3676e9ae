"""Benchmark: homotopy first stage vs the classical frequency least-squares fit on the
cantilever of paper test case 2, in one process.

Run:  python benchmarks/cantilever.py [--repeat N]

Prints mean frequency error and seconds of both methods and their time ratio. The homotopy
time includes building the CasADi/IPOPT solver.
"""

from __future__ import annotations

import argparse
import os
import platform
import time

os.environ.setdefault("OMP_NUM_THREADS", "1")

import numpy as np  # noqa: E402

from vibupdate.inverse.baseline import frequency_fit  # noqa: E402
from vibupdate.examples import cantilever  # noqa: E402
from vibupdate.inverse.update import update  # noqa: E402


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=3, help="runs of each method (best time kept)")
    args = parser.parse_args()
    configurations = cantilever.configurations()
    update(configurations)  # warm-up: imports and first CasADi build
    homotopy_times, classical_times = [], []
    for _ in range(args.repeat):
        t0 = time.perf_counter()
        result = update(configurations)
        homotopy_times.append(time.perf_counter() - t0)
        fit = frequency_fit(configurations)
        classical_times.append(fit.seconds)
    th, tc = min(homotopy_times), min(classical_times)
    print(f"machine: {platform.machine()}, {os.cpu_count()} cores, Python {platform.python_version()}")
    print(f"{'method':<36} {'mean error %':>12} {'seconds':>9}")
    print(f"{'homotopy (this project, 10 steps)':<36} {result.mean_error():12.3f} {th:9.3f}")
    print(f"{'classical least_squares (scipy trf)':<36} {fit.mean_error_pct:12.3f} {tc:9.3f}")
    print(f"{'paper (Table 5)':<36} {0.6:12.3f} {'-':>9}")
    print(f"time ratio homotopy / classical: {th / tc:.2f}  (status {result.status.value}, "
          f"{fit.n_evaluations} model evaluations in the classical fit)")
    print(f"homotopy parameters: {np.array2string(result.values, precision=4)}")
    print(f"classical parameters: {np.array2string(fit.values, precision=4)}")


if __name__ == "__main__":
    main()
