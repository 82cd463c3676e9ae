"""Command-line interface: parse, call the library, write files.

Exit codes: 0 success, 1 the updating did not reach lambda = 1 (results are still written,
with the status), 2 bad input (nothing written).
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
    run.add_argument("--certify", type=float, default=None, metavar="SECONDS",
                     help="also compute certified outer parameter ranges within this time budget")
    check = sub.add_parser("check", help="validate a case file and print the problem size")
    check.add_argument("case")
    ex = sub.add_parser("example", help="run a bundled example")
    ex.add_argument("name", nargs="?", help="example name (see --list)")
    ex.add_argument("--list", action="store_true", help="list the bundled examples")
    ex.add_argument("--out", default=None, help="output directory (default: ./NAME-results)")
    ex.add_argument("--certify", type=float, default=None, metavar="SECONDS",
                    help="also compute certified outer parameter ranges within this time budget")
    return parser


def _print_tables(document: dict) -> None:
    from vibupdate.report import (certified_table_text, damping_table_text, frequency_table_text,
                                  parameter_table_text, summary_text)

    for text in (frequency_table_text(document), parameter_table_text(document), certified_table_text(document),
                 damping_table_text(document), summary_text(document)):
        if text:
            print()
            print(text)


def _finish(document: dict) -> int:
    _print_tables(document)
    solver = document.get("solver") or {}
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
            return _finish(run_example(args.name, args.out or f"{args.name}-results", progress=print,
                                       certify=args.certify))
        case = load_case(args.case)
        if args.command == "check":
            size = check_case(case)
            print(f"{args.case}: OK; case {case.name!r}, {len(case.configurations)} configuration(s)")
            print("problem size: " + ", ".join(f"{k} {v}" for k, v in size.items()))
            return 0
        _, document = run_case(case, args.out or f"{case.name}-results", progress=print, certify=args.certify)
        return _finish(document)
    except ValueError as exc:
        print(f"vibupdate: error: {exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
