"""Modal extraction from measured FRFs: poles, damping, shapes and antiresonances with intervals.

Vector fitting at several orders, stable poles refined by variable projection
(`vibupdate.data.modal_fit`), residues refit with the poles fixed, antiresonances the real zeros
of the fitted undamped receptance (`vibupdate.data.fitted_zeros`), shapes a rank-one fit of the
modal constants (`_shapes`); intervals ``value +- z * SE`` with the floors below, ``z`` from
`per_interval`. The method, its options and the reasons: docs/frf-extraction.md, "Method".
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np
import scipy.optimize
import scipy.stats

from vibupdate.data.modal_fit import (NEAR_PSEUDO_POLE, best_subset, correlation_inflation, linear_fit, modal_basis,
                                       noise_from_differences, noise_from_repeats, real_stack, refine_poles,
                                       resolvable_poles, split_residual, stabilization_diagram, stable_poles)
from vibupdate.data.noise import residual_variance, variance_components
from vibupdate.data.names import zero_name
from vibupdate.data.window import ORDERS, Window, window_for
from vibupdate.data.fitted_zeros import local_zero, zero_se, zero_snr, zeros_of_all
from vibupdate.data.frf import KINDS, FRFSet
from vibupdate.data.residue_kind import check_fitted_kind


FREQUENCY_FLOOR = 1e-5      # relative half-width floor of frequency and antiresonance intervals
FIT_BAND_FACTOR = 2.0       # default fit band: up to this times the band's top
DAMPING_FLOOR = 0.001       # relative half-width floor of damping-ratio intervals
REPEAT_LINES = 9            # with repeats, the smooth noise component is locally constant over this many lines
SHAPE_FLOOR = 1e-3          # half-width floor of shape entries, relative to the largest entry
MISFIT_QUALITY = 2.0        # notes: an FRF fitted to a worse quality figure misses its data
NARROW_LINES = 4.0          # notes: a mode whose half-power bandwidth spans fewer lines
#: A zero whose signal-to-noise ratio (`vibupdate.data.fitted_zeros.zero_snr`) is under this is left
#: out unless kept (`benchmarks/RESULTS.md`, "Zeros at the noise floor, measured where they are located").
NOISY_ZERO_SNR = 0.1


@dataclass(frozen=True)
class ExtractedMode:
    """One extracted mode.

    Attributes
    ----------
    omega : float
        Undamped natural frequency, rad/s; ``omega_interval`` (lo, hi) rad/s.
    damping_ratio : float
        Modal viscous damping ratio (-); ``damping_interval`` (lo, hi).
    shape, shape_interval : mapping DOF name -> float, -> (lo, hi)
        Real normal mode at the measured DOFs (see ``normalization``).
    normalization : str
        ``"mass"`` (1/sqrt(kg)) or ``"unit-max"``.
    stable_orders : int
        In how many of the stabilization orders the pole recurred.
    """

    omega: float
    omega_interval: tuple
    damping_ratio: float
    damping_interval: tuple
    shape: Mapping
    shape_interval: Mapping
    normalization: str
    stable_orders: int


@dataclass(frozen=True)
class ExtractedZero:
    """One antiresonance of ``h_rc``: ``omega`` and ``interval`` in rad/s; ``index`` 1-based
    from the lowest zero in the band; ``snr`` its local signal-to-noise ratio (`extract`,
    ``keep_noisy_zeros``)."""

    response: str
    excitation: str
    index: int
    omega: float
    interval: tuple
    snr: float = math.nan

    def declared_index(self, first_mode: int | None) -> int | None:
        """The zero's index as a run reads it: the count in the band is the count from the
        lowest zero of the receptance only when the band starts below the model's first mode
        (``first_mode == 1``); None otherwise, and the run assigns it from the nominal model
        (`vibupdate.data.pairing`)."""
        return self.index if first_mode == 1 and self.index else None

    def name(self, first_mode: int | None) -> str:
        """``"zero 4 of h_y1,y1"`` (`vibupdate.data.names.zero_name`), as the run names it."""
        return zero_name(self.response, self.excitation, self.declared_index(first_mode))


@dataclass(frozen=True)
class FRFQuality:
    """Fit quality of one FRF: ``quality = sqrt(chi^2 / n)`` (about 1: within the noise) and
    ``relative_residual`` (RMS residual / RMS of the FRF)."""

    response: str
    excitation: str
    quality: float
    relative_residual: float
    n_repeats: int


@dataclass(frozen=True)
class Extraction:
    """Result of `extract` (all frequencies rad/s).

    Attributes
    ----------
    modes : tuple of ExtractedMode
        The modes in the band, ascending in frequency: natural frequency, damping ratio,
        shape, and their intervals.
    zeros : tuple of ExtractedZero
        The antiresonances in the band, grouped by pair, ascending, with their intervals.
    quality : tuple of FRFQuality
        The fit's quality on each FRF, one per pair.
    band : (float, float)
        The band whose modes and zeros are reported, rad/s.
    confidence : float
        The stated level: with ``joint`` (the default of `extract`), the probability that every
        interval holds its true value; else the level of each.
    noise : str
        ``"repeats"`` or ``"residual"`` (where sigma came from).
    stabilization : tuple of (int, ndarray, ndarray)
        ``(n_pole_pairs, omega, zeta)`` of the physical poles in the band at each order.
    pairs : tuple of (str, str)
        ``(response, excitation)`` DOF names of each fitted FRF, as in the `FRFSet`.
    coefficients : ndarray, shape (n_pairs, n_columns)
        Stage-2 linear coefficients (normalized units), for `synthesize`.
    scales : ndarray, shape (n_pairs,)
        Normalization of each FRF.
    fit_band : (float, float)
        The fitted lines, rad/s (contains ``band``).
    fitted_poles : ndarray, shape (n_fitted, 2)
        Natural frequency (rad/s) and damping ratio of every mode fitted, ascending: the
        reported modes and those fitted outside ``band``.
    window : str
        The data window of the FRF estimate that the fit modelled (`extract`), ``"none"``
        when the FRFs were taken as they are (``"force"``: an impact test's force window,
        declared, not modelled).
    record_s : float
        The record length of that estimate, s (one over the line spacing); 0 without window.
    window_tau : float
        The exponential window's time constant, s (``window="exponential"``); 0 otherwise.
    noisy_zeros : tuple of ExtractedZero
        Zeros whose local signal-to-noise ratio is under `NOISY_ZERO_SNR`, left out of
        ``zeros`` (`extract`, ``keep_noisy_zeros``); their ``index`` still counts them.
    measured : str
        The quantity the FRF files held (`FRFSet.measured`): the one a window smooths.
    line_spacing : float
        Spacing of the fitted lines, rad/s.
    outer_zeros : tuple of ExtractedZero
        Zeros in the band below the lowest or above the highest fitted pole, left out of
        ``zeros`` (`extract`, ``keep_outer_zeros``; `notes` says why).
    cancelled_zeros : tuple of ExtractedZero
        Zeros whose interval holds a fitted pole, left out of ``zeros`` (`notes` says why);
        their ``index`` still counts them.
    level : float
        The level of each interval (`per_interval`): ``confidence`` when not ``joint``.
    """

    modes: tuple
    zeros: tuple
    quality: tuple
    band: tuple
    confidence: float
    noise: str
    stabilization: tuple
    pairs: tuple
    coefficients: np.ndarray
    scales: np.ndarray
    fit_band: tuple
    fitted_poles: np.ndarray
    window: str = "none"
    record_s: float = 0.0
    measured: str = "receptance"
    line_spacing: float = 0.0
    outer_zeros: tuple = ()
    window_tau: float = 0.0
    noisy_zeros: tuple = ()
    cancelled_zeros: tuple = ()
    level: float = math.nan

    def synthesize(self, omega, damped: bool = True) -> np.ndarray:
        """The fitted receptances at some frequencies.

        Parameters
        ----------
        omega : array_like, shape (n_freq,)
            Angular frequencies, rad/s.
        damped : bool
            The receptances as estimated (through the window the fit modelled, if any); else
            the undamped receptance of the fitted modes.

        Returns
        -------
        ndarray of complex, shape (n_pairs, n_freq)
            The fitted receptance of each pair, in the units of the FRFs (m/N).
        """
        x = np.asarray(omega, dtype=float) / self.fit_band[1]
        xn = self.fitted_poles[:, 0] / self.fit_band[1]
        zeta = self.fitted_poles[:, 1]
        decay = 1.0 / (self.window_tau * self.fit_band[1]) if self.window_tau else 0.0
        window = None if self.window in ("none", "force") else Window(
            self.window, self.record_s * self.fit_band[1], ORDERS[self.measured], decay)
        return (modal_basis(x, xn, zeta, damped, window) @ self.coefficients.T).T * self.scales[:, None]

    def notes(self, first_mode: int = 1, modes=None) -> list:
        """What a user should know before using this extraction, as sentences.

        Parameters
        ----------
        first_mode : int
            The number the sentences give the lowest extracted mode (the next ones counted on).
        modes : sequence of int, optional
            The number of each extracted mode instead (modes the test skipped left out).

        Returns
        -------
        list of str
            FRFs fitted worse than `MISFIT_QUALITY`, zeros left out, the damping an exponential
            window adds and, with no window modelled, modes narrower than `NARROW_LINES` lines;
            empty when there is nothing to say.
        """
        number = list(modes) if modes is not None else [first_mode + k for k in range(len(self.modes))]
        out = []
        misfit = [q for q in self.quality if q.quality > MISFIT_QUALITY]
        if misfit:
            out.append(f"{len(misfit)} of {len(self.quality)} FRF(s) have quality above {MISFIT_QUALITY:g}: the modal "
                       f"model misses them by more than their line-to-line noise (often at the peaks: leakage, a "
                       f"nonlinearity, a mode not fitted); the intervals count that misfit as noise")
        narrow = [(number[k], 2 * m.damping_ratio * m.omega / self.line_spacing) for k, m in enumerate(self.modes)
                  if 2 * m.damping_ratio * m.omega < NARROW_LINES * self.line_spacing]
        if self.outer_zeros:
            listed = _zeros_text(self.outer_zeros)
            poles = self.fitted_poles[:, 0] / (2 * math.pi)
            out.append(f"{len(self.outer_zeros)} antiresonance(s) outside the fitted poles ({poles.min():.5g}-"
                       f"{poles.max():.5g} Hz) left out: {listed}; the residual terms that stand for modes outside "
                       f"the fitted lines place them only loosely (keep them with keep_outer_zeros, or widen the "
                       f"fit band to the next mode)")
        if self.window == "exponential":
            added = ", ".join(f"mode {number[k]}: {100 / (self.window_tau * m.omega):.3g} %"
                              for k, m in enumerate(self.modes))
            out.append(f"exponential window of tau = {self.window_tau:.4g} s on the response modelled: it adds "
                       f"1/(tau w_n) to each damping ratio ({added}), which the ratios reported do not hold")
        if self.noisy_zeros:
            listed = _zeros_text(self.noisy_zeros, snr=True)
            out.append(f"{len(self.noisy_zeros)} antiresonance(s) at the noise floor left out: {listed}; the fit's "
                       f"|H| around them is under {NOISY_ZERO_SNR:g} of the noise, where noise makes zeros as well "
                       f"(keep them with keep_noisy_zeros)")
        if self.cancelled_zeros:
            listed = _zeros_text(self.cancelled_zeros)
            out.append(f"{len(self.cancelled_zeros)} antiresonance(s) on a fitted pole left out: {listed}; each "
                       f"interval holds the pole, so the data cannot tell the zero from it (a mode with a node at "
                       f"the response or the excitation shows as a pole and a zero that cancel)")
        if narrow and self.window == "none":
            listed = ", ".join(f"mode {k}: {lines:.1f}" for k, lines in narrow)
            out.append(f"half-power bandwidths of fewer than {NARROW_LINES:g} lines ({listed}): such damping ratios "
                       f"depend on the window of the spectral estimate (a Hann-windowed H1 reads them high, on known "
                       f"truth by 55, 13 and 5 % at 1.3, 2.4 and 3.7 lines) and their intervals do not hold that "
                       f"bias; the estimate's window, when named, is modelled (window)")
        return out

    @property
    def mass_normalized(self) -> bool:
        """Whether every extracted shape is mass-normalized (a driving point was measured)."""
        return bool(self.modes) and all(m.normalization == "mass" for m in self.modes)

    def to_measured(self, first_mode: int | None = None, weight: float = 1.0, mass_normalized: bool = False):
        """Measured data for a `Configuration`.

        Parameters
        ----------
        first_mode : int, optional
            The model mode number of the lowest extracted mode; each natural frequency's
            ``mode`` is set from it, each antiresonance's ``index`` as
            `ExtractedZero.declared_index` says.
        weight : float
            The user weight of every datum (`NaturalFrequency`, `Antiresonance`).
        mass_normalized : bool
            Take the shapes as mass-normalized (`ShapeInterval`), for FRFs calibrated in SI
            units.

        Returns
        -------
        naturals : list of NaturalFrequency
            With their intervals, damping ratios and their intervals, and a `ShapeInterval`
            from the shape intervals.
        antiresonances : list of Antiresonance
            With their intervals.

        Raises
        ------
        ValueError
            ``mass_normalized`` is asked for shapes that are not (no driving point).
        """
        from vibupdate.data.measured import Antiresonance, NaturalFrequency, ShapeInterval

        if mass_normalized and not self.mass_normalized:
            raise ValueError("the extracted shapes are not mass-normalized: that needs a driving-point FRF")
        naturals = [NaturalFrequency(m.omega, weight=weight, damping_ratio=m.damping_ratio,
                                     interval=m.omega_interval, damping_interval=m.damping_interval,
                                     shape=ShapeInterval(m.shape_interval, mass_normalized) if m.shape_interval
                                     else None,
                                     mode=None if first_mode is None else first_mode + k)
                    for k, m in enumerate(self.modes)]
        zeros = [Antiresonance(z.omega, z.response, z.excitation, weight=weight, interval=z.interval,
                               index=z.declared_index(first_mode)) for z in self.zeros]
        return naturals, zeros


# ----------------------------------------------------------------------------- stage 2: shapes

def _shapes(pairs, constants, se, n_modes):
    """Rank-one fit phi_a phi_b = m_ab per mode; returns (shapes, ses, normalization) per mode."""
    dofs = list(dict.fromkeys(d for pair in pairs for d in pair))
    index = {d: i for i, d in enumerate(dofs)}
    responses = list(dict.fromkeys(r for r, _ in pairs))
    drive = [k for k, (r, c) in enumerate(pairs) if r == c]
    k0 = drive[0] if drive else 0
    exc = pairs[k0][1]
    out = []
    for r in range(n_modes):
        # fitted in units of the mode's largest constant, so that the fit holds at any scale of
        # the data (the constants are |H| omega^2)
        unit = float(np.max(np.abs(constants[:, r]))) or 1.0
        m, s = constants[:, r] / unit, np.maximum(se[:, r] / unit, 1e-300)
        if drive:
            root = math.sqrt(abs(m[k0])) or 1.0
            init = np.zeros(len(dofs))
            init[index[exc]] = root * (1.0 if m[k0] >= 0 else -1.0)
            for k, (a, c) in enumerate(pairs):
                if c == exc and a != exc:
                    init[index[a]] = m[k] / root

            def resid(phi):
                return np.array([(phi[index[a]] * phi[index[c]] - m[k]) / s[k] for k, (a, c) in enumerate(pairs)])

            sol = scipy.optimize.least_squares(resid, init, method="lm" if len(pairs) >= len(dofs) else "trf")
            chi2 = float(sol.fun @ sol.fun) / (len(pairs) - len(dofs)) if len(pairs) > len(dofs) else 1.0
            cov = np.linalg.pinv(sol.jac.T @ sol.jac) * max(1.0, chi2)
            phi = sol.x * (1.0 if np.sum(sol.x) >= 0 else -1.0) * math.sqrt(unit)
            ses = np.sqrt(np.abs(np.diag(cov)) * unit)
            shape = {d: float(phi[index[d]]) for d in dofs if d in responses or d == exc}
            out.append((shape, {d: float(ses[index[d]]) for d in shape}, "mass"))
        else:
            col = [k for k, (_, c) in enumerate(pairs) if c == exc]
            top = max(abs(m[k]) for k in col) or 1.0
            sign = 1.0 if sum(m[k] for k in col) >= 0 else -1.0
            shape = {pairs[k][0]: float(sign * m[k] / top) for k in col}
            out.append((shape, {pairs[k][0]: float(s[k] / top) for k in col}, "unit-max"))
    return out


# ----------------------------------------------------------------------------- front end

def extract(frfs: FRFSet, band: tuple | None = None, n_modes: int | None = None,
            orders: Sequence[int] | None = None, min_stable: int = 3, max_damping: float = 0.1,
            confidence: float = 0.95, fit_band: tuple | None = None, local_zeros: bool = True,
            window: str | None = None, keep_outer_zeros: bool = False, window_decay: float | None = None,
            window_tau: float | None = None, keep_noisy_zeros: bool = False, joint: bool = True) -> Extraction:
    """Natural frequencies, damping ratios, shapes and antiresonances from measured FRFs.

    Parameters
    ----------
    frfs : FRFSet
        Receptances (repeats are averaged; their scatter is the noise estimate).
    band : (float, float), optional
        The band, rad/s, whose modes and antiresonances are reported. Default the whole
        frequency axis.
    n_modes : int, optional
        Report this many of the stable modes in ``band`` (those whose model fits best);
        default all.
    orders : sequence of int, optional
        Numbers of pole pairs of the stabilization check (default 2..10; raise it when the
        fit band holds more than about eight modes).
    min_stable : int
        Orders in which a pole must recur to count as a mode.
    max_damping : float
        Poles with a larger damping ratio are not modes (they are computational).
    confidence : float
        Level of the intervals, in (0, 1): with ``joint``, the probability that all of them
        hold their true values at once.
    fit_band : (float, float), optional
        The fitted lines' band, rad/s, containing ``band``. Every stable mode in it is
        fitted as a mode (with its own residues), but only those in ``band`` are reported.
        Default: from ``band``'s bottom to ``FIT_BAND_FACTOR`` (2) times its top, within the
        data (why: docs/frf-extraction.md, "Method", step 0).
    local_zeros : bool
        Refine each antiresonance on the lines around it (`local_zero`); default true.
    window : {None, "none", "hann", "rectangular", "exponential", "force"}
        The data window of the FRF estimate, whose leakage (or, ``"exponential"``, added
        damping: needs ``window_decay`` or ``window_tau``) the fit models; ``"force"`` needs no
        model; default None, the FRFs fitted as they are (docs/frf-extraction.md, "Input").
    keep_outer_zeros : bool
        Report the antiresonances below the lowest or above the highest fitted pole with the
        others; by default they are left out (`Extraction.outer_zeros`) and said in the notes.
    window_decay : float, optional
        The exponential window's value at the end of the record, in (0, 1).
    window_tau : float, optional
        The exponential window's time constant, s (instead of ``window_decay``).
    keep_noisy_zeros : bool
        Report the antiresonances whose local signal-to-noise ratio is under `NOISY_ZERO_SNR`
        with the others; by default they are left out (`Extraction.noisy_zeros`) and said in
        the notes.
    joint : bool
        State ``confidence`` for all the intervals together (default; each at the level
        `per_interval` gives for their number), as a run's verification reads them; False: each
        interval at ``confidence``.

    Returns
    -------
    Extraction
        The modes and antiresonances in ``band`` with their intervals at ``confidence``, the
        fit's quality per FRF and the record of the fit (`Extraction.notes` says what a user
        should know before using it).

    Raises
    ------
    ValueError
        An option is out of range (a band not ``0 < low < high``, a ``fit_band`` that does
        not contain ``band``, the window's values missing or contradictory), an FRF is zero
        over the band, or no stable mode (or fewer than ``n_modes``) is found in the band.
    """
    from threadpoolctl import threadpool_limits

    # many small least-squares problems: a multithreaded BLAS spends its time waking threads
    # (`benchmarks/RESULTS.md`, "Shrinking data, modal, damping, model and examples")
    with threadpool_limits(limits=1, user_api="blas"):
        return _extract(frfs, band, n_modes, orders, min_stable, max_damping, confidence, fit_band, local_zeros,
                        window, keep_outer_zeros, _decay_rate(window, window_decay, window_tau, frfs.omega),
                        keep_noisy_zeros, joint)


def _decay_rate(window, decay, tau, omega) -> float:
    """The exponential window's rate ``1 / tau`` (1/s) from its end value ``decay`` over the
    record (one over the line spacing) or its ``tau``; 0 for the other windows. A ValueError
    names a missing, contradictory or out-of-range value."""
    if window != "exponential":
        if decay is not None or tau is not None:
            raise ValueError(f"window_decay / window_tau describe an exponential window, but window = {window!r}")
        return 0.0
    if (decay is None) == (tau is None):
        raise ValueError("window 'exponential' needs its decay: window_decay (the window's value at the end of the "
                         f"record, in (0, 1)) or window_tau (its time constant, s), one of them; got {decay!r} and "
                         f"{tau!r}")
    if tau is not None:
        if not float(tau) > 0:
            raise ValueError(f"window_tau must be a positive time constant (s), got {tau!r}")
        return 1.0 / float(tau)
    if not 0 < float(decay) < 1:
        raise ValueError(f"window_decay is the window's value at the end of the record, in (0, 1), got {decay!r}")
    record = 2 * math.pi / float(np.median(np.diff(omega)))
    return -math.log(float(decay)) / record


def _extract(frfs, band, n_modes, orders, min_stable, max_damping, confidence, fit_band, local_zeros,
             window_name, keep_outer_zeros=False, decay_rate=0.0, keep_noisy_zeros=False, joint=True) -> Extraction:
    if not 0 < confidence < 1:
        raise ValueError(f"confidence must be in (0, 1), got {confidence!r}")
    if n_modes is not None and (isinstance(n_modes, bool) or not isinstance(n_modes, int) or n_modes < 1):
        raise ValueError(f"n_modes must be an integer >= 1 (how many modes to keep), got {n_modes!r}")
    report = _check_band(band, "band") if band is not None else (float(frfs.omega[0]), float(frfs.omega[-1]))
    if fit_band is None:
        fit = (report[0], max(min(FIT_BAND_FACTOR * report[1], float(frfs.omega[-1])), report[1]))
    else:
        fit = _check_band(fit_band, "fit_band")
        if fit[0] > report[0] or fit[1] < report[1]:
            raise ValueError(f"fit_band {fit[0] / 2 / math.pi:.6g}-{fit[1] / 2 / math.pi:.6g} Hz must contain the "
                             f"band {report[0] / 2 / math.pi:.6g}-{report[1] / 2 / math.pi:.6g} Hz")
    frfs.band(*report)  # the report band must hold data (a clear error otherwise)
    frfs = frfs.band(*fit)
    omega = frfs.omega
    scale_w = omega[-1]
    x = omega / scale_w
    inside = (omega >= report[0]) & (omega <= report[1])
    window = window_for(window_name, x, frfs.measured, decay_rate / scale_w)
    x_report = (float(x[inside][0]), float(x[inside][-1]))
    Hbar = frfs.mean()
    top = np.max(np.abs(Hbar[:, inside]), axis=1)
    with np.errstate(invalid="ignore", divide="ignore"):   # a zero or infinite FRF is named below
        scales = top * np.sqrt(np.mean(np.abs(Hbar[:, inside] / top[:, None]) ** 2, axis=1))
    flat = [f"h({r},{c})" for (r, c), scale in zip(frfs.pairs, scales) if not (np.isfinite(scale) and scale > 0)]
    if flat:
        raise ValueError(f"{', '.join(flat)}: zero (or not a finite number) at every line of the band "
                         f"{report[0] / 2 / math.pi:.6g}-{report[1] / 2 / math.pi:.6g} Hz; expected a measured FRF "
                         "(is it the right column or file?)")
    _check_range(frfs.pairs, scales, scale_w)
    F = Hbar / scales[:, None]
    orders = list(orders) if orders is not None else list(range(2, 11))
    if len(orders) < min_stable:
        raise ValueError(f"{len(orders)} model orders given, fewer than min_stable = {min_stable}")
    var = noise_from_repeats(frfs.H)
    groups = [c for _, c in frfs.pairs]  # the proportional noise comes with the force: shared per excitation
    noise = "repeats" if var is not None else "residual"
    if var is not None:  # floored: identical repeats (noise-free data) would give infinite weights
        tiny = 1e-12 * np.mean(np.abs(F) ** 2, axis=1, keepdims=True)
        var = variance_components(np.maximum(var / scales[:, None] ** 2, tiny), np.abs(F) ** 2, groups,
                                   REPEAT_LINES)[0]
    line_var = noise_from_differences(F) if var is None else var
    stab = stabilization_diagram(x, F, orders, max_damping, 1.0 / np.sqrt(line_var))
    wn, zeta, counts = stable_poles(stab, min_stable)
    estimated = {}

    def noise_at(wn, zeta):   # the residual's noise, estimated once at each set of poles
        key = (wn.tobytes(), zeta.tobytes())
        if key not in estimated:
            estimated[key] = residual_variance(x, F, wn, zeta, groups, window=window)
        return estimated[key]

    if wn.size:
        var = var if var is not None else noise_at(wn, zeta)
        wn, zeta, counts, peak = resolvable_poles(x, F, wn, zeta, counts, var, window=window)
    in_band = (wn >= x_report[0]) & (wn <= x_report[1])
    if not np.any(in_band):
        raise ValueError(f"no stable mode found in the band {report[0] / 2 / math.pi:.6g}-"
                         f"{report[1] / 2 / math.pi:.6g} Hz (orders {orders}, min_stable {min_stable}; fitted "
                         f"{omega[0] / 2 / math.pi:.6g}-{omega[-1] / 2 / math.pi:.6g} Hz)")
    if n_modes is not None:
        if n_modes > int(in_band.sum()):
            raise ValueError(f"n_modes = {n_modes} but only {int(in_band.sum())} stable mode(s) were found in the band")
        keep = np.sort(np.r_[_choose_modes(x, F, wn, zeta, peak, in_band, n_modes, window), np.nonzero(~in_band)[0]])
        wn, zeta, counts, in_band = wn[keep], zeta[keep], [counts[k] for k in keep], in_band[keep]

    if noise == "repeats":
        wn, zeta, cov_poles = refine_poles(x, F, wn, zeta, var, weighted=True, window=window)
    else:  # feasible weighted least squares: noise from the residual, refit, once more
        for _ in range(2):   # at the poles the significance test kept, its estimate again (not recomputed)
            var = noise_at(wn, zeta)
            wn, zeta, cov_poles = refine_poles(x, F, wn, zeta, var, weighted=True, window=window)
        var = noise_at(wn, zeta)
    order = np.argsort(wn)
    wn, zeta, counts, in_band = wn[order], zeta[order], [counts[k] for k in order], in_band[order]
    cov_poles = cov_poles[np.ix_(np.r_[order, order + wn.size], np.r_[order, order + wn.size])]
    fitted = _Fitted(x, F, var, scales, wn, zeta, cov_poles, in_band, inside, x_report, scale_w, window)
    result = _stage_two(frfs, fitted, counts, stab, noise, confidence, local_zeros, keep_outer_zeros,
                        keep_noisy_zeros, joint)
    check_fitted_kind(result, KINDS, frfs.sources)   # a kind one order off turns every constant by 90 degrees
    if window_name == "force":
        result = dataclasses.replace(result, window="force")
    return dataclasses.replace(result, window_tau=1.0 / decay_rate) if decay_rate else result


def _check_band(band, name):
    lo, hi = (float(b) for b in band)
    if not 0 < lo < hi:
        raise ValueError(f"{name} must be 0 < low < high (rad/s), got ({lo!r}, {hi!r})")
    return lo, hi


def _choose_modes(x, F, wn, zeta, peak, in_band, n_modes, window=None):
    """Indices of the ``n_modes`` poles in the band whose model fits best, the poles outside it
    always fitted; one pole per split peak (two within 2 %) when enough single peaks remain."""
    cand, fixed = np.nonzero(in_band)[0], np.nonzero(~in_band)[0]
    keep = cand[best_subset(x, F, wn, zeta, peak, n_modes, cand, fixed, window=window)]
    if np.any(np.diff(wn[keep]) < 0.02 * wn[keep][1:]):  # a split peak: one pole per peak
        single = np.array([k for k in cand if not np.any((np.abs(wn[cand] - wn[k]) < 0.02 * wn[k])
                                                         & (peak[cand] > peak[k]))], dtype=int)
        if single.size >= n_modes:
            keep = single[best_subset(x, F, wn, zeta, peak, n_modes, single, fixed, window=window)]
    return keep


@dataclass(frozen=True)
class _Fitted:
    """The stage-1 model handed to stage 2 (normalized units: ``x = omega / scale_w``)."""

    x: np.ndarray           # (n_freq,) fitted lines
    F: np.ndarray           # (n_pairs, n_freq) FRFs over their RMS in the band
    var: np.ndarray         # (n_pairs, n_freq) noise variance per line
    scales: np.ndarray      # (n_pairs,)
    wn: np.ndarray          # (n,) every fitted mode
    zeta: np.ndarray        # (n,)
    cov_poles: np.ndarray   # (2n, 2n) of (wn, zeta)
    in_band: np.ndarray     # (n,) bool: reported
    inside: np.ndarray      # (n_freq,) bool: line in the band
    x_band: tuple           # the band, normalized
    scale_w: float
    window: object = None   # vibupdate.data.window.Window of the estimate, or None


def _zeros_text(zeros, snr: bool = False) -> str:
    """Zeros left out, named for a note: ``h_r,c`` and the frequency (Hz), with ``snr`` their
    signal-to-noise ratio."""
    return ", ".join(f"h_{z.response},{z.excitation} {z.omega / (2 * math.pi):.5g} Hz"
                     + (f" (SNR {z.snr:.2g})" if snr else "") for z in zeros)


def _located_zeros(estimates, fit, zq, keep_outer=False, keep_noisy=False):
    """`ExtractedZero` of every FRF from its estimates (`_stage_two`) with half-widths
    ``zq`` standard errors: reported, outer, noisy and cancelled (`Extraction`), each ``index``
    counting them all."""
    zeros, outer, noisy, cancelled = [], [], [], []
    lowest, highest = float(np.min(fit.wn)), float(np.max(fit.wn))
    for pair, zs, ses, snrs in estimates:
        located = []
        for z, se, snr in zip(zs, ses, snrs):
            half = max(zq * se, FREQUENCY_FLOOR * z)
            if z - half < fit.x_band[0] or z + half > fit.x_band[1]:
                continue  # not located within the band (a residual-term artefact near an edge)
            located.append((z, half, snr))
        for index, (z, half, snr) in enumerate(sorted(located), start=1):   # a local refit can pass its neighbour
            found_zero = ExtractedZero(pair[0], pair[1], index, float(z * fit.scale_w),
                                       (float((z - half) * fit.scale_w), float((z + half) * fit.scale_w)), snr)
            if np.any(np.abs(fit.wn - z) <= half):
                cancelled.append(found_zero)
            elif not keep_outer and not lowest <= z <= highest:
                outer.append(found_zero)
            elif not keep_noisy and snr < NOISY_ZERO_SNR:
                noisy.append(found_zero)
            else:
                zeros.append(found_zero)
    return zeros, outer, noisy, cancelled


def per_interval(confidence: float, count: int, joint: bool) -> float:
    """The level of each of ``count`` intervals: ``confidence`` itself, or with ``joint`` the
    level at which all of them hold their true values with probability at least
    ``confidence``, ``confidence ** (1 / count)`` (Sidak: exact for independent errors, and a
    lower bound for jointly normal errors whatever their correlation)."""
    return confidence ** (1.0 / max(count, 1)) if joint else confidence


def _check_range(pairs, scales, scale_w: float) -> None:
    """The modal constants are of the order of |H| omega^2 (omega in rad/s, up to ``scale_w``):
    a ValueError naming the FRF when that product, or omega^2, is beyond the range of floating
    point (frequencies or FRF values many orders of magnitude off their units)."""
    low, high = math.log(np.finfo(float).tiny), math.log(np.finfo(float).max)
    square = 2.0 * math.log(scale_w)
    for (r, c), scale in zip(pairs, scales):
        if not (low < square < high and low < math.log(scale) + square < high):
            power = (math.log(scale) + square) / math.log(10.0)
            raise ValueError(f"h({r},{c}): frequencies up to {scale_w / 2 / math.pi:.6g} Hz and values of about "
                             f"{scale:.3g}: its modal constants (|H| times the angular frequency squared, about "
                             f"1e{power:+.0f}; angular frequency squared about 1e{square / math.log(10.0):+.0f}) are "
                             "beyond the range of floating point; expected frequencies in Hz and the FRF in SI units")


def _stage_two(frfs, fit, counts, stab, noise, confidence, local_refit, keep_outer_zeros=False,
               keep_noisy_zeros=False, joint=True):
    x, F, var, scales, wn, zeta, scale_w = fit.x, fit.F, fit.var, fit.scales, fit.wn, fit.zeta, fit.scale_w
    n = wn.size
    Phi = modal_basis(x, wn, zeta, window=fit.window)
    Phi_near = modal_basis(x, wn, zeta, window=fit.window, pseudo=NEAR_PSEUDO_POLE)
    coefs, covs, nears, quality, constants, const_se = [], [], [], [], [], []
    # the quality figure's noise: the repeats' scatter, or without repeats the model-free
    # second-difference estimate (the residual's own would make the figure about 1, or below)
    reference = var if noise == "repeats" else noise_from_differences(F)
    wd = wn * np.sqrt(1 - zeta**2)
    for k, (pair, f, v) in enumerate(zip(frfs.pairs, F, var)):
        w = 1.0 / np.sqrt(v)
        coef, res = linear_fit(Phi, f, w)
        A = real_stack(Phi, w)
        # weighted residual components have variance 1/2 (complex noise of variance sigma^2)
        chi2 = 2.0 * float(res @ res) / max(res.size - coef.size, 1)
        tau = correlation_inflation(split_residual(res, (1, x.size)))
        cov = np.linalg.pinv(A.T @ A) * 0.5 * max(1.0, chi2) * tau
        coefs.append(coef)
        covs.append(cov)
        nears.append(linear_fit(Phi_near, f, w)[0])
        miss = np.abs(f - Phi @ coef)[fit.inside] ** 2
        quality.append(FRFQuality(pair[0], pair[1], math.sqrt(float(np.mean(miss / reference[k][fit.inside]))),
                                  float(np.sqrt(np.mean(miss) / np.mean(np.abs(f[fit.inside]) ** 2))),
                                  int(frfs.H[k].shape[0])))
        constants.append(-2.0 * wd * coef[1:2 * n:2] * scales[k] * scale_w**2)       # Re(2 j w_d A)
        const_se.append(2.0 * wd * np.sqrt(np.abs(np.diag(cov)[1:2 * n:2])) * scales[k] * scale_w**2)
    # the FRFs share the poles: their zeros are searched together, one grid for all. Each zero's error adds its
    # shift to first order (-u_near(z) / u'(z)) on the fit with the pseudo-mode at NEAR_PSEUDO_POLE; the zero
    # refined on the lines around it (local_zero) replaces it where its error is the smaller (docs/frf-extraction.md,
    # "Method", step 4 and "Noise and intervals"). Per FRF: (pair, zeros, ses, snrs)
    estimates = []
    for pair, f, v, coef, cov, noise_var, near, fitted in zip(frfs.pairs, F, var, coefs, covs, reference, nears,
                                                              zeros_of_all(x[fit.inside], np.array(coefs), wn, zeta)):
        near_values = modal_basis(np.asarray(fitted, dtype=float), wn, zeta, False, pseudo=NEAR_PSEUDO_POLE) @ near
        zs, ses = [], []
        for z, near_value in zip(fitted, near_values):
            se, slope = zero_se(z, coef, cov, wn, zeta, fit.cov_poles)
            se = math.hypot(se, float(near_value) / slope)
            local = local_zero(z, x, f, v, Phi, coef, wn, zeta, fit.cov_poles) if local_refit else None
            if local is not None and local[1] < se:
                z, se = local
            zs.append(z)
            ses.append(se)
        damped = Phi @ coef
        estimates.append((pair, zs, ses, [zero_snr(z, x, damped, noise_var, wn) for z in zs]))
    reported = np.nonzero(fit.in_band)[0]
    shapes = _shapes(frfs.pairs, np.array(constants)[:, reported], np.array(const_se)[:, reported], reported.size)
    # the intervals reported: a frequency and a damping ratio per mode, its shape entries, the zeros (counted
    # at the stated level: a zero the wider interval then leaves out still counts, so the level holds)
    count = 0 if not joint else 2 * reported.size + sum(len(shape) for shape, _, _ in shapes) + len(
        _located_zeros(estimates, fit, _quantile(confidence), keep_outer_zeros, keep_noisy_zeros)[0])
    level = per_interval(confidence, count, joint)
    zq = _quantile(level)
    zeros, outer, noisy, cancelled = _located_zeros(estimates, fit, zq, keep_outer_zeros, keep_noisy_zeros)
    modes = []
    se_pole = np.sqrt(np.abs(np.diag(fit.cov_poles)))
    for r, shape_fit in zip(reported, shapes):
        hw = max(zq * se_pole[r], FREQUENCY_FLOOR * wn[r]) * scale_w
        hz = max(zq * se_pole[n + r], DAMPING_FLOOR * zeta[r])
        shape, sd, norm = shape_fit
        top = max(abs(v) for v in shape.values()) or 1.0
        bounds = {d: (v - max(zq * sd[d], SHAPE_FLOOR * top), v + max(zq * sd[d], SHAPE_FLOOR * top))
                  for d, v in shape.items()}
        modes.append(ExtractedMode(float(wn[r] * scale_w), (float(wn[r] * scale_w - hw), float(wn[r] * scale_w + hw)),
                                   float(zeta[r]), (float(max(zeta[r] - hz, 0.0)), float(zeta[r] + hz)),
                                   shape, bounds, norm, int(counts[r])))
    stabilization = tuple((o, w * scale_w, z) for o, w, z in stab)
    band = (float(frfs.omega[fit.inside][0]), float(frfs.omega[fit.inside][-1]))
    return Extraction(tuple(modes), tuple(zeros), tuple(quality), band, float(confidence), noise, stabilization,
                      frfs.pairs, np.array(coefs), np.asarray(scales), (float(frfs.omega[0]), float(frfs.omega[-1])),
                      np.column_stack([wn * scale_w, zeta]), "none" if fit.window is None else fit.window.name,
                      0.0 if fit.window is None else fit.window.record / scale_w, frfs.measured,
                      float(np.median(np.diff(x))) * scale_w, tuple(outer), noisy_zeros=tuple(noisy),
                      cancelled_zeros=tuple(cancelled), level=level)


def _quantile(level: float) -> float:
    """Half-width of a two-sided normal interval at ``level``, in standard errors."""
    return float(scipy.stats.norm.ppf(0.5 + level / 2))
