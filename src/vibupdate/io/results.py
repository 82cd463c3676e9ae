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
import functools
import json
import math
import types
import typing
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field, replace
from enum import Enum
from pathlib import Path

import numpy as np
import scipy.sparse as sp

from vibupdate.inverse.status import Status, Verdict


#: Version of the layout of ``results.json`` (raised when a key is added).
FORMAT_VERSION = 2


def _num(value) -> float | None:
    """A finite Python float, or None."""
    if value is None:
        return None
    value = float(value)
    return value if math.isfinite(value) else None


def _plain(obj):
    """JSON-safe copy: records to their documents, numpy to Python, NaN/inf to None, tuples to
    lists, enums (`Status`, `Verdict`) to their values."""
    if isinstance(obj, _Row):
        return obj.as_dict()
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
    if isinstance(obj, Enum):
        return obj.value
    if dataclasses.is_dataclass(obj) and hasattr(obj, "as_dict"):   # a record of the library (`Check`)
        return _plain(obj.as_dict())
    return obj


def json_text(obj) -> str:
    """``obj`` as strict JSON text (indented): numpy to Python, NaN and +-inf to ``null`` (no
    ``NaN``/``Infinity`` tokens, which JSON does not have)."""
    return json.dumps(_plain(obj), indent=2, allow_nan=False)


def _optional(**kwargs):
    """A field written only when it is not None (a section the run may not have computed)."""
    return field(default=None, metadata={"omit": True, **kwargs})


@functools.cache
def _hints(cls) -> dict:
    return typing.get_type_hints(cls)


def _typed(tp, value):
    """``value`` of a JSON document as the type ``tp`` of a record's field: records and enums
    from their documents, tuples from lists, mappings by their values' type; numbers as they
    are (an integer written stays one, so that a document reads and writes back the same)."""
    if value is None:
        return None
    origin, args = typing.get_origin(tp), typing.get_args(tp)
    if origin in (typing.Union, types.UnionType):
        inner = [a for a in args if a is not type(None)]
        return _typed(inner[0], value) if len(inner) == 1 else value
    if origin is tuple:
        if len(args) == 2 and args[1] is Ellipsis:
            return tuple(_typed(args[0], v) for v in value)
        return tuple(_typed(a, v) for a, v in zip(args, value)) if args else tuple(value)
    if origin is dict:
        return {k: _typed(args[1], v) for k, v in value.items()}
    if isinstance(tp, type) and issubclass(tp, Enum):
        return tp(value)
    if isinstance(tp, type) and issubclass(tp, _Row):
        return tp.from_dict(value)
    return value


@dataclass(frozen=True, kw_only=True)
class _Row:
    """Records of ``results.json``: typed fields (written under their names, or the ``key`` of
    their metadata) plus ``extra``, further keys of the producer, written flat after them."""

    extra: tuple = ()

    def as_dict(self) -> dict:
        out = {}
        for f in dataclasses.fields(self):
            value = getattr(self, f.name)
            if f.name != "extra" and not (value is None and f.metadata.get("omit")):
                out[f.metadata.get("key", f.name)] = _plain(value)
        out.update({k: _plain(v) for k, v in self.extra})
        return out

    @classmethod
    def from_dict(cls, data: Mapping):
        """The record of a document: each field read as its type; a field without a default
        must be there."""
        hints, values, missing, keys = _hints(cls), {}, [], set()
        for f in dataclasses.fields(cls):
            key = f.metadata.get("key", f.name)
            keys.add(key)
            if f.name == "extra":
                continue
            if key in data:
                values[f.name] = _typed(hints[f.name], data[key])
            elif f.default is dataclasses.MISSING and f.default_factory is dataclasses.MISSING:
                missing.append(key)
        if missing:
            raise ValueError(f"{cls.__name__} lacks {', '.join(missing)}")
        return cls(**values, extra=tuple((k, _plain(v)) for k, v in data.items() if k not in keys))


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


@dataclass(frozen=True)
class FrequencyRow(_Row):
    """One measured frequency (Hz) against the nominal and updated models: which model mode or
    zero (``model_index``, the ``receptance`` of a zero), the measured interval and the datum's
    ``name`` (`vibupdate.data.names.frequency_name`)."""

    configuration: str
    kind: str
    index: int
    measured_hz: float
    nominal_hz: float | None
    updated_hz: float | None
    error_nominal_pct: float | None
    error_updated_pct: float | None
    model_index: int | None = None
    receptance: str | None = None
    measured_lower_hz: float | None = None
    measured_upper_hz: float | None = None
    name: str | None = None


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


@dataclass(frozen=True)
class Summary(_Row):
    """Mean absolute errors in per cent (None where not computed)."""

    mean_error_nominal_pct: float | None
    mean_error_updated_pct: float | None
    mean_damping_error_pct: float | None
    mean_damping_error_rayleigh_pct: float | None


@dataclass(frozen=True)
class MacMatrix(_Row):
    """MAC of the measured shapes (rows, interval midpoints on ``dofs``) with the updated
    model's declared modes (columns): the MAC plot."""

    dofs: tuple[str, ...]
    values: tuple[tuple[float | None, ...], ...]


@dataclass(frozen=True)
class PlottedReceptance(_Row):
    """The receptance of a configuration's FRF plot: ``response`` and ``excitation`` DOFs."""

    response: str
    excitation: str


@dataclass(frozen=True)
class CheckRow(_Row):
    """One verification check as written (`vibupdate.inverse.verify.Check`)."""

    name: str
    passed: bool
    severity: str
    message: str
    value: float | None = None
    limit: float | None = None
    limited_by: str | None = None


@dataclass(frozen=True)
class StepRow(_Row):
    """One solve of the homotopy (`vibupdate.inverse.homotopy.StepRecord`)."""

    lam: float = field(metadata={"key": "lambda"})
    objective: float | None
    iterations: int
    status: Status
    seconds: float | None
    cold: bool
    accepted: bool
    reused: bool = False


@dataclass(frozen=True)
class PolishRow(_Row):
    """What the polish did (`vibupdate.inverse.polish.PolishResult`)."""

    cost_start: float | None
    cost: float | None
    kept: bool
    evaluations: int
    message: str
    seconds: float | None
    rounds: int = 0
    reduced_evaluations: int = 0
    stopped_on: str | None = None
    budget: int | None = None


@dataclass(frozen=True)
class AttemptRow(_Row):
    """One first-stage attempt (`vibupdate.inverse.update.Attempt`)."""

    shape_margin: float
    adjunct_margin: float
    relaxation_lower_bound: float | None
    objective: float | None
    status: Status
    active_bounds: tuple[str, ...] = ()


@dataclass(frozen=True)
class StartRow(_Row):
    """One start of the search (`vibupdate.inverse.search.Start`)."""

    start: str
    purpose: str
    status: str
    failed: tuple[str, ...] = ()
    cost: float | None = None
    seconds: float | None = 0.0


@dataclass(frozen=True)
class SoughtRow(_Row):
    """What the update sought (`vibupdate.inverse.search.Sought`): the search's settings, the
    starts in order, whether uniqueness was searched and why."""

    search: dict[str, int | float]
    starts: tuple[StartRow, ...]
    uniqueness_searched: bool
    reason: str


@dataclass(frozen=True)
class MinimumChangeRow(_Row):
    """The move along undetermined directions (`vibupdate.inverse.minimum_change.MinimumChange`)."""

    applied: bool
    kept: bool
    rank: int
    norm_start: float | None
    norm: float | None
    data_change: float | None
    iterations: int
    message: str


@dataclass(frozen=True, kw_only=True)
class AlternativeRow(_Row):
    """Another verified answer (`vibupdate.inverse.search.Alternative`); ``xbar`` only in
    ``solver.alternatives``."""

    start: str
    objective: float | None
    xbar: tuple[float | None, ...] | None = _optional()
    values: dict[str, float | None]
    differs: tuple[str, ...]


@dataclass(frozen=True, kw_only=True)
class SolverRecord(_Row):
    """``solver`` of ``results.json``: the first stage's status and verdict, message, every
    solve of the homotopy, objective, relaxation lower bound, seconds, checks, warnings, the
    polish, the attempts, what was sought, the minimum change and other answers."""

    status: Status
    message: str
    steps: tuple[StepRow, ...] = ()
    objective: float | None = None
    relaxation_lower_bound: float | None = None
    seconds: float | None = None
    verified: bool = False
    checks: tuple[CheckRow, ...] = ()
    warnings: tuple[str, ...] = ()
    first_stage_xbar: tuple[float | None, ...] | None = None
    polish: PolishRow | None = None
    attempts: tuple[AttemptRow, ...] = ()
    verdict: Verdict | None = None
    sought: SoughtRow | None = None
    minimum_change: MinimumChangeRow | None = None
    alternatives: tuple[AlternativeRow, ...] = ()


@dataclass(frozen=True)
class LinearRange(_Row):
    """One parameter's consistent range linearized at the answer, in its unit."""

    lower: float | None
    upper: float | None
    width_pct: float | None


@dataclass(frozen=True)
class SampledRange(_Row):
    """One parameter over the verified samples of ``run --samples``, in its unit: ``min`` and
    ``max`` over the answers and the line ends along null directions; the quantiles, and
    ``answers_min``, ``answers_max``, over the answers (None without a verified sample)."""

    unit: str
    min: float | None
    max: float | None
    q05: float | None
    q50: float | None
    q95: float | None
    answers_min: float | None = None
    answers_max: float | None = None

    @property
    def lower(self) -> float | None:
        """``min``, read as the lower end of a range."""
        return self.min

    @property
    def upper(self) -> float | None:
        """``max``, read as the upper end of a range."""
        return self.max


@dataclass(frozen=True)
class Sampled(_Row):
    """``identifiability.sampled``: the counts of the samples and each parameter's range."""

    samples: int
    verified: int
    unverified: int
    failed: int
    line_ends: int
    seed: int
    distribution: str
    ranges: dict[str, SampledRange]


@dataclass(frozen=True)
class LocalMinimum(_Row):
    """One distinct local minimum of the multistart: objective, starts that reached it, the
    parameters' values in their units."""

    objective: float | None
    starts: int
    values: dict[str, float | None]


@dataclass(frozen=True)
class Multistart(_Row):
    """``identifiability.multistart``: random starts of the point estimate grouped into
    distinct local minima, best first."""

    starts: int
    failed: int
    distinct_minima: int
    x_tol: float
    minima: tuple[LocalMinimum, ...]
    seed: int | None = _optional()


@dataclass(frozen=True)
class CertifiedRange(_Row):
    """One parameter's certified outer range over the consistent set, and the root box's."""

    lower: float | None
    upper: float | None
    width_pct: float | None
    certified: bool
    root_lower: float | None = None
    root_upper: float | None = None


@dataclass(frozen=True)
class WidenedWindow(_Row):
    """A datum whose window the certification widened to hold a reported answer."""

    datum: str
    beyond_pct: float | None


@dataclass(frozen=True)
class WidenedBox(_Row):
    """A vector box the certification widened to hold a reported answer."""

    vector: str
    entries: int
    bound_ratio: float | None


@dataclass(frozen=True)
class Inclusion(_Row):
    """How the consistent set was widened to hold every answer the run reports."""

    points: int
    widened_by: tuple[str, ...]
    windows: tuple[WidenedWindow, ...]
    vector_boxes: tuple[WidenedBox, ...]
    bounds_widened: int


@dataclass(frozen=True, kw_only=True)
class CertifiedRecord(_Row):
    """``identifiability.certified`` (`vibupdate.ranges.certify.CertifiedRanges.record`)."""

    definition: str
    message: str
    empty: bool | None = _optional()
    seconds: float | None = _optional()
    root_seconds: float | None = _optional()
    passes: int | None = _optional()
    splits: int | None = _optional()
    leaves: int | None = _optional()
    n_lps: int | None = _optional()
    history: tuple[tuple[float | None, float | None], ...] | None = _optional()
    included: Inclusion | None = None
    uncovered: tuple[str, ...] | None = _optional()
    ranges: dict[str, CertifiedRange]


@dataclass(frozen=True, kw_only=True)
class Identifiability(_Row):
    """``identifiability``: what the data determine. The exact sensitivity at the answer
    (``rank``, ``condition``, singular values, each parameter's column norm, undetermined
    combinations), the minimum change and other answers in words; at a verified answer the
    linearized ``ranges`` (else ``ranges_note``), and the sections of further studies
    (``sampled``, ``multistart``, ``certified``) where they ran."""

    rank: int
    condition: float | None
    singular_values: tuple[float | None, ...]
    column_norm: dict[str, float | None]
    undetermined_combinations: tuple[str, ...]
    minimum_change: str | None
    alternatives: tuple[AlternativeRow, ...]
    ranges_note: str | None = _optional()
    ranges: dict[str, LinearRange] | None = _optional()
    frequency_tolerance: float | None = _optional()
    frequency_windows: str | None = _optional()
    sampled: Sampled | None = _optional()
    multistart: Multistart | None = _optional()
    certified: CertifiedRecord | None = _optional()


@dataclass(frozen=True)
class DampingModel(_Row):
    """``damping_model``: the Caughey exponents and coefficients, the Rayleigh baseline's, the
    fit's condition number and its weighting in words."""

    exponents: tuple[float, ...]
    beta: tuple[float | None, ...]
    rayleigh_beta: tuple[float | None, ...]
    condition: float | None
    weights_text: str


@dataclass(frozen=True, kw_only=True)
class ReferenceColumns(_Row):
    """``paper``: reference columns of the report's tables (`vibupdate.report.table.with_reference`):
    ``columns`` by table, column name and row key; ``errors`` by table, column name and the
    two columns compared; ``notes`` by table."""

    columns: dict[str, dict[str, dict[str, float | str | None]]] | None = _optional()
    errors: dict[str, dict[str, tuple[str, str]]] | None = _optional()
    notes: dict[str, tuple[str, ...]] | None = _optional()


@dataclass(frozen=True)
class MeshSensor(_Row):
    """A measured point on an imported FE mesh: the DOF it reads (``"<node>:<dir>"``), its sign,
    the distance to the node and the unit direction read (None for a rotation)."""

    sensor: str
    dof: str
    sign: float
    distance_m: float | None
    direction: tuple[float, ...] | None = None


@dataclass(frozen=True)
class DeclaredSensor(_Row):
    """A sensor of the case file: its name and the weight of each DOF in its reading."""

    sensor: str
    weights: dict[str, float]


@dataclass(frozen=True)
class SetUpdate(_Row):
    """The full update of one set of candidates (`vibupdate.ranges.candidates`)."""

    status: Status
    success: bool
    message: str
    values: dict[str, float | None]
    units: dict[str, str]
    natural_mean_pct: float | None
    natural_max_pct: float | None
    antiresonance_mean_pct: float | None
    antiresonance_max_pct: float | None
    failed: tuple[str, ...]
    limited_by: str | None
    range_pct: dict[str, float | None] | None


@dataclass(frozen=True)
class SetTrialRow(_Row):
    """One set of candidates screened (`vibupdate.ranges.candidates.SetTrial`)."""

    candidates: tuple[str, ...]
    objective: float | None
    passed: bool
    failed: tuple[str, ...]
    natural_mean_pct: float | None
    natural_max_pct: float | None
    antiresonance_mean_pct: float | None
    antiresonance_max_pct: float | None
    rank: int
    free: int
    condition: float | None
    determined: bool
    values: dict[str, float | None]
    tied_with: tuple[tuple[str, ...], ...]
    update: SetUpdate | None
    seconds: float | None


@dataclass(frozen=True)
class SuggestionRecord(_Row):
    """``suggestion``: the screening of candidates after a run that did not verify
    (`vibupdate.ranges.candidates.Suggestion.record`)."""

    own: tuple[str, ...]
    candidates: tuple[str, ...]
    nominal: dict[str, float | bool | tuple[str, ...] | None]
    sizes: tuple[int, ...]
    untried: int
    seconds: float | None
    untried_sets: tuple[tuple[str, ...], ...]
    best: tuple[str, ...] | None
    screened_best: tuple[str, ...] | None
    message: str
    trials: tuple[SetTrialRow, ...]
    limits: dict[str, float]


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
    failed: tuple[str, ...]
    mean_error_pct: float | None
    max_error_pct: float | None
    shape_misses: int
    xbar: tuple[float | None, ...]
    seconds: float | None


@dataclass(frozen=True)
class DiagnosisBest(_Row):
    """The update run again without the top group: which group (``without``, its key, and
    ``without_label``), its ``status``, ``success`` and ``message``, the physical ``values`` by
    parameter name, ``xbar``, frequency errors on the data kept (per cent), its verification
    ``checks`` on the data kept and seconds."""

    without: str
    without_label: str
    status: Status
    success: bool
    message: str
    values: dict[str, float | None]
    xbar: tuple[float | None, ...]
    mean_error_pct: float | None
    max_error_pct: float | None
    checks: tuple[CheckRow, ...]
    seconds: float | None


@dataclass(frozen=True)
class DiagnosisRecord(_Row):
    """``diagnosis`` of ``results.json``: which data conflict with the model. The checks that
    ``failed``, the full answer's polish ``objective`` and frequency errors, the number of
    ``groups`` and of those ``untried`` (limits), the ``trials`` ranked (best fit without the
    group first), the ``best`` update without the top group, and ``seconds``."""

    failed: tuple[str, ...]
    objective: float | None
    mean_error_pct: float | None
    max_error_pct: float | None
    groups: int
    untried: int
    trials: tuple[GroupTrialRow, ...]
    best: DiagnosisBest | None
    seconds: float | None
    limits: dict[str, float]
    untried_groups: tuple[str, ...] = ()

    @property
    def worst(self) -> GroupTrialRow | None:
        """The group whose removal leaves the best fit."""
        return self.trials[0] if self.trials else None


@dataclass(frozen=True)
class ConfigurationMatrices:
    """Not written to JSON: one configuration's updated matrices (scipy sparse ``M``, ``K``),
    the identified damping (a dense ``C`` on small models, its modal law ``damping_law`` on
    large ones; None without damping data), the nominal ``(M0, K0, None)`` (the case has no
    nominal damping model, so the nominal FRF is drawn undamped, never with the updated
    ``C``) and, after a diagnosis, ``(M, K)`` of the update without the top group."""

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
    mac : dict of str to tuple of float or None
        Per configuration, MAC of each measured mode shape with its paired updated mode
        (None where no shape was measured).
    mac_matrix : dict of str to MacMatrix
        Per configuration with measured shapes: the MAC plot.
    dofs : dict of str to tuple of str
        DOF names of each configuration's model, in matrix order.
    frf : dict of str to PlottedReceptance
        Per configuration, the receptance plotted.
    damping : tuple of DampingRow
    summary : Summary
    problem_size : dict of str to int
    solver : SolverRecord
    identifiability : Identifiability or None
    damping_model : DampingModel or None
    warnings : tuple of str
    checks : tuple of CheckRow
        Verification checks of the first stage.
    paper : ReferenceColumns or None
        Reference columns of the tables (a bundled example's ``reference_columns()``:
        published values, a synthetic example's truth; `vibupdate.report.table.with_reference`).
    sensors : tuple of MeshSensor
        Measured points on an imported FE mesh (``[model] sensors``, `vibupdate import`);
        empty otherwise.
    declared_sensors : tuple of DeclaredSensor
        Sensors declared in the case file (``[[sensor]]``, a ``sensors`` CSV; ``docs/sensors.md``);
        empty otherwise.
    diagnosis : DiagnosisRecord or None
        Which data conflict with the model, when the answer did not fit them
        (`vibupdate.inverse.diagnosis`); None otherwise.
    matrix_files : dict of str to dict of str to str
        Per configuration, the file of each matrix written (``M``, ``K``, ``C`` and, after a
        diagnosis, ``M_without_worst``, ``K_without_worst``): the names say when a model is
        not verified (`vibupdate.io.outputs.matrix_file`).
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
    checks: tuple[CheckRow, ...] = ()
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
        """The ``results.json`` document (JSON-safe)."""
        return {f.name: _plain(getattr(self, f.name)) for f in dataclasses.fields(self) if f.name not in _NOT_WRITTEN}

    @classmethod
    def from_document(cls, doc: Mapping) -> RunResult:
        """The typed object of a ``results.json`` document (`validate_document` first)."""
        hints = _hints(cls)
        return cls(**{f.name: _typed(hints[f.name], doc[f.name]) for f in dataclasses.fields(cls)
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


def _receptance_dofs(cfg, M) -> PlottedReceptance:
    receptances = cfg.receptances()
    if receptances:
        return PlottedReceptance(receptances[0][0], receptances[0][1])
    dof = cfg.model.dofs[int(np.argmax(np.abs(M.diagonal())))]
    return PlottedReceptance(dof, dof)


def _matrices(cfg, updated, stage, modal) -> ConfigurationMatrices:
    """One configuration's matrices: updated ``M``, ``K``, the nominal model
    undamped, and the identified damping (a dense ``C`` on small models, its modal law on
    large ones) built from the updated spectrum ``modal.spectrum`` when there is one."""
    from vibupdate.damping import caughey_damping

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
    return MacMatrix.from_dict(_plain({"dofs": names, "values": mac(X, cfg.model.measurement(names) @ Phi)}))


def frequencies_of(correlation) -> tuple[FrequencyRow, ...]:
    """The ``frequencies`` table (Hz) of an answer's `vibupdate.inverse.correlation.Correlation`."""
    from vibupdate.inverse.correlation import frequency_rows

    c = correlation
    return tuple(FrequencyRow.from_dict(_plain(row)) for row in frequency_rows(c.configurations, c.nominal, c.updated))


def modal_masses_of(correlation) -> tuple[ModalMassRow, ...]:
    """The ``modal_masses`` table (kg) of an answer's correlation; empty without mass-normalized
    shapes."""
    from vibupdate.inverse.correlation import modal_mass_rows

    c = correlation
    return tuple(ModalMassRow.from_dict(_plain(row))
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
                     reference=float(p.reference), updated=_num(values[i]), xbar=_num(xbar[i]))
        for i, p in enumerate(model.parameters))
    frequencies = frequencies_of(result.correlation)
    damping = tuple(DampingRow.from_dict(_plain(row)) for row in (stage.rows() if stage else ()))
    summary = Summary(
        mean_error_nominal_pct=_mean(r.error_nominal_pct for r in frequencies),
        mean_error_updated_pct=_mean(r.error_updated_pct for r in frequencies),
        mean_damping_error_pct=_num(stage.caughey.mean_error_pct) if stage else None,
        mean_damping_error_rayleigh_pct=_num(stage.rayleigh.mean_error_pct) if stage else None)
    matrices, mac_matrix, frf = {}, {}, {}
    best = diagnosis.best if diagnosis is not None else None
    updated = result.matrices
    for cfg, modal in zip(configurations, result.correlation.updated):   # the updated modes: never solved again
        matrices[cfg.name] = _matrices(cfg, updated[cfg.name], stage, modal)
        if best is not None:   # every configuration: the parameters are shared, whatever data were left out
            matrices[cfg.name] = replace(matrices[cfg.name], without_worst=tuple(
                sp.csr_matrix(A) for A in cfg.model.matrices(best.xbar)))
        frf[cfg.name] = _receptance_dofs(cfg, matrices[cfg.name].M)
        if any(f.shape is not None for f in cfg.natural):
            mac_matrix[cfg.name] = _mac_matrix(cfg, modal.Phi)
    section = (lambda cls, data: cls.from_dict(_plain(data)) if data else None)
    return RunResult(
        version=__version__, format_version=FORMAT_VERSION, case=case.name, success=bool(result.success),
        parameters=parameters, xbar=tuple(float(v) for v in xbar), frequencies=frequencies,
        mac={name: tuple(_plain(v)) for name, v in macs_of(result.correlation).items()},
        mac_matrix=mac_matrix, dofs={c.name: tuple(c.model.dofs) for c in configurations}, frf=frf,
        damping=damping, summary=summary, problem_size=_plain(dict(result.problem_size)),
        solver=SolverRecord.from_dict(_plain(result.solver_record())),
        identifiability=section(Identifiability, identifiability), damping_model=section(DampingModel, damping_model),
        warnings=tuple(str(w) for w in (*result.warnings, *warnings)),
        checks=tuple(CheckRow.from_dict(_plain(c)) for c in result.checks),
        paper=section(ReferenceColumns, paper),
        sensors=tuple(MeshSensor.from_dict(_plain(s)) for s in getattr(case, "sensors", ())),
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
