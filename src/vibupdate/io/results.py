"""One results object per run, and ``results.json``, its document.

`run_result` builds a frozen `RunResult` once, from the first stage's `UpdateResult`, the
damping stage and the case; ``results.json`` (`write_results`), ``report.md``, the terminal
tables, the plots and the matrix files are all written from it. `load_results` reads a
``results.json`` back into the same typed object; the JSON Schema shipped with the package
(``results.schema.json``, `schema`) describes the file.

Contract of the file: keys may be added, never renamed. Every key is a field of the typed
object, each section a record of `vibupdate.io.records` (a record carries any further keys of
its producer in ``extra``, written flat), read back as its type.
Frequencies are in Hz, percentages are absolute relative errors times 100 (Eqs. 26-27),
``index`` and ``mode`` are 1-based within their kind and configuration; non-finite numbers
are written as ``null``.
"""

from __future__ import annotations

import dataclasses
import json
import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np
import scipy.sparse as sp

from vibupdate.inverse.status import Status
from vibupdate.inverse.verify import Check
from vibupdate.io.records import (
    DampingModel, DampingRow, DeclaredSensor, DiagnosisRecord, FrequencyRow, Identifiability, MacMatrix,
    MeshSensor, ModalMassRow, Multistart, ParameterRow, PlottedReceptance, ReferenceColumns, Sampled, SolverRecord,
    SuggestionRecord, Summary, field_types, number, plain, typed)


#: Version of the layout of ``results.json`` (raised when a key is added).
FORMAT_VERSION = 2


@dataclass(frozen=True)
class ConfigurationMatrices:
    """One configuration's updated, nominal and identified matrices (not written to JSON).

    Attributes
    ----------
    M, K : scipy.sparse matrix, shape (n, n)
        The updated mass and stiffness matrices (SI: kg and N/m on translations, kg m^2 and
        N m/rad on rotations).
    nominal : (scipy.sparse matrix, scipy.sparse matrix, None)
        The nominal ``(M0, K0, None)``: the case has no nominal damping model, so the nominal
        FRF is drawn undamped, never with the updated ``C``.
    C : ndarray, shape (n, n), or None
        The identified damping matrix (N s/m on translations) on small models; None on large
        ones and without damping data.
    damping_law : callable or None
        The identified modal damping law on large models, where ``C`` is not formed.
    without_worst : (scipy.sparse matrix, scipy.sparse matrix) or None
        After a diagnosis, ``(M, K)`` of the update without the top group of data.
    """

    M: sp.spmatrix
    K: sp.spmatrix
    nominal: tuple[sp.spmatrix, sp.spmatrix, None]
    C: np.ndarray | None = None
    damping_law: Callable | None = None
    without_worst: tuple[sp.spmatrix, sp.spmatrix] | None = None

    @property
    def damping(self):
        """``C`` or the modal damping law, whichever was identified (None without damping)."""
        return self.C if self.C is not None else self.damping_law


#: Top-level fields of `RunResult` that are not written to ``results.json``.
_NOT_WRITTEN = ("matrices",)


@dataclass(frozen=True)
class RunResult:
    """Everything a run produced; ``results.json`` is `as_document` of it.

    Each key of the file is described in ``docs/outputs.md`` ("`results.json`").

    Attributes
    ----------
    version : str
        vibupdate version that wrote the results.
    format_version : int
        Layout version of ``results.json`` (`FORMAT_VERSION`).
    case : str
        The case's name.
    success : bool
        Whether the first stage succeeded (``UpdateResult.success``: verified).
    parameters : tuple of ParameterRow
        One row per parameter.
    xbar : tuple of float
        Updated normalized parameters (Eq. 12), in the order of ``parameters``.
    frequencies : tuple of FrequencyRow
        One row per measured natural frequency and antiresonance (Hz).
    modal_masses : tuple of ModalMassRow
        The modal masses of mass-normalized measured shapes; empty without them.
    mac : dict of str to tuple of float or None
        Per configuration, MAC of each measured mode shape with its paired updated mode.
    mac_matrix : dict of str to MacMatrix
        Per configuration with measured shapes: the MAC plot.
    dofs : dict of str to tuple of str
        DOF names of each configuration's model, in matrix order.
    frf : dict of str to PlottedReceptance
        Per configuration, the receptance plotted.
    damping : tuple of DampingRow
        One row per measured damping ratio; empty without a damping stage.
    summary : Summary
        The mean absolute errors of the frequencies and of the damping ratios, in per cent.
    problem_size : dict of str to int
        Counts of the first stage's problem (``reduced_dofs`` after a reduction).
    solver : SolverRecord
        The first stage's record.
    identifiability : Identifiability or None
        What the data determine, and the further studies' sections.
    damping_model : DampingModel or None
        The fitted Caughey series and the Rayleigh baseline; None without a damping stage.
    warnings : tuple of str
        Every warning of the run, in words, with its figures.
    checks : tuple of Check
        Verification checks of the first stage.
    paper : ReferenceColumns or None
        Reference columns of the tables (`vibupdate.report.table.with_reference`).
    sensors : tuple of MeshSensor
        Measured points on an imported FE mesh (``[model] sensors``); empty otherwise.
    declared_sensors : tuple of DeclaredSensor
        Sensors declared in the case file (``docs/sensors.md``); empty otherwise.
    diagnosis : DiagnosisRecord or None
        Which data conflict with the model (`vibupdate.inverse.diagnosis`); None otherwise.
    matrix_files : dict of str to dict of str to str
        Per configuration, the file of each matrix written (`vibupdate.io.outputs.matrix_file`).
    suggestion : SuggestionRecord or None
        Which candidates might be missing, after a run that did not verify.
    matrices : dict of str to ConfigurationMatrices
        Not written to JSON; empty after `load_results` (the ``.mtx`` files hold them).
    """

    version: str
    format_version: int
    case: str
    success: bool
    parameters: tuple[ParameterRow, ...]
    xbar: tuple[float, ...]
    frequencies: tuple[FrequencyRow, ...]
    mac: dict[str, tuple[float | None, ...]]
    mac_matrix: dict[str, MacMatrix]
    dofs: dict[str, tuple[str, ...]]
    frf: dict[str, PlottedReceptance]
    damping: tuple[DampingRow, ...]
    summary: Summary
    problem_size: dict[str, int]
    solver: SolverRecord
    identifiability: Identifiability | None = None
    damping_model: DampingModel | None = None
    warnings: tuple[str, ...] = ()
    checks: tuple[Check, ...] = ()
    paper: ReferenceColumns | None = None
    sensors: tuple[MeshSensor, ...] = ()
    declared_sensors: tuple[DeclaredSensor, ...] = ()
    diagnosis: DiagnosisRecord | None = None
    matrix_files: dict[str, dict[str, str]] = field(default_factory=dict)
    suggestion: SuggestionRecord | None = None
    modal_masses: tuple[ModalMassRow, ...] = ()
    matrices: dict[str, ConfigurationMatrices] = field(default_factory=dict, compare=False, repr=False)

    @property
    def status(self) -> Status:
        """The first stage's status (``solver.status``)."""
        return self.solver.status

    @property
    def sampled(self) -> Sampled | None:
        """The sampled ranges (``run --samples``); None when not computed."""
        return self.identifiability.sampled if self.identifiability is not None else None

    @property
    def multistart(self) -> Multistart | None:
        """The multistart of the point estimate; None when not run."""
        return self.identifiability.multistart if self.identifiability is not None else None

    def as_document(self) -> dict:
        """The ``results.json`` document.

        Returns
        -------
        dict
            Every field but ``matrices`` as plain JSON values (lists, numbers, strings, None).
        """
        return {f.name: plain(getattr(self, f.name)) for f in dataclasses.fields(self) if f.name not in _NOT_WRITTEN}

    @classmethod
    def from_document(cls, doc: Mapping) -> RunResult:
        """The typed object of a ``results.json`` document.

        Parameters
        ----------
        doc : mapping
            A parsed ``results.json`` document that passed `validate_document`.

        Returns
        -------
        RunResult
            Each section as its record type; ``matrices`` empty.
        """
        hints = field_types(cls)
        return cls(**{f.name: typed(hints[f.name], doc[f.name]) for f in dataclasses.fields(cls)
                      if f.name not in _NOT_WRITTEN and f.name in doc})


def _mean(values) -> float | None:
    values = [v for v in values if v is not None and math.isfinite(v)]
    return float(np.mean(values)) if values else None


def _declared_sensors(configurations) -> tuple[DeclaredSensor, ...]:
    """The sensors of the configurations' models (each model carries the case's ``[[sensor]]``
    declarations), once each, in their order."""
    seen = {}
    for cfg in configurations:
        for s in getattr(cfg.model, "sensors", ()):
            seen.setdefault(s.name, DeclaredSensor(s.name, {d: float(w) for d, w in s.weights}))
    return tuple(seen.values())


def plotted_receptance(cfg, M) -> PlottedReceptance:
    """The receptance an FRF plot of ``cfg`` shows: its first measured one, else the driving
    point of the DOF with the largest diagonal mass in ``M``."""
    receptances = cfg.receptances()
    if receptances:
        return PlottedReceptance(receptances[0][0], receptances[0][1])
    dof = cfg.model.dofs[int(np.argmax(np.abs(M.diagonal())))]
    return PlottedReceptance(dof, dof)


def _matrices(cfg, updated, stage, modal) -> ConfigurationMatrices:
    """One configuration's matrices: updated ``M``, ``K``, the nominal model
    undamped, and the identified damping (a dense ``C`` on small models, its modal law on
    large ones) built from the updated spectrum ``modal.spectrum`` when there is one."""
    from vibupdate.damping.models import caughey_damping

    M, K = updated
    M0, K0 = cfg.model.matrices()
    damping = None
    if stage is not None:
        damping = caughey_damping(M, K, stage.caughey.exponents, stage.caughey.beta,
                                  max((f.mode for f in cfg.natural), default=1),
                                  spectrum=modal.spectrum if modal is not None else None)
    dense = isinstance(damping, np.ndarray)
    return ConfigurationMatrices(M, K, (M0, K0, None), C=damping if dense else None,
                                 damping_law=None if dense else damping)


def _mac_matrix(cfg, Phi: np.ndarray) -> MacMatrix:
    """MAC of the measured shapes (interval midpoints, rows) with the updated model's declared
    modes ``Phi`` (shape (n, n_p), columns)."""
    from vibupdate.modal.analysis import mac

    measured = [f for f in cfg.natural if f.shape is not None]
    order = {d: i for i, d in enumerate((*cfg.model.dofs, *(s.name for s in cfg.model.sensors)))}
    names = sorted({d for f in measured for d in f.shape.bounds}, key=order.__getitem__)
    X = np.array([[f.shape.midpoint.get(d, 0.0) for d in names] for f in measured]).T
    return MacMatrix.from_dict(plain({"dofs": names, "values": mac(X, cfg.model.measurement(names) @ Phi)}))


def frequencies_of(correlation) -> tuple[FrequencyRow, ...]:
    """The ``frequencies`` table (Hz) of an answer's `vibupdate.inverse.correlation.Correlation`."""
    from vibupdate.inverse.correlation import frequency_rows

    c = correlation
    return tuple(FrequencyRow.from_dict(plain(row)) for row in frequency_rows(c.configurations, c.nominal, c.updated))


def modal_masses_of(correlation) -> tuple[ModalMassRow, ...]:
    """The ``modal_masses`` table (kg) of an answer's correlation; empty without mass-normalized
    shapes."""
    from vibupdate.inverse.correlation import modal_mass_rows

    c = correlation
    return tuple(ModalMassRow.from_dict(plain(row))
                 for row in modal_mass_rows(c.configurations, c.nominal, c.updated, c.xbar))


def macs_of(correlation) -> dict[str, np.ndarray]:
    """Per configuration, the MAC of each measured shape with its paired updated mode (NaN
    where no shape was measured)."""
    from vibupdate.inverse.correlation import shape_mac
    from vibupdate.inverse.repeated import paired_modes

    return {c.name: shape_mac(c, paired_modes(c, f)) for c, f in zip(correlation.configurations, correlation.updated)}


def run_result(case, result, stage=None, *, identifiability: dict | None = None,
               damping_model: dict | None = None, warnings: Sequence[str] = (),
               paper: dict | None = None, diagnosis=None, suggestion: dict | None = None) -> RunResult:
    """Build the results object of a run.

    Parameters
    ----------
    case : Case
        The case (its configurations give the nominal models and measured data).
    result : UpdateResult
        First stage. Its correlation (the nominal and updated modal data: the modes of the
        MAC, the spectrum of the Caughey ``C``) gives the tables as it is: no modal analysis
        is repeated here.
    stage : DampingStage, optional
        Second stage; without it no ``C`` and no damping rows.
    identifiability, damping_model : dict, optional
        Sections computed by the pipeline, read into `Identifiability` and `DampingModel`.
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
                     reference=float(p.reference), updated=number(values[i]), xbar=number(xbar[i]))
        for i, p in enumerate(model.parameters))
    frequencies = frequencies_of(result.correlation)
    damping = tuple(DampingRow.from_dict(plain(row)) for row in (stage.rows() if stage else ()))
    summary = Summary(
        mean_error_nominal_pct=_mean(r.error_nominal_pct for r in frequencies),
        mean_error_updated_pct=_mean(r.error_updated_pct for r in frequencies),
        mean_damping_error_pct=number(stage.caughey.mean_error_pct) if stage else None,
        mean_damping_error_rayleigh_pct=number(stage.rayleigh.mean_error_pct) if stage else None)
    matrices, mac_matrix, frf = {}, {}, {}
    best = diagnosis.best if diagnosis is not None else None
    updated = result.matrices
    for cfg, modal in zip(configurations, result.correlation.updated):   # the updated modes: never solved again
        matrices[cfg.name] = _matrices(cfg, updated[cfg.name], stage, modal)
        if best is not None:   # every configuration: the parameters are shared, whatever data were left out
            matrices[cfg.name] = replace(matrices[cfg.name], without_worst=tuple(
                sp.csr_matrix(A) for A in cfg.model.matrices(best.xbar)))
        frf[cfg.name] = plotted_receptance(cfg, matrices[cfg.name].M)
        if any(f.shape is not None for f in cfg.natural):
            mac_matrix[cfg.name] = _mac_matrix(cfg, modal.Phi)
    section = (lambda cls, data: cls.from_dict(plain(data)) if data else None)
    return RunResult(
        version=__version__, format_version=FORMAT_VERSION, case=case.name, success=bool(result.success),
        parameters=parameters, xbar=tuple(float(v) for v in xbar), frequencies=frequencies,
        mac={name: tuple(plain(v)) for name, v in macs_of(result.correlation).items()},
        mac_matrix=mac_matrix, dofs={c.name: tuple(c.model.dofs) for c in configurations}, frf=frf,
        damping=damping, summary=summary, problem_size=plain(dict(result.problem_size)),
        solver=SolverRecord.from_dict(plain(result.solver_record())),
        identifiability=section(Identifiability, identifiability), damping_model=section(DampingModel, damping_model),
        warnings=tuple(str(w) for w in (*result.warnings, *warnings)),
        checks=typed(field_types(RunResult)["checks"], plain(result.checks)),
        paper=section(ReferenceColumns, paper),
        sensors=tuple(MeshSensor.from_dict(plain(s)) for s in getattr(case, "sensors", ())),
        declared_sensors=_declared_sensors(configurations),
        diagnosis=section(DiagnosisRecord, diagnosis.record() if diagnosis is not None else None),
        matrix_files=_matrix_files(configurations, matrices, bool(result.success), best),
        suggestion=section(SuggestionRecord, suggestion), modal_masses=modal_masses_of(result.correlation),
        matrices=matrices)


def _matrix_files(configurations, matrices: dict, verified: bool, best) -> dict[str, dict[str, str]]:
    """Per configuration, the file of each matrix written (`vibupdate.io.outputs.matrix_file`):
    a model that is not verified is written under a name that says so."""
    from vibupdate.io.outputs import file_names, matrix_file

    parts = file_names([c.name for c in configurations])
    files = {}
    for cfg in configurations:
        entry = matrices[cfg.name]
        names = {m: matrix_file(m, parts[cfg.name], verified=verified) for m in ("M", "K", "C")
                 if getattr(entry, m) is not None}
        if entry.without_worst is not None:
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
    """Read a ``results.json`` file into a `RunResult`.

    Parameters
    ----------
    path : str or Path
        The ``results.json`` file of a run.

    Returns
    -------
    RunResult
        Every section as its record type, without matrices (the ``.mtx`` files hold them).

    Raises
    ------
    ValueError
        Naming the file, when it cannot be read, is not JSON, or does not match the schema
        (e.g. a file of an older vibupdate, before ``format_version`` 2).
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
