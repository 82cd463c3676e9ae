"""Data sets drawn inside the measured intervals, one per sample of a sweep.

The measured data are intervals (paper Section 2.3). A sweep asks which parameter values the
data allow by updating many point data sets drawn inside those intervals. This module draws
them; `vibupdate.study.sweep` runs the updates.

What is drawn, per configuration:

* natural frequencies and antiresonances inside their ``interval`` (rad/s) when given, else
  inside ``omega * (1 +- frequency_tolerance)`` (relative); with no interval and a zero
  tolerance the datum has no stated uncertainty and drawing refuses with an error;
* damping ratios inside their ``damping_interval`` when given, else inside
  ``xi * (1 +- damping_tolerance)`` (relative, default 10 %);
* mode-shape entries: by default (``shape_width = 1``) the measured intervals as they are:
  the formulation takes intervals, so a sample needs no point inside them, and a point
  drawn independently per entry is a shape no model has. With ``shape_width < 1``, a centre
  ``v`` inside each entry's bounds and the interval ``v +- shape_width * h`` (``h`` the
  entry's half-width, clipped to the bounds). Narrow drawn centres can leave no model that
  fits at all (`benchmarks/RESULTS.md`, "Figures behind src/: shape width of sampled sweeps").

Distributions: ``"uniform"`` over each interval, or ``"gaussian"``: a normal centred on the
interval's midpoint with ``sigma = h / z`` where ``z`` is the two-sided normal quantile of
``confidence`` (1.96 for 95 %), truncated to the interval (redrawn until inside).

Each sample's random generator is derived from ``(seed, index)`` alone, so a sample is the
same whichever worker draws it, in whatever order, in a resumed run or a re-run.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import asdict, dataclass, replace
from typing import NamedTuple

import numpy as np

from vibupdate.data.measured import TWO_PI, Antiresonance, Configuration, NaturalFrequency, ShapeInterval
from vibupdate.data.names import mode_column, mode_name, zero_column, zero_name


DISTRIBUTIONS = ("uniform", "gaussian")


@dataclass(frozen=True)
class SamplingOptions:
    """How data sets are drawn (module docstring).

    Attributes
    ----------
    distribution : {"uniform", "gaussian"}
    confidence : float
        Confidence level the intervals are stated at, in (0, 1); used by ``"gaussian"``.
    frequency_tolerance : float, optional
        Relative half-width for frequencies without an interval; None takes the case's.
    damping_tolerance : float
        Relative half-width for damping ratios without an interval (-).
    shape_width : float
        Half-width kept around a drawn shape entry, as a fraction of the entry's half-width;
        1 (the default) keeps the measured intervals and draws nothing.
    random_start : bool
        Also solve each sample from a random start and keep that answer when it is no worse
        (``docs/cli.md``, ``--no-random-start``; `vibupdate.study.sweep`).
    walk : bool
        Walk a verified answer along exact null directions to the ends of its line of equally
        good answers (``docs/cli.md``, ``--no-walk``; `vibupdate.study.extent`).
    """

    distribution: str = "uniform"
    confidence: float = 0.95
    frequency_tolerance: float | None = None
    damping_tolerance: float = 0.10
    shape_width: float = 1.0
    random_start: bool = True
    walk: bool = True

    def __post_init__(self):
        if self.distribution not in DISTRIBUTIONS:
            raise ValueError(f"distribution must be one of {', '.join(DISTRIBUTIONS)}, got {self.distribution!r}")
        if not 0.0 < self.confidence < 1.0:
            raise ValueError(f"confidence must be in (0, 1), got {self.confidence!r}")
        if self.frequency_tolerance is not None and not 0.0 <= self.frequency_tolerance < 1.0:
            raise ValueError(f"frequency tolerance must be in [0, 1) (relative), got {self.frequency_tolerance!r}")
        if not 0.0 <= self.damping_tolerance < 1.0:
            raise ValueError(f"damping tolerance must be in [0, 1) (relative), got {self.damping_tolerance!r}")
        if not 0.0 <= self.shape_width <= 1.0:
            raise ValueError(f"shape_width must be in [0, 1], got {self.shape_width!r}")

    def as_dict(self) -> dict:
        return asdict(self)


def sample_rng(seed: int, index: int, stream: int = 0) -> np.random.Generator:
    """The generator of sample ``index`` of a sweep with ``seed``: stream 0 draws the data,
    stream 1 the random start (independent streams)."""
    if seed < 0 or index < 0:
        raise ValueError(f"seed and sample index must be >= 0, got seed {seed!r}, index {index!r}")
    return np.random.Generator(np.random.PCG64(np.random.SeedSequence([int(seed), int(index), int(stream)])))


def _frequency_interval(value: float, interval, tolerance: float, what: str) -> tuple[float, float]:
    if interval is not None:
        return interval
    if tolerance <= 0.0:
        raise ValueError(f"{what} ({value / TWO_PI:.6g} Hz) has no interval and the frequency tolerance is 0: "
                         "give intervals in the data or a relative frequency_tolerance "
                         "(case file key or --frequency-tolerance)")
    return (value * (1.0 - tolerance), value * (1.0 + tolerance))


def _damping_interval(f: NaturalFrequency, options: SamplingOptions) -> tuple[float, float]:
    return f.damping_interval or (f.damping_ratio * (1 - options.damping_tolerance),
                                  f.damping_ratio * (1 + options.damping_tolerance))


class SampledDatum(NamedTuple):
    """One sampled scalar datum (`data_intervals`).

    Attributes
    ----------
    label : str
        Its column (`vibupdate.data.names`): ``"A:mode3_hz"``, ``"A:zero4_h_y1/y1_hz"``,
        ``"A:mode3_xi"``.
    value, lower, upper : float
        The measured value and its interval: Hz for a frequency, - for a damping ratio.
    kind : {"natural", "antiresonance", "damping"}
    configuration : str
    name : str
        The datum's one name: ``"mode 3 (measured 1)"``, ``"zero 4 of h_y1,y1"`` (for a damping
        ratio, the name of its mode).
    """

    label: str
    value: float
    lower: float
    upper: float
    kind: str
    configuration: str
    name: str


def data_intervals(configurations: Sequence[Configuration], frequency_tolerance: float,
                   options: SamplingOptions | None = None) -> list[SampledDatum]:
    """Every sampled scalar datum with its interval, per configuration: the natural
    frequencies, the antiresonances, then the damping ratios (the columns of ``samples.csv``
    in their order). Raises ValueError naming a frequency that has neither an interval nor a
    tolerance, or two data whose columns read alike (DOF names holding ``/``: ``h_a/b,c`` and
    ``h_a,b/c`` both give ``zero1_h_a/b/c_hz``).
    """
    options = options or SamplingOptions()
    tol = frequency_tolerance if options.frequency_tolerance is None else options.frequency_tolerance
    rows = []
    for cfg in configurations:
        for k, f in enumerate(cfg.natural, start=1):
            name = mode_name(f.mode, k)
            lo, hi = _frequency_interval(f.omega, f.interval, tol, f"the natural frequency of "
                                         f"{name} of configuration {cfg.name!r}")
            rows.append(SampledDatum(mode_column(cfg.name, f.mode), f.omega / TWO_PI, lo / TWO_PI, hi / TWO_PI,
                                     "natural", cfg.name, name))
        for a in cfg.antiresonances:
            name = zero_name(a.response, a.excitation, a.index)
            lo, hi = _frequency_interval(a.omega, a.interval, tol, f"{name} of configuration {cfg.name!r}")
            rows.append(SampledDatum(zero_column(cfg.name, a.response, a.excitation, a.index), a.omega / TWO_PI,
                                     lo / TWO_PI, hi / TWO_PI, "antiresonance", cfg.name, name))
        for k, f in enumerate(cfg.natural, start=1):
            if f.damping_ratio is not None:
                lo, hi = _damping_interval(f, options)
                rows.append(SampledDatum(mode_column(cfg.name, f.mode, "xi"), f.damping_ratio, lo, hi, "damping",
                                         cfg.name, mode_name(f.mode, k)))
    seen: dict[str, SampledDatum] = {}
    for d in rows:
        if d.label in seen:
            raise ValueError(f"{seen[d.label].name} and {d.name} of configuration {d.configuration!r} would share "
                             f"the column {d.label!r} of samples.csv: rename a DOF so that no name holds '/'")
        seen[d.label] = d
    return rows


def positional_labels(configurations: Sequence[Configuration]) -> dict[str, str]:
    """The labels of `data_intervals` as earlier versions wrote them, by position in the
    configuration (``"A:f1_hz"``, ``"A:z1_hz"``, ``"A:xi1"``), mapped to the labels of today
    (``"A:mode3_hz"``, ...): how a sweep resumes from a ``samples.csv`` of such a version."""
    out = {}
    for cfg in configurations:
        for k, f in enumerate(cfg.natural, start=1):
            out[f"{cfg.name}:f{k}_hz"] = mode_column(cfg.name, f.mode)
            if f.damping_ratio is not None:
                out[f"{cfg.name}:xi{k}"] = mode_column(cfg.name, f.mode, "xi")
        for k, a in enumerate(cfg.antiresonances, start=1):
            out[f"{cfg.name}:z{k}_hz"] = zero_column(cfg.name, a.response, a.excitation, a.index)
    return out


class _Drawer:
    """Draws scalars inside intervals with one generator, in a fixed order."""

    def __init__(self, rng: np.random.Generator, options: SamplingOptions):
        self.rng, self.options = rng, options
        self.z = None
        if options.distribution == "gaussian":
            from scipy.stats import norm

            self.z = float(norm.ppf(0.5 + 0.5 * options.confidence))

    def __call__(self, lo: float, hi: float) -> float:
        if hi <= lo:
            return lo
        if self.z is None:
            return float(self.rng.uniform(lo, hi))
        mid, sigma = 0.5 * (lo + hi), 0.5 * (hi - lo) / self.z
        while True:
            v = float(self.rng.normal(mid, sigma))
            if lo <= v <= hi:
                return v


def _draw_shape(draw: _Drawer, shape: ShapeInterval, width: float) -> ShapeInterval:
    if width >= 1.0:   # the measured intervals as they are
        return shape
    bounds = {}
    for dof, (lo, hi) in shape.bounds.items():
        v, h = draw(lo, hi), width * 0.5 * (hi - lo)
        bounds[dof] = (max(lo, v - h), min(hi, v + h))
    return ShapeInterval(bounds, shape.mass_normalized)


def draw_configurations(configurations: Sequence[Configuration], frequency_tolerance: float, seed: int,
                        index: int, options: SamplingOptions | None = None
                        ) -> tuple[tuple[Configuration, ...], dict[str, float]]:
    """Sample ``index`` of a sweep: the configurations with drawn data, and the drawn scalars.

    Parameters
    ----------
    configurations : sequence of Configuration
        The measured data with their intervals.
    frequency_tolerance : float
        Relative half-width of frequencies without an interval (the case's; overridden by
        ``options.frequency_tolerance`` when that is set).
    seed, index : int
        Seed of the sweep and index of the sample (0-based).
    options : SamplingOptions, optional

    Returns
    -------
    configurations : tuple of Configuration
        Same models, drawn data (point values; intervals of the drawn data dropped, shape
        intervals narrowed as the module docstring says).
    drawn : dict of str to float
        The drawn scalars under the labels of `data_intervals` (Hz and -).

    Raises
    ------
    ValueError
        A datum without an interval or tolerance, or drawn data that contradict each other
        (frequencies no longer ascending, a zero on a pole); the message names them.
    """
    options = options or SamplingOptions()
    tol = frequency_tolerance if options.frequency_tolerance is None else options.frequency_tolerance
    draw = _Drawer(sample_rng(seed, index), options)
    out, drawn = [], {}
    for cfg in configurations:
        natural, zeros = [], []
        for k, f in enumerate(cfg.natural, start=1):
            lo, hi = _frequency_interval(f.omega, f.interval, tol, f"the natural frequency of "
                                         f"{mode_name(f.mode, k)} of configuration {cfg.name!r}")
            omega = draw(lo, hi)
            xi = None
            if f.damping_ratio is not None:
                xi = draw(*_damping_interval(f, options))
                drawn[mode_column(cfg.name, f.mode, "xi")] = xi
            shape = None if f.shape is None else _draw_shape(draw, f.shape, options.shape_width)
            natural.append(NaturalFrequency(omega, weight=f.weight, shape=shape, damping_ratio=xi, mode=f.mode))
            drawn[mode_column(cfg.name, f.mode)] = omega / TWO_PI
        for a in cfg.antiresonances:
            lo, hi = _frequency_interval(a.omega, a.interval, tol, f"{zero_name(a.response, a.excitation, a.index)} "
                                                                   f"of configuration {cfg.name!r}")
            omega = draw(lo, hi)
            zeros.append(Antiresonance(omega, a.response, a.excitation, weight=a.weight, index=a.index))
            drawn[zero_column(cfg.name, a.response, a.excitation, a.index)] = omega / TWO_PI
        try:
            out.append(replace(cfg, natural=tuple(natural), antiresonances=tuple(zeros)))
        except ValueError as exc:
            raise ValueError(f"sample {index}: drawn data are inconsistent: {exc}") from None
    return tuple(out), drawn
