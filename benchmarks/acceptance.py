"""Known-truth acceptance over many problems of every family: what fails today, by class.

Run: ``PYTHONPATH=src python benchmarks/acceptance.py --profile ci|dev|full|held-out
[--family NAME ...] [--cases N] [--skip K] [--workers 1] [--routes cli api] [--json FILE]
[--compromise] [--against FILE]``
(``--cases``: the first N seeds of each family of the profile; ``--skip K`` leaves out the first
K), or, for the random family alone, ``--cases 500 [--seed 0] [--named]``.

A profile (`acceptance.criteria.PROFILES`) is a set of seeds per family: ``ci`` the test suite's,
``dev`` the development profile, ``full`` over 2,000 runs, ``held-out`` seeds kept out of
development and run only at the end of a change. Each problem runs through ``vibupdate run``
(in-process) and ``vibupdate.update`` and is judged (`acceptance.runner`, `acceptance.judge`).
Prints the per-family summary with the judge's excused classes, every criterion of
`acceptance.criteria` with its measured value and limit, markdown tables per class (family,
structure, problem kind, exact or noisy data, determinacy at the truth, route): runs, the share
ending ``success`` and ``not_verified``, the counts of each defect, the median time per run; then
the case ids of every failure class. ``--json`` writes every verdict; ``--against FILE`` (a
``--json`` file of another run) compares, per family, the share verified and the share right by
the family's meaning (`acceptance.criteria.right`), with the sampling error of each difference. The exit code is 1 when a
criterion fails.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from collections import defaultdict
from pathlib import Path

os.environ.setdefault("OMP_NUM_THREADS", "1")   # before numpy loads its BLAS: one thread per worker process
import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))

COLUMNS = ("runs", "success %", "not_verified %", "path failed %", "crash", "refused", "outside",
           "determined miss (other solution)", "truth outside reported", "damping", "worse than nominal", "median s")


def _one(args) -> list[dict]:
    family, index, routes, compromise = args
    from acceptance import criteria as C
    from acceptance import runner as R

    try:
        problem = C.FAMILIES[family].make(index)
        if compromise:
            from dataclasses import replace

            problem = replace(problem, compromise=True)
    except Exception as exc:   # a generator failure is reported, not hidden
        return [{"case": f"{family}{index}", "route": "engine", "family": family, "status": "engine_error",
                 "exit_code": None, "seconds": 0.0, "failures": ["engine_error"], "excused": [],
                 "details": [f"{type(exc).__name__}: {exc}"]}]
    try:
        return [v.as_dict() for v in R.run_problem(problem, routes=routes)]
    except Exception as exc:   # a judge failure likewise
        return [{"case": problem.case_id, "route": "engine", **problem.classes(), "determinacy": "?",
                 "status": "engine_error", "exit_code": None, "seconds": 0.0, "failures": ["engine_error"],
                 "excused": [], "details": [f"{type(exc).__name__}: {exc}"]}]


def _row(rows: list[dict]) -> list[str]:
    n = len(rows)

    def count(code):
        return sum(code in r["failures"] for r in rows)

    ok = sum(r["status"] in ("success", "not_unique") for r in rows)
    nv = sum(r["status"] == "not_verified" for r in rows)
    return [str(n), f"{100 * ok / n:.1f}", f"{100 * nv / n:.1f}", f"{100 * count('path_failed') / n:.1f}",
            str(count("crash")), str(count("refused") + count("exit_code")), str(count("outside") + count("report")),
            f"{count('determined_miss')} ({count('other_solution')})", str(count("truth_outside_reported")),
            str(count("damping_fit") + count("damping_truth") + count("damping_unwarned")),
            str(count("worse_than_nominal")), f"{np.median([r['seconds'] for r in rows]):.2f}"]


def tables(rows: list[dict]) -> str:
    """Markdown tables per class dimension (module docstring)."""
    out = []
    for dim in ("family", "structure", "kind", "data", "determinacy", "route"):
        groups = defaultdict(list)
        for r in rows:
            groups[str(r.get(dim))].append(r)
        out.append(f"| {dim} | " + " | ".join(COLUMNS) + " |")
        out.append("|---" * (len(COLUMNS) + 1) + "|")
        for key in sorted(groups):
            out.append(f"| {key} | " + " | ".join(_row(groups[key])) + " |")
        out.append(f"| **all** | " + " | ".join(_row(rows)) + " |")
        out.append("")
    return "\n".join(out)


def defects(rows: list[dict], limit: int = 12) -> str:
    """Case ids of each failure class, with the first detail of one of them."""
    by = defaultdict(list)
    for r in rows:
        for f in r["failures"]:
            by[f].append(r)
    lines = []
    for code in sorted(by):
        ids = sorted({f"{r['case']}" for r in by[code]}, key=lambda s: (len(s), s))
        example, detail = by[code][0], ""
        for r in by[code]:
            found = [d for d in r["details"] if d.startswith(code + ":")]
            if found:
                example, detail = r, found[0]
                break
        lines.append(f"- `{code}` ({len(by[code])} runs): {', '.join(ids[:limit])}"
                     + (" ..." if len(ids) > limit else "") + (f" - e.g. {example['case']} [{example['route']}]: "
                                                               f"{detail[:220]}" if detail else ""))
    return "\n".join(lines)


def _verdicts(rows: list[dict]):
    """The rows as `acceptance.judge.Verdict` s, for `acceptance.criteria`."""
    from acceptance.judge import Verdict

    keys = ("case", "route", "status", "exit_code", "seconds", "failures", "excused", "details", "diagnosis",
            "compromise")
    return [Verdict(r["case"], r["route"], {k: v for k, v in r.items() if k not in keys}, r["status"],
                    r["exit_code"], r["seconds"], list(r["failures"]), list(r.get("excused", [])),
                    list(r["details"]), tuple(r.get("diagnosis") or ()), r.get("compromise")) for r in rows]


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--profile", choices=["ci", "dev", "full", "held-out"], default=None)
    parser.add_argument("--family", nargs="+", default=None, help="only these families of the profile")
    parser.add_argument("--cases", type=int, default=None, help="random problems seed .. seed + cases - 1; with "
                        "--profile, the first CASES seeds of each family")
    parser.add_argument("--seed", type=int, default=0, help="first seed (with --cases)")
    parser.add_argument("--skip", type=int, default=0, help="with --profile, leave out the first SKIP seeds of "
                        "each family (with --cases N: seeds SKIP+1 .. N of each family)")
    parser.add_argument("--workers", type=int, default=1)
    parser.add_argument("--routes", nargs="+", default=["cli", "api"], choices=["cli", "api"])
    parser.add_argument("--named", action="store_true", help="also the named problems (with --cases)")
    parser.add_argument("--json", default=None, help="write every verdict to this file")
    parser.add_argument("--against", default=None, help="a --json file of another run (e.g. the development "
                        "seeds): per family, both runs' verified and right shares and their differences")
    parser.add_argument("--compromise", action="store_true", help="the judge's least-squares compromise on every "
                        "problem (each run's time and misfit against it, per family), not only where a family asks")
    args = parser.parse_args(argv)
    from acceptance import criteria as C

    routes = tuple(args.routes)
    if args.profile is not None:
        seeds = {f: list(s)[args.skip:args.cases] for f, s in C.PROFILES[args.profile].items()}
        jobs = [(f, s, routes, args.compromise) for f, s in C.profile_jobs(args.profile)
                if (not args.family or f in args.family) and s in seeds[f]]
        title = f"profile {args.profile}" + (f", seeds {args.skip + 1} to {args.cases or 'last'} of each family"
                                             if args.cases or args.skip else "")
    else:
        cases = 500 if args.cases is None else args.cases
        jobs = [("random", s, routes, args.compromise) for s in range(args.seed, args.seed + cases)]
        jobs += [("named", i, routes, args.compromise) for i in range(9)] if args.named else []
        title = f"random seeds {args.seed}..{args.seed + cases - 1}" + (", named" if args.named else "")
    if not jobs:
        parser.error(f"no problem selected (--cases {args.cases} with --skip {args.skip}: the seeds kept are "
                     f"SKIP+1 .. CASES of each family; --family {' '.join(args.family or []) or 'any'})")
    start = time.perf_counter()
    results = []

    def done(result):
        results.append(result)
        print(f"{len(results)}/{len(jobs)} problems, {time.perf_counter() - start:.0f} s", file=sys.stderr, flush=True)

    if args.workers > 1:
        from multiprocessing import get_context

        with get_context("spawn").Pool(args.workers) as pool:
            for result in pool.imap_unordered(_one, jobs, chunksize=1):
                done(result)
    else:
        for job in jobs:
            done(_one(job))
    rows = [r for rs in results for r in rs]
    wall = time.perf_counter() - start
    print(f"{title}: {len(jobs)} problems, {len(rows)} runs, {wall:.0f} s wall, {args.workers} worker(s)\n")
    verdicts = _verdicts([r for r in rows if r["route"] != "engine"])
    print(C.summary(verdicts) + "\n")
    findings = C.check(verdicts, C.FAMILIES)
    engine = [r for r in rows if r["route"] == "engine"]
    print("\n".join("- " + f.line() for f in findings if not (f.ok and f.criterion.startswith("defect"))))
    print(f"- engine errors: {len(engine)}" + (f" ({', '.join(r['case'] for r in engine[:8])})" if engine else "") + "\n")
    print(tables(rows))
    print(defects(rows))
    if args.against:
        those = json.loads(Path(args.against).read_text())
        print(f"\nAgainst {args.against} (right: `acceptance.criteria.right`, the family's meaning of a right answer):\n")
        print(C.compare(verdicts, _verdicts([r for r in those if r["route"] != "engine"]), C.FAMILIES))
    if args.json:
        Path(args.json).write_text(json.dumps(rows, indent=1, default=str))
    return 1 if engine or not all(f.ok for f in findings) else 0


if __name__ == "__main__":
    sys.exit(main())
