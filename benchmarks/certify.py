"""Benchmark: certified outer parameter ranges against an inner estimate of the same set,
on the cantilever (paper test case 2) and frame examples, in one process.

Run:  python benchmarks/certify.py [--examples cantilever frame] [--seconds 120]

The cantilever case has no frequency tolerance; its windows would be the answer's misfit
alone (the answer on their edge, S thin), so it is run with +-2 % (holding every misfit of
the answer, up to 1.45 %). The frame uses its case's 0.9 % (3 sigma).

For each example: the first-stage answer; the consistent set S (frequency windows from the
case's tolerance, widened to hold the answer); the inner estimate (local NLP solves at each
parameter's bounds, every point confirmed to lie in S); the linearized ranges at the answer
(`parameter_ranges`, same tolerance); the certified enclosure with its root and its history
under the time budget (bound tightening, then branching); per parameter the widths and the
ratio of certified to inner width; and the root LPs solved three ways (scipy's
linprog/HiGHS cold, highspy warm, Clarabel) with their times and safe bounds. The load
average is printed before and after: the machine is shared.
"""

from __future__ import annotations

import argparse
import os
import time

os.environ.setdefault("OMP_NUM_THREADS", "1")

import numpy as np  # noqa: E402
import scipy.sparse as sp  # noqa: E402

from vibupdate.ranges.certify import enclosure  # noqa: E402
from vibupdate.ranges.lp_relaxation import highs_model, lift, relax, safe_bound, solve, solve_clarabel  # noqa: E402
from vibupdate.ranges.consistent import consistent_set, inner_ranges  # noqa: E402
from vibupdate.ranges.identifiability import parameter_ranges  # noqa: E402
from vibupdate.inverse.update import update  # noqa: E402


def _linprog(lp, c):
    from scipy.optimize import linprog

    up, dn = np.isfinite(lp.hi), np.isfinite(lp.lo)
    res = linprog(c, A_ub=sp.vstack([lp.A[up], -lp.A[dn]], format="csr"),
                  b_ub=np.concatenate([lp.hi[up], -lp.lo[dn]]), bounds=np.column_stack([lp.zl, lp.zu]),
                  method="highs")
    y = np.zeros(lp.A.shape[0])
    y[up] += res.ineqlin.marginals[: int(up.sum())]
    y[dn] -= res.ineqlin.marginals[int(up.sum()):]
    return res.fun, safe_bound(c, lp, y)


def _clarabel(lp, c):
    return solve_clarabel(lp, c)[1:]


def compare_solvers(cs) -> list[str]:
    """The 2 n_x root LPs with each solver: seconds and the mean gap safe bound - optimum."""
    L = lift(cs)
    lp = relax(L, cs.x_lower, cs.x_upper, L.u_lower, L.u_upper)
    h = highs_model(lp)
    rows = []
    for name, method in (("scipy linprog (HiGHS, cold)", _linprog),
                        ("highspy (HiGHS, warm)", lambda lp_, c: solve(lp_, c, h)[1:]),
                        ("Clarabel (interior point)", _clarabel)):
        t0, gaps = time.perf_counter(), []
        for i in range(cs.n_x):
            for sign in (1.0, -1.0):
                c = np.zeros(L.n_z)
                c[i] = sign
                opt, bound = method(lp, c)
                gaps.append(opt - bound)
        rows.append(f"| {name} | {time.perf_counter() - t0:.2f} | {np.max(gaps):.2e} |")
    return rows


TOLERANCE = {"cantilever": 0.02}


def run(example: str, seconds: float) -> None:
    import importlib

    module = importlib.import_module(f"vibupdate.examples.{example}")
    case = module.case()
    t0 = time.perf_counter()
    result = update(case.configurations, formulation=case.formulation, solver=case.solver)
    print(f"\n### {example}: update {time.perf_counter() - t0:.1f} s, status {result.status.value}")
    tol = TOLERANCE.get(example, case.frequency_tolerance)
    cs = consistent_set(case.configurations, frequency_tolerance=tol, include=result.xbar, options=case.formulation)
    print(cs.definition())
    inner = inner_ranges(cs, [result.xbar])
    print(f"inner estimate: {len(inner.points)} points of S, {inner.seconds:.1f} s")
    linear = parameter_ranges(case.configurations, result.xbar, frequency_tolerance=tol)
    history = []
    r = enclosure(cs, seconds=seconds, known=[result.xbar], progress=lambda m: (history.append(m), print(m)))
    lo, hi = cs.models[0].normalized(r.lower), cs.models[0].normalized(r.upper)
    lo, hi = np.minimum(lo, hi), np.maximum(lo, hi)
    rlo, rhi = cs.models[0].normalized(r.root_lower), cs.models[0].normalized(r.root_upper)
    rlo, rhi = np.minimum(rlo, rhi), np.maximum(rlo, rhi)
    contains = all(np.all(lo <= p) and np.all(p <= hi) for p in inner.points)
    print(f"certified: {r.message}; root {r.root_seconds:.1f} s, total {r.seconds:.1f} s, {r.passes} passes, "
          f"{r.splits} splits, {r.leaves} leaves, {r.n_lps} LPs; every inner point inside: {contains}; "
          f"all certified: {bool(np.all(r.certified))}")
    print("| parameter | root width % | certified width % | inner width % | linearized width % | ratio | certified |")
    print("|---|---:|---:|---:|---:|---:|---|")
    ratios = []
    for k, name in enumerate(r.names):
        wi = 100 * (inner.upper[k] - inner.lower[k])
        wc = 100 * (hi[k] - lo[k])
        ratio = wc / wi if wi > 1e-9 else np.inf
        ratios.append(ratio)
        print(f"| {name} | {100 * (rhi[k] - rlo[k]):.3g} | {wc:.3g} | {wi:.3g} | {linear.width_pct[k]:.3g} | "
              f"{ratio:.3g} | {r.certified[k]} |")
    finite = np.array([x for x in ratios if np.isfinite(x)])
    if finite.size:
        print(f"width ratio certified / inner: median {np.median(finite):.3g}, max {finite.max():.3g} "
              f"({len(ratios) - finite.size} parameter(s) with zero inner width)")
    print("| root LPs solved with | seconds | max (optimum - safe bound) |")
    print("|---|---:|---:|")
    for row in compare_solvers(cs):
        print(row)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--examples", nargs="+", default=["cantilever", "frame"])
    parser.add_argument("--seconds", type=float, default=120.0, help="time budget of the bound tightening")
    args = parser.parse_args()
    print(f"load average before: {os.getloadavg()}")
    for example in args.examples:
        run(example, args.seconds)
    print(f"load average after: {os.getloadavg()}")


if __name__ == "__main__":
    main()
