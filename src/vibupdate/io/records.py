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
    if dataclasses.is_dataclass(obj) and hasattr(obj, "as_dict"):   # a record, here or of the library (`Check`)
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


#: The end of every record's ``Attributes`` (added to its docstring by `_Row`).
_EXTRA_DOC = """    extra : tuple of (str, object)
        Keys of the producer that the record does not name, with their values, written after
        the fields.
    """


@dataclass(frozen=True, kw_only=True)
class _Row:
    """Records of ``results.json``: typed fields (written under their names, or the ``key`` of
    their metadata) plus ``extra``, further keys of the producer, written flat after them."""

    extra: tuple = ()

    def __init_subclass__(cls, **kwargs):
        super().__init_subclass__(**kwargs)
        if cls.__doc__:   # None under ``python -OO``
            cls.__doc__ = cls.__doc__.rstrip() + "\n" + _EXTRA_DOC

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
    """One updating parameter: its bounds, reference, nominal and updated values.

    Attributes
    ----------
    name : str
        The parameter's name.
    unit : str
        Its physical unit (e.g. ``"N/m"``, ``"kg"``), the unit of every value below.
    nominal : float
        Value of the nominal model.
    lower, upper : float
        Bounds of the parameter.
    reference : float
        Reference value ``p_ref`` of Eq. 12 (``xbar = 0``).
    updated : float or None
        Updated value; None when the update gave no answer.
    xbar : float or None
        Updated normalized value (Eq. 12); None when the update gave no answer.
    """

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
    """One measured frequency against the nominal and updated models.

    Attributes
    ----------
    configuration : str
        The configuration it was measured on.
    kind : {"natural", "antiresonance"}
        A natural frequency or an antiresonance.
    index : int
        Its position (1-based) among the configuration's data of that kind.
    measured_hz : float
        The measured frequency, Hz.
    nominal_hz, updated_hz : float or None
        The paired frequency of the nominal and updated models, Hz; None where the model has
        none (or the update gave no answer).
    error_nominal_pct, error_updated_pct : float or None
        Their relative errors against the measured frequency, per cent.
    model_index : int or None
        The model mode (a natural frequency's declared mode) or zero (an antiresonance's
        index) it is paired with, 1-based.
    receptance : str or None
        The receptance of an antiresonance (``"h_response,excitation"``); None for a natural
        frequency.
    measured_lower_hz, measured_upper_hz : float or None
        The measured interval, Hz; None without one.
    name : str or None
        The datum's name (`vibupdate.data.names.frequency_name`).
    """

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
    """One measured modal mass against the nominal and updated models.

    The modal mass is that of a mass-normalized shape at its reference DOF; the errors are
    against the measured interval's midpoint.

    Attributes
    ----------
    configuration : str
        The configuration it was measured on.
    mode : int
        The mode (1-based), as the data declare it.
    dof : str
        The reference DOF.
    measured_lower_kg, measured_upper_kg : float
        The measured interval, kg.
    nominal_kg, updated_kg : float or None
        The modal mass of the nominal and updated models' paired mode, kg.
    error_nominal_pct, error_updated_pct : float or None
        Their relative errors against the interval's midpoint, per cent.
    """

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
    """One measured damping ratio against the Caughey fit and the Rayleigh baseline.

    Attributes
    ----------
    configuration : str
        The configuration it was measured on.
    mode : int
        The mode (1-based), as the data declare it.
    measured : float
        The measured damping ratio (dimensionless, a fraction of critical).
    identified : float or None
        The Caughey fit's damping ratio of the mode (dimensionless).
    error_pct : float or None
        Its relative error against the measured ratio, per cent.
    rayleigh : float or None
        The Rayleigh baseline's damping ratio (dimensionless).
    error_rayleigh_pct : float or None
        Its relative error against the measured ratio, per cent.
    """

    configuration: str
    mode: int
    measured: float
    identified: float | None
    error_pct: float | None
    rayleigh: float | None
    error_rayleigh_pct: float | None


@dataclass(frozen=True)
class Summary(_Row):
    """Mean absolute errors of the run, in per cent.

    Attributes
    ----------
    mean_error_nominal_pct, mean_error_updated_pct : float or None
        Mean absolute relative error of the measured frequencies against the nominal and the
        updated model, per cent; None where not computed.
    mean_damping_error_pct, mean_damping_error_rayleigh_pct : float or None
        Mean absolute relative error of the measured damping ratios against the Caughey fit and
        the Rayleigh baseline, per cent; None without a damping stage.
    """

    mean_error_nominal_pct: float | None
    mean_error_updated_pct: float | None
    mean_damping_error_pct: float | None
    mean_damping_error_rayleigh_pct: float | None


@dataclass(frozen=True)
class MacMatrix(_Row):
    """MAC of the measured shapes with the updated model's declared modes: the MAC plot.

    Attributes
    ----------
    dofs : tuple of str
        The measured DOFs the shapes (interval midpoints) are compared on.
    values : tuple of tuple of float or None
        MAC, between zero and one: a row per measured shape, a column per declared model
        mode; None where it could not be computed.
    """

    dofs: tuple[str, ...]
    values: tuple[tuple[float | None, ...], ...]


@dataclass(frozen=True)
class PlottedReceptance(_Row):
    """The receptance of a configuration's FRF plot.

    Attributes
    ----------
    response, excitation : str
        The response and excitation DOFs.
    """

    response: str
    excitation: str


@dataclass(frozen=True)
class PolishRow(_Row):
    """What the polish did (`vibupdate.inverse.polish.PolishResult`).

    Attributes
    ----------
    cost_start, cost : float or None
        Polish objective (dimensionless) at the first-stage answer and at the polished point.
    kept : bool
        Whether the polished point replaced the first-stage answer.
    evaluations : int
        Evaluations of the full model (residual and Jacobian).
    message : str
        Why it stopped, in words.
    seconds : float or None
        Wall time, s.
    rounds : int
        Reduced rounds taken; 0 on the full model only.
    reduced_evaluations : int
        Evaluations of the reduced models in those rounds.
    stopped_on : str or None
        What ended it: ``"convergence"``, ``"stall"``, ``"evaluations"``, ``"time"``,
        ``"known answer"`` or ``"failure"``.
    budget : int or None
        The evaluation limit it had.
    """

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
    """The move along undetermined directions (`vibupdate.inverse.minimum_change.MinimumChange`).

    Attributes
    ----------
    applied : bool
        Whether the data left directions undetermined (rank below the number of parameters).
    kept : bool
        Whether the minimum-change point replaced the polished answer.
    rank : int
        Rank of the data Jacobian at the polished answer.
    norm_start, norm : float or None
        Euclidean norm of the normalized parameters at the polished answer and at the point
        returned.
    data_change : float or None
        Largest change of a datum between the two points (relative frequency, shape ratio).
    iterations : int
        Gauss-Newton iterations.
    message : str
        What it did, in words.
    """

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
    """``solver`` of ``results.json``: the record of the first stage.

    Attributes
    ----------
    status : Status
        The first stage's status.
    message : str
        Its message, in words.
    steps : tuple of StepRecord
        Every solve of the homotopy, in order.
    objective : float or None
        Objective at the answer (dimensionless).
    relaxation_lower_bound : float or None
        Lower bound of the objective from the McCormick relaxation.
    seconds : float or None
        Wall time of the first stage, s.
    verified : bool
        Whether the answer passed the verification.
    checks : tuple of Check
        The verification checks.
    warnings : tuple of str
        The first stage's warnings, in words.
    first_stage_xbar : tuple of float or None, or None
        The normalized answer of the homotopy before the polish.
    polish : PolishRow or None
        What the polish did.
    attempts : tuple of Attempt
        The first stage's attempts, in order.
    verdict : Verdict or None
        The answer's verdict.
    sought : Sought or None
        What the search for other answers looked for, and why.
    minimum_change : MinimumChangeRow or None
        The move along undetermined directions.
    alternatives : tuple of Alternative
        Other answers found that fit the data as well.
    """

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
    """One parameter's consistent range, linearized at the answer.

    Attributes
    ----------
    lower, upper : float or None
        Ends of the range, in the parameter's unit.
    width_pct : float or None
        Width in per cent of the parameter's reference value.
    """

    lower: float | None
    upper: float | None
    width_pct: float | None


@dataclass(frozen=True)
class SampledRange(_Row):
    """One parameter over the verified samples of ``run --samples``, in its unit.

    Attributes
    ----------
    unit : str
        The parameter's unit, the unit of every value below.
    min, max : float or None
        Smallest and largest value over the answers and the line ends along undetermined
        directions; None without a verified sample.
    q05, q50, q95 : float or None
        The 5 %, 50 % and 95 % quantiles over the answers.
    answers_min, answers_max : float or None
        Smallest and largest value over the answers alone.
    """

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
    """``identifiability.sampled``: the counts of the samples and each parameter's range.

    Attributes
    ----------
    samples : int
        Data sets drawn.
    verified, unverified, failed : int
        Samples whose update was verified, not verified, or failed.
    line_ends : int
        Ends of lines along undetermined directions that were added to the answers.
    seed : int
        The seed the samples were drawn from.
    distribution : str
        The distribution the data were drawn from.
    ranges : dict of str to SampledRange
        Each parameter's range, by name.
    """

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
    """One distinct local minimum of the multistart.

    Attributes
    ----------
    objective : float or None
        Objective at the minimum (dimensionless).
    starts : int
        Random starts that reached it.
    values : dict of str to float or None
        The parameters' values there, in their units, by name.
    """

    objective: float | None
    starts: int
    values: dict[str, float | None]


@dataclass(frozen=True)
class Multistart(_Row):
    """``identifiability.multistart``: random starts grouped into distinct local minima.

    Attributes
    ----------
    starts : int
        Random starts of the point estimate.
    failed : int
        Starts whose solve failed.
    distinct_minima : int
        Distinct local minima found.
    x_tol : float
        Two answers are one minimum when their normalized parameters differ by at most this in
        every entry.
    minima : tuple of LocalMinimum
        The minima, best first.
    seed : int or None
        The seed of the starts; not written when None.
    """

    starts: int
    failed: int
    distinct_minima: int
    x_tol: float
    minima: tuple[LocalMinimum, ...]
    seed: int | None = _optional()


@dataclass(frozen=True)
class CertifiedRange(_Row):
    """One parameter's certified outer range over the consistent set, and the root box's.

    Attributes
    ----------
    lower, upper : float or None
        Outer range, in the parameter's unit: every point of the consistent set lies inside;
        None when the set is certified empty.
    width_pct : float or None
        Width in per cent of the parameter's reference value.
    certified : bool
        Whether both ends are safe bounds that confirm the LP solver's optimum.
    root_lower, root_upper : float or None
        The range before any bound tightening, in the parameter's unit.
    """

    lower: float | None
    upper: float | None
    width_pct: float | None
    certified: bool
    root_lower: float | None = None
    root_upper: float | None = None


@dataclass(frozen=True)
class WidenedWindow(_Row):
    """A datum whose window the certification widened to hold a reported answer.

    Attributes
    ----------
    datum : str
        The datum.
    beyond_pct : float or None
        How far the farthest held frequency lies beyond the data's window, per cent of the
        measured frequency.
    """

    datum: str
    beyond_pct: float | None


@dataclass(frozen=True)
class WidenedBox(_Row):
    """A vector box the certification widened to hold a reported answer.

    Attributes
    ----------
    vector : str
        The vector.
    entries : int
        Its entries widened.
    bound_ratio : float or None
        Its largest bound after the widening against before.
    """

    vector: str
    entries: int
    bound_ratio: float | None


@dataclass(frozen=True)
class Inclusion(_Row):
    """How the consistent set was widened to hold every answer the run reports.

    Attributes
    ----------
    points : int
        Points held (the answer and other reported answers).
    widened_by : tuple of str
        Labels of the points that needed any widening.
    windows : tuple of WidenedWindow
        The frequency windows widened.
    vector_boxes : tuple of WidenedBox
        The vector boxes widened.
    bounds_widened : int
        Parameters whose bounds were widened by rounding.
    """

    points: int
    widened_by: tuple[str, ...]
    windows: tuple[WidenedWindow, ...]
    vector_boxes: tuple[WidenedBox, ...]
    bounds_widened: int


@dataclass(frozen=True, kw_only=True)
class CertifiedRecord(_Row):
    """``identifiability.certified`` (`vibupdate.ranges.certify.CertifiedRanges.record`).

    Attributes
    ----------
    definition : str
        The consistent set, in words.
    message : str
        The outcome, in words.
    empty : bool or None
        Whether the consistent set is certified empty.
    seconds, root_seconds : float or None
        Wall time in all and to the root ranges, s.
    passes : int or None
        Completed bound-tightening passes over the whole box.
    splits : int or None
        Splits of the parameter box (branching).
    leaves : int or None
        Parts of the box not proved empty; the ranges are their hull.
    n_lps : int or None
        Linear programs solved.
    history : tuple of (float or None, float or None), or None
        (seconds, mean width in per cent) after the root and after each pass.
    included : Inclusion or None
        How the set was widened to hold the reported answers.
    uncovered : tuple of str or None
        Why a reported answer is not held by the set or not inside the ranges, with the figure.
    ranges : dict of str to CertifiedRange
        Each parameter's range, by name.
    """

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
    """``identifiability``: what the data determine.

    Attributes
    ----------
    rank : int
        Numerical rank of the exact sensitivity of the data at the answer.
    condition : float or None
        Its condition number.
    singular_values : tuple of float or None
        Singular values of the scaled sensitivity, descending (dimensionless).
    column_norm : dict of str to float or None
        Norm of each parameter's column of the sensitivity, by name.
    undetermined_combinations : tuple of str
        Combinations of parameters that leave every datum unchanged to first order, in words.
    minimum_change : str or None
        The move along undetermined directions, in words; None where none was made.
    alternatives : tuple of Alternative
        Other answers that fit the data as well.
    ranges_note : str or None
        Why the linearized ranges were not computed; not written when they were.
    ranges : dict of str to LinearRange or None
        The linearized consistent range of each parameter, by name, at a verified answer.
    frequency_tolerance : float or None
        Relative half-width of the frequency windows of data without an interval.
    frequency_windows : str or None
        How the ranges bound each frequency, in words.
    sampled : Sampled or None
        The sampled ranges (``run --samples``).
    multistart : Multistart or None
        The multistart (``run --samples``).
    certified : CertifiedRecord or None
        The certified ranges (``run --certify``).
    """

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
    """``damping_model``: the fitted Caughey series and the Rayleigh baseline.

    Attributes
    ----------
    exponents : tuple of float
        The Caughey series' exponents.
    beta : tuple of float or None
        Its coefficients, one per exponent (SI units, `vibupdate.damping.models`).
    rayleigh_beta : tuple of float or None
        The Rayleigh baseline's two coefficients (of ``M`` and ``K``).
    condition : float or None
        Condition number of the fit.
    weights_text : str
        The fit's weighting, in words.
    """

    exponents: tuple[float, ...]
    beta: tuple[float | None, ...]
    rayleigh_beta: tuple[float | None, ...]
    condition: float | None
    weights_text: str


@dataclass(frozen=True, kw_only=True)
class ReferenceColumns(_Row):
    """``paper``: reference columns of the report's tables.

    The columns come from a bundled example's ``reference_columns()`` (published values, a
    synthetic example's truth; `vibupdate.report.table.with_reference`).

    Attributes
    ----------
    columns : dict of str to dict of str to dict of str to float or str or None, or None
        By table, column name and row key: the reference value.
    errors : dict of str to dict of str to (str, str), or None
        By table and column name: the two columns compared.
    notes : dict of str to tuple of str, or None
        By table: notes under it.
    """

    columns: dict[str, dict[str, dict[str, float | str | None]]] | None = _optional()
    errors: dict[str, dict[str, tuple[str, str]]] | None = _optional()
    notes: dict[str, tuple[str, ...]] | None = _optional()


@dataclass(frozen=True)
class MeshSensor(_Row):
    """A measured point on an imported FE mesh.

    Attributes
    ----------
    sensor : str
        The sensor's name.
    dof : str
        The DOF it reads, ``"<node>:<dir>"``.
    sign : float
        The sign of the reading against the DOF (+1 or -1).
    distance_m : float or None
        Distance from the sensor to the node, m.
    direction : tuple of float or None
        Unit direction read; None for a rotation.
    """

    sensor: str
    dof: str
    sign: float
    distance_m: float | None
    direction: tuple[float, ...] | None = None


@dataclass(frozen=True)
class DeclaredSensor(_Row):
    """A sensor of the case file: its name and the weight of each DOF in its reading.

    Attributes
    ----------
    sensor : str
        The sensor's name.
    weights : dict of str to float
        Weight of each DOF in its reading (dimensionless), by DOF name.
    """

    sensor: str
    weights: dict[str, float]


@dataclass(frozen=True)
class SetUpdate(_Row):
    """The full update of one set of candidates (`vibupdate.ranges.candidates`).

    Attributes
    ----------
    status : Status
        The update's status.
    success : bool
        Whether it succeeded (verified).
    message : str
        Its message, in words.
    values : dict of str to float or None
        Physical values of the free parameters, in their units, by name.
    units : dict of str to str
        Their units, by name.
    natural_mean_pct, natural_max_pct : float or None
        Mean and largest relative error of the declared modes' frequencies, per cent.
    antiresonance_mean_pct, antiresonance_max_pct : float or None
        The same of the antiresonances; None without any.
    failed : tuple of str
        The failed checks.
    limited_by : str or None
        What limited a verified answer: ``"measurement"`` or ``"model_form"``.
    range_pct : dict of str to float or None, or None
        Linearized range width of each parameter, per cent of its reference, at a verified
        answer.
    """

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
    """One set of candidates screened (`vibupdate.ranges.candidates.SetTrial`).

    Attributes
    ----------
    candidates : tuple of str
        The candidates added to the case's parameters.
    objective : float or None
        Polish objective at the screened answer (the misfit, dimensionless).
    passed : bool
        Whether every screened check passed.
    failed : tuple of str
        The failed checks of the screening.
    natural_mean_pct, natural_max_pct : float or None
        Mean and largest relative error of the declared modes' frequencies, per cent.
    antiresonance_mean_pct, antiresonance_max_pct : float or None
        The same of the antiresonances; None without any.
    rank : int
        Numerical rank of the data's sensitivity to the free parameters.
    free : int
        Free parameters: the case's own and the set's.
    condition : float or None
        Condition number of that sensitivity.
    determined : bool
        Whether the data determine every free parameter (rank equal to ``free``).
    values : dict of str to float or None
        Physical values of the free parameters at the screened answer, by name.
    tied_with : tuple of tuple of str
        Other sets whose objective equals this one's within the tie tolerance.
    update : SetUpdate or None
        The full update of a checked set; None when not checked.
    seconds : float or None
        Wall time, s.
    """

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
    """``suggestion``: the screening of candidates after a run that did not verify.

    The record is `vibupdate.ranges.candidates.Suggestion.record`.

    Attributes
    ----------
    own : tuple of str
        The case's own parameters, free in every set.
    candidates : tuple of str
        The pool of candidates, in declaration order.
    nominal : dict of str to float or bool or tuple of str or None
        The model with the case's own parameters alone, screened as the sets are.
    sizes : tuple of int
        The set sizes screened.
    untried : int
        Sets of those sizes not screened because of the limits (or whose fit failed).
    seconds : float or None
        Wall time, s.
    untried_sets : tuple of tuple of str
        Those sets, each by its candidates' names.
    best : tuple of str or None
        The top set whose full update succeeded.
    screened_best : tuple of str or None
        The top set of the screening alone.
    message : str
        The outcome, in words.
    trials : tuple of SetTrialRow
        Every set screened, ranked.
    limits : dict of str to float
        The limits of the screening (``sets``, ``seconds``, ``tie_rtol``).
    """

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
    """One group of the data left out by the diagnosis (`vibupdate.inverse.diagnosis`).

    Attributes
    ----------
    key : str
        The group, unique within a run (``"CFG/natural/MODE"``, ``"CFG/dof/DOF"``, ...).
    kind : str
        ``"natural"``, ``"antiresonance"``, ``"shape"`` or ``"dof"``.
    configuration : str
        The configuration the group belongs to.
    label : str
        The group in words.
    size : int
        Data removed with it (frequencies and shape entries).
    share : float or None
        Fraction of the full answer's objective that the group carries there.
    objective : float or None
        Polish objective on the data kept, after refitting.
    passed : bool
        Whether every screened check passed on the data kept.
    failed : tuple of str
        The failed checks.
    mean_error_pct, max_error_pct : float or None
        Mean and largest relative frequency error on the frequencies kept, per cent.
    shape_misses : int
        Measured mode shapes outside their admissible intervals at their best scale.
    xbar : tuple of float or None
        The refitted answer, normalized parameters.
    seconds : float or None
        Wall time, s.
    """

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
    """The update run again without the top group of the diagnosis.

    Attributes
    ----------
    without : str
        The key of the group left out.
    without_label : str
        That group in words.
    status : Status
        The update's status.
    success : bool
        Whether it succeeded (verified).
    message : str
        Its message, in words.
    values : dict of str to float or None
        Physical values of the parameters, in their units, by name.
    xbar : tuple of float or None
        The answer, normalized parameters.
    mean_error_pct, max_error_pct : float or None
        Mean and largest relative frequency error on the data kept, per cent.
    checks : tuple of Check
        Its verification checks on the data kept.
    seconds : float or None
        Wall time, s.
    """

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
    """``diagnosis`` of ``results.json``: which data conflict with the model.

    Attributes
    ----------
    failed : tuple of str
        The checks of the full answer that failed.
    objective : float or None
        The full answer's polish objective.
    mean_error_pct, max_error_pct : float or None
        The full answer's mean and largest relative frequency error, per cent.
    groups : int
        Groups of data the diagnosis formed.
    untried : int
        Groups not tried because of the limits.
    trials : tuple of GroupTrialRow
        The groups tried, ranked: best fit without the group first.
    best : DiagnosisBest or None
        The update without the top group.
    seconds : float or None
        Wall time, s.
    limits : dict of str to float
        The limits of the diagnosis (``groups``, ``seconds``).
    untried_groups : tuple of str
        The keys of the groups not tried.
    """

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
