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
    check = sub.add_parser("check", help="validate a case file and print the problem size")
    check.add_argument("case")
    ex = sub.add_parser("example", help="run a bundled example")
    ex.add_argument("name", nargs="?", help="example name (see --list)")
    ex.add_argument("--list", action="store_true", help="list the bundled examples")
    ex.add_argument("--out", default=None, help="output directory (default: ./NAME-results)")
    fx = sub.add_parser("extract", help="extract modes and antiresonances from measured FRFs (docs/frf-extraction.md)")
    fx.add_argument("files", nargs="+", help="UFF (.uff/.unv, dataset 58) or CSV/npz FRF files")
    fx.add_argument("--band", nargs=2, type=float, metavar=("F1", "F2"), help="frequency band, Hz")
    fx.add_argument("--out", default="extraction", help="output directory (default: ./extraction)")
    fx.add_argument("--responses", nargs="+", help="table files: response DOF of each data column")
    fx.add_argument("--excitations", nargs="+", help="table files: excitation DOF of each file, in order")
    fx.add_argument("--kind", choices=("receptance", "mobility", "accelerance"),
                    help="what the files hold (UFF: from the record; tables: receptance)")
    fx.add_argument("--g", action="store_true", help="the data are in g per newton")
    fx.add_argument("--re-im", action="store_true", help="tables hold real/imaginary column pairs")
    fx.add_argument("--map", nargs="+", default=(), metavar="FROM=TO",
                    help="rename DOFs, e.g. y3=x2 y4=-x3 (a '-' flips the sign)")
    fx.add_argument("--modes", type=int, default=None, help="keep this many modes (default: all stable ones)")
    fx.add_argument("--first-mode", type=int, default=1, help="model mode number of the lowest extracted mode")
    fx.add_argument("--confidence", type=float, default=0.95, help="level of the intervals (default 0.95)")
    fx.add_argument("--no-plot", action="store_true", help="do not write fit.png")
    return parser


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


def _extract(args) -> int:
    import math

    from vibupdate.extraction import extract
    from vibupdate.extraction_io import configuration_block, write_extraction
    from vibupdate.frf import read_frfs

    mapping = {}
    for item in args.map:
        if "=" not in item:
            raise ValueError(f"--map entries are FROM=TO, got {item!r}")
        key, value = item.split("=", 1)
        mapping[key.strip()] = value.strip()
    frfs = read_frfs(args.files, args.responses, args.excitations, args.kind, args.g, args.re_im, mapping)
    band = None if args.band is None else (2 * math.pi * args.band[0], 2 * math.pi * args.band[1])
    result = extract(frfs, band=band, n_modes=args.modes, confidence=args.confidence)
    paths = write_extraction(result, frfs, args.out, first_mode=args.first_mode, plot=not args.no_plot)
    print(f"{len(result.modes)} mode(s), {len(result.zeros)} antiresonance(s); noise from {result.noise}; "
          f"intervals at {100 * args.confidence:g} %")
    for k, m in enumerate(result.modes):
        lo, hi = (v / 2 / math.pi for v in m.omega_interval)
        print(f"  mode {args.first_mode + k}: {m.omega / 2 / math.pi:.4f} Hz [{lo:.4f}, {hi:.4f}], "
              f"damping {100 * m.damping_ratio:.3f} %")
    for z in result.zeros:
        lo, hi = (v / 2 / math.pi for v in z.interval)
        print(f"  zero {z.index} of h({z.response},{z.excitation}): {z.omega / 2 / math.pi:.4f} Hz [{lo:.4f}, {hi:.4f}]")
    for q in result.quality:
        print(f"  fit of h({q.response},{q.excitation}): quality {q.quality:.2f}, residual {100 * q.relative_residual:.2f} %")
    print(f"wrote {', '.join(str(p) for p in paths.values())}")
    print("paste into a case file (paths relative to it):")
    print(configuration_block())
    return 0


def main(argv=None) -> int:
    args = _parser().parse_args(argv)
    from vibupdate.case import load_case
    from vibupdate.pipeline import check_case, example_names, run_case, run_example

    try:
        if args.command == "extract":
            return _extract(args)
        if args.command == "example":
            if args.list or not args.name:
                print("\n".join(example_names()))
                return 0
            return _finish(run_example(args.name, args.out or f"{args.name}-results", progress=print))
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
