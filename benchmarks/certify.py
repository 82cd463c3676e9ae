"""Benchmark: certified outer parameter ranges against an inner estimate of the same set,
on the cantilever (paper test case 2) and frame examples, in one process.

Run:  python benchmarks/certify.py [--examples cantilever frame] [--seconds 120] [--compare]

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

``--compare`` runs the enclosure twice in the same process under the same budget, first with
the tightening's economies off (`vibupdate.ranges.tightening.BEFORE`: a new Clarabel instance
per LP, a HiGHS re-solve whenever Clarabel's bound is not within 1e-6 of its optimum, vector
entries before parameters, the stall on all widths) and then on (`Tactics()`), and times the
root LPs of all blocks both ways (re-solves counted, bounds compared). ``--ablate`` runs it
with each economy switched in turn (the stall rule on, the others off).
"""

from __future__ import annotations

import argparse
import os
import time

os.environ.setdefault("OMP_NUM_THREADS", "1")

import numpy as np  # noqa: E402
import scipy.sparse as sp  # noqa: E402

from vibupdate.ranges.certify import enclosure  # noqa: E402
from vibupdate.ranges.lp_relaxation import (clarabel_model, highs_model, lift, relax, safe_bound, solve,  # noqa: E402
                                             solve_clarabel)
from vibupdate.ranges.tightening import BEFORE, GAP, Tactics, lifts, root_box, tighten  # noqa: E402
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


def compare_parameter_lps(cs, tactics_list) -> list[str]:
    """The 2 n_x LPs of all blocks, on the box after one pass of bound tightening, as
    `tighten_parameters` solves them under each tactics: seconds, HiGHS re-solves, and the
    largest loss of a bound against the first (strict) rule (normalized units, and relative
    to the parameter's width)."""
    R = lifts(cs)
    box = root_box(cs, R)
    tighten(R, box, np.inf, max_passes=1)
    L, n = R.full, cs.n_x
    lp = relax(L, box.lo[:n], box.hi[:n], box.lo[n:], box.hi[n:])
    rows, strict = [], None
    for name, tac in tactics_list:
        t0, resolves, bounds = time.perf_counter(), 0, []
        cla = clarabel_model(lp) if tac.reuse_solver else None
        h = None
        for i in range(cs.n_x):
            for sign in (1.0, -1.0):
                c = np.zeros(L.n_z)
                c[i] = sign
                status, opt, bound = solve_clarabel(lp, c, cla)
                slack = max(GAP, tac.useful_gap * (box.hi[i] - box.lo[i]))
                if status == "optimal" and not bound >= opt - slack:
                    if tac.reuse_solver and h is None:
                        h = highs_model(lp)
                    status, opt, bound = solve(lp, c, h)
                    resolves += 1
                bounds.append(bound)
        seconds = time.perf_counter() - t0
        bounds = np.array(bounds)
        if strict is None:
            strict = bounds
        width = np.repeat(np.maximum(box.hi[:n] - box.lo[:n], 1e-300), 2)
        loss = strict - bounds
        rows.append(f"| {name} | {seconds:.2f} | {resolves} | {np.max(loss):.2e} | {np.max(loss / width):.2e} |")
    return rows


def compare(cs, known, seconds: float, variants) -> dict:
    """The enclosure under the same budget with each of ``variants`` (label, Tactics), in
    turn in the same process."""
    print("| root LPs of all blocks | seconds | HiGHS re-solves | max bound loss | relative to width |")
    print("|---|---:|---:|---:|---:|")
    for row in compare_parameter_lps(cs, [("before (new Clarabel per LP, strict re-solve)", BEFORE),
                                          ("after (one Clarabel, useful_gap 1e-3)", Tactics())]):
        print(row)
    results = {}
    for name, tac in variants:
        load = os.getloadavg()[0]
        r = enclosure(cs, seconds=seconds, known=known, tactics=tac)
        results[name] = r
        print(f"{name}: load {load:.1f}; {r.message}; root {r.root_seconds:.1f} s, {r.passes} passes, "
              f"{r.splits} splits, {r.leaves} leaves, {r.n_lps} LPs; all certified {bool(np.all(r.certified))}")
    return results


TOLERANCE = {"cantilever": 0.02}


def run(example: str, seconds: float, compare_tactics: bool = False, ablate: bool = False) -> None:
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
    if compare_tactics or ablate:
        variants = [("before", BEFORE), ("after", Tactics())] if not ablate else [
            ("after, parameters not first", Tactics(parameters_first=False)),
            ("after, stall on parameter widths", Tactics(parameter_stall=True)),
            ("after, strict re-solve", Tactics(useful_gap=0.0))]
        both = compare(cs, [result.xbar], seconds, variants)
        model = cs.models[0]
        print("| parameter | inner width % | " + " | ".join(f"{v} width % | ratio" for v, _ in variants)
              + " | certified |")
        print("|---|---:|" + "---:|---:|" * len(variants) + "---|")
        for k, name in enumerate(next(iter(both.values())).names):
            wi = 100 * (inner.upper[k] - inner.lower[k])
            cells = []
            for r in both.values():
                lo, hi = model.normalized(r.lower)[k], model.normalized(r.upper)[k]
                wc = 100 * abs(hi - lo)
                cells.append(f"{wc:.3g} | {wc / wi if wi > 1e-9 else np.inf:.3g}")
            flags = " / ".join(str(r.certified[k]) for r in both.values())
            print(f"| {name} | {wi:.3g} | " + " | ".join(cells) + f" | {flags} |")
        for label, r in both.items():
            lo, hi = model.normalized(r.lower), model.normalized(r.upper)
            lo, hi = np.minimum(lo, hi), np.maximum(lo, hi)
            ok = all(np.all(lo <= p) and np.all(p <= hi) for p in inner.points)
            print(f"{label}: every inner point inside: {ok}")
        return
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
    parser.add_argument("--compare", action="store_true",
                        help="the enclosure with the tightening's economies off, then on, same budget")
    parser.add_argument("--ablate", action="store_true",
                        help="the enclosure with each default switched in turn, same budget")
    args = parser.parse_args()
    print(f"load average before: {os.getloadavg()}")
    for example in args.examples:
        run(example, args.seconds, args.compare, args.ablate)
    print(f"load average after: {os.getloadavg()}")


if __name__ == "__main__":
    main()
