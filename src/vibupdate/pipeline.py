"""The whole job in one call: data in, results out.

``run_case`` checks the results folder, runs both stages, builds one results object
(`vibupdate.io.results.RunResult`) and writes the folder from it: ``results.json``,
``report.md``, PNG plots and the updated ``M``, ``C``, ``K`` of each configuration as Matrix
Market files, listed in the folder's manifest (`vibupdate.io.outputs`). The CLI is a thin layer
over these functions.
"""

from __future__ import annotations

from dataclasses import replace

import importlib
import warnings
from collections.abc import Callable
from pathlib import Path

import numpy as np

from vibupdate.io.case_types import Case, DampingOptions
from vibupdate.damping.series import DampingWarning
from vibupdate.damping.stage import DampingStage, damping_data, damping_weights, identify_damping
from vibupdate.examples import EXAMPLES
from vibupdate.io.interrupted import Interrupted
from vibupdate.io.outputs import (MANIFEST, collected, file_names, kept_note, matrix_file, matrix_files_planned,
                                  prepare_output, write_published)
from vibupdate.io.results import RunResult, run_result, write_results
from vibupdate.inverse.status import Status
from vibupdate.inverse.update import UpdateResult, update
from vibupdate.io.validation import validate_case


def example_names() -> list[str]:
    """Names of the bundled examples (the FE-code ones, ``fe-<code>``, and the bar's roving-hammer
    test, ``bar``, run from the command line)."""
    from vibupdate.examples.fe import CODES

    return sorted(EXAMPLES) + ["bar"] + sorted(CODES)


def example_module(name: str):
    """The module of a bundled example (``case()``, ``configurations()``, ``reference_columns()``)."""
    if name.startswith("fe-") and name in example_names():
        raise ValueError(f"example {name!r} runs FE-code commands: `vibupdate example {name}` on the command line")
    if name == "bar":
        raise ValueError("example 'bar' runs the commands of a roving-hammer test: `vibupdate example bar` on the "
                         "command line")
    if name not in EXAMPLES:
        raise ValueError(f"unknown example {name!r}; bundled examples: {', '.join(example_names())}")
    return importlib.import_module(f"vibupdate.examples.{EXAMPLES[name]}")


def _identifiability(result: UpdateResult) -> dict:
    from vibupdate.inverse.data_map import describe_direction

    s = result.sensitivity
    names = [p.name for p in result.parameters]
    return {"rank": s.rank, "condition": s.condition, "singular_values": s.singular_values,
            "column_norm": {p.name: float(v) for p, v in zip(result.parameters, s.column_norm)},
            "undetermined_combinations": [describe_direction(names, v) for v in s.null_directions],
            "minimum_change": (result.minimum_change.message
                               if result.minimum_change is not None and result.minimum_change.applied else None),
            "alternatives": list(result.alternatives)}


def damping_stage(case: Case, xbar, say, freqs=None) -> tuple[DampingStage | None, list[str], dict]:
    """The second stage at ``xbar``; ``freqs``: the configurations' modal data there when
    already computed (``UpdateResult.correlation``)."""
    options = case.damping or DampingOptions()
    if not _has_damping(case):
        return None, [], {}
    _, ratios, labels = damping_data(case.configurations, xbar, freqs)
    rule = damping_weights(labels, ratios, options.mode_weights, relative=options.relative,
                           half_widths=_damping_half_widths(case, labels))
    weights = rule.weights
    with collected(DampingWarning) as notes:
        stage = identify_damping(case.configurations, xbar, options.exponents, weights, freqs=freqs)
    notes += list(stage.warnings)
    for n in notes:
        say(f"warning: {n}")
    text = rule.rule
    if options.rationale:
        text += f". {options.rationale}"
    info = {"exponents": list(options.exponents), "beta": stage.caughey.beta.tolist(),
            "rayleigh_beta": stage.rayleigh.beta.tolist(), "condition": stage.caughey.condition,
            "weights_text": text}
    say(f"damping: Caughey Y = {list(options.exponents)} mean error {stage.caughey.mean_error_pct:.1f} %, "
        f"Rayleigh {stage.rayleigh.mean_error_pct:.1f} %")
    return stage, notes, info


def _damping_half_widths(case: Case, labels) -> np.ndarray | None:
    """Half-widths of the measured damping-ratio intervals, one per ratio in the order of
    ``labels`` ((configuration, model mode) pairs of `damping_data`); None unless every ratio has
    an interval of positive width (then the damping fit weighs each ratio by ``1 / h^2``)."""
    by_mode = {(c.name, f.mode): f for c in case.configurations for f in c.natural}
    half = []
    for label in labels:
        pair = by_mode[label].damping_interval
        if pair is None or not pair[1] > pair[0]:
            return None
        half.append(0.5 * (pair[1] - pair[0]))
    return np.array(half)


def frequency_windows(case: Case) -> str:
    """How the consistent ranges bound each frequency: the text of the report."""
    data = [d for c in case.configurations for d in (*c.natural, *c.antiresonances)]
    n = sum(d.interval is not None for d in data)
    if n == 0:
        return f"{100 * case.frequency_tolerance:.2g} % of each frequency"
    text = f"the half-width of its measured interval ({n} of {len(data)} frequencies)"
    return text if n == len(data) else text + f", {100 * case.frequency_tolerance:.2g} % for the others"


def planned_files(case: Case) -> list[str]:
    """Names of the files a run of ``case`` writes (before knowing which plots apply: the MAC
    plots only where shapes were measured, ``C`` only with damping ratios)."""
    names = ["results.json", "report.md", "homotopy.png", "frf.png"]
    for part in file_names([c.name for c in case.configurations]).values():
        names += matrix_files_planned(part) + [f"frf_{part}.png", f"mac_{part}.png"]
    return names


def write_outputs(folder: Path, case: Case, run: RunResult,
                  extra: Callable[[Path], list[tuple[str, str]]] | None = None) -> RunResult:
    """Write ``results.json``, matrices, plots and ``report.md`` of ``run`` into ``folder``.

    Every file is written from ``run`` (the nominal models for the FRF plot from ``case``);
    ``extra(folder)``, when given, writes a study's files and returns its plots as
    ``(caption, file name)`` for the report. The order, and what a file that cannot be written
    costs (an `vibupdate.io.outputs.OutputWarning` added to the run's warnings and to a
    ``results.json`` written again), is ``docs/outputs.md`` (step 2). Returns the run as written.
    """
    from vibupdate.extras import installed, skipped
    from vibupdate.io.outputs import OutputWarning, drawn

    plots = installed("plots")
    if not plots:      # without matplotlib: one note and no plots
        run = replace(run, warnings=run.warnings + (skipped("plots", "plots"),))
    parts = file_names([c.name for c in case.configurations])
    for cfg in case.configurations:
        _write_matrices(folder, parts[cfg.name], run.matrices[cfg.name], run.matrix_files.get(cfg.name), run)
    write_results(folder / "results.json", run)
    images = []
    with collected(OutputWarning) as failures:
        if plots:
            from vibupdate.report.plots import plot_homotopy

            images += _receptance_plot(folder, case, run)
            for cfg in case.configurations:
                images += _configuration_plots(folder, case, cfg, parts[cfg.name], run)
            # the path is worth a plot when it has steps between the relaxation and lambda = 1
            if len(run.solver.steps) > 2 and drawn(folder / "homotopy.png", plot_homotopy, run.solver.steps):
                images.append(("homotopy objective per step", "homotopy.png"))
        if extra is not None:
            try:
                images += extra(folder)
            except Exception as exc:  # the study's files are extras: the run's results stand without them
                warnings.warn(OutputWarning(f"the files of the study were not all written: {type(exc).__name__}: "
                                            f"{exc}"))
    failures += _write_report(folder / "report.md", replace(run, warnings=run.warnings + tuple(failures)), images)
    if failures:
        run = replace(run, warnings=run.warnings + tuple(failures))
        write_results(folder / "results.json", run)
    return run


def _write_matrices(folder: Path, part: str, matrices, files: dict | None, run: RunResult) -> None:
    """The Matrix Market files of one configuration, under the names of ``run.matrix_files``
    (``files``; None: the run's own matrices, named from its status): a model that is not
    verified says so in its name and its comment line."""
    import scipy.io   # here: its many readers are not needed before the first matrix is written
    import scipy.sparse as sp

    for role, file in (files or {m: matrix_file(m, part, verified=run.success) for m in ("M", "K", "C")
                                 if getattr(matrices, m) is not None}).items():
        name, _, variant = role.partition("_")
        if variant:   # the diagnosis's model: the update without the group that conflicts most
            best = run.diagnosis.best
            matrix = matrices.without_worst[0 if name == "M" else 1]
            what = f"{best.status.value} model updated without the {best.without_label}"
        else:
            matrix = getattr(matrices, name)
            what = f"{run.status.value} updated model"
        scipy.io.mmwrite(str(folder / file), sp.coo_matrix(matrix), **mm_symmetry(matrix),
                         comment=f"vibupdate: {name} of configuration {part}, {what} (SI units)")


#: Below this many rows `scipy.io.mmwrite` finds a matrix's symmetry itself (its default), one
#: entry at a time in Python, which `mm_symmetry` spares it.
MM_SYMMETRY_ROWS = 100


def mm_symmetry(matrix) -> dict:
    """Keywords of `scipy.io.mmwrite` for ``matrix``: ``symmetry="symmetric"`` for a small matrix
    equal to its transpose entry by entry, which is what scipy's default finds there (only the
    lower triangle is written); otherwise none (scipy's own choice)."""
    import scipy.sparse as sp

    A = sp.csr_matrix(matrix)
    if max(A.shape) < MM_SYMMETRY_ROWS and A.shape[0] == A.shape[1] and (A != A.T).nnz == 0:
        return {"symmetry": "symmetric"}
    return {}


def _receptance_plot(folder: Path, case: Case, run: RunResult) -> list[tuple[str, str]]:
    """``frf.png``: the receptances with measured antiresonances of every configuration with
    typed data, nominal and updated, in one figure (one panel each); nothing when no
    configuration has antiresonances (any pair drawn would be arbitrary: the frequency table
    compares the models with the data). Returns the ``(caption, file name)`` when drawn."""
    from vibupdate.io.outputs import drawn
    from vibupdate.report.plots import plot_receptances

    panels = []
    for cfg in case.configurations:
        if cfg.name in case.frfs or not cfg.antiresonances:
            continue
        matrices = run.matrices[cfg.name]
        updated = (matrices.M, matrices.K, matrices.damping)
        pairs = [(cfg.model.dof(r), cfg.model.dof(c), f"h_{r},{c}",
                  [a.omega for a in cfg.antiresonances if a.receptance == (r, c)]) for r, c in cfg.receptances()]
        panels.append((cfg, matrices.nominal, updated, pairs))
    if not panels or not drawn(folder / "frf.png", plot_receptances, panels):
        return []
    drawn_pairs = "; ".join(f"{cfg.name} {', '.join(p[2] for p in pairs)}" for cfg, _, _, pairs in panels)
    return [(f"Receptances with measured antiresonances, nominal and updated models ({drawn_pairs})", "frf.png")]


def _configuration_plots(folder: Path, case: Case, cfg, part: str, run: RunResult) -> list[tuple[str, str]]:
    """The FRF plot of a configuration whose data came from FRF files (measured over model
    receptances) and the MAC plot of one with measured shapes; returns the ``(caption, file
    name)`` of those drawn (`vibupdate.io.outputs.drawn`: a failure is a warning)."""
    from vibupdate.io.outputs import drawn
    from vibupdate.report.plots import plot_mac, plot_measured_frf

    images = []
    matrices = run.matrices[cfg.name]
    file = f"frf_{part}.png"
    updated = (matrices.M, matrices.K, matrices.damping)
    frfs = case.frfs.get(cfg.name)
    # the case has no nominal damping model: the nominal FRF is drawn undamped
    damped = "with the identified Caughey damping" if updated[2] is not None else "undamped"
    if frfs is not None and drawn(folder / file, plot_measured_frf, frfs, cfg.model.dofs, matrices.nominal, updated,
                                  f"configuration {cfg.name}: measured and model receptances (m/N)",
                                  "nominal model (undamped)", f"updated model ({damped})", cfg.model.sensors):
        images.append((f"FRFs of configuration {cfg.name}: measured receptance (m/N, mean of the repeats, "
                       f"{frfs.freq_hz[0]:.4g}-{frfs.freq_hz[-1]:.4g} Hz) against the nominal model (undamped) "
                       f"and the updated model ({damped})", file))
    mac = run.mac_matrix.get(cfg.name)
    if mac is not None:
        file = f"mac_{part}.png"
        values = np.array(mac.values, dtype=float)  # None (not computed) becomes NaN
        if drawn(folder / file, plot_mac, values, f"MAC, configuration {cfg.name}"):
            images.append((f"MAC configuration {cfg.name}", file))
    return images


def _write_report(path: Path, run: RunResult, images) -> list[str]:
    """Write ``report.md``; when the full report fails, a short one saying what failed.
    Returns the note of the failure ([] when the full report was written)."""
    from vibupdate.report.document import failed_report, markdown_report

    try:
        path.write_text(markdown_report(run, images, list(run.warnings)), encoding="utf-8")
        return []
    except Exception as exc:  # the report is a view of results.json, already written: a failure is a note
        note = f"report.md is a short report: the full report failed ({type(exc).__name__}: {exc})"
        path.write_text(failed_report(run.case, run.status.value, f"{type(exc).__name__}: {exc}", list(run.warnings)),
                        encoding="utf-8")
        return [note]


def run_case(case: Case, out_dir, *, progress: Callable[[str], None] | None = None,
             paper: dict | None = None, force: bool = False, certify: float | None = None,
             study=None, diagnose: bool | None = None) -> RunResult:
    """Run both stages on a case and write the results folder.

    The folder is checked before solving and written as ``docs/outputs.md`` says
    (`vibupdate.io.outputs`): a run that fails or is interrupted leaves it as it was.

    Parameters
    ----------
    case : Case
        The case to run (`load_case`, or built in Python).
    out_dir : str or Path
        The results folder (docs/outputs.md names its files); created when missing.
    progress : callable, optional
        Receives one line of progress at a time.
    paper : dict, optional
        Reference columns for the report's tables (a bundled example's
        ``reference_columns()``: published values, a synthetic example's truth).
    force : bool
        Accept a folder that holds files other than this command's unchanged results of the
        case (they are kept) or results of another case.
    certify : float, optional
        Time budget, s, of the certified outer parameter ranges (`vibupdate.ranges.certify`,
        in ``identifiability.certified``); None skips them.
    study : callable, optional
        A further study of the case run after the update, such as the sampled ranges and
        multistart of `vibupdate.study.sampled_ranges.SampledRanges`. It has ``files`` (names
        it writes), ``check(case)`` (raises ValueError before any work) and is called as
        ``study(case, result, say) -> (sections, write, answers)``: ``sections`` join
        ``identifiability``, ``write(folder)`` writes its files and returns its plots,
        ``answers`` are the further answers it reports as consistent with the data
        (``(label, xbar)``, normalized). The study runs before the certification, which widens
        the consistent set to hold the run's answer and these (`vibupdate.ranges.inclusion`),
        so the certified range contains every answer the run reports or is not flagged
        certified.
    diagnose : bool, optional
        Whether an answer that does not fit the data is followed by the diagnosis of which
        data conflict (`vibupdate.inverse.diagnosis`); None takes the case's
        ``[verification] diagnose``.

    Returns
    -------
    RunResult
        What the run wrote to ``results.json``, with the updated matrices.

    Raises
    ------
    ValueError
        The case or the options are invalid, or the folder cannot be used; raised before any
        solve.
    KeyboardInterrupt
        Ctrl-C: what is then written is ``docs/cli.md`` ("Exit codes", 130); after the update
        has an answer, `vibupdate.io.interrupted.Interrupted` says what was kept.
    """
    from vibupdate import __version__

    if certify is not None and not certify >= 0:
        raise ValueError(f"the certification time budget must be >= 0 seconds, got {certify!r}")
    say = progress or (lambda message: None)
    checked = validate_case(case)       # what check validates, before anything is touched
    for w in checked.warnings:
        say(f"warning: {w}")
    case = checked.case or case         # with the solver's bounds where the box reaches unphysical models
    if study is not None:
        study.check(case)
    target = prepare_output(out_dir, force=force, planned=planned_files(case) + list(study.files if study else ()),
                            command="run", inputs=case.inputs, case=case.name)
    verification = case.verify_options()
    result = update(case.configurations, formulation=case.formulation, solver=case.solver, polish=case.polish,
                    verification=verification, progress=say, prepared=checked.prepared)
    later = _Stages(say, "uniqueness search" if result.sought is not None and result.sought.interrupted else None)
    later.say(f"{result.status.value} ({result.verdict.value}): {result.message} ({result.seconds:.2f} s)")
    if result.success:
        from vibupdate.report.document import limited_text

        limited = limited_text(result.checks)
        if limited:
            later.say(limited[2:])
    diagnose = verification.diagnose if diagnose is None else diagnose
    # each stage's condition is its `wanted`: when it is false the stage's module is not imported
    diagnosis, diagnosis_notes = later.run("diagnosis", diagnose and not result.success, (None, []),
                                           lambda: (_diagnosis(case, result, verification, say), ()))
    suggestion, suggestion_notes = later.run(
        "screening of candidates", result.status == Status.NOT_VERIFIED and bool(case.candidates)
        and verification.suggest, (None, []), lambda: (_suggestion(case, result, verification, say), ()))
    stage, notes, info = later.run("damping fit", _has_damping(case), (None, [], {}),
                                   lambda: _said_after(lambda said: damping_stage(case, result.xbar, said,
                                                                                   result.correlation.updated)))
    notes = list(checked.warnings) + notes + diagnosis_notes + suggestion_notes
    identifiability = _identifiability(result)
    for combo in identifiability["undetermined_combinations"]:
        later.say(f"not determined by the data (exact null direction of the frequency sensitivity): {combo}")
    if not result.success:
        identifiability["ranges_note"] = ("consistent ranges not computed: they are linearized at the "
                                          "answer and mean something only at a verified answer")
    else:
        ranges = later.run("range computation", True, None, lambda: _ranges(case, result))
        identifiability.update(ranges or {"ranges_note": "consistent ranges not computed: the run was interrupted "
                                                         "(Ctrl-C)"})
    extra, answers = None, ()
    if study is not None:
        sections, extra, answers = later.run("study", True, ({}, None, ()), lambda: (study(case, result, say), ()))
        identifiability.update(sections)
    if certify is not None:
        certified = later.run("certification", True, None, lambda: _certified(case, result, certify, say, answers))
        if certified is not None:
            identifiability["certified"] = certified
    if later.stopped:
        notes.append(later.note())
        later.say(f"warning: {notes[-1]}")
    run = run_result(case, result, stage, identifiability=identifiability, damping_model=info or None,
                     warnings=notes, paper=paper, diagnosis=diagnosis, suggestion=suggestion)
    written = write_published(target, lambda staged: write_outputs(staged, case, run, extra), case=case.name,
                              version=__version__)
    try:
        _say_written(target, written, run, say)
    except KeyboardInterrupt:
        raise Interrupted(f"the results were written to {target.path}/ before it") from None
    if later.stopped:
        without = f" without {_listed(later.skipped)}" if later.skipped else ""
        raise Interrupted(f"{later.what()}; the update's answer ({result.verdict.value}) was "
                          f"written to {target.path}/{without}")
    return written


class _Stages:
    """The stages after the update, ended by Ctrl-C: the stage a Ctrl-C interrupts returns
    what it would return when not wanted, and every later stage is skipped, so that the update's
    answer is written at once with what was computed before (`run_case`).

    A stage computes and returns its value with the lines that say it is done; `run` keeps
    the value before it says them, and a Ctrl-C while a line is said (`say`) stops the run
    after what is done. So a stage is either in the results whole, or left out and said to be:
    never kept and said to be missing, or said done and then dropped."""

    def __init__(self, say: Callable[[str], None], stopped: str | None = None):
        self._say = say
        self.stopped = stopped      # the stage Ctrl-C ended (the update's uniqueness search included)
        self.after = False          # Ctrl-C came while a line was said, after ``stopped`` was done
        self.done = "update"        # the last stage done
        self.skipped: list[str] = []

    def run(self, name: str, wanted: bool, otherwise, compute: Callable):
        """``compute()``, which returns the stage's value and the lines to say once it is kept,
        when ``wanted`` and no Ctrl-C came before; else ``otherwise``."""
        if not wanted:
            return otherwise
        if self.stopped is not None:
            self.skipped.append(name)
            return otherwise
        try:
            value, lines = compute()
        except KeyboardInterrupt:
            self.stopped = name
            return otherwise
        self.done = name
        for line in lines:
            self.say(line)
        return value

    def say(self, line: str) -> None:
        """``line`` said; a Ctrl-C while it is said stops the run after the last stage done."""
        try:
            self._say(line)
        except KeyboardInterrupt:
            if self.stopped is None:
                self.stopped, self.after = self.done, True

    def what(self) -> str:
        """What was interrupted, in words."""
        return (f"the run was interrupted after the {self.stopped}" if self.after
                else f"the {self.stopped} was interrupted")

    def note(self) -> str:
        """The run's warning that says what the interruption left out."""
        return (f"{self.what()} (Ctrl-C): the results hold what was computed before it"
                + (f"; not computed: {_listed(self.skipped)}" if self.skipped else ""))


def _listed(names) -> str:
    names = [f"the {n}" for n in names]
    return ", ".join(names[:-1]) + " and " + names[-1] if len(names) > 1 else "".join(names)


def _has_damping(case: Case) -> bool:
    return any(f.damping_ratio is not None for c in case.configurations for f in c.natural)


def _ranges(case: Case, result: UpdateResult) -> tuple[dict, list[str]]:
    """The linearized parameter ranges at a verified answer: the sections of ``identifiability``
    and the line that says them."""
    from vibupdate.ranges.identifiability import parameter_ranges

    # at any size: the Jacobian is the exact sparse one (its cost: docs/notes/ranges.md, "Linearized ranges")
    ranges = parameter_ranges(case.configurations, result.xbar, frequency_tolerance=case.frequency_tolerance,
                              freqs=result.correlation.updated, valley=result.valley)
    sections = {"ranges": ranges.as_dict(), "frequency_tolerance": case.frequency_tolerance,
                "frequency_windows": frequency_windows(case)}
    return sections, ["parameters determined within 5 % by the data: " + (", ".join(ranges.determined(5.0)) or "none")]


def _said_after(stage: Callable):
    """``stage(say)``'s value and the lines it said, kept to be said once the value is
    (`_Stages.run`)."""
    lines: list[str] = []
    return stage(lines.append), lines


def _say_written(target, written: RunResult, run: RunResult, say) -> None:
    """The lines after the results are in place: new warnings, what was written, what was kept."""
    from vibupdate.io.manifests import read_manifest

    for note in written.warnings[len(run.warnings):]:
        say(f"warning: {note}")
    plotted = any(name.endswith(".png") for name in read_manifest(target.path) or ())
    kinds = "results.json, report.md, " + ("plots, " if plotted else "") + "matrices"
    say(f"wrote {target.path}/ ({kinds}; {MANIFEST} lists them)")
    kept = kept_note(target)
    if kept:
        say(kept)


def _diagnosis(case: Case, result: UpdateResult, verification, say):
    """Which data conflict (`vibupdate.inverse.diagnosis`), for an answer that is not verified
    and failed a check of its fit to the data; None otherwise. Returns it and the run's notes:
    a diagnosis that fails costs a note, never the run's results."""
    from vibupdate.inverse.diagnosis import diagnose, wants_diagnosis

    failed = [c.name for c in result.checks if c.severity == "error" and not c.passed]
    if not wants_diagnosis(result.status, failed):
        return None, []
    try:
        return diagnose(case.configurations, result, formulation=case.formulation, solver=case.solver,
                        polish=case.polish, verification=verification, progress=say), []
    except Exception as exc:  # the diagnosis explains the answer; the answer stands without it
        note = f"the diagnosis of which data conflict failed: {type(exc).__name__}: {exc}"
        say(f"warning: {note}")
        return None, [note]


#: Seconds of the screening of candidates after a run that is not verified (docs/method.md, 7.9).
SUGGEST_SECONDS = 60.0


def _suggestion(case: Case, result: UpdateResult, verification, say):
    """When the answer is not verified and the case declares candidates (and ``[verification]
    suggest``): each single candidate screened from the answer, no full update
    (`vibupdate.ranges.candidates`). Returns its record and the run's notes: a screening that
    fails costs a note, never the run's results."""
    from vibupdate.ranges.candidates import suggest_sets

    own = [p.name for p in result.parameters]
    try:
        found = suggest_sets(case.pool, own, [p.name for p in case.candidates], max_size=1, checked=0,
                             polish=case.polish, verification=verification, progress=say,
                             start=dict(zip(own, np.asarray(result.xbar, dtype=float))), max_seconds=SUGGEST_SECONDS)
        return found.record(), []
    except (ValueError, np.linalg.LinAlgError) as exc:  # the screening explains the answer; it stands without it
        note = f"the screening of the candidates failed: {exc}"
        say(f"warning: {note}")
        return None, [note]


def _certified(case: Case, result: UpdateResult, seconds: float, say, answers=()) -> tuple[dict, list[str]]:
    """Certified outer ranges over the consistent set, with the vector boxes the first stage
    ended with (it may have widened the margins), widened to hold the answer and ``answers``
    (the study's, ``(label, xbar)``); with the line that says them."""
    from vibupdate.ranges.certify import certified_ranges

    last = result.attempts[-1] if result.attempts else None
    boxes = case.formulation if last is None else replace(case.formulation, shape_margin=last.shape_margin,
                                                          adjunct_margin=last.adjunct_margin)
    cert = certified_ranges(case.configurations, result.xbar, include=answers,
                            frequency_tolerance=case.frequency_tolerance, seconds=seconds, options=boxes, progress=say)
    return cert.record(), [f"certified ranges: {cert.message} ({cert.seconds:.1f} s)"]


def run_example(name: str, out_dir, *, progress: Callable[[str], None] | None = None,
                force: bool = False, certify: float | None = None, study=None,
                diagnose: bool | None = None) -> RunResult:
    """Run a bundled example end to end (`run_case`); returns the results object."""
    say = progress or (lambda message: None)
    module = example_module(name)
    case = module.case()
    model = case.configurations[0].model
    say(f"example {name}: {len(case.configurations)} configuration(s), {model.n_parameters} parameters, "
        f"{model.n_dofs} DOFs")
    paper = module.reference_columns() if hasattr(module, "reference_columns") else None
    return run_case(case, out_dir, progress=say, paper=paper, force=force, certify=certify, study=study,
                    diagnose=diagnose)
