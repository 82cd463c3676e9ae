"""Benchmark: what the polish and the verification cost, against the first stage and against a
competent classical fit, in one process.

Run:  python benchmarks/verification.py [--repeat N]

For the cantilever (paper test case 2) and the frame example it times, best of N:

* the first stage alone (homotopy, polish off; verification still runs, it is cheap),
* the full `update()` (homotopy, polish, verification, sensitivities),
* the verification alone at the answer,
* the classical frequency least-squares fit from the nominal model with the exact Jacobian
  and one dense eigen-solve per evaluation (`vibupdate.inverse.baseline.frequency_fit`), the peer a
  competent user would write.

and prints the ratios and the mean frequency errors.
"""

from __future__ import annotations

import argparse
import os
import platform
import time

os.environ.setdefault("OMP_NUM_THREADS", "1")

from vibupdate.inverse.baseline import frequency_fit  # noqa: E402
from vibupdate.inverse.correlation import model_frequencies  # noqa: E402
from vibupdate.examples import cantilever, frame  # noqa: E402
from vibupdate.inverse.polish import PolishOptions  # noqa: E402
from vibupdate.inverse.update import update  # noqa: E402
from vibupdate.inverse.verify import verify  # noqa: E402


def best(fn, repeat):
    times, out = [], None
    for _ in range(repeat):
        t0 = time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - t0)
    return min(times), out


def measure(name, configurations, repeat):
    update(configurations)  # warm-up
    t_first, first = best(lambda: update(configurations, polish=PolishOptions(enabled=False)), repeat)
    t_full, full = best(lambda: update(configurations), repeat)
    nominal = [model_frequencies(c) for c in configurations]

    def checks():
        updated = [model_frequencies(c, full.xbar) for c in configurations]
        return verify(configurations, full.xbar, nominal=nominal, updated=updated,
                      lower_bound=full.relaxation_lower_bound, n_blocks=len(full.vectors))

    t_check, _ = best(checks, repeat)
    t_fit, fit = best(lambda: frequency_fit(configurations), repeat)
    polish_s = full.polish.seconds if full.polish else 0.0
    print(f"\n{name}: {len(configurations)} configuration(s), {configurations[0].model.n_parameters} parameters, "
          f"{configurations[0].model.n_dofs} DOFs")
    print(f"  {'stage':<44} {'seconds':>8} {'mean err %':>10} {'status':>13}")
    print(f"  {'first stage only (polish off)':<44} {t_first:8.3f} {first.mean_error():10.4f} {first.status.value:>13}")
    print(f"  {'update(): first stage + polish + checks':<44} {t_full:8.3f} {full.mean_error():10.4f} "
          f"{full.status.value:>13}")
    print(f"  {'  of which polish':<44} {polish_s:8.3f}")
    print(f"  {'verification alone':<44} {t_check:8.4f}")
    print(f"  {'classical fit (exact Jacobian, eigh)':<44} {t_fit:8.3f} {fit.mean_error_pct:10.4f} "
          f"{fit.n_evaluations:>7d} evals")
    print(f"  ratios: full / first stage {t_full / t_first:.2f}; polish / first stage {polish_s / t_first:.2f}; "
          f"checks / first stage {t_check / t_first:.4f}; full / classical {t_full / t_fit:.2f}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=5, help="runs of each method (best time kept)")
    args = parser.parse_args()
    print(f"machine: {platform.machine()}, {os.cpu_count()} cores, Python {platform.python_version()}")
    measure("cantilever (test case 2)", cantilever.configurations(), args.repeat)
    measure("frame example (Problem 1)", frame.case().configurations, max(1, args.repeat // 2))


if __name__ == "__main__":
    main()
