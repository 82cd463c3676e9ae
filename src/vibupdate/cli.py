"""Command-line interface: parse, call the library, write files.

Exit codes (`EXIT`) are those of ``docs/cli.md`` ("Exit codes"): 0 success (verified), 1 not
verified or failed (results written), 2 bad input (one message; nothing written), 3 internal
error, 130 interrupted (one line saying what was kept). A command or option whose optional
extra is not installed (`NEEDS`, `vibupdate.extras`) exits 2 with one line naming the extra,
before any work.
"""

from __future__ import annotations

import argparse
import contextlib
import os
import sys
import traceback
from pathlib import Path

from vibupdate import __version__
from vibupdate.extras import MissingExtra, install_hint, require
from vibupdate.io.interrupted import Interrupted


#: Exit codes of the command line.
EXIT = {"success": 0, "not_verified": 1, "bad_input": 2, "internal": 3, "interrupted": 130}

#: What a command, or one of its options, needs beyond the core: ``(command, option, extra)``,
#: option None for the command itself (``extract`` of UFF files is checked where they are read).
NEEDS = (("sweep", None, "study"), ("batch", None, "study"),
         ("run", "--samples", "study"), ("example", "--samples", "study"),
         ("run", "--certify", "certify"), ("example", "--certify", "certify"))


class _BadInput(Exception):
    """Bad input found outside the library's own ValueErrors (user code of a builder)."""


def parser() -> argparse.ArgumentParser:
    """The command line's parser: every command and option (``docs/cli.md``)."""
    top = argparse.ArgumentParser(prog="vibupdate", description="Model updating of vibrating systems.")
    top.add_argument("--version", action="version", version=f"vibupdate {__version__}")
    top.add_argument("--debug", action="store_true", help="print the traceback of an internal error")
    sub = top.add_subparsers(dest="command", required=True)
    run = sub.add_parser("run", help="run a case file (both stages) and write DIR")
    run.add_argument("case", help="case file (TOML), see docs/case-file.md")
    run.add_argument("--out", default=None, help="output folder (default: ./CASE-results)")
    check = sub.add_parser("check", help="validate a case file and print the problem size")
    check.add_argument("case", help="case file (TOML), see docs/case-file.md")
    ex = sub.add_parser("example", help="run a bundled example")
    ex.add_argument("name", nargs="?", help="example name (see --list)")
    ex.add_argument("--list", action="store_true", help="list the bundled examples")
    ex.add_argument("--out", default=None, help="output folder (default: ./NAME-results)")
    imp = sub.add_parser("import", help="read an FE code's export set and write the model of a case file "
                                        "(docs/fe-models.md)")
    imp.add_argument("spec", help="import file (TOML): the code, the nominal export and one per parameter")
    imp.add_argument("--out", required=True, help="new folder for model.toml and the matrix files")
    for p in (run, ex):
        p.add_argument("--certify", type=float, default=None, metavar="SECONDS",
                       help="also compute certified outer parameter ranges within this time budget (needs the "
                            "extra [certify])")
        p.add_argument("--force", action="store_true",
                       help="write into a folder that holds other files or another case's results (only this "
                            "command's own files, unchanged since written, are replaced or removed; every other "
                            "file is kept and named)")
        p.add_argument("--no-diagnose", dest="diagnose", action="store_false", default=None,
                       help="when the answer does not fit the data, do not rank which data conflict (the case's "
                            "[verification] diagnose, default true)")
        p.add_argument("--samples", type=int, default=None, metavar="N",
                       help="also update N data sets drawn inside the measured intervals on Dask and report the "
                            "sampled ranges beside the linearized (and certified) ones (needs the extra [study])")
        p.add_argument("--multistart", type=int, default=None, metavar="N",
                       help="random starts of the point estimate whose distinct local minima are counted "
                            "(default 20 with --samples, else none)")
        p.add_argument("--seed", type=int, default=0, help="seed of the samples and starts (default 0)")
        p.add_argument("--frequency-tolerance", type=float, default=None,
                       help="for --samples: relative half-width of frequencies without an interval (default: the "
                            "case's)")
    sg = sub.add_parser("suggest", help="which of the case's [[candidate]] parameters to update: the smallest sets "
                                         "that let the data fit, ranked and checked by a full update")
    sg.add_argument("case", help="case file (TOML) with [[candidate]] tables, see docs/case-file.md")
    sg.add_argument("--max-size", type=int, default=3, metavar="K", help="largest set of candidates tried (default 3)")
    sg.add_argument("--checked", type=int, default=3, metavar="N",
                    help="top sets checked by a full update (default 3)")
    sg.add_argument("--out", default=None, help="folder for suggestion.json and suggestion.md (default: none written)")
    sg.add_argument("--force", action="store_true", help="as for run")
    fx = sub.add_parser("extract", help="extract modes and antiresonances from measured FRFs (docs/frf-extraction.md)")
    fx.add_argument("files", nargs="+", help="UFF (.uff/.unv, dataset 58; needs the extra [frf]) or CSV/npz FRF "
                                             "files")
    fx.add_argument("--band", nargs=2, type=float, metavar=("F1", "F2"), help="frequency band, Hz")
    fx.add_argument("--fit-band", nargs=2, type=float, metavar=("F1", "F2"),
                    help="lines fitted, Hz, containing --band (default: the band's bottom to twice its top)")
    fx.add_argument("--window", choices=("none", "hann", "rectangular", "exponential", "force"), default="none",
                    help="data window of the FRF estimate (random excitation, H1 per record of 1/spacing s): the fit "
                         "models its leakage, which otherwise reads peaks a few lines wide as extra damping "
                         "(default none: the FRFs are fitted as they are); impact tests: exponential (on the "
                         "response, with --window-decay or --window-tau: its added damping is modelled) or force")
    fx.add_argument("--window-decay", type=float, help="exponential window: its value at the end of the record")
    fx.add_argument("--window-tau", type=float, help="exponential window: its time constant, s")
    fx.add_argument("--out", default="extraction", help="output folder (default: ./extraction)")
    fx.add_argument("--responses", nargs="+", help="table files: response DOF of each data column")
    fx.add_argument("--excitations", nargs="+", help="table files: excitation DOF of each file, in order")
    fx.add_argument("--kind", choices=("receptance", "mobility", "accelerance"),
                    help="what the files hold (UFF: from the record; tables: receptance)")
    fx.add_argument("--g", action="store_true", help="the data are in g per newton")
    fx.add_argument("--re-im", action="store_true", help="tables hold real/imaginary column pairs")
    fx.add_argument("--map", nargs="+", default=(), metavar="FROM=TO",
                    help="rename DOFs, e.g. y3=x2 y4=-x3 (a '-' flips the sign)")
    fx.add_argument("--keep-outer-zeros", action="store_true",
                    help="report antiresonances below the lowest or above the highest fitted pole "
                         "(left out by default)")
    fx.add_argument("--keep-noisy-zeros", action="store_true",
                    help="report antiresonances at the noise floor (local SNR under 0.1; left out by default)")
    fx.add_argument("--reciprocal", action="store_true",
                    help="roving hammer: read each h_rc as h_cr (reciprocity), so the shapes are at every hammer point")
    fx.add_argument("--modes", type=int, default=None, help="keep this many modes (default: all stable ones)")
    fx.add_argument("--first-mode", type=int, default=1, help="model mode number of the lowest extracted mode")
    fx.add_argument("--confidence", type=float, default=0.95,
                    help="level of all the intervals together (default 0.95; each is then at a higher level)")
    fx.add_argument("--per-interval", action="store_true", help="state --confidence for each interval instead")
    fx.add_argument("--no-plot", action="store_true", help="do not write fit.png (drawn with the extra [plots])")
    fx.add_argument("--force", action="store_true", help="as for run")
    sweep = sub.add_parser("sweep", help="update many data sets drawn inside the measured intervals (Dask; needs "
                                         "the extra [study])")
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
    sweep.add_argument("--no-walk", action="store_true",
                       help="do not walk a verified answer along exact null directions of the sensitivity to the "
                            "ends of its line of equally good answers")
    sweep.add_argument("--resume", action="store_true", help="finish the sweep already in --out")
    sweep.add_argument("--force", action="store_true",
                       help="start a new sweep in a folder that holds other files (the files of an earlier sweep "
                            "there, unchanged since written, are removed; every other file is kept and named)")
    sweep.add_argument("--out", default=None, help="output directory (default: ./CASE-sweep)")
    batch = sub.add_parser("batch", help="run many case files, one results folder each and a summary table (needs "
                                         "the extra [study])")
    batch.add_argument("cases", nargs="+", help="case files (TOML)")
    batch.add_argument("--out", required=True, help="output directory")
    for p in (run, ex, sweep, batch):
        p.add_argument("--workers", type=int, default=None, help="local Dask worker processes (default: one per core)")
        p.add_argument("--scheduler", default=None, metavar="ADDRESS",
                       help="address of an existing Dask scheduler, e.g. tcp://10.0.0.5:8786")
    # --debug is accepted after the subcommand too.
    for p in (run, check, ex, fx, sweep, batch, imp, sg):
        p.add_argument("--debug", action="store_true", default=argparse.SUPPRESS, help=argparse.SUPPRESS)
    return top


def _say(line: str) -> None:
    print(line, flush=True)


def _sweep(args) -> int:
    from vibupdate.io.case import load_case
    from vibupdate.io.outputs import safe_name
    from vibupdate.report.numbers import fmt
    from vibupdate.study.sampling import SamplingOptions
    from vibupdate.study.sweep import run_sweep

    sampling = SamplingOptions(args.distribution, args.confidence, args.frequency_tolerance,
                               random_start=not args.no_random_start, walk=not args.no_walk)
    case = load_case(args.case)
    out = Path(args.out or f"{safe_name(case.name)}-sweep")
    if args.multistart < 0:
        raise ValueError(f"--multistart must be >= 0, got {args.multistart}")
    summary = run_sweep(args.case, out, args.samples, seed=args.seed, sampling=sampling, workers=args.workers,
                        scheduler=args.scheduler, resume=args.resume, force=args.force, progress=_say)
    if args.multistart:
        from vibupdate.study.multistart import multistart
        from vibupdate.study.sweep_files import write_multistart

        result = multistart(case, args.multistart, seed=args.seed, workers=args.workers, scheduler=args.scheduler,
                            progress=_say)
        write_multistart(out, case, result)
    print()
    print(f"{'parameter':<12} {'unit':<8} {'min':>12} {'q05':>12} {'q50':>12} {'q95':>12} {'max':>12}")
    for p in summary.document["parameters"]:
        cells = " ".join(fmt(p[k], ">12.6g") for k in ("min", "q05", "q50", "q95", "max"))
        print(f"{p['name']:<12} {p['unit']:<8} {cells}")
    return EXIT["success"] if summary.verified > 0 else EXIT["not_verified"]


def _study(args):
    """The sampled ranges and multistart of ``run``/``example`` (None without them)."""
    starts = args.multistart
    if args.samples is None:
        if starts:
            raise ValueError("--multistart in a run needs --samples (the multistart is reported beside the sampled "
                             "ranges); use `vibupdate sweep --multistart N` for a multistart alone")
        if args.frequency_tolerance is not None:
            raise ValueError(f"--frequency-tolerance {args.frequency_tolerance:g} in a run needs --samples (it is the "
                             "sampling's half-width of frequencies without an interval); without --samples it would "
                             "be ignored")
        return None
    from vibupdate.study.sampled_ranges import SampledRanges
    from vibupdate.study.sampling import SamplingOptions

    return SampledRanges(args.samples, 20 if starts is None else starts, args.seed,
                         SamplingOptions(frequency_tolerance=args.frequency_tolerance), workers=args.workers,
                         scheduler=args.scheduler)


def _batch(args) -> int:
    from vibupdate.study.batch import run_batch

    rows = run_batch(args.cases, args.out, workers=args.workers, scheduler=args.scheduler, progress=_say)
    return EXIT["success"] if all(r["status"] in ("success", "acceptable") for r in rows) else EXIT["not_verified"]


def _finished(run, out) -> int:
    """The tables of a run whose results are in ``out`` and its exit code; Ctrl-C while they
    print keeps the results."""
    from vibupdate.inverse.status import Status
    from vibupdate.report.document import terminal_text

    try:
        print()
        print(terminal_text(run))
        if run.success:
            return EXIT["success"]
        if run.status == Status.NOT_VERIFIED:
            print(f"vibupdate: {run.solver.message}; see the warnings above and the report", file=sys.stderr)
        else:
            print(f"vibupdate: updating failed: {run.solver.message}; results written with the status",
                  file=sys.stderr)
        return EXIT["not_verified"]
    except KeyboardInterrupt:
        raise Interrupted(f"the results were written to {out}/ before it") from None


def _load(path):
    """Read the case file; failures of user code (a builder) are bad input, not internal errors."""
    from vibupdate.io.case import load_case

    try:
        return load_case(path)
    except (ValueError, KeyboardInterrupt, MissingExtra):
        raise
    except Exception as exc:  # user code: a builder that raises, has a syntax error or a wrong signature
        raise _BadInput(f"{path}: the model could not be built: {type(exc).__name__}: {exc}") from exc


def _check_extras(args) -> None:
    """Raise `MissingExtra` for the first command or option of ``args`` whose extra is missing."""
    for command, option, extra in NEEDS:
        if command != args.command:
            continue
        if option is None:
            require(extra, f"vibupdate {command}")
        elif getattr(args, option.lstrip("-").replace("-", "_"), None) is not None:
            require(extra, f"vibupdate {command} {option}")


def _command(args) -> int:
    from vibupdate.io.outputs import safe_name
    from vibupdate.io.validation import validate_case
    from vibupdate.pipeline import example_names, run_case, run_example

    _check_extras(args)
    if args.command in ("extract", "sweep", "batch", "import"):
        return {"extract": _extract, "sweep": _sweep, "batch": _batch, "import": _import}[args.command](args)
    if args.command == "example":
        if args.list or not args.name:
            print("\n".join(example_names()))
            return EXIT["success"]
        if (args.name.startswith("fe-") or args.name == "bar") and args.force:
            raise ValueError(f"example {args.name} writes into a new folder (--out); --force does not apply to it")
        if args.name.startswith("fe-"):
            return _fe_example(args)
        if args.name == "bar":
            return _bar_example(args)
        out = args.out or f"{safe_name(args.name)}-results"
        return _finished(run_example(args.name, out, progress=print, force=args.force, certify=args.certify,
                                     study=_study(args), diagnose=args.diagnose), out)
    case = _load(args.case)
    if args.command == "suggest":
        return _suggest(args, case)
    if args.command == "check":
        checked = validate_case(case)   # as `run_case` validates it before solving
        print(f"{args.case}: OK; case {case.name!r}, {len(case.configurations)} configuration(s)")
        for note in checked.notes:
            print(f"model {note}")
        for warning in checked.warnings:
            print(f"warning: {warning}")
        print("problem size: " + ", ".join(f"{k} {v}" for k, v in checked.sizes.items()))
        return EXIT["success"]
    out = args.out or f"{safe_name(case.name)}-results"
    return _finished(run_case(case, out, progress=print, force=args.force, certify=args.certify, study=_study(args),
                              diagnose=args.diagnose), out)


def _suggest(args, case) -> int:
    from vibupdate.io.records import SuggestionRecord
    from vibupdate.report.suggestion import suggestion_text
    from vibupdate.study.suggest import suggest_case

    found = suggest_case(case, args.out, max_size=args.max_size, checked=args.checked, force=args.force,
                         progress=_say)
    print()
    print(suggestion_text(SuggestionRecord.from_dict(found.record())))
    return EXIT["success"] if found.best is not None else EXIT["not_verified"]


def _run_options(args) -> list[str]:
    """The options of ``example`` given on its command line, as ``run`` takes them."""
    words = []
    for option in ("certify", "samples", "multistart", "frequency_tolerance", "workers", "scheduler"):
        value = getattr(args, option)
        if value is not None:
            words += [f"--{option.replace('_', '-')}", str(value)]
    return words + (["--seed", str(args.seed)] if args.seed else [])


def _fe_example(args) -> int:
    """``example fe-<code>``: write the export set and the measured data, then run the import and
    the run commands it prints (`vibupdate.examples.fe`)."""
    from vibupdate.examples import fe
    from vibupdate.io.outputs import safe_name

    out = args.out or f"{safe_name(args.name)}-results"
    with _example_folder(out, ["results"]):
        fe.write_inputs(args.name, out)
        print(f"example {args.name}: wrote the export set in {out}/exports and the measured data in {out}/measured")
        imp, run = fe.commands(out)
        _shown_and_run(imp)
        print(f"wrote {fe.write_case(args.name, out)}: the model with the measured data")
        code = _shown_and_run(run + _run_options(args))
    if (Path(out) / "results" / "results.json").is_file():
        print()
        print("\n".join(fe.truth_lines(out)))
    return code


def _shown_and_run(words: list[str]) -> int:
    """Print the command line ``vibupdate WORDS`` and run it."""
    print("$ vibupdate " + " ".join(words))
    return _command(parser().parse_args(words))


@contextlib.contextmanager
def _example_folder(out, results: list[str]):
    """An example that writes its inputs into the new (or empty) folder ``out`` and its commands'
    results into its sub-folders ``results``. Stopped (Ctrl-C or an error) before any of those
    results was written, it removes what it wrote (the folder too when it made it), so that
    the same command runs again; Ctrl-C then says what was kept."""
    import shutil

    out = Path(out)
    existed = out.exists()
    fresh = not existed or (out.is_dir() and not any(out.iterdir()))   # else the example refuses the folder
    try:
        yield
    except BaseException as exc:
        written = [r for r in results if (out / r / "results.json").is_file()]
        if written:
            kept = f"kept {out}/ with the results of the commands that finished ({', '.join(written)})"
        elif fresh and out.is_dir():
            shutil.rmtree(out)
            if existed:
                out.mkdir()
            kept = f"nothing of value was written ({out}/ {'emptied' if existed else 'removed'}; run it again)"
        else:
            kept = "nothing written"
        if isinstance(exc, KeyboardInterrupt):
            raise Interrupted(kept) from None
        raise


def _bar_example(args) -> int:
    """``example bar``: write the roving-hammer test of the free-free bar and its case files, then
    run the extract, run, suggest and run commands it prints (`vibupdate.examples.bar`)."""
    from vibupdate.examples import bar

    ignored = _run_options(args) + (["--no-diagnose"] if args.diagnose is False else [])
    if ignored:
        # its commands are the ones docs/worked-bar.md shows; run them by hand to change them
        raise ValueError(f"example bar runs its commands as shown; {' '.join(ignored)} does not apply to it "
                         "(expected only --out)")
    out = args.out or "bar-results"
    with _example_folder(out, ["results-E", "results-E-r"]):
        bar.write_inputs(out)
        print(f"example bar: wrote the test in {out}/hammer.uff and the case files {out}/{bar.CASE} (E) and "
              f"{out}/{bar.CASE_R} (E and r)")
        codes = [_shown_and_run(command) for command in bar.commands(out)]
    print()
    print("\n".join(bar.truth_lines(out)))
    # the example did what it shows when the run with E alone is not verified and the others succeed
    return EXIT["success"] if codes == [0, 1, 0, 0] else EXIT["not_verified"]


def _check_extract_options(args) -> None:
    """The numbers of ``extract``'s options, checked before any file is read: a ValueError
    naming the option and the value expected."""
    import math

    for option in ("band", "fit_band"):
        pair = getattr(args, option)
        name = "--" + option.replace("_", "-")
        if pair is not None and not (all(math.isfinite(f) for f in pair) and 0 < pair[0] < pair[1]):
            raise ValueError(f"{name} {pair[0]:g} {pair[1]:g}: expected two frequencies in Hz, 0 < F1 < F2")
    if args.modes is not None and args.modes < 1:
        raise ValueError(f"--modes must be an integer >= 1 (how many modes to keep), got {args.modes}")
    if args.first_mode < 1:
        raise ValueError(f"--first-mode must be an integer >= 1 (the model mode number of the lowest extracted "
                         f"mode; modes count from 1), got {args.first_mode}")
    if not 0 < args.confidence < 1:
        raise ValueError(f"--confidence must be between 0 and 1 (e.g. 0.95), got {args.confidence:g}")
    for option in ("window_decay", "window_tau"):
        value = getattr(args, option)
        if value is not None and not (math.isfinite(value) and value > 0):
            raise ValueError(f"--{option.replace('_', '-')} must be a finite number > 0, got {value:g}")


def _import(args) -> int:
    from vibupdate.io.fe_import import import_model, summary_lines

    imported = import_model(args.spec, args.out)
    for line in summary_lines(imported):
        print(line)
    print(f"wrote {args.out}/model.toml and its matrix files; add the configurations to make a case file")
    return EXIT["success"]


def _extract(args) -> int:
    import math

    from vibupdate.data.extraction import extract
    from vibupdate.data.names import mode_name, receptance_name
    from vibupdate.io.outputs import OutputWarning, collected, kept_note
    from vibupdate.io.extraction_io import check_extraction_folder, configuration_block, write_extraction
    from vibupdate.data.frf import FRFWarning, read_frfs

    _check_extract_options(args)
    mapping = {}
    for item in args.map:
        key, _, value = (part.strip() for part in item.partition("="))
        if "=" not in item or not key or value.lstrip("-") == "":
            raise ValueError(f"--map entries are FROM=TO with two DOF names (a '-' before TO flips the sign), "
                             f"got {item!r}")
        if key in mapping:
            raise ValueError(f"--map renames {key!r} twice ({key}={mapping[key]} and {item})")
        mapping[key] = value
    with collected(FRFWarning) as doubts:
        frfs = read_frfs(args.files, args.responses, args.excitations, args.kind, args.g, args.re_im, mapping)
    for message in doubts:
        print(f"warning: {message}")
    if args.reciprocal:
        frfs = frfs.reciprocal()
    band = None if args.band is None else (2 * math.pi * args.band[0], 2 * math.pi * args.band[1])
    fit_band = None if args.fit_band is None else (2 * math.pi * args.fit_band[0], 2 * math.pi * args.fit_band[1])
    target = check_extraction_folder(args.out, args.force, args.files)  # before the fit, as run checks before solving
    result = extract(frfs, band=band, n_modes=args.modes, confidence=args.confidence, fit_band=fit_band,
                     window=args.window, keep_outer_zeros=args.keep_outer_zeros, window_decay=args.window_decay,
                     window_tau=args.window_tau, keep_noisy_zeros=args.keep_noisy_zeros, joint=not args.per_interval)
    with collected(OutputWarning) as failures:
        paths = write_extraction(result, frfs, args.out, first_mode=args.first_mode, plot=not args.no_plot,
                                 force=args.force, inputs=args.files)
    for message in failures:
        print(f"warning: {message}")
    print(f"{len(result.modes)} mode(s), {len(result.zeros)} antiresonance(s); noise from {result.noise}; "
          + (f"intervals at {100 * args.confidence:g} % each" if args.per_interval else
             f"intervals at {100 * args.confidence:g} % together ({100 * result.level:.4g} % each)"))
    for k, m in enumerate(result.modes):
        lo, hi = (v / 2 / math.pi for v in m.omega_interval)
        print(f"  {mode_name(args.first_mode + k)}: {m.omega / 2 / math.pi:.4f} Hz [{lo:.4f}, {hi:.4f}], "
              f"damping {100 * m.damping_ratio:.3f} %")
    for z in result.zeros:
        lo, hi = (v / 2 / math.pi for v in z.interval)
        print(f"  {z.name(args.first_mode)}: {z.omega / 2 / math.pi:.4f} Hz [{lo:.4f}, {hi:.4f}]")
    if result.zeros and args.first_mode != 1:
        print(f"  (the zeros are numbered by the run, from the nominal model: the lowest mode here is mode "
              f"{args.first_mode})")
    for q in result.quality:
        print(f"  fit of {receptance_name(q.response, q.excitation)}: quality {q.quality:.2f}, "
              f"residual {100 * q.relative_residual:.2f} %")
    for note in result.notes(args.first_mode):
        print(f"note: {note}")
    print(f"wrote {', '.join(str(p) for p in paths.values())}")
    if kept_note(target):
        print(kept_note(target))
    print("paste into a case file (paths relative to it):")
    print(configuration_block())
    return EXIT["success"]


class _ReaderGone:
    """The program's standard output or error, for a reader that stops reading (``vibupdate
    run CASE | head`` closes the pipe after its lines) or a stream that cannot be written (closed
    at the start, a full disk). The command goes on to its end and its own exit code (its files
    are written as usual); what it prints after that is dropped, where a bare stream would end
    the run with an internal error and the interpreter's exit with code 120."""

    def __init__(self, stream, fd: int):
        self._stream = stream
        self._fd = fd
        self.gone = False

    def write(self, text):
        if not self.gone:
            try:
                return self._stream.write(text)
            except (OSError, ValueError):
                self._drop()
        return len(text)

    def flush(self):
        if not self.gone:
            try:
                self._stream.flush()
            except (OSError, ValueError):
                self._drop()

    def _drop(self):
        self.gone = True
        try:   # the descriptor onto the null device: no later flush, the interpreter's own included, can fail
            null = os.open(os.devnull, os.O_WRONLY)
            os.dup2(null, self._fd)
            os.close(null)
        except OSError:
            pass

    def __getattr__(self, name):
        return getattr(self._stream, name)


def _guard_streams() -> None:
    """Standard output and error as `_ReaderGone`; a descriptor closed at the start is opened on
    the null device first, so that no file the command opens takes its number."""
    for fd in (1, 2):
        try:
            os.fstat(fd)
        except OSError:
            null = os.open(os.devnull, os.O_WRONLY)
            if null != fd:
                os.dup2(null, fd)
                os.close(null)
    if not isinstance(sys.stdout, _ReaderGone):
        streams = [stream if stream is not None else open(os.devnull, "w", encoding="utf-8")   # closed at the start
                   for stream in (sys.stdout, sys.stderr)]
        sys.stdout, sys.stderr = _ReaderGone(streams[0], 1), _ReaderGone(streams[1], 2)


def main(argv=None) -> int:
    """Run the command line; returns the exit code (module docstring). Called without
    arguments, as the program itself, it keeps going when the reader of its output stops
    reading or its output cannot be written (`_ReaderGone`)."""
    if argv is None:
        _guard_streams()
    args = parser().parse_args(argv)
    return _main(args)


def _main(args) -> int:
    try:
        return _command(args)
    except KeyboardInterrupt as exc:
        kept = exc.kept if isinstance(exc, Interrupted) else "nothing written (earlier results are untouched)"
        print(f"vibupdate: interrupted; {kept}", file=sys.stderr)
        return EXIT["interrupted"]
    except MissingExtra as exc:
        line = str(exc) if exc.feature.startswith("vibupdate ") else (
            f"vibupdate {args.command} needs the optional extra [{exc.extra}] for {exc.feature}: "
            f"{install_hint(exc.extra)}")
        print(line, file=sys.stderr)
        return EXIT["bad_input"]
    except (ValueError, _BadInput) as exc:
        print(f"vibupdate: error: {exc}", file=sys.stderr)
        return EXIT["bad_input"]
    except Exception as exc:  # internal error: one line, the traceback on request
        if getattr(args, "debug", False):
            traceback.print_exc()
        where = traceback.extract_tb(exc.__traceback__)[-1] if exc.__traceback__ else None
        place = f" in {where.name} ({where.filename.rsplit('/', 1)[-1]}:{where.lineno})" if where else ""
        print(f"vibupdate: internal error{place}: {type(exc).__name__}: {exc}; nothing written"
              + ("" if getattr(args, "debug", False) else " (run with --debug for the traceback)"),
              file=sys.stderr)
        return EXIT["internal"]


if __name__ == "__main__":
    sys.exit(main())
