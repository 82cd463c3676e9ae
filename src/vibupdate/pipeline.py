"""The whole job in one call: data in, results out (DESIGN.md data flow).

``run_case`` runs both stages and writes the output directory: ``results.json``,
``report.md``, PNG plots and the updated ``M``, ``C``, ``K`` of each configuration as Matrix
Market files. Everything is written to a temporary directory beside the target and moved
into place only when complete, so a failed run never leaves an output that looks finished.
The CLI is a thin layer over these functions.
"""

from __future__ import annotations

import importlib
import shutil
import tempfile
import warnings
from collections.abc import Callable
from pathlib import Path

import numpy as np
import scipy.io
import scipy.sparse as sp

from vibupdate.analysis import mac as mac_matrix
from vibupdate.case import Case, DampingOptions
from vibupdate.correlation import model_frequencies
from vibupdate.damping import DampingStage, DampingWarning, caughey_matrix, damping_data, identify_damping
from vibupdate.examples import EXAMPLES
from vibupdate.results import results_document, write_results
from vibupdate.update import UpdateResult, prepare, update

__all__ = ["run_case", "run_example", "example_names", "example_module", "check_case"]

OUTPUT_MARKER = "results.json"
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


def check_case(case: Case) -> dict:
    """Validate a case and build its problem without solving; returns the problem size."""
    return prepare(case.configurations, case.formulation).sizes()


def _identifiability(result: UpdateResult) -> dict:
    from vibupdate.correlation import describe_direction

    s = result.sensitivity
    names = [p.name for p in result.parameters]
    return {"rank": s["rank"], "condition": s["condition"], "singular_values": s["singular_values"],
            "column_norm": {p.name: float(v) for p, v in zip(result.parameters, s["column_norm"])},
            "undetermined_combinations": [describe_direction(names, v) for v in s["null_directions"]]}


def _damping_stage(case: Case, xbar, say) -> tuple[DampingStage | None, list[str], dict]:
    options = case.damping or DampingOptions()
    if not any(f.damping_ratio is not None for c in case.configurations for f in c.natural):
        return None, [], {}
    _, ratios, labels = damping_data(case.configurations, xbar)
    factors = dict(options.mode_weights)
    weights = np.array([factors.get(mode, 1.0) for _, mode in labels])
    if options.relative:
        weights = weights / ratios**2
    notes = []
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", DampingWarning)
        stage = identify_damping(case.configurations, xbar, options.exponents, weights)
    notes += [str(w.message) for w in caught if issubclass(w.category, DampingWarning)]
    for n in notes:
        say(f"warning: {n}")
    text = ("W_ii = " + ("w_mode / xi_i^2 (relative errors)" if options.relative else "w_mode")
            + (f" with w_mode = {factors}" if factors else " with w_mode = 1"))
    if options.rationale:
        text += f". {options.rationale}"
    info = {"exponents": list(options.exponents), "beta": stage.caughey.beta.tolist(),
            "rayleigh_beta": stage.rayleigh.beta.tolist(), "condition": stage.caughey.condition,
            "weights_text": text}
    say(f"damping: Caughey Y = {list(options.exponents)} mean error {stage.caughey.mean_error_pct:.1f} %, "
        f"Rayleigh {stage.rayleigh.mean_error_pct:.1f} %")
    return stage, notes, info


def _write_outputs(tmp: Path, case: Case, result: UpdateResult, stage: DampingStage | None,
                   document: dict, notes: list[str]) -> None:
    from vibupdate.plots import plot_frf, plot_homotopy, plot_mac
    from vibupdate.report import markdown_report

    images = []
    for cfg in case.configurations:
        M, K = result.matrices[cfg.name]
        M0, K0 = cfg.model.matrices()
        C = C0 = None
        if stage is not None:
            C = caughey_matrix(M, K, stage.caughey.exponents, stage.caughey.beta)
            C0 = caughey_matrix(M0, K0, stage.caughey.exponents, stage.caughey.beta)
        for name, A in (("M", M), ("K", K)) + ((("C", C),) if C is not None else ()):
            scipy.io.mmwrite(str(tmp / f"{name}_{cfg.name}.mtx"), sp.coo_matrix(A),
                             comment=f"vibupdate {case.name}: updated {name} of configuration {cfg.name} (SI units)")
        rc = cfg.receptances()[0] if cfg.receptances() else None
        if rc is None:
            dof = int(np.argmax(np.abs(np.diag(M.toarray()))))
            r = c = dof
            label = f"h_{cfg.model.dofs[dof]},{cfg.model.dofs[dof]}"
        else:
            r, c = cfg.model.dof(rc[0]), cfg.model.dof(rc[1])
            label = f"h_{rc[0]},{rc[1]}"
        file = f"frf_{cfg.name}.png"
        plot_frf(tmp / file, cfg, (M0, K0, C0), (M, K, C), r, c, label)
        images.append((f"FRF {label}, configuration {cfg.name}", file))
        mac = result.mac.get(cfg.name)
        if mac is not None and np.any(np.isfinite(mac)):
            measured = [f for f in cfg.natural if f.shape is not None]
            dofs = sorted({d for f in measured for d in f.shape.bounds}, key=cfg.model.dof)
            idx = [cfg.model.dof(d) for d in dofs]
            X = np.array([[f.shape.midpoint.get(d, 0.0) for d in dofs] for f in measured]).T
            Phi = model_frequencies(cfg, result.xbar).Phi[idx]
            file = f"mac_{cfg.name}.png"
            plot_mac(tmp / file, mac_matrix(X, Phi), f"MAC, configuration {cfg.name}")
            images.append((f"MAC configuration {cfg.name}", file))
    plot_homotopy(tmp / "homotopy.png", document["solver"]["steps"])
    images.append(("homotopy objective per step", "homotopy.png"))
    (tmp / "report.md").write_text(markdown_report(document, images, notes), encoding="utf-8")
    write_results(tmp / "results.json", document)


def _publish(tmp: Path, final: Path) -> None:
    if final.exists():
        if not final.is_dir():
            raise ValueError(f"output path {str(final)!r} exists and is not a directory")
        if any(final.iterdir()) and not (final / OUTPUT_MARKER).exists():
            raise ValueError(f"output directory {str(final)!r} is not empty and holds no vibupdate results; "
                             "choose another --out")
        shutil.rmtree(final)
    tmp.rename(final)


def run_case(case: Case, out_dir, *, progress: Callable[[str], None] | None = None,
             paper: dict | None = None, certify: float | None = None) -> tuple[UpdateResult, dict]:
    """Both stages on a case; writes the output directory and returns (result, document).

    ``certify``: time budget in seconds of the certified outer parameter ranges
    (`vibupdate.certify`); None skips them.
    """
    say = progress or (lambda message: None)
    final = Path(out_dir)
    if final.exists() and not final.is_dir():
        raise ValueError(f"output path {str(final)!r} exists and is not a directory")
    if certify is not None and not certify >= 0:
        raise ValueError(f"the certification time budget must be >= 0 seconds, got {certify!r}")
    result = update(case.configurations, formulation=case.formulation, solver=case.solver, progress=say)
    say(f"{result.status.value}: {result.message} ({result.seconds:.2f} s)")
    stage, notes, info = _damping_stage(case, result.xbar, say)
    extra = {"identifiability": _identifiability(result)}
    for combo in extra["identifiability"]["undetermined_combinations"]:
        say(f"not determined by the data (exact null direction of the frequency sensitivity): {combo}")
    if not result.success:
        extra["identifiability"]["ranges_note"] = ("consistent ranges not computed: they are linearized at the "
                                                   "answer and mean something only at a verified answer")
    elif case.configurations[0].model.n_dofs <= RANGES_DOF_LIMIT:
        from vibupdate.identifiability import parameter_ranges

        ranges = parameter_ranges(case.configurations, result.xbar, frequency_tolerance=case.frequency_tolerance)
        extra["identifiability"]["ranges"] = ranges.as_dict()
        extra["identifiability"]["frequency_tolerance"] = case.frequency_tolerance
        say("parameters determined within 5 % by the data: " + (", ".join(ranges.determined(5.0)) or "none"))
    if certify is not None:
        from dataclasses import replace

        from vibupdate.certify import certified_ranges

        # The vector boxes the first stage ended with (it may have widened the margins).
        last = result.attempts[-1] if result.attempts else {}
        boxes = replace(case.formulation, **{k: last[k] for k in ("shape_margin", "adjunct_margin") if k in last})
        cert = certified_ranges(case.configurations, result.xbar, frequency_tolerance=case.frequency_tolerance,
                                seconds=certify, options=boxes, progress=say)
        extra["identifiability"]["certified"] = cert.record()
        say(f"certified ranges: {cert.message} ({cert.seconds:.1f} s)")
    if info:
        extra["damping_model"] = info
    if paper:
        extra["paper"] = paper
    document = results_document(
        case.name, case.configurations, updated_xbar=result.xbar, problem_size=result.problem_size,
        solver=result.solver_record(), damping=stage.rows() if stage else None,
        damping_summary=stage.summary() if stage else None, extra=extra)
    final.parent.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(prefix=f".{final.name}.partial-", dir=final.parent))
    try:
        _write_outputs(tmp, case, result, stage, document, notes)
        _publish(tmp, final)
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
    say(f"wrote {final}/ (results.json, report.md, plots, matrices)")
    return result, document


def run_example(name: str, out_dir, *, progress: Callable[[str], None] | None = None,
                certify: float | None = None) -> dict:
    """Run a bundled example end to end; returns the ``results.json`` document."""
    say = progress or (lambda message: None)
    module = example_module(name)
    case = module.case()
    model = case.configurations[0].model
    say(f"example {name}: {len(case.configurations)} configuration(s), {model.n_parameters} parameters, "
        f"{model.n_dofs} DOFs")
    paper = module.paper_values() if hasattr(module, "paper_values") else None
    _, document = run_case(case, out_dir, progress=say, paper=paper, certify=certify)
    return document
