"""The admissible data: one definition of "the model fits the data".

Every datum gets one admissible interval, built once from the configurations and the
verification options (`Admissible.of`):

    admissible = measurement interval + model-form tolerance + numerical floor

(a datum known exactly: its stated half-width ``exact_half_width``; the tolerances per kind:
`VerifyOptions`; the floor: `FLOOR`). A measured shape is known up to one free scale per mode,
eliminated by variable projection (`_scales`); a mass-normalized shape's scale is fixed
besides, and its modal mass is one more datum. The polish minimizes each value's distance
outside its interval plus a small pull toward its midpoint, in half-widths (`residuals`); the
verification asks whether every value lies in its interval, a shape at some scale (`misses`).
The rules in full: docs/polish-and-verification.md, sections 7.2 and 7.3.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace
from functools import cached_property
from itertools import groupby

import numpy as np

from vibupdate.options import check, default
from vibupdate.data.measured import Antiresonance, Configuration
from vibupdate.inverse.repeated import cluster

#: Relative numerical floor added to every admissible interval: the rounding of a
#: double-precision eigen-solve with room for the polish's own stopping test.
FLOOR = 1e-8
#: Weight of the pull toward the midpoints against the distance outside the intervals (`_rows`):
#: small, so that inside the intervals it only picks the weighted least-squares point. A datum
#: held at its interval's end by a pull ``F`` half-widths strong (its own and the other data's)
#: stays ``F PULL^2`` half-widths outside its target: `MARGIN` covers ``F`` up to 10.
PULL = 1e-2
#: The polish aims at each interval shrunk by this many half-widths (and by the floor): more
#: than the pull's trade-off (``F PULL^2``) and than where the least squares stops on an
#: interval's end.
MARGIN = 1e-3

#: Smallest relative half-width the first stage's weights use (`weighted`): a chosen cap, so
#: that an exact datum among 1 % ones weighs 1e4^2 times more rather than without bound.
WEIGHT_FLOOR = 1e-4


@dataclass(frozen=True)
class VerifyOptions:
    """Thresholds of the verification.

    Attributes
    ----------
    mac_min : float
        Smallest MAC of a measured shape with its declared mode (0.8: the usual threshold
        below which two shapes are not taken as the same mode).
    frequency_tolerance : float
        Relative frequency uncertainty used for the consistency allowance (a case file's
        ``frequency_tolerance`` when it states one; 1 % otherwise).
    measurement_tolerance : float
        Relative half-width of the measurement interval of a frequency that has no interval of
        its own (a case file's ``frequency_tolerance``; 0: known exactly).
    exact_half_width : float
        Relative half-width given to a datum known exactly (a measurement interval of zero
        width), against its value (a shape entry: against the shape's largest entry).
    natural_tolerance, antiresonance_tolerance : float
        Model-form tolerances: the largest relative miss of a natural frequency or an
        antiresonance beyond its measurement interval.
    shape_tolerance : float
        Model-form tolerance of the shapes: the largest distance of a shape ratio (normalized at
        the mode's largest measured entry) beyond its measurement interval.
    modal_mass_tolerance : float
        Model-form tolerance of the modal masses of mass-normalized shapes: the largest
        relative miss beyond the measurement interval.
    diagnose : bool
        Not a threshold: whether a run whose answer does not fit the data goes on to say which
        data conflict (`vibupdate.inverse.diagnosis`); the checks ignore it.
    suggest : bool
        Not a threshold: whether a run that is not verified screens the case's candidates
        (`vibupdate.ranges.candidates`); the checks ignore it.
    """

    mac_min: float = default("verification", "mac_min")
    frequency_tolerance: float = default("verification", "frequency_tolerance")
    measurement_tolerance: float = default("verification", "measurement_tolerance")
    exact_half_width: float = default("verification", "exact_half_width")
    natural_tolerance: float = default("verification", "natural_tolerance")
    antiresonance_tolerance: float = default("verification", "antiresonance_tolerance")
    shape_tolerance: float = default("verification", "shape_tolerance")
    modal_mass_tolerance: float = default("verification", "modal_mass_tolerance")
    diagnose: bool = default("verification", "diagnose")
    suggest: bool = default("verification", "suggest")

    def __post_init__(self):
        check("verification", self)     # types and ranges: vibupdate.options


@dataclass(frozen=True)
class Datum:
    """The admissible interval of one frequency or modal mass (rad/s or kg)."""

    label: str
    kind: str              # "natural", "antiresonance" or "modal_mass"
    value: float
    measured: tuple[float, float]
    lower: float
    upper: float
    weight: float = 1.0    # the datum's own weight, on the pull

    @property
    def half_width(self) -> float:
        return 0.5 * (self.upper - self.lower)


@dataclass(frozen=True)
class Shape:
    """The admissible intervals of one measured shape, free scale: entries in the order
    reference first, then `vibupdate.inverse.data_map.MeasuredShape.entries`."""

    label: str
    position: int
    mode: int
    dofs: tuple
    measured_lower: np.ndarray
    measured_upper: np.ndarray
    lower: np.ndarray
    upper: np.ndarray
    scale: float           # the magnitude of the reference entry's midpoint
    calibration: tuple[float, float] | None = None   # a mass-normalized shape: `Shape.scales`

    @property
    def half_width(self) -> np.ndarray:
        return 0.5 * (self.upper - self.lower)

    @cached_property
    def targets(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """The polish's target intervals of the entries (`_targets`), computed once."""
        return _targets(self.lower, self.upper, FLOOR * self.scale)

    def scales(self, modal_mass: float) -> tuple[float, float] | None:
        """The scales the model's shape (normalized to 1 at the reference entry) may take: any
        (None) for a free-scale shape; for a mass-normalized one, the mass-normalized mode's own,
        ``1 / sqrt(m)`` with ``m`` the model's modal mass at the reference entry, signed as the
        measured reference entry and times a calibration factor within ``calibration``."""
        if self.calibration is None:
            return None
        if not (np.isfinite(modal_mass) and modal_mass > 0):
            return (np.nan, np.nan)
        sign = 1.0 if self.measured_lower[0] + self.measured_upper[0] > 0 else -1.0
        a, b = (sign * c / np.sqrt(modal_mass) for c in self.calibration)
        return (min(a, b), max(a, b))


@dataclass(frozen=True)
class Miss:
    """How far one datum lies outside its admissible interval, in its half-widths (0: inside);
    ``measured``: whether it also lies in its measurement interval."""

    label: str
    kind: str
    miss: float
    measured: bool
    text: str
    relative: float = 0.0    # of a frequency: its relative difference from the measured value


def _widened(lo, hi, scale: float, tolerance: float, exact: float):
    extra = np.where(hi - lo <= 0, exact * scale, 0.0) + (tolerance + FLOOR) * scale
    return lo - extra, hi + extra


@dataclass(frozen=True)
class Admissible:
    """The admissible intervals of every datum of every configuration (module docstring).

    Attributes
    ----------
    frequencies : tuple of tuple of Datum
        Per configuration, its natural frequencies then its antiresonances, as declared.
    shapes : tuple of tuple of Shape
        Per configuration, its measured shapes with two entries or more, in the order of
        `vibupdate.inverse.data_map.measured_shapes`.
    masses : tuple of tuple of Datum
        Per configuration, the modal masses of its mass-normalized shapes, in that order.
    """

    frequencies: tuple
    shapes: tuple
    masses: tuple

    @classmethod
    def of(cls, configurations: Sequence[Configuration], options=None) -> "Admissible":
        """The contract of ``configurations`` under ``options`` (a
        `VerifyOptions`; its defaults when None)."""
        o = options or VerifyOptions()
        freqs, shapes, masses = [], [], []
        for cfg in configurations:
            row = []
            for d in (*cfg.natural, *cfg.antiresonances):
                anti = isinstance(d, Antiresonance)
                t = o.antiresonance_tolerance if anti else o.natural_tolerance
                lo, hi = d.interval or tuple(d.omega * (1 + sign * o.measurement_tolerance) for sign in (-1, 1))
                label = (f"configuration {cfg.name!r}, "
                         + (f"zero {d.index} of h_{d.response},{d.excitation}" if anti else f"mode {d.mode}"))
                row.append(Datum(label, "antiresonance" if anti else "natural", d.omega, (lo, hi),
                                 *_widened(lo, hi, d.omega, t, o.exact_half_width), d.weight))
            freqs.append(tuple(row))
            srow, mrow = [], []
            for k, nat in enumerate(cfg.natural):
                if nat.shape is None:
                    continue
                label = f"configuration {cfg.name!r}, mode {nat.mode} ({nat.freq_hz:.5g} Hz)"
                bounds = nat.shape.bounds
                ref = nat.shape.reference
                order = [ref] + [d for d in bounds if d != ref]
                scale = abs(nat.shape.midpoint[ref])
                if len(order) >= 2:
                    mlo, mhi = np.array([bounds[d] for d in order], dtype=float).T
                    t = o.modal_mass_tolerance   # the modal mass's m (1 -+ t): the scale's 1 / sqrt of it
                    srow.append(Shape(label, k, nat.mode, tuple(order), mlo, mhi,
                                      *_widened(mlo, mhi, scale, o.shape_tolerance, o.exact_half_width), scale,
                                      (1.0 / np.sqrt(1.0 + t), 1.0 / np.sqrt(1.0 - t))
                                      if nat.shape.mass_normalized else None))
                if nat.shape.mass_normalized:
                    lo, hi = nat.shape.modal_mass_bounds()
                    mid = 0.5 * (lo + hi)
                    mrow.append(Datum(f"{label}, modal mass at {ref!r}", "modal_mass", mid, (lo, hi),
                                      *_widened(lo, hi, mid, o.modal_mass_tolerance, o.exact_half_width)))
            shapes.append(tuple(srow))
            masses.append(tuple(mrow))
        return cls(tuple(freqs), tuple(shapes), tuple(masses))

    def floored(self, relative: float) -> "Admissible":
        """The same data with every admissible half-width at least ``relative`` times the
        datum's scale (its value; a shape entry: its shape's `Shape.scale`), each interval
        widened about its midpoint: the softer objective a polish starts on (`vibupdate.inverse.polish.START_FLOOR`).
        Built once per ``relative`` and kept with this contract (every start of a run is polished
        from it)."""
        def wide(d, scale):
            mid, h = 0.5 * (d.lower + d.upper), np.maximum(d.half_width, relative * scale)
            return replace(d, lower=mid - h, upper=mid + h)

        kept = self._floored.get(relative)
        if kept is None:
            kept = self._floored[relative] = Admissible(
                tuple(tuple(wide(d, abs(d.value)) for d in row) for row in self.frequencies),
                tuple(tuple(wide(s, s.scale) for s in row) for row in self.shapes),
                tuple(tuple(wide(d, abs(d.value)) for d in row) for row in self.masses))
        return kept

    @cached_property
    def _floored(self) -> dict:
        return {}

    @cached_property
    def datum_targets(self) -> tuple:
        """Per configuration, the polish's target intervals (`_targets`) of its frequencies and
        of its modal masses, each with the square roots of the data's weights repeated for the
        two rows of each datum (None for no data), computed once."""
        return tuple((_target_block(f), _target_block(m)) for f, m in zip(self.frequencies, self.masses))

    @cached_property
    def frequency_stack(self) -> tuple:
        """Every configuration's frequencies as one target block (`datum_targets`: the same
        elementwise figures), and per configuration the indices of its rows among the block's
        rows, its pull rows then its distance rows (None without frequencies); ``(None, picks)``
        without any frequency. `residuals` takes every frequency's rows in one array operation."""
        sizes = [len(row) for row in self.frequencies]
        n, ends = sum(sizes), np.cumsum(sizes)
        picks = tuple(np.r_[e - k:e, n + e - k:n + e] if k else None for k, e in zip(sizes, ends))
        for i in picks:
            if i is not None:
                i.flags.writeable = False
        return _target_block([d for row in self.frequencies for d in row]), picks

    def relative_half_widths(self) -> np.ndarray:
        """Every frequency's admissible half-width over its value, shape (n_f,)."""
        return np.array([d.half_width / d.value for row in self.frequencies for d in row])

    def exact_fit(self, exact_half_width: float) -> float:
        """The polish's objective of missing every frequency by ``exact_half_width`` of its
        value (`VerifyOptions.exact_half_width`): a fit below it is exact, since exact data are
        met to that and not to the last digit; 0 without frequencies."""
        h = self.relative_half_widths()
        return 0.5 * float(np.sum((exact_half_width / h) ** 2)) if h.size else 0.0


def _rows(v, lo, hi, mid, h, pull=PULL, slopes=True):
    """The polish's rows of values ``v`` (last axis: the data) against ``[lo, hi]`` with
    midpoints ``mid`` and half-widths ``h`` (arrays of one shape), and their slopes
    ``d row / d v`` (None without ``slopes``): per datum two rows, stacked on the last axis,
    the pull ``(v - mid) / h`` then the distance outside ``(v - clip(v, lo, hi)) / (pull h)``
    (two rows, not one, for a continuous gradient: docs/polish-and-verification.md, section 7.2)."""
    out = v - v.clip(lo, hi)
    pull_h = pull * h
    rows = np.concatenate([(v - mid) / h, out / pull_h], axis=-1)
    if not slopes:
        return rows, None
    return rows, np.concatenate([1.0 / h, np.where(out != 0, 1.0 / pull_h, 0.0)], axis=-1)


def _target_block(items) -> tuple | None:
    """The targets (`_targets`) of the data ``items`` with the square roots of their weights
    repeated for the two rows of each datum, read-only; None for no data."""
    if not items:
        return None
    lower, upper, value = (np.array([getattr(d, k) for d in items]) for k in ("lower", "upper", "value"))
    w = np.tile(np.sqrt([d.weight for d in items]), 2)
    w.flags.writeable = False
    return (*_targets(lower, upper, FLOOR * np.abs(value)), w)


def _targets(lower, upper, floor) -> tuple[np.ndarray, ...]:
    """The polish's target intervals: the admissible ones ``[lower, upper]`` without their
    ``floor``, shrunk by `MARGIN` half-widths, as read-only ``(lo, hi, mid, h)``, ``h`` the
    admissible half-widths."""
    inset = floor + MARGIN * 0.5 * (upper - lower - 2 * floor)
    lo, hi = lower + inset, upper - inset
    out = (lo, hi, 0.5 * (lo + hi), 0.5 * (upper - lower))
    for a in out:
        a.flags.writeable = False
    return out


def _scales(Q: np.ndarray, lo: np.ndarray, hi: np.ndarray, mid: np.ndarray, h: np.ndarray,
            pull: float) -> np.ndarray:
    """The scale ``s`` minimizing ``sum rows(s q)^2`` (`_rows`) of each row ``q`` of ``Q``
    (shapes with the same number of entries; every array shape (m, k), ``Q[:, 0] = 1``), exact:
    the pull's own minimizer where it puts every entry inside, else the zero of the slope
    ``g(s) = sum_j q_j (s q_j - mid_j) / h_j^2 + q_j (s q_j - clip(s q_j)) / (pull h_j)^2``,
    increasing and linear between the scales where an entry crosses an interval end, found on
    the piece where it changes sign (docs/polish-and-verification.md, section 7.2)."""
    w_in, w_out = (1.0 / h) ** 2, (1.0 / (pull * h)) ** 2
    s = np.sum(w_in * Q * mid, axis=1) / np.sum(w_in * Q * Q, axis=1)
    V = s[:, None] * Q
    rest = np.flatnonzero(~np.all((V >= lo) & (V <= hi), axis=1))
    if not rest.size:
        return s
    q, lo, hi, mid, w_in, w_out = (a[rest] for a in (Q, lo, hi, mid, w_in, w_out))
    with np.errstate(divide="ignore", invalid="ignore"):
        ends = np.where(q[:, :, None] != 0, np.stack([lo, hi], axis=-1) / q[:, :, None], 0.0).reshape(rest.size, -1)
    ends = np.sort(ends, axis=1)
    first, last = ends[:, :1], ends[:, -1:]
    at = np.hstack([first - 1.0 - np.abs(first), ends, last + 1.0 + np.abs(last)])   # (r, 2 k + 2)
    v = at[:, :, None] * q[:, None, :]
    g = np.sum(q[:, None, :] * (w_in[:, None, :] * (v - mid[:, None, :])
                                + w_out[:, None, :] * (v - np.clip(v, lo[:, None, :], hi[:, None, :]))), axis=2)
    # the zero lies in [at[j - 1], at[j]], or beyond an outer one
    j = np.clip(np.sum(g < 0, axis=1), 1, at.shape[1] - 1)
    i = np.arange(rest.size)
    a, b, ga, gb = at[i, j - 1], at[i, j], g[i, j - 1], g[i, j]
    s[rest] = np.where(gb > ga, a - ga * (b - a) / np.where(gb > ga, gb - ga, 1.0), a)
    return s


def _shape_rows(shapes: Sequence[Shape], ratios: Sequence[np.ndarray], jacs: Sequence[np.ndarray] | None,
                pull: float, masses: Sequence[tuple[float, np.ndarray | None]]):
    """Rows of shapes with the same number of entries ``k``, each at its best scale, and their
    Jacobian (Gauss-Newton in the scale), shapes stacked in their order: one array operation
    for all of them. A mass-normalized shape's scale lies within `Shape.scales` of the model's
    modal mass in ``masses`` (its value and, with ``jacs``, its gradient).

    ``ratios``: per shape, shape (k - 1,); ``jacs``: per shape, shape (k - 1, n_x), or None
    for the rows alone. Returns the rows, shape (2 k m,), and their Jacobian, shape
    (2 k m, n_x), or None."""
    m = len(shapes)
    Q = np.hstack([np.ones((m, 1)), np.vstack(ratios)])                  # (m, k): the reference entry first
    lo, hi, mid, h = (np.vstack(t) for t in zip(*(s.targets for s in shapes)))
    scales = [s.scales(value) for s, (value, _) in zip(shapes, masses)]
    bound = np.array([(-np.inf, np.inf) if b is None else b for b in scales], dtype=float).reshape(m, 2)
    lost = np.isnan(bound[:, 0])                                         # no modal mass: the model lost the mode
    s = np.clip(_scales(np.where(lost[:, None], 1.0, Q), lo, hi, mid, h, pull), bound[:, 0], bound[:, 1])
    s[lost] = 0.0
    r, slope = _rows(s[:, None] * Q, lo, hi, mid, h, pull, jacs is not None)   # (m, 2 k)
    k = Q.shape[1]
    r[lost] = np.concatenate([np.zeros(k), np.full(k, 1.0 / pull)])
    if jacs is None:
        return r.ravel(), None
    n_x = jacs[0].shape[1]
    dq = np.concatenate([np.zeros((m, 1, n_x)), np.stack(jacs)], axis=1)
    dq, q = np.concatenate([dq, dq], axis=1), np.concatenate([Q, Q], axis=1)   # the two rows of each entry
    J = (slope * s[:, None])[:, :, None] * dq
    Js = slope * q                                                       # d rows / d s
    # the scale follows the shape (variable projection): d/dx of sum r dr/ds = 0 at the best scale
    ds = -(np.einsum("mi,mix->mx", Js, J) + np.einsum("mi,mix->mx", r * slope, dq)) \
        / np.maximum(np.sum(Js * Js, axis=1), 1e-300)[:, None]
    for i, b in enumerate(scales):
        if b is not None and not lost[i] and s[i] in b:                  # held at a bound: it follows the modal mass
            ds[i] = -0.5 * s[i] / masses[i][0] * masses[i][1]
    J = J + Js[:, :, None] * ds[:, None, :]
    J[lost] = 0.0
    return r.ravel(), J.reshape(-1, n_x)


def evaluate(configurations: Sequence[Configuration], contract: Admissible, xbar, jacobian: bool = True,
             basis: list | None = None, pull: float = PULL, maps: list | None = None):
    """`residuals` at ``xbar`` from one data map per configuration; ``basis``, a list (with
    ``jacobian``), receives per configuration the vectors the evaluation computed
    (`vibupdate.inverse.data_map.DataMap.vectors`): the basis of the polish's reduced rounds;
    ``maps``, a list, receives the data maps (`residuals` of them is the same point at another
    ``pull``, with no eigen-solve)."""
    from vibupdate.inverse.data_map import data_map

    want = basis is not None and jacobian
    found = [data_map(c, xbar, jacobian=jacobian, shapes=bool(s or m), vectors=want)
             for c, s, m in zip(configurations, contract.shapes, contract.masses)]
    if want:
        basis.extend(np.hstack(m.vectors) for m in found)
    if maps is not None:
        maps.extend(found)
    return residuals(contract, found, jacobian, pull)


def residuals(contract: Admissible, maps: Sequence, jacobian: bool = True, pull: float = PULL):
    """The polish's residual rows (`_rows`) from the data maps of each configuration
    (`vibupdate.inverse.data_map.DataMap`, with ``jacobian`` their Jacobians), and their
    Jacobian, shape (n_r, n_x) (None without ``jacobian``). Order per configuration:
    frequencies, modal masses (each: the pull rows, then the distance rows), shapes (reference
    entry first, the same two blocks). A zero the model lost costs a constant distance row of
    ``1 / pull`` with no direction. Every configuration's frequencies are one array operation
    (`Admissible.frequency_stack`), each configuration's rows then taken in this order."""
    res, jac = [], []
    stacked, picks = contract.frequency_stack
    if stacked is not None:
        held = [m for m, pick in zip(maps, picks) if pick is not None]
        freq_r, freq_J = _datum_rows(stacked, np.concatenate([m.frequency_values for m in held]),
                                     np.concatenate([m.frequency_jacobian for m in held]) if jacobian else None,
                                     pull, jacobian)
    for shapes, targets, m, pick in zip(contract.shapes, contract.datum_targets, maps, picks):
        if pick is not None:
            res.append(freq_r[pick])
            if jacobian:
                jac.append(freq_J[pick])
        if targets[1] is not None:
            r, J = _datum_rows(targets[1], m.masses, m.mass_jacobian, pull, jacobian)
            res.append(r)
            if jacobian:
                jac.append(J)
        by = {s.position: s for s in shapes}
        mass = _modal_masses(m, jacobian)
        held = [k for k, measured in enumerate(m.shapes) if measured.position in by]
        for _, run in groupby(held, key=lambda k: m.ratios[k].size):   # consecutive shapes of one size at once
            group = list(run)
            r, J = _shape_rows([by[m.shapes[k].position] for k in group], [m.ratios[k] for k in group],
                               [m.ratio_jacobians[k] for k in group] if jacobian else None, pull,
                               [mass[k] for k in group])
            res.append(r)
            if jacobian:
                jac.append(J)
    r = np.concatenate(res) if res else np.zeros(0)
    return r, (np.vstack(jac) if jacobian and jac else None)


def _datum_rows(target: tuple, values: np.ndarray, J: np.ndarray | None, pull: float, jacobian: bool):
    """The rows (`_rows`) of frequencies or modal masses ``values`` against ``target``
    (``(lo, hi, mid, h, w)`` of `Admissible.datum_targets`), weighed by ``w``, and their
    Jacobian from ``J = d values / d xbar`` (None without ``jacobian``)."""
    lo, hi, mid, h, w = target
    lost = ~np.isfinite(values)
    rows_lost = np.concatenate([lost, lost]) if lost.any() else None   # None: nothing lost
    r, slope = _rows(values if rows_lost is None else np.where(lost, mid, values), lo, hi, mid, h, pull, jacobian)
    # a lost zero: its pull row 0, its distance row 1 / pull, no direction
    r = w * r if rows_lost is None else np.where(rows_lost, np.concatenate([0 * lost, lost / pull]), w * r)
    if not jacobian:
        return r, None
    dv = J if np.isfinite(J).all() else np.nan_to_num(J)
    rows = (w * slope)[:, None] * np.concatenate([dv, dv])
    return r, (rows if rows_lost is None else np.where(rows_lost[:, None], 0.0, rows))


def _modal_masses(m, jacobian: bool) -> list:
    """Per measured shape of the data map ``m``: its model modal mass and gradient (a
    mass-normalized shape), else ``(nan, None)``."""
    if not m.shapes:
        return []
    row = np.cumsum([s.mass is not None for s in m.shapes], dtype=int) - 1   # of each shape among the masses
    return [(np.nan, None) if s.mass is None else (float(m.masses[k]), m.mass_jacobian[k] if jacobian else None)
            for s, k in zip(m.shapes, row)]


def scaling_miss(q: np.ndarray, lower: np.ndarray, upper: np.ndarray, scale: bool = False,
                 scales: tuple[float, float] | None = None):
    """The least ``t`` such that some scale ``s`` (within ``scales``, when given:
    `Shape.scales`) puts every ``s q_j`` within ``t`` half-widths ``h_j`` of
    ``[lower_j, upper_j]`` (0: the shape is admissible); with ``scale``, ``(t, s)``, ``s`` the
    middle of the scales admitted at that ``t``.

    Exact: an entry with ``q_j != 0`` admits the scales between ``(lower_j - t h_j) / q_j`` and
    ``(upper_j + t h_j) / q_j``, whose lower end falls and upper end rises linearly in ``t``
    (``scales`` adds two constant ends); the entries share a scale from the largest ``t`` at
    which a lower end meets an upper end. An entry with ``q_j = 0`` needs ``t`` to reach zero."""
    half = 0.5 * (upper - lower)
    zero = q == 0
    if not np.all(np.isfinite(q)) or np.any(half <= 0) or zero.all() or \
            (scales is not None and not np.isfinite(scales[0])):
        return (np.inf, np.nan) if scale else np.inf
    qn, slope = q[~zero], half[~zero] / np.abs(q[~zero])
    low, high = np.where(qn > 0, lower[~zero], upper[~zero]) / qn, np.where(qn > 0, upper[~zero], lower[~zero]) / qn
    if scales is not None:   # the ends low - slope t and high + slope t, and the two constant ones
        low, high, slope = np.append(low, scales[0]), np.append(high, scales[1]), np.append(slope, 0.0)
    gap, rate = low[:, None] - high[None, :], slope[:, None] + slope[None, :]
    meet = np.divide(gap, rate, out=np.full(gap.shape, -np.inf), where=rate > 0)
    t = max(0.0, float(np.max(meet)), float(np.max(np.maximum(lower[zero], -upper[zero]) / half[zero], initial=0.0)))
    s = 0.5 * (np.max(low - t * slope) + np.min(high + t * slope))
    return (t, s) if scale else t


def misses(contract: Admissible, maps: Sequence) -> list[Miss]:
    """Every datum against its admissible interval (the verification's one membership test),
    from the data maps of each configuration (`vibupdate.inverse.data_map.DataMap`)."""
    out = []
    for data, shapes, masses, m in zip(contract.frequencies, contract.shapes, contract.masses, maps):
        for items, values in ((data, m.frequency_values), (masses, m.masses)):
            for d, v in zip(items, values):
                miss = max(d.lower - v, v - d.upper, 0.0) / d.half_width if np.isfinite(v) else np.inf
                inside = bool(np.isfinite(v) and d.measured[0] - FLOOR * abs(d.value) <= v
                              <= d.measured[1] + FLOOR * abs(d.value))
                unit = "kg" if d.kind == "modal_mass" else "rad/s"
                rel = abs(v - d.value) / abs(d.value) if np.isfinite(v) else np.inf
                out.append(Miss(d.label, d.kind, float(miss), inside,
                                f"{d.label}: model {v:.7g} {unit}, measured {d.value:.7g} ({100 * rel:.3g} %), "
                                f"admissible [{d.lower:.7g}, {d.upper:.7g}]", float(rel)))
        by = {s.position: s for s in shapes}
        for measured, ratios, mass in zip(m.shapes, m.ratios, _modal_masses(m, False)):
            if measured.position not in by:
                continue
            shape = by[measured.position]
            q = np.concatenate([[1.0], ratios])
            scales = shape.scales(mass[0])
            miss, s = scaling_miss(q, shape.lower, shape.upper, scale=True, scales=scales)
            floor = FLOOR * shape.scale
            inside = scaling_miss(q, shape.measured_lower - floor, shape.measured_upper + floor, scales=scales) == 0
            near = cluster(m.frequencies.omega_all, shape.mode - 1)
            text = f"{shape.label}: the model shape at its best scale" + (
                "" if near.size == 1 else f" (best combination of the repeated modes {near[0] + 1}-{near[-1] + 1})")
            if miss > 0 and np.isfinite(s):
                v = s * q
                far = np.maximum(shape.lower - v, v - shape.upper) / shape.half_width
                worst = np.argsort(-far)[:3]
                text += " has " + ", ".join(f"{shape.dofs[j]!r} {v[j]:.6g} against [{shape.lower[j]:.6g}, "
                                            f"{shape.upper[j]:.6g}]" for j in worst if far[j] > 0)
            out.append(Miss(shape.label, "shape", float(miss), bool(inside), text))
    return out


def weighted(configurations: Sequence[Configuration], contract: Admissible):
    """The data with each frequency's weight multiplied by ``1 / h^2``, ``h`` its relative
    admissible half-width, the multipliers normalized to mean 1: the first stage weighs each
    residual as the contract does (the same objects when every ``h`` is equal)."""
    factor = 1.0 / np.maximum(contract.relative_half_widths(), WEIGHT_FLOOR) ** 2
    factor = factor / factor.mean() if factor.size else factor
    if np.allclose(factor, 1.0, rtol=1e-12, atol=0.0):   # every h equal, or no frequency at all
        return list(configurations)
    each = iter(factor)   # in the contract's order: per configuration, natural then antiresonances
    return [replace(c, natural=tuple(replace(d, weight=d.weight * next(each)) for d in c.natural),
                    antiresonances=tuple(replace(d, weight=d.weight * next(each)) for d in c.antiresonances))
            for c in configurations]
