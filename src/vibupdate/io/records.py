"""The records of ``results.json``: each section of the file as a frozen dataclass
(`vibupdate.io.results.RunResult` holds them).

A record writes its fields under their names (`plain` of each value) and reads them back as
their types (`typed`: records and enums from their documents, tuples from lists, numbers as
written), so that a loaded file writes back the same bytes. Keys a producer adds that a
record does not name are kept in its ``extra`` and written after its fields.
"""

from __future__ import annotations

import dataclasses
import functools
import json
import math
import types
import typing
from collections.abc import Mapping
from dataclasses import dataclass, field
from enum import Enum

import numpy as np

from vibupdate.inverse.status import Status, Verdict

if typing.TYPE_CHECKING:   # resolved by `field_types` when first read, not at import
    from vibupdate.inverse.homotopy import StepRecord
    from vibupdate.inverse.search import Alternative, Sought
    from vibupdate.inverse.update import Attempt
    from vibupdate.inverse.verify import Check


def number(value) -> float | None:
    """A finite Python float, or None."""
    if value is None:
        return None
    value = float(value)
    return value if math.isfinite(value) else None


def plain(obj):
    """JSON-safe copy: records to their documents, numpy to Python, NaN/inf to None, tuples to
    lists, enums (`Status`, `Verdict`) to their values."""
    if isinstance(obj, _Row):
        return obj.as_dict()
    if isinstance(obj, Mapping):
        return {str(k): plain(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [plain(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return plain(obj.tolist())
    if isinstance(obj, (bool, np.bool_)):
        return bool(obj)
    if isinstance(obj, (np.floating, float)):
        return number(obj)
    if isinstance(obj, np.integer):
        return int(obj)
    if isinstance(obj, Enum):
        return obj.value
    if dataclasses.is_dataclass(obj) and hasattr(obj, "as_dict"):   # a record of the library (`Check`)
        return plain(obj.as_dict())
    return obj


def json_text(obj) -> str:
    """``obj`` as strict JSON text (indented): numpy to Python, NaN and +-inf to ``null`` (no
    ``NaN``/``Infinity`` tokens, which JSON does not have)."""
    return json.dumps(plain(obj), indent=2, allow_nan=False)


def _optional():
    """A field written only when it is not None (a section the run may not have computed)."""
    return field(default=None, metadata={"omit": True})


@functools.cache
def field_types(cls) -> dict:
    """The resolved annotation of each field of a record class, by field name (the library's
    records that sections hold, imported here when first read)."""
    from vibupdate.inverse.homotopy import StepRecord
    from vibupdate.inverse.search import Alternative, Sought
    from vibupdate.inverse.update import Attempt
    from vibupdate.inverse.verify import Check

    library = {"Alternative": Alternative, "Attempt": Attempt, "Check": Check, "Sought": Sought,
               "StepRecord": StepRecord}
    return typing.get_type_hints(cls, localns=library)


def from_dict(cls, data: Mapping):
    """The record ``cls`` (of this module, or a frozen dataclass of the library such as
    `vibupdate.inverse.verify.Check`) of a document: each field, under its name or the ``key``
    of its metadata, read as its type; a field without a default must be there. A record of
    this module keeps further keys in ``extra``."""
    hints, values, missing, keys = field_types(cls), {}, [], set()
    for f in dataclasses.fields(cls):
        key = f.metadata.get("key", f.name)
        keys.add(key)
        if f.name == "extra":
            continue
        if key in data:
            values[f.name] = typed(hints[f.name], data[key])
        elif f.default is dataclasses.MISSING and f.default_factory is dataclasses.MISSING:
            missing.append(key)
    if missing:
        raise ValueError(f"{cls.__name__} lacks {', '.join(missing)}")
    if issubclass(cls, _Row):
        values["extra"] = tuple((k, plain(v)) for k, v in data.items() if k not in keys)
    return cls(**values)


def typed(tp, value):
    """``value`` of a JSON document as the type ``tp`` of a record's field: records and enums
    from their documents, tuples from lists, mappings by their values' type; numbers as they
    are (an integer written stays one, so that a document reads and writes back the same)."""
    if value is None:
        return None
    origin, args = typing.get_origin(tp), typing.get_args(tp)
    if origin in (typing.Union, types.UnionType):
        inner = [a for a in args if a is not type(None)]
        return typed(inner[0], value) if len(inner) == 1 else value
    if origin is tuple:
        if len(args) == 2 and args[1] is Ellipsis:
            return tuple(typed(args[0], v) for v in value)
        return tuple(typed(a, v) for a, v in zip(args, value)) if args else tuple(value)
    if origin is dict:
        return {k: typed(args[1], v) for k, v in value.items()}
    if isinstance(tp, type) and issubclass(tp, Enum):
        return tp(value)
    if dataclasses.is_dataclass(tp):
        return from_dict(tp, value)
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
                out[f.metadata.get("key", f.name)] = plain(value)
        out.update({k: plain(v) for k, v in self.extra})
        return out

    @classmethod
    def from_dict(cls, data: Mapping):
        """The record of a document (`from_dict`)."""
        return from_dict(cls, data)


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
class SolverRecord(_Row):
    """``solver`` of ``results.json``: the first stage's status and verdict, message, every
    solve of the homotopy, objective, relaxation lower bound, seconds, checks, warnings, the
    polish, the attempts, what was sought, the minimum change and other answers."""

    status: Status
    message: str
    steps: tuple[StepRecord, ...] = ()
    objective: float | None = None
    relaxation_lower_bound: float | None = None
    seconds: float | None = None
    verified: bool = False
    checks: tuple[Check, ...] = ()
    warnings: tuple[str, ...] = ()
    first_stage_xbar: tuple[float | None, ...] | None = None
    polish: PolishRow | None = None
    attempts: tuple[Attempt, ...] = ()
    verdict: Verdict | None = None
    sought: Sought | None = None
    minimum_change: MinimumChangeRow | None = None
    alternatives: tuple[Alternative, ...] = ()


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
    alternatives: tuple[Alternative, ...]
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
    checks: tuple[Check, ...]
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
