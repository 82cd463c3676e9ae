"""Command-line interface: parse, call the library, write files."""

from __future__ import annotations

import argparse
import sys

from vibupdate import __version__
from vibupdate.pipeline import example_names, run_example
from vibupdate.report import frequency_table_text, parameter_table_text, summary_text

__all__ = ["main"]


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="vibupdate", description="Model updating of vibrating systems.")
    parser.add_argument("--version", action="version", version=f"vibupdate {__version__}")
    sub = parser.add_subparsers(dest="command", required=True)
    ex = sub.add_parser("example", help="run a bundled example")
    ex.add_argument("name", nargs="?", help="example name (see --list)")
    ex.add_argument("--list", action="store_true", help="list the bundled examples")
    ex.add_argument("--out", default=None, help="output directory (default: ./NAME-results)")
    return parser


def main(argv=None) -> int:
    args = _parser().parse_args(argv)
    if args.command == "example":
        if args.list or not args.name:
            print("\n".join(example_names()))
            return 0
        out = args.out or f"{args.name}-results"
        try:
            document = run_example(args.name, out, progress=print)
        except ValueError as exc:
            print(f"vibupdate: error: {exc}", file=sys.stderr)
            return 2
        print()
        print(frequency_table_text(document))
        print()
        print(parameter_table_text(document))
        print()
        print(summary_text(document))
        if document["solver"].get("status") not in ("success", "acceptable"):
            print(f"vibupdate: updating failed: {document['solver'].get('message')}", file=sys.stderr)
            return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
