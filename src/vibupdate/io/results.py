"""One results object per run, and ``results.json``, its document.

`run_result` builds a frozen `RunResult` once, from the first stage's `UpdateResult`, the
damping stage and the case; ``results.json`` (`write_results`), ``report.md``, the terminal
tables, the plots and the matrix files are all written from it. `load_results` reads a
``results.json`` back into the same typed object; the JSON Schema shipped with the package
(``results.schema.json``, `schema`) describes the file.

Contract of the file: keys may be added, never renamed. Every key is a field of the typed
object (rows carry any further keys of their producers in ``extra``, written flat).
Frequencies are in Hz, percentages are absolute relative errors times 100 (Eqs. 26-27),
``index`` and ``mode`` are 1-based within their kind and configuration; non-finite numbers
are written as ``null``.
"""

from __future__ import annotations

import dataclasses
import json
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import scipy.sparse as sp


#: Version of the layout of ``results.json`` (raised when a key is added).
FORMAT_VERSION = 2


def _num(value) -> float | None:
    """A finite Python float, or None."""
    if value is None:
        return None
    value = float(value)
    return value if math.isfinite(value) else None


def _plain(obj):
    """JSON-safe copy: numpy to Python, NaN/inf to None, tuples to lists."""
    if isinstance(obj, Mapping):
        return {str(k): _plain(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_plain(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return _plain(obj.tolist())
    if isinstance(obj, (bool, np.bool_)):
        return bool(obj)
    if isinstance(obj, (np.floating, float)):
        return _num(obj)
    if isinstance(obj, np.integer):
        return int(obj)
    if hasattr(obj, "value") and isinstance(getattr(obj, "value"), str):  # enums such as Status
        return obj.value
    return obj


def json_text(obj) -> str:
    """``obj`` as strict JSON text (indented): numpy to Python, NaN and +-inf to ``null`` (no
    ``NaN``/``Infinity`` tokens, which JSON does not have)."""
    return json.dumps(_plain(obj), indent=2, allow_nan=False)


class _Row:
    """Rows: typed fields plus ``extra``, further keys of the producer, written flat."""

    def as_dict(self) -> dict:
        out = {f.name: _plain(getattr(self, f.name)) for f in dataclasses.fields(self) if f.name != "extra"}
        out.update({k: _plain(v) for k, v in self.extra})
        return out

    @classmethod
    def from_dict(cls, data: Mapping):
        names = [f.name for f in dataclasses.fields(cls) if f.name != "extra"]
        missing = [n for n in names if n not in data]
        if missing:
            raise ValueError(f"{cls.__name__} lacks {', '.join(missing)}")
        extra = tuple((k, _plain(v)) for k, v in data.items() if k not in names)
        return cls(**{n: data[n] for n in names}, extra=extra)


@dataclass(frozen=True)
class ParameterRow(_Row):
    """One parameter: bounds, reference value (``p_ref`` of Eq. 12), updated value, ``xbar``."""

    name: str
    unit: str
    nominal: float
    lower: float
    upper: float
    reference: float
    updated: float | None
    xbar: float | None
    extra: tuple = ()


@dataclass(frozen=True)
class FrequencyRow(_Row):
    """One measured frequency (Hz) against the nominal and updated models."""

    configuration: str
    kind: str
    index: int
    measured_hz: float
    nominal_hz: float | None
    updated_hz: float | None
    error_nominal_pct: float | None
    error_updated_pct: float | None
    extra: tuple = ()


@dataclass(frozen=True)
class ModalMassRow(_Row):
    """One measured modal mass (kg, of a mass-normalized shape at its reference DOF) against
    the nominal and updated models; errors against the measured interval's midpoint."""

    configuration: str
    mode: int
    dof: str
    measured_lower_kg: float
    measured_upper_kg: float
    nominal_kg: float | None
    updated_kg: float | None
    error_nominal_pct: float | None
    error_updated_pct: float | None
    extra: tuple = ()


@dataclass(frozen=True)
class DampingRow(_Row):
    """One measured damping ratio against the Caughey fit and the Rayleigh baseline."""

    configuration: str
    mode: int
    measured: float
    identified: float | None
    error_pct: float | None
    rayleigh: float | None
    error_rayleigh_pct: float | None
    extra: tuple = ()


@dataclass(frozen=True)
class Summary(_Row):
    """Mean absolute errors in per cent (None where not computed)."""

    mean_error_nominal_pct: float | None
    mean_error_updated_pct: float | None
    mean_damping_error_pct: float | None
    mean_damping_error_rayleigh_pct: float | None
    extra: tuple = ()


@dataclass(frozen=True)
class SampledRange(_Row):
    """One parameter over the verified samples of ``run --samples``, in its unit: ``min`` and
    ``max`` over the answers and the line ends along null directions; the quantiles over the
    answers (None without a verified sample)."""

    unit: str
    min: float | None
    max: float | None
    q05: float | None
    q50: float | None
    q95: float | None
    extra: tuple = ()


@dataclass(frozen=True)
class Sampled:
    """``identifiability.sampled``: the counts of the samples and each parameter's range."""

    samples: int
    verified: int
    unverified: int
    failed: int
    line_ends: int
    seed: int
    distribution: str
    ranges: dict[str, SampledRange]

    @classmethod
    def from_dict(cls, data: Mapping) -> Sampled:
        return cls(int(data["samples"]), int(data["verified"]), int(data["unverified"]), int(data["failed"]),
                   int(data["line_ends"]), int(data["seed"]), str(data["distribution"]),
                   {n: SampledRange.from_dict(r) for n, r in data["ranges"].items()})


@dataclass(frozen=True)
class Multistart:
    """``identifiability.multistart``: random starts of the point estimate grouped into
    distinct local minima (``minima``: dicts with ``objective``, ``starts``, ``values`` per
    parameter in its unit), best first."""

    starts: int
    failed: int
    distinct_minima: int
    x_tol: float
    minima: tuple[dict, ...]

    @classmethod
    def from_dict(cls, data: Mapping) -> Multistart:
        return cls(int(data["starts"]), int(data["failed"]), int(data["distinct_minima"]), float(data["x_tol"]),
                   tuple(dict(m) for m in data["minima"]))


@dataclass(frozen=True)
class GroupTrialRow(_Row):
    """One group of the data left out by the diagnosis (`vibupdate.inverse.diagnosis`): the
    group (``key``, ``kind``, ``configuration``, ``label``, ``size``), its ``share`` of the
    misfit at the full answer, and the fit without it after refitting: polish ``objective``,
    whether the screened checks ``passed`` (``failed``: those that did not), relative frequency
    errors on the data kept (per cent), shape-interval misses, the answer ``xbar``, seconds."""

    key: str
    kind: str
    configuration: str
    label: str
    size: int
    share: float | None
    objective: float | None
    passed: bool
    failed: tuple
    mean_error_pct: float | None
    max_error_pct: float | None
    shape_misses: int
    xbar: tuple
    seconds: float | None
    extra: tuple = ()


@dataclass(frozen=True)
class DiagnosisBest(_Row):
    """The update run again without the top group: which group (``without``, its key, and
    ``without_label``), its ``status``, ``success`` and ``message``, the physical ``values`` by
    parameter name, ``xbar``, frequency errors on the data kept (per cent), its verification
    ``checks`` on the data kept and seconds."""

    without: str
    without_label: str
    status: str
    success: bool
    message: str
    values: dict
    xbar: tuple
    mean_error_pct: float | None
    max_error_pct: float | None
    checks: tuple
    seconds: float | None
    extra: tuple = ()


@dataclass(frozen=True)
class DiagnosisRecord(_Row):
    """``diagnosis`` of ``results.json``: which data conflict with the model. The checks that
    ``failed``, the full answer's polish ``objective`` and frequency errors, the number of
    ``groups`` and of those ``untried`` (limits), the ``trials`` ranked (best fit without the
    group first), the ``best`` update without the top group, and ``seconds``."""

    failed: tuple
    objective: float | None
    mean_error_pct: float | None
    max_error_pct: float | None
    groups: int
    untried: int
    trials: tuple[GroupTrialRow, ...]
    best: DiagnosisBest | None
    seconds: float | None
    limits: dict
    untried_groups: tuple = ()
    extra: tuple = ()

    def as_dict(self) -> dict:
        out = super().as_dict()
        out["trials"] = [t.as_dict() for t in self.trials]
        out["best"] = None if self.best is None else self.best.as_dict()
        return out

    @classmethod
    def from_dict(cls, data: Mapping) -> DiagnosisRecord:
        plain = dict(data)
        plain["trials"] = tuple(GroupTrialRow.from_dict(t) for t in data["trials"])
        plain["best"] = None if data.get("best") is None else DiagnosisBest.from_dict(data["best"])
        plain["failed"] = tuple(data["failed"])
        plain["untried_groups"] = tuple(data.get("untried_groups", ()))
        return super().from_dict(plain)

    @property
    def worst(self) -> GroupTrialRow | None:
        """The group whose removal leaves the best fit."""
        return self.trials[0] if self.trials else None


#: Top-level fields of `RunResult` that are not written to ``results.json``.
_NOT_WRITTEN = ("matrices",)


@dataclass(frozen=True)
class RunResult:
    """Everything a run produced; ``results.json`` is `as_document` of it.

    Attributes
    ----------
    version : str
        vibupdate version that wrote the results.
    format_version : int
        Layout version of ``results.json`` (`FORMAT_VERSION`).
    case : str
    success : bool
        Whether the first stage succeeded (``UpdateResult.success``: verified, once the
        verification stage exists).
    parameters : tuple of ParameterRow
    xbar : tuple of float
        Updated normalized parameters (Eq. 12), in the order of ``parameters``.
    frequencies : tuple of FrequencyRow
    modal_masses : tuple of ModalMassRow
        The modal masses of mass-normalized measured shapes; empty without them.
    mac : dict of str to list
        Per configuration, MAC of each measured mode shape with its paired updated mode
        (None where no shape was measured).
    mac_matrix : dict of str to dict
        Per configuration with measured shapes, ``{"values": (n_measured, n_model) MAC,
        "dofs": measured DOF names}``: the MAC plot.
    dofs : dict of str to list of str
        DOF names of each configuration's model, in matrix order.
    frf : dict of str to dict
        Per configuration, the receptance plotted: ``response``, ``excitation`` (DOF names).
    damping : tuple of DampingRow
    summary : Summary
    problem_size : dict
    solver : dict
        Status, message, every solve of the homotopy (``steps``), objective, relaxation lower
        bound, seconds.
    identifiability : dict or None
    damping_model : dict or None
    warnings : tuple of str
    checks : tuple of dict
        Verification checks of the first stage, as it reports them.
    paper : dict or None
        Reference columns of the tables (a bundled example's ``reference_columns()``:
        published values, a synthetic example's truth; `vibupdate.report.table.with_reference`).
    sensors : tuple of dict
        Measured points on an imported FE mesh (``[model] sensors``, `vibupdate import`):
        ``sensor``, ``dof`` (``"<node>:<dir>"``), ``sign``, ``distance_m``, ``direction``;
        empty otherwise.
    declared_sensors : tuple of dict
        Sensors declared in the case file (``[[sensor]]``, a ``sensors`` CSV; ``docs/sensors.md``):
        ``sensor`` (its name) and ``weights`` (DOF name to weight, the reading being
        ``sum_d weight_d u_d``); empty otherwise.
    diagnosis : DiagnosisRecord or None
        Which data conflict with the model, when the answer did not fit them
        (`vibupdate.inverse.diagnosis`); None otherwise.
    matrix_files : dict of str to dict
        Per configuration, the file of each matrix written (``M``, ``K``, ``C`` and, after a
        diagnosis, ``M_without_worst``, ``K_without_worst``): the names say when a model is
        not verified (`vibupdate.io.outputs.matrix_file`).
    matrices : dict
        Not written to JSON: per configuration ``{"M", "K", "C"}`` updated matrices (scipy
        sparse; ``C`` absent without damping data) and ``"nominal"`` ``(M0, K0, None)``: the
        case has no nominal damping model, so the nominal FRF is drawn undamped, never with
        the updated ``C``. Empty after `load_results`; the ``.mtx`` files hold them.
    """

    version: str
    format_version: int
    case: str
    success: bool
    parameters: tuple[ParameterRow, ...]
    xbar: tuple[float, ...]
    frequencies: tuple[FrequencyRow, ...]
    mac: dict
    mac_matrix: dict
    dofs: dict
    frf: dict
    damping: tuple[DampingRow, ...]
    summary: Summary
    problem_size: dict
    solver: dict
    identifiability: dict | None = None
    damping_model: dict | None = None
    warnings: tuple[str, ...] = ()
    checks: tuple[dict, ...] = ()
    paper: dict | None = None
    sensors: tuple[dict, ...] = ()
    declared_sensors: tuple[dict, ...] = ()
    diagnosis: DiagnosisRecord | None = None
    matrix_files: dict = field(default_factory=dict)
    suggestion: dict | None = None
    modal_masses: tuple[ModalMassRow, ...] = ()
    matrices: dict = field(default_factory=dict, compare=False, repr=False)

    @property
    def status(self) -> str:
        """The first stage's status string (``solver["status"]``)."""
        return str(self.solver.get("status", ""))

    @property
    def sampled(self) -> Sampled | None:
        """The sampled ranges (``run --samples``), typed; None when not computed."""
        data = (self.identifiability or {}).get("sampled")
        return Sampled.from_dict(data) if data else None

    @property
    def multistart(self) -> Multistart | None:
        """The multistart of the point estimate, typed; None when not run."""
        data = (self.identifiability or {}).get("multistart")
        return Multistart.from_dict(data) if data else None

    def as_document(self) -> dict:
        """The ``results.json`` document (JSON-safe)."""
        doc = {}
        for f in dataclasses.fields(self):
            if f.name in _NOT_WRITTEN:
                continue
            value = getattr(self, f.name)
            if isinstance(value, _Row):
                value = value.as_dict()
            elif isinstance(value, tuple) and value and isinstance(value[0], _Row):
                value = [row.as_dict() for row in value]
            doc[f.name] = _plain(value)
        return doc

    @classmethod
    def from_document(cls, doc: Mapping) -> RunResult:
        """The typed object of a ``results.json`` document (`validate_document` first)."""
        return cls(
            version=str(doc["version"]), format_version=int(doc["format_version"]), case=doc["case"],
            success=bool(doc["success"]),
            parameters=tuple(ParameterRow.from_dict(p) for p in doc["parameters"]),
            xbar=tuple(doc["xbar"]),
            frequencies=tuple(FrequencyRow.from_dict(r) for r in doc["frequencies"]),
            mac=dict(doc["mac"]), mac_matrix=dict(doc["mac_matrix"]), dofs=dict(doc["dofs"]), frf=dict(doc["frf"]),
            damping=tuple(DampingRow.from_dict(d) for d in doc["damping"]),
            summary=Summary.from_dict(doc["summary"]),
            problem_size=dict(doc["problem_size"]), solver=dict(doc["solver"]),
            identifiability=doc.get("identifiability"), damping_model=doc.get("damping_model"),
            warnings=tuple(doc.get("warnings", ())), checks=tuple(doc.get("checks", ())), paper=doc.get("paper"),
            sensors=tuple(dict(s) for s in doc.get("sensors", ())),
            declared_sensors=tuple({"sensor": s["sensor"], "weights": dict(s["weights"])}
                                   for s in doc.get("declared_sensors", ())),
            diagnosis=DiagnosisRecord.from_dict(doc["diagnosis"]) if doc.get("diagnosis") else None,
            matrix_files={k: dict(v) for k, v in doc.get("matrix_files", {}).items()},
            suggestion=doc.get("suggestion"),
            modal_masses=tuple(ModalMassRow.from_dict(r) for r in doc.get("modal_masses", ())),
        )


def _mean(values) -> float | None:
    values = [v for v in values if v is not None and math.isfinite(v)]
    return float(np.mean(values)) if values else None


def _check_dict(check) -> dict:
    """A verification check as a plain dict, whatever form the first stage gives it."""
    if isinstance(check, Mapping):
        return _plain(dict(check))
    if hasattr(check, "as_dict"):
        return _plain(check.as_dict())
    if dataclasses.is_dataclass(check):
        return _plain(dataclasses.asdict(check))
    return {"text": str(check)}


def _declared_sensors(configurations) -> tuple[dict, ...]:
    """The sensors of the configurations' models (each model carries the case's ``[[sensor]]``
    declarations), once each, in their order: ``{"sensor": name, "weights": {dof: weight}}``."""
    seen = {}
    for cfg in configurations:
        for s in getattr(cfg.model, "sensors", ()):
            seen.setdefault(s.name, {"sensor": s.name, "weights": {d: float(w) for d, w in s.weights}})
    return tuple(seen.values())


def _receptance_dofs(cfg, M) -> tuple[str, str]:
    receptances = cfg.receptances()
    if receptances:
        return receptances[0][0], receptances[0][1]
    dof = int(np.argmax(np.abs(M.diagonal())))
    return cfg.model.dofs[dof], cfg.model.dofs[dof]


def _matrices(cfg, updated, stage, modal) -> dict:
    """The ``matrices`` entry of one configuration: updated ``M``, ``K``, the nominal model
    undamped, and the identified damping (a dense ``C`` on small models, its modal law on
    large ones) built from the updated spectrum ``modal.spectrum`` when there is one."""
    from vibupdate.damping import caughey_damping

    M, K = updated
    M0, K0 = cfg.model.matrices()
    entry = {"M": M, "K": K, "nominal": (M0, K0, None)}
    if stage is not None:
        model_c = caughey_damping(M, K, stage.caughey.exponents, stage.caughey.beta,
                                  max((f.mode for f in cfg.natural), default=1),
                                  spectrum=modal.spectrum if modal is not None else None)
        entry["C" if isinstance(model_c, np.ndarray) else "damping_law"] = model_c
    return entry


def _mac_matrix(cfg, Phi: np.ndarray) -> dict:
    """MAC of the measured shapes (interval midpoints, rows) with the updated model's declared
    modes ``Phi`` (shape (n, n_p), columns); ``{"dofs", "values"}``."""
    from vibupdate.modal.analysis import mac

    measured = [f for f in cfg.natural if f.shape is not None]
    order = {d: i for i, d in enumerate((*cfg.model.dofs, *(s.name for s in cfg.model.sensors)))}
    names = sorted({d for f in measured for d in f.shape.bounds}, key=order.__getitem__)
    X = np.array([[f.shape.midpoint.get(d, 0.0) for d in names] for f in measured]).T
    return {"dofs": names, "values": mac(X, cfg.model.measurement(names) @ Phi)}


def run_result(case, result, stage=None, *, identifiability: dict | None = None,
               damping_model: dict | None = None, warnings: Sequence[str] = (),
               paper: dict | None = None, diagnosis=None, suggestion: dict | None = None) -> RunResult:
    """Build the results object of a run.

    Parameters
    ----------
    case : Case
        The case (its configurations give the nominal models and measured data).
    result : UpdateResult
        First stage. Its ``frequencies`` rows, ``mac`` and updated modal data (``modal``: the
        modes of the MAC matrix, the spectrum of the Caughey ``C``) are used as they are: no
        modal analysis is repeated here; ``checks`` and ``warnings`` when it has them.
    stage : DampingStage, optional
        Second stage; without it no ``C`` and no damping rows.
    identifiability, damping_model : dict, optional
        Sections computed by the pipeline.
    warnings : sequence of str
        Warnings of the run besides those of ``result``.
    paper : dict, optional
        Reference columns of the tables (a bundled example's ``reference_columns()``).
    diagnosis : Diagnosis, optional
        Which data conflict (`vibupdate.inverse.diagnosis`): its record goes to ``diagnosis``,
        the matrices of its best model (the update without the top group) beside the run's.
    suggestion : dict, optional
        Which candidates might be missing (`vibupdate.ranges.candidates.Suggestion.record`, the
        screening after a run that did not verify).
    """
    from vibupdate import __version__

    configurations = case.configurations
    model = configurations[0].model
    xbar = np.asarray(result.xbar, dtype=float)
    values = np.asarray(result.values, dtype=float)
    parameters = tuple(
        ParameterRow(name=p.name, unit=p.unit, nominal=float(p.nominal), lower=float(p.lower), upper=float(p.upper),
                     reference=float(p.reference), updated=_num(values[i]), xbar=_num(xbar[i]))
        for i, p in enumerate(model.parameters))
    frequencies = tuple(FrequencyRow.from_dict(_plain(row)) for row in result.frequencies)
    damping = tuple(DampingRow.from_dict(_plain(row)) for row in (stage.rows() if stage else ()))
    summary = Summary(
        mean_error_nominal_pct=_mean(r.error_nominal_pct for r in frequencies),
        mean_error_updated_pct=_mean(r.error_updated_pct for r in frequencies),
        mean_damping_error_pct=_num(stage.caughey.mean_error_pct) if stage else None,
        mean_damping_error_rayleigh_pct=_num(stage.rayleigh.mean_error_pct) if stage else None)
    matrices, mac_matrix, frf, dofs = {}, {}, {}, {}
    for cfg in configurations:
        modal = result.modal.get(cfg.name)   # the updated modes: never solved again here
        matrices[cfg.name] = _matrices(cfg, result.matrices[cfg.name], stage, modal)
        dofs[cfg.name] = list(cfg.model.dofs)
        response, excitation = _receptance_dofs(cfg, matrices[cfg.name]["M"])
        frf[cfg.name] = {"response": response, "excitation": excitation}
        if any(f.shape is not None for f in cfg.natural):
            mac_matrix[cfg.name] = _mac_matrix(cfg, modal.Phi)
    best = diagnosis.best if diagnosis is not None else None
    if best is not None:   # every configuration: the parameters are shared, whatever data were left out
        for cfg in configurations:
            matrices[cfg.name]["without_worst"] = tuple(sp.csr_matrix(A) for A in cfg.model.matrices(best.xbar))
    run_warnings = tuple(str(w) for w in getattr(result, "warnings", ())) + tuple(str(w) for w in warnings)
    return RunResult(
        version=__version__, format_version=FORMAT_VERSION, case=case.name, success=bool(result.success),
        parameters=parameters, xbar=tuple(float(v) for v in xbar), frequencies=frequencies,
        mac={name: _plain(np.asarray(v, dtype=float)) for name, v in result.mac.items()},
        mac_matrix=_plain(mac_matrix), dofs=dofs, frf=frf, damping=damping, summary=summary,
        problem_size=_plain(dict(result.problem_size)), solver=_plain(result.solver_record()),
        identifiability=_plain(identifiability) if identifiability else None,
        damping_model=_plain(damping_model) if damping_model else None,
        warnings=run_warnings, checks=tuple(_check_dict(c) for c in getattr(result, "checks", ())),
        paper=_plain(paper) if paper else None, sensors=tuple(dict(s) for s in getattr(case, "sensors", ())),
        declared_sensors=_declared_sensors(configurations),
        diagnosis=DiagnosisRecord.from_dict(_plain(diagnosis.record())) if diagnosis is not None else None,
        matrix_files=_matrix_files(configurations, matrices, bool(result.success), best),
        suggestion=_plain(suggestion) if suggestion else None,
        modal_masses=tuple(ModalMassRow.from_dict(_plain(row)) for row in getattr(result, "modal_masses", ())),
        matrices=matrices)


def _matrix_files(configurations, matrices: dict, verified: bool, best) -> dict:
    """Per configuration, the file of each matrix written (`vibupdate.io.outputs.matrix_file`):
    a model that is not verified is written under a name that says so."""
    from vibupdate.io.outputs import file_names, matrix_file

    parts = file_names([c.name for c in configurations])
    files = {}
    for cfg in configurations:
        entry = matrices[cfg.name]
        names = {m: matrix_file(m, parts[cfg.name], verified=verified) for m in ("M", "K", "C") if m in entry}
        if "without_worst" in entry:
            names.update({f"{m}_without_worst": matrix_file(m, parts[cfg.name], verified=bool(best.success),
                                                             variant="without_worst") for m in ("M", "K")})
        files[cfg.name] = names
    return files


def schema() -> dict:
    """The JSON Schema of ``results.json`` (shipped as ``vibupdate/results.schema.json``)."""
    from importlib import resources

    return json.loads(resources.files("vibupdate.io").joinpath("results.schema.json").read_text(encoding="utf-8"))


def validate_document(doc) -> None:
    """Raise ValueError naming the first place where ``doc`` breaks the schema
    (`vibupdate.io.schema_check`: the keywords the schema uses, no schema library)."""
    from vibupdate.io.schema_check import first_error

    error = first_error(doc, schema())
    if error is not None:
        path, message = error
        where = "/".join(str(p) for p in path) or "(top level)"
        raise ValueError(f"results document does not match the schema at {where}: {message}")


def write_results(path, run: RunResult) -> Path:
    """Write ``run`` as ``results.json`` at ``path`` (directories created); returns the path."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_suffix(".json.tmp")
    tmp.write_text(json.dumps(run.as_document(), indent=2, allow_nan=False) + "\n", encoding="utf-8")
    tmp.replace(path)
    return path


def load_results(path) -> RunResult:
    """Read a ``results.json`` file into a `RunResult` (without matrices: see the ``.mtx`` files).

    Raises ValueError naming the file when it cannot be read, is not JSON, or does not match
    the schema (e.g. a file of an older vibupdate, before ``format_version`` 2).
    """
    path = Path(path)
    try:
        doc = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise ValueError(f"results file {str(path)!r} could not be read: {exc}") from None
    try:
        validate_document(doc)
        return RunResult.from_document(doc)
    except (ValueError, KeyError, TypeError) as exc:
        raise ValueError(f"results file {str(path)!r}: {exc}") from None
