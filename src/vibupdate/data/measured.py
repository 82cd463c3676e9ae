"""Measured modal data of one or several configurations of the structure.

Frequencies are stored in rad/s; the ``*_hz`` constructors convert at the edge. Mode shapes
are known only within intervals (paper Section 2.3, Fig. 1): each measured entry has a lower
and an upper bound, an exactly known entry has ``lower == upper``, unmeasured entries get
default bounds in the formulation.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace
from functools import cached_property

import numpy as np

from vibupdate.data.pairing import declare, declared_modes
from vibupdate.model.affine import AffineModel


TWO_PI = 2.0 * math.pi
#: Measured frequencies are mechanical vibration: from a period of about eleven days to a
#: terahertz, Hz. A value outside is taken as a unit or typing error and refused where it is
#: read (its square and the weights built on it would leave double precision).
FREQUENCY_RANGE_HZ = (1e-6, 1e12)


def _positive_finite(value, what: str) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float, np.floating, np.integer)):
        raise ValueError(f"{what} must be a number, got {value!r}")
    value = float(value)
    if not math.isfinite(value) or value <= 0:
        raise ValueError(f"{what} must be positive and finite, got {value!r}")
    return value


def _frequency(value, what: str) -> float:
    """A measured frequency in rad/s: positive, finite and within `FREQUENCY_RANGE_HZ`."""
    value = _positive_finite(value, what)
    lo, hi = FREQUENCY_RANGE_HZ
    if not TWO_PI * lo <= value <= TWO_PI * hi:
        raise ValueError(f"{what} {value / TWO_PI:.6g} Hz ({value:.6g} rad/s) is outside {lo:g} to {hi:g} Hz, "
                         "the range of mechanical vibration: a unit or typing error?")
    return value


def _optional_index(value, what: str) -> int | None:
    if value is None:
        return None
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < 1:
        raise ValueError(f"{what} must be an integer >= 1 (1-based), got {value!r}")
    return int(value)


def _bounds(pair, what: str) -> tuple[float, float]:
    """``pair`` as a finite ``(lower, upper)``, ``lower <= upper``; a ValueError names ``what``."""
    try:
        lo, hi = (float(v) for v in pair)
    except (TypeError, ValueError):
        raise ValueError(f"{what} must be (lower, upper), got {pair!r}") from None
    if not (math.isfinite(lo) and math.isfinite(hi)):
        raise ValueError(f"{what} is not finite: ({lo}, {hi})")
    if lo > hi:
        raise ValueError(f"{what} has lower {lo:g} > upper {hi:g}")
    return lo, hi


def _interval(pair, value, what: str) -> tuple[float, float] | None:
    if pair is None:
        return None
    lo, hi = _bounds(pair, what)
    if not lo <= value <= hi:
        raise ValueError(f"{what} ({lo:.6g}, {hi:.6g}) does not contain its value {value:.6g}")
    return (lo, hi)


@dataclass(frozen=True)
class ShapeInterval:
    """A measured mode shape known within bounds on some named DOFs.

    Attributes
    ----------
    bounds : mapping of DOF name to (lower, upper)
        Interval of each measured entry, in the units of the DOF (m or rad), any common
        scaling (the shape's normalization is free) unless ``mass_normalized``.
    mass_normalized : bool
        The entries are those of the mass-normalized mode (``phi^T M phi = 1``, units
        1/sqrt(kg) times the DOF's unit), up to a common sign; the shape then also measures the
        modal mass at its reference entry (`modal_mass_bounds`; docs/method.md, "Modal masses
        from mass-normalized shapes").
    """

    bounds: Mapping[str, tuple[float, float]]
    mass_normalized: bool = False

    def __post_init__(self):
        clean = {str(dof): _bounds(pair, f"mode-shape interval for {dof!r}")
                 for dof, pair in dict(self.bounds).items()}
        if not clean:
            raise ValueError("a mode-shape interval needs at least one measured DOF")
        object.__setattr__(self, "bounds", clean)
        if not isinstance(self.mass_normalized, (bool, np.bool_)):
            raise ValueError(f"mass_normalized must be true or false, got {self.mass_normalized!r}")
        object.__setattr__(self, "mass_normalized", bool(self.mass_normalized))
        if self.mass_normalized:
            lo, hi = clean[self.reference]
            if lo <= 0 <= hi:
                raise ValueError(f"a mass-normalized shape's largest entry ({self.reference!r}) has the interval "
                                 f"({lo:g}, {hi:g}), which holds zero: its modal mass is not measured")

    @classmethod
    def from_values(cls, values: Mapping[str, float], tolerance) -> "ShapeInterval":
        """Intervals ``value +- tolerance`` around measured entries.

        Parameters
        ----------
        values : mapping of str to float
            The measured entry at each DOF or sensor name, in the DOF's unit (m or rad).
        tolerance : float or mapping of str to float
            The half-width of every interval, or one per name, in the same units; >= 0.

        Returns
        -------
        ShapeInterval
            The intervals, not mass-normalized.

        Raises
        ------
        ValueError
            A tolerance is negative or not finite.
        """
        tol = tolerance if isinstance(tolerance, Mapping) else {d: tolerance for d in values}
        for d, t in tol.items():
            if not math.isfinite(float(t)) or float(t) < 0:
                raise ValueError(f"mode-shape tolerance for {d!r} must be >= 0, got {t!r}")
        return cls({d: (v - tol[d], v + tol[d]) for d, v in values.items()})

    def on_dofs(self, model) -> "ShapeInterval | None":
        """The intervals these imply on ``model``'s DOFs, for a shape given (partly) at sensors.

        This is what the first stage's formulation bounds: its unknowns are DOF entries
        (`vibupdate.model.measurement.dof_box`). The box bounds entries, not the modal mass (it
        may hold zero at its largest entry): it is not marked mass-normalized.

        Parameters
        ----------
        model : AffineModel
            The model whose DOFs and sensors the names refer to.

        Returns
        -------
        ShapeInterval or None
            The intervals themselves, in their order, where every name is a DOF; an outer box
            where sensors give DOFs in combination; None when no DOF is implied.
        """
        from vibupdate.model.measurement import dof_box

        names = list(self.bounds)
        sensors = {s.name for s in model.sensors}
        if all(model.measures(d) and d not in sensors for d in names):   # every name a DOF: its own interval
            return ShapeInterval(dict(self.bounds))
        lower, upper = np.array(list(self.bounds.values()), dtype=float).T
        idx, lo, hi = dof_box(model.measurement(names), lower, upper)
        if not idx.size:
            return None
        return ShapeInterval({model.dofs[i]: (a, b) for i, a, b in zip(idx, lo, hi)})

    @property
    def midpoint(self) -> dict[str, float]:
        """The midpoint of each interval, by name."""
        return {d: 0.5 * (lo + hi) for d, (lo, hi) in self.bounds.items()}

    @cached_property
    def reference(self) -> str:
        """The DOF whose interval midpoint has the largest magnitude.

        It is the entry a measured shape is normalized at (shape ratios
        ``phi_j / phi_reference``). Computed once: the bounds do not change.
        """
        mid = self.midpoint
        return max(mid, key=lambda d: abs(mid[d]))

    def modal_mass_bounds(self) -> tuple[float, float] | None:
        """The interval of the modal mass at the reference entry, for a mass-normalized shape.

        Returns
        -------
        (float, float) or None
            ``1 / phi_p^2`` over the interval of the reference entry ``p``: the mass (kg, or
            kg m^2 at a rotation) of the mode scaled to 1 at ``p``. None when the shape is not
            mass-normalized.
        """
        if not self.mass_normalized:
            return None
        lo, hi = sorted(abs(v) for v in self.bounds[self.reference])
        return (1.0 / hi**2, 1.0 / lo**2)

    def ratio_bounds(self) -> dict[str, tuple[float, float]]:
        """Interval of each ratio ``phi_j / phi_reference`` over the other entries.

        Returns
        -------
        dict of str to (float, float)
            For each name but `reference`, its bounds divided by the reference midpoint
            (dimensionless, lower first).
        """
        ref = self.midpoint[self.reference]
        return {d: (min(lo / ref, hi / ref), max(lo / ref, hi / ref))
                for d, (lo, hi) in self.bounds.items() if d != self.reference}


@dataclass(frozen=True)
class NaturalFrequency:
    """One measured natural frequency (a pole, Eq. 3).

    Attributes
    ----------
    omega : float
        The natural frequency, rad/s.
    weight : float
        User weight multiplying the default weight of its residual (docs/method.md, "Default weights").
    shape : ShapeInterval, optional
        Interval of the mode shape (Problem 1).
    damping_ratio : float, optional
        Measured modal damping ratio (-), for the second stage.
    mode : int, optional
        Which mode of the model this is (1-based, counted from the lowest). When omitted,
        measured frequencies are taken as consecutive modes: the first as mode 1 (or the mode
        after the previous measured one).
    interval : (float, float), optional
        Interval of the frequency, rad/s, at a stated confidence (e.g. from an extraction);
        must contain ``omega``.
    damping_interval : (float, float), optional
        Interval of the damping ratio (-); must contain ``damping_ratio``.
    """

    omega: float
    weight: float = 1.0
    shape: ShapeInterval | None = None
    damping_ratio: float | None = None
    mode: int | None = None
    interval: tuple[float, float] | None = None
    damping_interval: tuple[float, float] | None = None

    def __post_init__(self):
        object.__setattr__(self, "omega", _frequency(self.omega, "natural frequency"))
        object.__setattr__(self, "weight", _positive_finite(self.weight, "natural-frequency weight"))
        if self.damping_ratio is not None:
            xi = self.damping_ratio
            if not isinstance(xi, (int, float, np.floating)) or not math.isfinite(xi) or xi < 0:
                raise ValueError(f"damping ratio must be a finite number >= 0, got {xi!r}")
        object.__setattr__(self, "mode", _optional_index(self.mode, "mode"))
        object.__setattr__(self, "interval", _interval(self.interval, self.omega, "natural-frequency interval"))
        if self.damping_interval is not None and self.damping_ratio is None:
            raise ValueError("a damping-ratio interval needs a damping ratio")
        object.__setattr__(self, "damping_interval",
                           _interval(self.damping_interval, self.damping_ratio, "damping-ratio interval"))

    @classmethod
    def from_hz(cls, freq_hz: float, **kwargs) -> "NaturalFrequency":
        """A measured natural frequency given in Hz.

        Parameters
        ----------
        freq_hz : float
            The frequency, Hz; positive and finite.
        **kwargs
            The other fields (``weight``, ``shape``, ``damping_ratio``, ...).

        Returns
        -------
        NaturalFrequency
            With ``omega = 2 pi freq_hz`` rad/s.
        """
        return cls(TWO_PI * _positive_finite(freq_hz, "natural frequency (Hz)"), **kwargs)

    @property
    def freq_hz(self) -> float:
        """The natural frequency, Hz."""
        return self.omega / TWO_PI


def damped_shift(damping_ratio: float) -> float:
    """``omega_n / omega_d - 1 = 1 / sqrt(1 - zeta^2) - 1``: how much higher a mode's natural
    frequency is than its damped one, for viscous modal damping ``zeta`` in [0, 1) (about
    ``zeta^2 / 2``: 0.18 % at ``zeta = 0.06``)."""
    if not 0 <= damping_ratio < 1:
        raise ValueError(f"a damped frequency needs a damping ratio in [0, 1) to give its natural frequency, "
                         f"got {damping_ratio!r}")
    return 1.0 / math.sqrt(1.0 - damping_ratio**2) - 1.0


def natural_from_damped(frequency: "NaturalFrequency") -> "NaturalFrequency":
    """A measured damped frequency ``omega_d`` made the natural frequency the model computes:
    ``omega_n = omega_d / sqrt(1 - zeta^2)`` with its damping ratio ``zeta`` (a mode of viscous
    modal damping, pole ``-zeta omega_n +- j omega_d``).

    An interval of ``omega_d`` becomes the interval of ``omega_n``: each end converted with the
    damping ratio that moves it farthest (the ends of the ratio's own interval, when it has one).
    The shape, weight and mode stay.
    """
    zeta = frequency.damping_ratio
    if zeta is None:
        raise ValueError(f"the damped frequency {frequency.freq_hz:.6g} Hz has no damping ratio to give its natural "
                         "frequency")
    interval = frequency.interval
    if interval is not None:
        low, high = frequency.damping_interval or (zeta, zeta)
        interval = (interval[0] * (1 + damped_shift(low)), interval[1] * (1 + damped_shift(high)))
    return replace(frequency, omega=frequency.omega * (1 + damped_shift(zeta)), interval=interval)


@dataclass(frozen=True)
class Antiresonance:
    """One measured antiresonance of the receptance ``h_rc`` (Eq. 8).

    Attributes
    ----------
    omega : float
        The antiresonance frequency, rad/s.
    response, excitation : str
        Names of the DOFs ``r`` (response) and ``c`` (force).
    weight : float
        User weight multiplying the default weight of its residual (docs/method.md, "Default
        weights").
    index : int, optional
        Which antiresonance of ``h_rc`` this is (1-based, counted from the lowest zero of the
        model's receptance). When omitted it is assigned from the measured poles around it
        and the nominal model's zeros between them.
    interval : (float, float), optional
        Interval of the frequency, rad/s; must contain ``omega``.
    """

    omega: float
    response: str
    excitation: str
    weight: float = 1.0
    index: int | None = None
    interval: tuple[float, float] | None = None

    def __post_init__(self):
        object.__setattr__(self, "omega", _frequency(self.omega, "antiresonance frequency"))
        object.__setattr__(self, "weight", _positive_finite(self.weight, "antiresonance weight"))
        object.__setattr__(self, "index", _optional_index(self.index, "antiresonance index"))
        object.__setattr__(self, "interval", _interval(self.interval, self.omega, "antiresonance interval"))

    @classmethod
    def from_hz(cls, freq_hz: float, response: str, excitation: str, **kwargs) -> "Antiresonance":
        """A measured antiresonance given in Hz.

        Parameters
        ----------
        freq_hz : float
            The frequency, Hz; positive and finite.
        response, excitation : str
            Names of the DOFs ``r`` (response) and ``c`` (force).
        **kwargs
            The other fields (``weight``, ``index``, ``interval``).

        Returns
        -------
        Antiresonance
            With ``omega = 2 pi freq_hz`` rad/s.
        """
        return cls(TWO_PI * _positive_finite(freq_hz, "antiresonance frequency (Hz)"), response, excitation, **kwargs)

    @property
    def freq_hz(self) -> float:
        """The antiresonance frequency, Hz."""
        return self.omega / TWO_PI

    @property
    def receptance(self) -> tuple[str, str]:
        """The receptance's DOF names ``(response, excitation)``."""
        return (self.response, self.excitation)


@dataclass(frozen=True)
class Configuration:
    """One configuration of the structure: its model and the data measured on it.

    All configurations of an updating problem share the parameter vector.

    Attributes
    ----------
    name : str
        The configuration's name, as reports and ``results.json`` show it.
    model : AffineModel
        The configuration's model; every configuration's model has the same parameters.
    natural : tuple of NaturalFrequency
        Measured natural frequencies, ascending; equal ones are the modes of a repeated
        frequency (`vibupdate.inverse.repeated`). After construction each carries its model
        ``mode`` (`vibupdate.data.pairing`).
    antiresonances : tuple of Antiresonance
        Measured antiresonances, of one or more receptances, any subset of each receptance's
        zeros. After construction each carries its ``index`` (`vibupdate.data.pairing`).
    interlacing : bool
        Derive sign bounds on modal constants from the pole/zero pattern of each receptance
        (Eq. 11, Section 3.6), for pairs of measured poles that are consecutive model modes.
        Asserts that the antiresonances listed are all those of that receptance between
        such poles.
    first_sign : mapping of (response, excitation) to +1 or -1, optional
        Sign of the first modal constant ``u(r) u(c)``; from the nominal model when omitted.
    """

    name: str
    model: AffineModel
    natural: tuple[NaturalFrequency, ...] = ()
    antiresonances: tuple[Antiresonance, ...] = ()
    interlacing: bool = True
    first_sign: Mapping[tuple[str, str], int] = field(default_factory=dict)

    def __post_init__(self):
        object.__setattr__(self, "natural", tuple(self.natural))
        object.__setattr__(self, "antiresonances", tuple(self.antiresonances))
        validate_configuration(self)
        natural, zeros = declare(self)
        object.__setattr__(self, "natural", natural)
        object.__setattr__(self, "antiresonances", zeros)

    def receptances(self) -> list[tuple[str, str]]:
        """The receptances with measured antiresonances.

        Returns
        -------
        list of (str, str)
            Each receptance's ``(response, excitation)`` DOF names, once, in order of
            appearance.
        """
        return list(dict.fromkeys(a.receptance for a in self.antiresonances))


def validate_configuration(cfg: Configuration) -> None:
    """Raise ValueError on data that do not fit the model or contradict each other."""
    where = f"configuration {cfg.name!r}"
    if not isinstance(cfg.model, AffineModel):
        raise ValueError(f"{where}: model must be an AffineModel, got {type(cfg.model).__name__}")
    if not cfg.natural and not cfg.antiresonances:
        raise ValueError(f"{where}: no measured natural frequency or antiresonance")
    omegas = [f.omega for f in cfg.natural]
    if len(omegas) > cfg.model.n_dofs:
        raise ValueError(f"{where}: {len(omegas)} natural frequencies measured, but the model has only "
                         f"{cfg.model.n_dofs} DOFs (modes)")
    if any(b < a for a, b in zip(omegas, omegas[1:])):
        shown = ", ".join(f"{w / TWO_PI:.4g}" for w in omegas)
        raise ValueError(f"{where}: natural frequencies must not fall, got {shown} Hz (equal ones are the "
                         "modes of a repeated frequency)")
    for i, f in enumerate(cfg.natural, start=1):
        if f.shape is not None:
            unknown = [d for d in f.shape.bounds if not cfg.model.measures(d)]
            if unknown:   # the measurement map names DOFs and sensors
                try:
                    cfg.model.measurement(unknown[:1])
                except ValueError as exc:
                    raise ValueError(f"{where}, mode {i}: {exc}") from None
    modes = declared_modes(cfg.natural)
    for rc in cfg.receptances():
        h = f"h_{rc[0]},{rc[1]}"
        for dof in rc:
            if dof not in cfg.model.dofs and cfg.model.measures(dof):
                raise ValueError(f"{where}, antiresonance of {h}: {dof!r} is a sensor (a combination of DOFs); "
                                 "antiresonances are measured between DOFs of the model, shapes at DOFs or sensors")
            try:
                cfg.model.dof(dof)
            except ValueError as exc:
                raise ValueError(f"{where}, antiresonance of {h}: {exc}") from None
        zs = [a.omega for a in cfg.antiresonances if a.receptance == rc]
        clash = [z for z in zs if any(abs(z - w) <= 1e-12 * w for w in omegas)]
        if clash:
            raise ValueError(f"{where}: antiresonance of {h} at {clash[0] / TWO_PI:.6g} Hz equals a natural frequency; "
                             f"a zero cannot sit on a pole (interlacing, Eq. 11). A mode with a node at {rc[0]} or "
                             f"{rc[1]} does not show in {h}: its pole cancels a zero at the same frequency, which is "
                             "no antiresonance of the measured FRF; leave it out")
        if any(b <= a for a, b in zip(zs, zs[1:])):
            raise ValueError(f"{where}: antiresonances of {h} must be strictly ascending")
        if rc[0] == rc[1]:   # a driving point alternates pole, zero, pole: one zero between consecutive modes
            for k in range(len(omegas) - 1):
                inside = [z for z in zs if omegas[k] < z < omegas[k + 1]]
                if modes[k + 1] == modes[k] + 1 and len(inside) > 1:
                    raise ValueError(f"{where}: the driving-point receptance {h} has one antiresonance between "
                                     f"consecutive modes ({omegas[k] / TWO_PI:.4g} and {omegas[k + 1] / TWO_PI:.4g} "
                                     f"Hz), found {len(inside)}")
    for rc, s in dict(cfg.first_sign).items():
        if s not in (1, -1):
            raise ValueError(f"{where}: first_sign of {rc} must be +1 or -1, got {s!r}")
    for k in range(1, len(modes)):
        if modes[k] <= modes[k - 1]:
            raise ValueError(
                f"{where}: measured natural frequency {k + 1} ({cfg.natural[k].freq_hz:.6g} Hz) is declared "
                f"mode {modes[k]}, not above mode {modes[k - 1]} of the lower frequency; modes must rise "
                "with frequency")
    if modes and modes[-1] > cfg.model.n_dofs:
        raise ValueError(f"{where}: mode {modes[-1]} is declared, but the model has only {cfg.model.n_dofs} DOFs")


def validate_configurations(configurations: Sequence[Configuration]) -> None:
    """Check that configurations have unique names and share the same parameters."""
    if not configurations:
        raise ValueError("at least one configuration is needed")
    names = [c.name for c in configurations]
    if len(set(names)) != len(names):
        raise ValueError(f"configuration names must be unique, got {names}")
    ref = configurations[0].model.parameters
    for c in configurations[1:]:
        if c.model.parameters != ref:
            raise ValueError(
                f"configuration {c.name!r} has other parameters than {configurations[0].name!r}: "
                "all configurations share one parameter vector"
            )
