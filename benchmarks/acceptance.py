"""Known-truth acceptance over many random problems: what fails today, by class.

Run: ``PYTHONPATH=src python benchmarks/acceptance.py [--cases 500] [--seed 0] [--workers 1]
[--routes cli api] [--json FILE]``.

Draws problems ``seed .. seed + cases - 1`` of `acceptance.generator.random_problem` (plus the
named problems with ``--named``), runs each through ``vibupdate run`` (in-process) and
``vibupdate.update`` and judges them (`acceptance.runner`). Prints markdown tables per class
(structure, problem kind, exact or noisy data, determinacy at the truth, route): runs, the share
ending ``success`` and ``not_verified``, and the counts of each defect (crash or internal error,
valid input refused, success with a datum outside its interval, determined parameter outside
its consistent range, truth outside a reported range), with the median time per run; then the
case ids of every defect class. ``--json`` writes every verdict.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from collections import defaultdict
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))

COLUMNS = ("runs", "success %", "not_verified %", "path failed %", "crash", "refused", "outside",
           "determined miss (other solution)", "truth outside reported", "median s")


def _one(args) -> list[dict]:
    index, routes, named = args
    os.environ.setdefault("OMP_NUM_THREADS", "1")
    from acceptance import generator as G
    from acceptance import runner as R

    try:
        problem = G.named_problems()[index]() if named else G.random_problem(index)
    except Exception as exc:   # a generator failure is reported, not hidden
        return [{"case": f"r{index}", "route": "engine", "status": "engine_error", "exit_code": None,
                 "seconds": 0.0, "failures": ["engine_error"], "details": [f"{type(exc).__name__}: {exc}"]}]
    try:
        return [v.as_dict() for v in R.run_problem(problem, routes=routes)]
    except Exception as exc:   # a judge failure likewise
        return [{"case": problem.case_id, "route": "engine", **problem.classes(), "determinacy": "?",
                 "status": "engine_error", "exit_code": None, "seconds": 0.0, "failures": ["engine_error"],
                 "details": [f"{type(exc).__name__}: {exc}"]}]


def _row(rows: list[dict]) -> list[str]:
    n = len(rows)

    def count(code):
        return sum(code in r["failures"] for r in rows)

    ok = sum(r["status"] in ("success", "acceptable") for r in rows)
    nv = sum(r["status"] == "not_verified" for r in rows)
    return [str(n), f"{100 * ok / n:.1f}", f"{100 * nv / n:.1f}", f"{100 * count('path_failed') / n:.1f}",
            str(count("crash")), str(count("refused") + count("exit_code")), str(count("outside") + count("report")),
            f"{count('determined_miss')} ({count('other_solution')})", str(count("truth_outside_reported")),
            f"{np.median([r['seconds'] for r in rows]):.2f}"]


def tables(rows: list[dict]) -> str:
    """Markdown tables per class dimension (module docstring)."""
    out = []
    for dim in ("structure", "kind", "data", "determinacy", "route"):
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


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cases", type=int, default=500)
    parser.add_argument("--seed", type=int, default=0, help="first seed")
    parser.add_argument("--workers", type=int, default=1)
    parser.add_argument("--routes", nargs="+", default=["cli", "api"], choices=["cli", "api"])
    parser.add_argument("--named", action="store_true", help="also the named problems")
    parser.add_argument("--json", default=None, help="write every verdict to this file")
    args = parser.parse_args(argv)
    from acceptance import generator as G

    jobs = [(s, tuple(args.routes), False) for s in range(args.seed, args.seed + args.cases)]
    if args.named:
        jobs += [(name, tuple(args.routes), True) for name in G.named_problems()]
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
    print(f"{len(jobs)} problems (seeds {args.seed}..{args.seed + args.cases - 1}"
          + (", named" if args.named else "") + f"), {len(rows)} runs, {wall:.0f} s wall, {args.workers} worker(s)\n")
    print(tables(rows))
    print(defects(rows))
    if args.json:
        Path(args.json).write_text(json.dumps(rows, indent=1, default=str))
    return 0


if __name__ == "__main__":
    sys.exit(main())
