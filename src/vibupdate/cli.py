"""Command-line interface: parse, call the library, write files.

Exit codes: 0 success, 1 the updating did not reach lambda = 1 (results are still written,
with the status; for ``sweep``: no verified sample; for ``batch``: a case did not succeed),
2 bad input (nothing written).
"""

from __future__ import annotations

import argparse
import sys

from vibupdate import __version__

__all__ = ["main"]


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="vibupdate", description="Model updating of vibrating systems.")
    parser.add_argument("--version", action="version", version=f"vibupdate {__version__}")
    sub = parser.add_subparsers(dest="command", required=True)
    run = sub.add_parser("run", help="run a case file (both stages) and write DIR")
    run.add_argument("case", help="case file (TOML), see docs/case-file.md")
    run.add_argument("--out", default=None, help="output directory (default: ./CASE-results)")
    check = sub.add_parser("check", help="validate a case file and print the problem size")
    check.add_argument("case")
    ex = sub.add_parser("example", help="run a bundled example")
    ex.add_argument("name", nargs="?", help="example name (see --list)")
    ex.add_argument("--list", action="store_true", help="list the bundled examples")
    ex.add_argument("--out", default=None, help="output directory (default: ./NAME-results)")
    sweep = sub.add_parser("sweep", help="update many data sets drawn inside the measured intervals (Dask)")
    sweep.add_argument("case", help="case file (TOML)")
    sweep.add_argument("--samples", type=int, required=True, help="number of data sets to draw")
    sweep.add_argument("--seed", type=int, default=0, help="seed; sample i depends on (seed, i) only (default 0)")
    sweep.add_argument("--distribution", choices=("uniform", "gaussian"), default="uniform",
                       help="uniform in each interval (default) or a normal truncated to it")
    sweep.add_argument("--confidence", type=float, default=0.95,
                       help="confidence the intervals are stated at, for --distribution gaussian (default 0.95)")
    sweep.add_argument("--frequency-tolerance", type=float, default=None,
                       help="relative half-width of frequencies without an interval (default: the case's)")
    sweep.add_argument("--multistart", type=int, default=0, metavar="N",
                       help="also solve the point estimate from N random starts and count distinct minima")
    sweep.add_argument("--no-random-start", action="store_true",
                       help="keep each sample's homotopy answer; no solve from a random start")
    sweep.add_argument("--resume", action="store_true", help="finish the sweep already in --out")
    sweep.add_argument("--out", default=None, help="output directory (default: ./CASE-sweep)")
    batch = sub.add_parser("batch", help="run many case files, one results folder each and a summary table")
    batch.add_argument("cases", nargs="+", help="case files (TOML)")
    batch.add_argument("--out", required=True, help="output directory")
    for p in (sweep, batch):
        p.add_argument("--workers", type=int, default=None, help="local Dask worker processes (default: one per core)")
        p.add_argument("--scheduler", default=None, metavar="ADDRESS",
                       help="address of an existing Dask scheduler, e.g. tcp://10.0.0.5:8786")
    return parser


def _say(line: str) -> None:
    print(line, flush=True)


def _sweep(args) -> int:
    import json
    from pathlib import Path

    from vibupdate.case import load_case
    from vibupdate.sampling import SamplingOptions
    from vibupdate.sweep import run_sweep

    sampling = SamplingOptions(args.distribution, args.confidence, args.frequency_tolerance,
                               random_start=not args.no_random_start)
    case = load_case(args.case)
    out = Path(args.out or f"{case.name}-sweep")
    if args.multistart < 0:
        raise ValueError(f"--multistart must be >= 0, got {args.multistart}")
    summary = run_sweep(args.case, out, args.samples, seed=args.seed, sampling=sampling, workers=args.workers,
                        scheduler=args.scheduler, resume=args.resume, progress=_say)
    if args.multistart:
        from vibupdate.multistart import multistart

        result = multistart(case, args.multistart, seed=args.seed, workers=args.workers, scheduler=args.scheduler,
                            progress=_say)
        doc = result.as_dict(case.configurations[0].model.parameters)
        (out / "multistart.json").write_text(json.dumps(doc, indent=2), encoding="utf-8")
    print()
    print(f"{'parameter':<12} {'unit':<8} {'min':>12} {'q05':>12} {'q50':>12} {'q95':>12} {'max':>12}")
    for p in summary.document["parameters"]:
        cells = " ".join(f"{p[k]:>12.6g}" if p[k] is not None else f"{'-':>12}"
                         for k in ("min", "q05", "q50", "q95", "max"))
        print(f"{p['name']:<12} {p['unit']:<8} {cells}")
    return 0 if summary.verified > 0 else 1


def _batch(args) -> int:
    from vibupdate.batch import run_batch

    rows = run_batch(args.cases, args.out, workers=args.workers, scheduler=args.scheduler, progress=_say)
    return 0 if all(r["status"] in ("success", "acceptable") for r in rows) else 1


def _print_tables(document: dict) -> None:
    from vibupdate.report import damping_table_text, frequency_table_text, parameter_table_text, summary_text

    for text in (frequency_table_text(document), parameter_table_text(document), damping_table_text(document),
                 summary_text(document)):
        if text:
            print()
            print(text)


def _finish(document: dict) -> int:
    _print_tables(document)
    solver = document.get("solver") or {}
    if solver.get("status") == "not_verified":
        print(f"vibupdate: {solver.get('message')}; see the warnings above and the report", file=sys.stderr)
        return 1
    if solver.get("status") not in ("success", "acceptable"):
        print(f"vibupdate: updating failed: {solver.get('message')}", file=sys.stderr)
        return 1
    return 0


def main(argv=None) -> int:
    args = _parser().parse_args(argv)
    from vibupdate.case import load_case
    from vibupdate.pipeline import check_case, example_names, run_case, run_example

    try:
        if args.command == "example":
            if args.list or not args.name:
                print("\n".join(example_names()))
                return 0
            return _finish(run_example(args.name, args.out or f"{args.name}-results", progress=print))
        if args.command == "sweep":
            return _sweep(args)
        if args.command == "batch":
            return _batch(args)
        case = load_case(args.case)
        if args.command == "check":
            size = check_case(case)
            print(f"{args.case}: OK; case {case.name!r}, {len(case.configurations)} configuration(s)")
            print("problem size: " + ", ".join(f"{k} {v}" for k, v in size.items()))
            return 0
        _, document = run_case(case, args.out or f"{case.name}-results", progress=print)
        return _finish(document)
    except ValueError as exc:
        print(f"vibupdate: error: {exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
