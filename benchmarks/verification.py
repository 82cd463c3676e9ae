"""Benchmark: what the polish and the verification cost, against the first stage and against a
competent classical fit, in one process.

Run:  python benchmarks/verification.py [--repeat N]

For the cantilever (paper test case 2) and the frame example it times, best of N:

* the first `update()` in the process (it compiles the CasADi solver of the problem's
  structure; later calls find it in the process-level cache),
* the first stage alone (homotopy, polish off; verification still runs, it is cheap),
* the full `update()` (homotopy, polish, verification, sensitivities),
* the verification alone at the answer,
* `update()` with the previous defaults (the stepped path 0, 0.1, 0.3, 0.7, 1 and the
  ``lam = 0`` relaxation by IPOPT instead of the QP solver), for the ratio before/after,
* the classical frequency least-squares fit from the nominal model with the exact Jacobian
  and one dense eigen-solve per evaluation (`vibupdate.inverse.baseline.frequency_fit`), the peer a
  competent user would write.

and prints the ratios to the classical fit and the mean frequency errors. The best-of-N runs
of `update()`, the first stage and the classical fit are interleaved, so that a change of
load on a shared machine hits them alike.
"""

from __future__ import annotations

import argparse
import os
import platform
import time

os.environ.setdefault("OMP_NUM_THREADS", "1")

from vibupdate.inverse.baseline import frequency_fit  # noqa: E402
from vibupdate.inverse.correlation import model_frequencies  # noqa: E402
from vibupdate.inverse.homotopy import SolverOptions  # noqa: E402
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


def interleaved(fns, repeat):
    """Best of ``repeat`` of each function, the runs interleaved (A B A B ...) so that a change
    of the machine's load between them hits every function alike. Returns the best wall
    times, the best CPU times of this process (single-threaded work: on a shared machine they
    leave out the time spent waiting for a core) and the last outputs."""
    times = [[] for _ in fns]
    cpu = [[] for _ in fns]
    outs = [None] * len(fns)
    for _ in range(repeat):
        for i, fn in enumerate(fns):
            t0, c0 = time.perf_counter(), time.process_time()
            outs[i] = fn()
            times[i].append(time.perf_counter() - t0)
            cpu[i].append(time.process_time() - c0)
    return [min(t) for t in times], [min(c) for c in cpu], outs


def measure(name, configurations, repeat):
    from vibupdate.inverse.backends.casadi_ipopt import CACHE

    # First call in this process for this structure: includes compiling the solver.
    t0 = time.perf_counter()
    fit = frequency_fit(configurations)
    t_fit_first = time.perf_counter() - t0
    builds = CACHE.builds
    t0 = time.perf_counter()
    full = update(configurations)
    t_cold = time.perf_counter() - t0
    compiled = CACHE.builds - builds
    previous = SolverOptions(n_lambda=10, step_growth=2.0, relaxation_solver="nlp")
    (t_full, t_first, t_prev, t_fit), (c_full, c_first, c_prev, c_fit), (full, first, prev, fit) = interleaved(
        [lambda: update(configurations), lambda: update(configurations, polish=PolishOptions(enabled=False)),
         lambda: update(configurations, solver=previous), lambda: frequency_fit(configurations)], repeat)
    nominal = [model_frequencies(c) for c in configurations]

    def checks():
        updated = [model_frequencies(c, full.xbar) for c in configurations]
        return verify(configurations, full.xbar, nominal=nominal, updated=updated,
                      lower_bound=full.relaxation_lower_bound, n_blocks=len(full.vectors))

    t_check, _ = best(checks, repeat)
    polish_s = full.polish.seconds if full.polish else 0.0
    solves = sum(s.seconds for s in full.steps)
    iterations = sum(s.iterations for s in full.steps)
    print(f"\n{name}: {len(configurations)} configuration(s), {configurations[0].model.n_parameters} parameters, "
          f"{configurations[0].model.n_dofs} DOFs; load average {os.getloadavg()[0]:.1f}")
    print(f"  {'stage':<48} {'seconds':>8} {'mean err %':>10} {'status':>13}")
    print(f"  {'update(), first call (solver compiled: ' + str(compiled) + ')':<48} {t_cold:8.3f}")
    print(f"  {'first stage only (polish off)':<48} {t_first:8.3f} {first.mean_error():10.4f} {first.status.value:>13}")
    print(f"  {'update(): first stage + polish + checks':<48} {t_full:8.3f} {full.mean_error():10.4f} "
          f"{full.status.value:>13}")
    print(f"  {'  of which step solves (' + str(len(full.steps)) + ' solves, ' + str(iterations) + ' it.)':<48} "
          f"{solves:8.3f}")
    for s in full.steps:
        print(f"  {'    lambda = ' + format(s.lam, '.3f') + ': ' + str(s.iterations) + ' it., ' + s.status.value:<48} "
              f"{s.seconds:8.3f}")
    print(f"  {'  of which polish':<48} {polish_s:8.3f}")
    print(f"  {'verification alone':<48} {t_check:8.4f}")
    prev_solves = sum(s.seconds for s in prev.steps)
    print(f"  {'update(), previous path (0 .. 0.7, 1; lam = 0 by IPOPT)':<48} {t_prev:8.3f} {prev.mean_error():10.4f} "
          f"{prev.status.value:>13}")
    print(f"  {'  of which step solves (' + str(len(prev.steps)) + ' solves, ' + str(sum(s.iterations for s in prev.steps)) + ' it.)':<48} "
          f"{prev_solves:8.3f}")
    print(f"  {'classical fit (exact Jacobian, eigh)':<48} {t_fit:8.3f} {fit.mean_error_pct:10.4f} "
          f"{fit.n_evaluations:>7d} evals")
    print(f"  ratios to the classical fit: update() first call {t_cold / t_fit:.2f} (fit's own first call "
          f"{t_fit_first:.3f} s), update() best of {repeat} {t_full / t_fit:.2f}, first stage {t_first / t_fit:.2f}, "
          f"step solves {solves / t_fit:.2f}, polish {polish_s / t_fit:.2f}; previous path {t_prev / t_fit:.2f}")
    print(f"  CPU seconds, best of {repeat}: update() {c_full:.3f}, first stage {c_first:.3f}, classical fit "
          f"{c_fit:.3f}, previous path {c_prev:.3f}; update() / classical fit {c_full / c_fit:.2f}, previous path / "
          f"classical fit {c_prev / c_fit:.2f}")
    print(f"  first-stage xbar: {' '.join(f'{v:.4f}' for v in full.first_stage_xbar)}; objective {full.objective:.6e}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=5, help="runs of each method (best time kept)")
    args = parser.parse_args()
    print(f"machine: {platform.machine()}, {os.cpu_count()} cores, Python {platform.python_version()}")
    measure("cantilever (test case 2)", cantilever.configurations(), args.repeat)
    measure("frame example (Problem 1)", frame.case().configurations, max(1, args.repeat // 2))


if __name__ == "__main__":
    main()
