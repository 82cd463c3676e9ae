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
import scipy.io
import scipy.sparse as sp

from vibupdate.io.case import Case, DampingOptions
from vibupdate.damping import DampingStage, DampingWarning, damping_data, identify_damping
from vibupdate.examples import EXAMPLES
from vibupdate.io.outputs import MANIFEST, file_names, prepare_output, write_published
from vibupdate.io.results import RunResult, run_result, write_results
from vibupdate.inverse.update import UpdateResult, update
from vibupdate.io.validation import CaseCheck, validate_case

__all__ = ["run_case", "run_example", "example_names", "example_module", "check_case", "write_outputs",
           "planned_files"]

#: Parameter ranges (exact Jacobian of the modal data, two LPs per parameter) up to this size.
RANGES_DOF_LIMIT = 2000


def example_names() -> list[str]:
    """Names of the bundled examples."""
    return sorted(EXAMPLES)


def example_module(name: str):
    """The module of a bundled example (``case()``, ``configurations()``, ``paper_values()``)."""
    if name not in EXAMPLES:
        raise ValueError(f"unknown example {name!r}; bundled examples: {', '.join(example_names())}")
    return importlib.import_module(f"vibupdate.examples.{EXAMPLES[name]}")


def check_case(case: Case) -> CaseCheck:
    """Validate a case exactly as `run_case` does before solving (`vibupdate.io.validation`);
    returns the problem size, notes and warnings. Raises ValueError naming file and key."""
    return validate_case(case)


def _identifiability(result: UpdateResult) -> dict:
    from vibupdate.inverse.correlation import describe_direction

    s = result.sensitivity
    names = [p.name for p in result.parameters]
    return {"rank": s["rank"], "condition": s["condition"], "singular_values": s["singular_values"],
            "column_norm": {p.name: float(v) for p, v in zip(result.parameters, s["column_norm"])},
            "undetermined_combinations": [describe_direction(names, v) for v in s["null_directions"]]}


def _damping_stage(case: Case, xbar, say, freqs=None) -> tuple[DampingStage | None, list[str], dict]:
    """The second stage at ``xbar``; ``freqs``: the configurations' modal data there when
    already computed (``UpdateResult.modal``)."""
    options = case.damping or DampingOptions()
    if not any(f.damping_ratio is not None for c in case.configurations for f in c.natural):
        return None, [], {}
    _, ratios, labels = damping_data(case.configurations, xbar, freqs)
    factors = dict(options.mode_weights)
    weights = np.array([factors.get(mode, 1.0) for _, mode in labels])
    half = _damping_half_widths(case, labels)
    from_intervals = half is not None
    if from_intervals:
        weights = weights / half**2
    elif options.relative:
        weights = weights / ratios**2
    notes = []
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", DampingWarning)
        stage = identify_damping(case.configurations, xbar, options.exponents, weights, freqs=freqs)
    notes += [str(w.message) for w in caught if issubclass(w.category, DampingWarning)]
    notes += list(stage.warnings)
    for n in notes:
        say(f"warning: {n}")
    if from_intervals:
        text = ("W_ii = w_mode / h_i^2, h_i the half-width of the measured ratio's interval ("
                + ", ".join(f"mode {mode}: {h:.3g}" for (_, mode), h in zip(labels, half)) + ")"
                + ("; the case's relative = true is superseded by the intervals" if options.relative else ""))
    else:
        text = "W_ii = " + ("w_mode / xi_i^2 (relative errors)" if options.relative else "w_mode")
    text += f" with w_mode = {factors}" if factors else " with w_mode = 1"
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
    ``labels`` ((configuration, mode) pairs of `damping_data`); None unless every ratio has an
    interval of positive width (then the damping fit weighs each ratio by ``1 / h^2``)."""
    by_name = {c.name: c for c in case.configurations}
    half = []
    for name, k in labels:
        pair = by_name[name].natural[k - 1].damping_interval
        if pair is None or not pair[1] > pair[0]:
            return None
        half.append(0.5 * (pair[1] - pair[0]))
    return np.array(half)


def _frequency_windows(case: Case) -> str:
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
    names = ["results.json", "report.md", "homotopy.png"]
    for part in file_names([c.name for c in case.configurations]).values():
        names += [f"M_{part}.mtx", f"K_{part}.mtx", f"C_{part}.mtx", f"frf_{part}.png", f"mac_{part}.png"]
    return names


def _measured_frf_plot(path: Path, cfg, frfs, nominal, updated) -> tuple[str, str]:
    """``frf_NAME.png`` of a configuration whose data came from FRF files: the measured
    receptances over the nominal and updated model receptances; returns the report's caption
    and the file name."""
    from vibupdate.report.plots import plot_measured_frf

    damped = "with the identified Caughey damping" if updated[2] is not None else "undamped"
    nominal_damping = "identified damping applied" if nominal[2] is not None else "undamped"
    title = f"configuration {cfg.name}: measured and model receptances (m/N)"
    plot_measured_frf(path, frfs, cfg.model.dofs, nominal, updated, title,
                      f"nominal model ({nominal_damping})", f"updated model ({damped})")
    caption = (f"FRFs of configuration {cfg.name}: measured receptance (m/N, mean of the repeats, "
               f"{frfs.freq_hz[0]:.4g}-{frfs.freq_hz[-1]:.4g} Hz) against the nominal model ({nominal_damping}) "
               f"and the updated model ({damped})")
    return caption, path.name


def write_outputs(folder: Path, case: Case, run: RunResult,
                  extra: Callable[[Path], list[tuple[str, str]]] | None = None) -> list[str]:
    """Write ``results.json``, ``report.md``, plots and matrices of ``run`` into ``folder``.

    Every file is written from ``run`` (the nominal models for the FRF plot from ``case``);
    ``extra(folder)``, when given, writes a study's files and returns its plots as
    ``(caption, file name)`` for the report. Returns the file names written.
    """
    from vibupdate.report.plots import plot_frf, plot_homotopy, plot_mac
    from vibupdate.report.document import markdown_report

    parts = file_names([c.name for c in case.configurations])
    images = []
    for cfg in case.configurations:
        part, matrices = parts[cfg.name], run.matrices[cfg.name]
        for name in ("M", "K", "C"):
            if name in matrices:
                scipy.io.mmwrite(str(folder / f"{name}_{part}.mtx"), sp.coo_matrix(matrices[name]),
                                 comment=f"vibupdate: updated {name} of configuration {part} (SI units)")
        file = f"frf_{part}.png"
        updated = (matrices["M"], matrices["K"], matrices.get("C", matrices.get("damping_law")))
        if cfg.name in case.frfs:
            images.append(_measured_frf_plot(folder / file, cfg, case.frfs[cfg.name], matrices["nominal"], updated))
        else:
            response, excitation = run.frf[cfg.name]["response"], run.frf[cfg.name]["excitation"]
            label = f"h_{response},{excitation}"
            plot_frf(folder / file, cfg, matrices["nominal"], updated, cfg.model.dof(response),
                     cfg.model.dof(excitation), label)
            images.append((f"FRF {label}, configuration {cfg.name}", file))
        mac = run.mac_matrix.get(cfg.name)
        if mac is not None:
            file = f"mac_{part}.png"
            values = np.array(mac["values"], dtype=float)  # None (not computed) becomes NaN
            plot_mac(folder / file, values, f"MAC, configuration {cfg.name}")
            images.append((f"MAC configuration {cfg.name}", file))
    plot_homotopy(folder / "homotopy.png", run.solver["steps"])
    images.append(("homotopy objective per step", "homotopy.png"))
    if extra is not None:
        images += extra(folder)
    document = run.as_document()
    (folder / "report.md").write_text(markdown_report(document, images, list(run.warnings)), encoding="utf-8")
    write_results(folder / "results.json", run)
    return sorted(p.name for p in folder.iterdir())


def run_case(case: Case, out_dir, *, progress: Callable[[str], None] | None = None,
             paper: dict | None = None, force: bool = False, certify: float | None = None,
             study=None) -> RunResult:
    """Both stages on a case; writes the results folder and returns the results object.

    ``certify``: time budget in seconds of the certified outer parameter ranges
    (`vibupdate.ranges.certify`, in ``identifiability.certified``); None skips them.

    ``study``: a further study of the case run after the update, such as the sampled ranges
    and multistart of `vibupdate.study.sampled_ranges.SampledRanges`. It has ``files`` (names
    it writes), ``check(case)`` (raises ValueError before any work) and is called as
    ``study(case, result, say) -> (sections, write, answers)``: ``sections`` join
    ``identifiability``, ``write(folder)`` writes its files and returns its plots, ``answers``
    are the further answers it reports as consistent with the data (``(label, xbar)``,
    normalized). The study runs before the certification, which widens the consistent set to
    hold the run's answer and these (`vibupdate.ranges.inclusion`), so the certified range
    contains every answer the run reports or is not flagged certified.

    The folder is checked before solving (`vibupdate.io.outputs.prepare_output`: writable, no
    file vibupdate did not write unless ``force``); the files are written beside it and moved
    into place at the end, so a run that fails or is interrupted leaves earlier results as
    they were, and files in the folder that vibupdate did not write are never touched.
    """
    from vibupdate import __version__

    say = progress or (lambda message: None)
    if certify is not None and not certify >= 0:
        raise ValueError(f"the certification time budget must be >= 0 seconds, got {certify!r}")
    checked = validate_case(case)       # what check validates, before anything is touched
    for w in checked.warnings:
        say(f"warning: {w}")
    case = checked.case or case         # with the solver's bounds where the box reaches unphysical models
    if study is not None:
        study.check(case)
    target = prepare_output(out_dir, force=force, planned=planned_files(case) + list(study.files if study else ()))
    verification = case.verification
    if case.frequency_tolerance > 0:
        verification = replace(verification, frequency_tolerance=case.frequency_tolerance)
    result = update(case.configurations, formulation=case.formulation, solver=case.solver, polish=case.polish,
                    verification=verification, progress=say, prepared=checked.prepared)
    say(f"{result.status.value}: {result.message} ({result.seconds:.2f} s)")
    stage, notes, info = _damping_stage(case, result.xbar, say, result.modal)
    notes = list(checked.warnings) + notes
    identifiability = _identifiability(result)
    for combo in identifiability["undetermined_combinations"]:
        say(f"not determined by the data (exact null direction of the frequency sensitivity): {combo}")
    if not result.success:
        identifiability["ranges_note"] = ("consistent ranges not computed: they are linearized at the "
                                          "answer and mean something only at a verified answer")
    elif case.configurations[0].model.n_dofs <= RANGES_DOF_LIMIT:
        from vibupdate.ranges.identifiability import parameter_ranges

        ranges = parameter_ranges(case.configurations, result.xbar, frequency_tolerance=case.frequency_tolerance)
        identifiability["ranges"] = ranges.as_dict()
        identifiability["frequency_tolerance"] = case.frequency_tolerance
        identifiability["frequency_windows"] = _frequency_windows(case)
        say("parameters determined within 5 % by the data: " + (", ".join(ranges.determined(5.0)) or "none"))
    extra, answers = None, ()
    if study is not None:
        sections, extra, answers = study(case, result, say)
        identifiability.update(sections)
    if certify is not None:
        identifiability["certified"] = _certified(case, result, certify, say, answers)
    run = run_result(case, result, stage, identifiability=identifiability, damping_model=info or None,
                     warnings=notes, paper=paper)
    write_published(target, lambda staged: write_outputs(staged, case, run, extra), case=case.name,
                    version=__version__)
    say(f"wrote {target.path}/ (results.json, report.md, plots, matrices; {MANIFEST} lists them)")
    return run


def _certified(case: Case, result: UpdateResult, seconds: float, say, answers=()) -> dict:
    """Certified outer ranges over the consistent set, with the vector boxes the first stage
    ended with (it may have widened the margins), widened to hold the answer and ``answers``
    (the study's, ``(label, xbar)``)."""
    from vibupdate.ranges.certify import certified_ranges

    last = result.attempts[-1] if result.attempts else {}
    boxes = replace(case.formulation, **{k: last[k] for k in ("shape_margin", "adjunct_margin") if k in last})
    cert = certified_ranges(case.configurations, result.xbar, include=answers,
                            frequency_tolerance=case.frequency_tolerance, seconds=seconds, options=boxes, progress=say)
    say(f"certified ranges: {cert.message} ({cert.seconds:.1f} s)")
    return cert.record()


def run_example(name: str, out_dir, *, progress: Callable[[str], None] | None = None,
                force: bool = False, certify: float | None = None, study=None) -> RunResult:
    """Run a bundled example end to end (`run_case`); returns the results object."""
    say = progress or (lambda message: None)
    module = example_module(name)
    case = module.case()
    model = case.configurations[0].model
    say(f"example {name}: {len(case.configurations)} configuration(s), {model.n_parameters} parameters, "
        f"{model.n_dofs} DOFs")
    paper = module.paper_values() if hasattr(module, "paper_values") else None
    return run_case(case, out_dir, progress=say, paper=paper, force=force, certify=certify, study=study)
