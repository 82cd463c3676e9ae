"""Verification: is the returned model the one the data describe?

A solver that reaches ``lam = 1`` has found a point where its objective is small; that does
not make the model right. Before an answer is called a success the returned model is checked
against the data it was given:

``mode_order``
    every measured natural frequency is nearest to its declared model mode, or to a mode that
    repeats its frequency (no mode of the model skipped or inserted below the highest measured
    one);
``zero_order``
    every measured antiresonance is nearest to its declared zero of its receptance, and the
    model has that zero;
``mac``
    where a shape was measured, its MAC with the declared mode is at least ``mac_min`` and
    no other model mode matches it better;
``shape_intervals``
    the model's shape ratios ``phi_j / phi_p`` lie in the measured intervals, widened by
    ``shape_slack`` half-widths (a model that fits the frequencies with a shape outside its
    interval has not used the data), by the model-form tolerance ``shape_tolerance`` and by
    what the model's pencil can resolve: `ROUNDING_SAFETY` times the largest change of the
    measured modes' ratios under one unit of rounding in every entry of ``K`` and ``M``
    (`vibupdate.modal.refinement.shape_ratio_floor`, the largest over the configuration's
    measured modes), computed only where a ratio
    lies outside the widened interval. It matters for point data (intervals of zero width): on
    the frame refined to 2,996 DOFs the estimate is 4e-10 to 1.1e-8 per mode, and the polished
    answer misses its point data by up to 1.5e-9, above the fixed 1e-9 that was allowed
    before; on the 2,940-DOF building frame it is 1.5e-12. A model whose matrices were written
    with fewer digits (``matrix_precision``) allows each mode besides what those digits do to
    its own ratios (`mode_rounding_allowance`: the entries rounded once more to the digits):
    the exact point shapes of a free-free frame missed its 10-digit model by 2.9e-9, where
    double precision allowed 1.4e-11; taken over every mode, as at double precision, the
    allowance of the worst-conditioned mode (2.4e-6) let noisy frequencies with point shapes
    verify, with a linearized range that missed the truth (a nonaffine problem of the explorer). A
    mode of a repeated frequency is checked as its eigenspace (`vibupdate.inverse.repeated`):
    the MAC and the ratios are those of the best combination of the modes that share the
    frequency, and the rounding allowance that of the eigenspace;
``modal_mass``
    where a shape was measured mass-normalized, the model's modal mass at its reference entry
    (``1 / phi_p^2``) lies in the measured interval widened by the model-form tolerance
    ``modal_mass_tolerance`` (relative, default 5 %) and by `FIT_FLOOR`;
``fit``
    every measured frequency is matched by its declared mode or zero within its measurement
    interval (its own, else ``measurement_tolerance``, else the value) widened by the
    model-form tolerance of its kind (``natural_tolerance``, ``antiresonance_tolerance``,
    relative; default 2 %: on the paper's cantilever the verified update misses no frequency
    by more than 1.63 %) and by `FIT_FLOOR`;
``correspondence``
    when the first-stage answer fitted the data under another pairing (a mode skipped), the
    final answer's mean natural-frequency error under the declared pairing must stay within
    twice that other fit's error plus a tenth of the natural frequencies' tolerance
    (measurement plus model-form: 0.2 % by default);
    otherwise the declared modes are likely wrong and the user is told which pairing fits;
``improvement``
    the updated mean frequency error is not above the nominal one;
``consistency``
    the optimum of the convex relaxation (a lower bound of the best objective inside the
    boxes) is within what the frequency tolerance explains, ``n_blocks (2 tol)^2`` (each
    block's weighted residual approximates a relative eigenvalue error, twice the relative
    frequency error). Above that, no parameter set inside the boxes fits the data: the data
    contradict the bounds, and the active bounds of the relaxed solution are named;
``bounds`` (warning only)
    parameters on a bound of their box.

A failed error check makes the status ``not_verified``; warnings are reported either way.
The ``fit`` and ``shape_intervals`` checks say what limited a passed answer (`Check.limited_by`):
the measurements, when every datum lies in its measurement interval, or the model's form, when
some lie outside it and within the model-form tolerance. The fit objective weighs each
frequency by the same tolerances (`tolerance_weights`).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, replace

import numpy as np

from vibupdate.options import check, default
from vibupdate.modal.analysis import mac
from vibupdate.inverse.correlation import ModelFrequencies, percent_error
from vibupdate.inverse.repeated import cluster, combination_miss, paired_vector, subspace_mac
from vibupdate.data.measured import TWO_PI, Antiresonance, Configuration


#: Multiple of the estimated rounding floor of the shape ratios allowed outside an interval
#: (module docstring): the estimate draws one rounding unit per entry with random signs, a
#: typical rather than a worst case, and exact data carry the rounding of the model they came
#: from as well (measured on the 2,996-DOF refined frame: the polished answer misses one mode's
#: point data by 3.6 times that mode's estimate, by 0.14 times the largest mode's).
ROUNDING_SAFETY = 10.0


@dataclass(frozen=True)
class VerifyOptions:
    """Thresholds of the verification.

    Attributes
    ----------
    mac_min : float
        Smallest MAC of a measured shape with its declared mode (0.8: the usual threshold
        below which two shapes are not taken as the same mode; the frame example's verified
        answer has 0.9917 at worst).
    shape_slack : float
        Allowed distance outside a shape interval, in half-widths of that interval: the model's
        own eigenvector differs slightly from the first stage's vector in its box when the
        residual is not zero; a wrong sign or mode is many half-widths out.
    frequency_tolerance : float
        Relative frequency uncertainty used for the consistency allowance (a case file's
        ``frequency_tolerance`` when it states one; 1 % otherwise).
    measurement_tolerance : float
        Relative half-width of the measurement interval of a frequency that has no interval of
        its own (a case file's ``frequency_tolerance``; 0: known exactly).
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
    shape_slack: float = default("verification", "shape_slack")
    frequency_tolerance: float = default("verification", "frequency_tolerance")
    measurement_tolerance: float = default("verification", "measurement_tolerance")
    natural_tolerance: float = default("verification", "natural_tolerance")
    antiresonance_tolerance: float = default("verification", "antiresonance_tolerance")
    shape_tolerance: float = default("verification", "shape_tolerance")
    modal_mass_tolerance: float = default("verification", "modal_mass_tolerance")
    diagnose: bool = default("verification", "diagnose")
    suggest: bool = default("verification", "suggest")

    def tolerance(self, datum) -> float:
        """The model-form tolerance of ``datum``'s kind (a natural frequency or an antiresonance)."""
        return self.antiresonance_tolerance if isinstance(datum, Antiresonance) else self.natural_tolerance

    def measurement_interval(self, datum) -> tuple[float, float]:
        """``datum``'s measurement interval, rad/s: its own, else ``omega (1 -+ measurement_tolerance)``."""
        t = self.measurement_tolerance
        return datum.interval or (datum.omega * (1 - t), datum.omega * (1 + t))

    def band(self, datum) -> tuple[float, float]:
        """Where the fit check accepts ``datum``'s model value, rad/s: its measurement interval
        widened by the model-form tolerance of its kind and by `FIT_FLOOR`, both relative to
        the measured value."""
        lo, hi = self.measurement_interval(datum)
        widen = (self.tolerance(datum) + FIT_FLOOR) * datum.omega
        return lo - widen, hi + widen

    def __post_init__(self):
        check("verification", self)     # types and ranges: vibupdate.options


@dataclass(frozen=True)
class Check:
    """One verification check.

    Attributes
    ----------
    name : str
    passed : bool
    severity : {"error", "warning"}
        A failed error check makes the answer not verified; a warning does not.
    message : str
        What was found, with the measured figures.
    value, limit : float or None
        The measured figure and the limit it was held against.
    limited_by : {"measurement", "model_form"} or None
        For a passed check of the data against their tolerances (``fit``, ``shape_intervals``):
        whether every datum lies in its measurement interval, or some only within the
        model-form tolerance beyond it.
    """

    name: str
    passed: bool
    severity: str
    message: str
    value: float | None = None
    limit: float | None = None
    limited_by: str | None = None

    def as_dict(self) -> dict:
        return {"name": self.name, "passed": self.passed, "severity": self.severity, "message": self.message,
                "value": self.value, "limit": self.limit, "limited_by": self.limited_by}


def consistency_allowance(n_blocks: int, tolerance: float) -> float:
    """Largest relaxation lower bound that frequency errors of ``tolerance`` explain."""
    return n_blocks * (2.0 * tolerance) ** 2


def _nearest(values: np.ndarray, target: float) -> int:
    return int(np.argmin(np.abs(values - target) / target))


def _mode_order(cfg: Configuration, f: ModelFrequencies) -> list[str]:
    bad = []
    for k, nat in enumerate(cfg.natural):
        j = _nearest(f.omega_all, nat.omega)
        if j not in cluster(f.omega_all, nat.mode - 1):   # a repeated frequency's modes tie (`repeated`)
            bad.append(f"configuration {cfg.name!r}: measured {nat.freq_hz:.5g} Hz (declared mode {nat.mode}) is "
                       f"nearest to model mode {j + 1} at {f.omega_all[j] / TWO_PI:.5g} Hz; its mode {nat.mode} "
                       f"is at {f.natural[k] / TWO_PI:.5g} Hz (a mode skipped or inserted)")
    return bad


def _zero_order(cfg: Configuration, f: ModelFrequencies) -> list[str]:
    bad = []
    for a in cfg.antiresonances:
        z = f.zeros_all.get(a.receptance, np.zeros(0))
        label = f"configuration {cfg.name!r}: antiresonance of h_{a.response},{a.excitation} at {a.freq_hz:.5g} Hz"
        if a.index > z.size:
            bad.append(f"{label} is declared zero {a.index}, but the model has {z.size} zeros")
            continue
        j = _nearest(z, a.omega)
        if j != a.index - 1:
            bad.append(f"{label} (declared zero {a.index}) is nearest to model zero {j + 1} at "
                       f"{z[j] / TWO_PI:.5g} Hz; zero {a.index} is at {z[a.index - 1] / TWO_PI:.5g} Hz")
    return bad


def rounding_allowance(cfg: Configuration, xbar, f: ModelFrequencies, vectors: dict | None = None) -> float:
    """The largest, over the measured modes of ``cfg`` at ``xbar``, of `ROUNDING_SAFETY` times
    the rounding floor of the shape ratios plus the computed vector's own error estimated from
    its residual (`vibupdate.modal.refinement.shape_ratio_floor` at double precision, one
    factorization per measured mode); ``f`` holds the model's modes there. A mode of a repeated
    frequency (`vibupdate.inverse.repeated.cluster`) is taken with its whole eigenspace, whose
    change stays bounded as the repeated frequencies' gap closes; ``vectors`` maps a mode's
    position in ``cfg.natural`` to the vector checked for it (by default `paired_vector`'s)."""
    floor = 0.0
    for k, nat in enumerate(cfg.natural):
        if nat.shape is not None and len(nat.shape.bounds) >= 2:
            floor = max(floor, mode_rounding_allowance(cfg, xbar, f, k, None, vectors))
    return floor


def mode_rounding_allowance(cfg: Configuration, xbar, f: ModelFrequencies, k: int, precision: float | None,
                            vectors: dict | None = None) -> float:
    """`ROUNDING_SAFETY` times the rounding floor of the shape ratios of the ``k``-th measured
    mode of ``cfg`` (0-based) plus its vector's own error
    (`vibupdate.modal.refinement.shape_ratio_floor`), the entries of ``K`` and ``M`` known to
    the relative ``precision`` (None: double precision); a repeated frequency's with its
    eigenspace (`rounding_allowance`)."""
    from vibupdate.modal.refinement import shape_ratio_floor

    nat = cfg.natural[k]
    M, K = cfg.model.matrices(xbar)
    m = nat.mode - 1
    phi, near = paired_vector(cfg, f.Phi_all, f.omega_all, k)
    phi = (vectors or {}).get(k, phi)
    idx = cfg.model.measurement(list(nat.shape.ratio_bounds()))
    w = float(f.omega_all[m])   # negative for a negative eigenvalue (`modes`)
    rounding, own = shape_ratio_floor(M, K, np.sign(w) * w**2, phi, idx, cfg.model.measurement([nat.shape.reference]),
                                      basis=f.Phi_all[:, near] if near.size > 1 else None, precision=precision)
    return ROUNDING_SAFETY * rounding + own


def _shapes(cfg: Configuration, f: ModelFrequencies, options: VerifyOptions, xbar):
    """Messages of the MAC check and of the interval check, the lowest MAC, and the labels of
    the modes whose shapes lie outside their measurement intervals but within the model-form
    tolerance ``shape_tolerance`` beyond them."""
    bad_mac, bad_box, worst_mac, by_model = [], [], 1.0, []
    rounding = None   # computed when a ratio lies outside its widened interval
    tol = options.shape_tolerance
    vectors = {k: paired_vector(cfg, f.Phi_all, f.omega_all, k, options.shape_slack)
               for k, nat in enumerate(cfg.natural) if nat.shape is not None}
    checked = {j: v for j, (v, _) in vectors.items()}   # the vector checked for each measured mode
    for k, nat in enumerate(cfg.natural):
        if nat.shape is None:
            continue
        dofs = list(nat.shape.bounds)
        idx = cfg.model.measurement(dofs)   # the readings of DOFs and sensors (`vibupdate.model.measurement`)
        mid = np.array([nat.shape.midpoint[d] for d in dofs])
        macs = mac(mid, idx @ f.Phi_all)[0]
        m = nat.mode - 1
        phi, near = vectors[k]
        own = subspace_mac(mid, idx @ f.Phi_all[:, near]) if near.size > 1 else float(macs[m])
        macs[near] = -np.inf   # the other modes of a repeated frequency are this one's
        worst_mac = min(worst_mac, own)
        label = f"configuration {cfg.name!r}, mode {nat.mode} ({nat.freq_hz:.5g} Hz)"
        of = "" if near.size == 1 else f" (best combination of the repeated modes {near[0] + 1}-{near[-1] + 1})"
        if own < options.mac_min:
            bad_mac.append(f"{label}: MAC {own:.3f} with the measured shape{of}, below {options.mac_min}")
        other = int(np.argmax(macs))
        if macs[other] > own + 1e-9:
            bad_mac.append(f"{label}: the measured shape matches model mode {other + 1} better "
                           f"(MAC {macs[other]:.3f} vs {own:.3f}{of})")
        if len(dofs) < 2:
            continue
        ref = nat.shape.reference
        phi_ref = float((cfg.model.measurement([ref]) @ phi)[0])
        at = dict(zip(dofs, idx @ phi))
        if phi_ref == 0:
            bad_box.append(f"{label}: the model mode is zero at the reference DOF {ref!r}"
                           + ("" if near.size == 1 else ", and so is every mode that repeats its frequency"))
            continue
        before, model_form, allowed = len(bad_box), 0.0, None
        for d, (lo, hi) in nat.shape.ratio_bounds().items():
            ratio = at[d] / phi_ref
            slack = options.shape_slack * 0.5 * (hi - lo)
            out = max(lo - slack - ratio, ratio - hi - slack, 0.0)
            if out == 0.0:
                continue
            if rounding is None:
                rounding = rounding_allowance(cfg, xbar, f, checked)
            if allowed is None:   # this mode's own floor at the model's precision, where it has one
                allowed = rounding if cfg.model.matrix_precision is None else max(
                    rounding, mode_rounding_allowance(cfg, xbar, f, k, cfg.model.matrix_precision, checked))
            if out <= allowed:
                continue
            if out <= tol + allowed:
                model_form = max(model_form, out)
                continue
            bad_box.append(f"{label}, DOF {d!r}: model shape ratio {ratio:.10g}{of} outside the measured "
                               f"interval [{lo:.10g}, {hi:.10g}] (normalized at {ref!r}) by "
                               f"{max(lo - ratio, ratio - hi):.2g}, more than the {slack:.2g} allowed, the "
                               f"{tol:g} model-form tolerance and {allowed:.2g} for rounding")
        widen = tol * abs(nat.shape.midpoint[ref])
        shape = idx @ phi if near.size == 1 else idx @ f.Phi_all[:, near]
        if len(bad_box) == before:   # said only where no ratio of the mode was already out
            miss = _common_scaling_miss(shape, nat.shape, widen)
            if miss > SCALING_SLACK:
                bad_box.append(f"{label}: no common scaling puts the model shape inside every measured interval "
                               f"widened by the {tol:g} model-form tolerance; at the best one it is {miss:.2g} "
                               f"half-widths outside (allowed {SCALING_SLACK:g})")
            elif model_form > 0 or (tol > 0 and _common_scaling_miss(shape, nat.shape) > SCALING_SLACK):
                by_model.append(f"mode {nat.mode} by {model_form:.2g}" if model_form > 0 else f"mode {nat.mode}")
    return bad_mac, bad_box, worst_mac, by_model


def _modal_mass_check(configurations, updated, options: VerifyOptions, xbar) -> Check:
    """The ``modal_mass`` check (module docstring): each measured modal mass against the model's
    (of the paired vector: the best combination of a repeated frequency's modes)."""
    from vibupdate.inverse.repeated import paired_modal_mass

    bad, by_model, worst = [], [], 0.0
    tol = options.modal_mass_tolerance
    for cfg, f in zip(configurations, updated):
        M = cfg.model.matrices(xbar)[0]
        for k, nat in enumerate(cfg.natural):
            if nat.shape is None or not nat.shape.mass_normalized:
                continue
            lo, hi = nat.shape.modal_mass_bounds()
            mid = 0.5 * (lo + hi)
            mass = paired_modal_mass(cfg, M, f.Phi_all, f.omega_all, k)
            out = max(lo - mass, mass - hi, 0.0) / mid
            worst = max(worst, abs(mass / mid - 1))
            label = (f"configuration {cfg.name!r}, mode {nat.mode} ({nat.freq_hz:.5g} Hz), modal mass at "
                     f"{nat.shape.reference!r}")
            if out > tol + FIT_FLOOR:
                bad.append(f"{label}: model {mass:.6g} kg, measured [{lo:.6g}, {hi:.6g}] kg: outside by "
                           f"{100 * out:.3g} %, more than the {100 * tol:g} % model-form tolerance")
            elif out > 0:
                by_model.append(f"mode {nat.mode} by {100 * out:.2g} %")
    if bad:
        text = _join(bad)
    elif by_model:
        text = (f"{len(by_model)} modal mass(es) lie outside their measurement intervals and within the "
                f"{100 * tol:g} % model-form tolerance ({_join(by_model, 6)}): the model's form, not the "
                "measurement, limits the answer")
    else:
        text = f"every modal mass lies in its measured interval (largest departure from a midpoint {100 * worst:.3g} %)"
    return Check("modal_mass", not bad, "error", text, 100 * worst, 100 * tol,
                 limited_by=None if bad else ("model_form" if by_model else "measurement"))


#: Largest distance, in half-widths, by which a model shape may lie outside its measured
#: intervals at the best common scaling (`_common_scaling_miss`): the polish ends on the edges
#: of the intervals it reaches, to about this.
SCALING_SLACK = 1e-3


def _common_scaling_miss(phi: np.ndarray, shape, widen: float = 0.0) -> float:
    """How far the model shape ``phi`` (at the measured DOFs, in the order of ``shape.bounds``)
    lies outside its intervals, each widened by ``widen`` on both sides, at the best common
    scaling, in half-widths: the least ``t`` such that some ``s`` puts every ``s phi_j`` within
    ``t`` half-widths of its widened interval ``j``. The ratio check normalizes at the
    reference entry's midpoint, a box stricter than the intervals, and lets a shape through
    within ``shape_slack`` of it; this is the intervals' own meaning. 0 for point data (zero
    widths), which the ratio check covers with its rounding allowance.

    Bisection on ``t``: for a given ``t`` the admissible scalings of each entry form one
    interval, and they intersect or not. For the modes of a repeated frequency ``phi`` is
    their vectors, shape (n_s, k), and ``s`` any combination of them (a linear program,
    `vibupdate.inverse.repeated.combination_miss`)."""
    bounds = np.array(list(shape.bounds.values()), dtype=float)
    lo, hi = bounds[:, 0], bounds[:, 1]
    half = 0.5 * (hi - lo)
    if np.any(half <= 0) or not np.all(np.isfinite(phi)):
        return 0.0
    lo, hi = lo - widen, hi + widen
    if phi.ndim == 2:
        return combination_miss(phi, lo, hi, half)

    def feasible(t: float) -> bool:
        a, b = lo - t * half, hi + t * half
        zero = phi == 0
        if np.any(zero & ((a > 0) | (b < 0))):
            return False
        p = phi[~zero]
        s1, s2 = a[~zero] / p, b[~zero] / p
        return bool(np.max(np.minimum(s1, s2)) <= np.min(np.maximum(s1, s2)))

    if feasible(0.0):
        return 0.0
    top = 1.0
    while not feasible(top) and top < 1e6:
        top *= 2.0
    low = 0.0
    for _ in range(40):
        mid = 0.5 * (low + top)
        low, top = (low, mid) if feasible(mid) else (mid, top)
    return top


#: Relative widening of every fit band for the rounding of a double-precision eigen-solve, so
#: that a model-form tolerance of 0 with point data asks for the data to rounding, not exactly.
FIT_FLOOR = 1e-8

#: Smallest relative tolerance (measurement half-width plus model-form tolerance) a datum is
#: weighted by (`tolerance_weights`): a chosen cap, not a measured one, so that an exact datum
#: among 1 % ones weighs 1e4^2 times more rather than without bound (extracted intervals of
#: 1e-5 with a model-form tolerance of 0 all sit at it, and keep equal weights).
WEIGHT_FLOOR = 1e-4


def _fit(cfg: Configuration, f: ModelFrequencies, options: VerifyOptions) -> tuple[list[str], float, list[str]]:
    """Messages of the data outside their bands, the largest relative miss, and the labels of
    the data outside their measurement intervals but inside their bands (accepted by the
    model-form tolerance)."""
    bad, worst, by_model = [], 0.0, []
    items = [(n, f.natural[k], f"mode {n.mode}") for k, n in enumerate(cfg.natural)]
    items += [(a, f.antiresonances[k], f"zero {a.index} of h_{a.response},{a.excitation}")
              for k, a in enumerate(cfg.antiresonances)]
    for datum, model, label in items:
        lo, hi = options.band(datum)
        miss = abs(model - datum.omega) / datum.omega if np.isfinite(model) else np.inf
        worst = max(worst, miss)
        m_lo, m_hi = options.measurement_interval(datum)
        floor = FIT_FLOOR * datum.omega
        if not (lo <= model <= hi):
            t = options.tolerance(datum)
            where = ("its measurement interval" if datum.interval or options.measurement_tolerance > 0
                     else "the measured value")
            bad.append(f"configuration {cfg.name!r}, {label}: model {model / TWO_PI:.5g} Hz vs measured "
                       f"{datum.omega / TWO_PI:.5g} Hz ({100 * miss:.3g} %, outside {where} widened by the "
                       f"{100 * t:g} % model-form tolerance)")
        elif not (m_lo - floor <= model <= m_hi + floor):
            by_model.append(f"{label} {100 * miss:.3g} %")
    return bad, worst, by_model


def _relative_tolerances(data, options: VerifyOptions) -> np.ndarray:
    """Each frequency's relative tolerance: measurement half-width plus the model-form
    tolerance of its kind, at least `WEIGHT_FLOOR`."""
    return np.array([max(0.5 * (np.subtract(*options.measurement_interval(d)[::-1])) / d.omega
                         + options.tolerance(d), WEIGHT_FLOOR) for d in data])


def tolerance_shape_weight(configurations: Sequence[Configuration], options: VerifyOptions,
                           shape_weight: float) -> float:
    """The polish's weight of a shape ratio's distance outside its interval, in the units the
    frequencies are weighed in (`tolerance_weights`): ``t_f / shape_tolerance``, ``t_f`` the
    frequencies' tolerance as their normalized weights use it (the root mean of ``1 / t^2``,
    inverted), capped by ``shape_weight``. A shape miss then costs in units of what the
    verification allows it, as a frequency miss does; without a shape tolerance, or with a
    larger ``t_f``, it is ``shape_weight``."""
    data = [d for c in configurations for d in (*c.natural, *c.antiresonances)]
    if options.shape_tolerance <= 0 or not data:
        return shape_weight
    t_f = 1.0 / math.sqrt(float(np.mean(1.0 / _relative_tolerances(data, options) ** 2)))
    return min(shape_weight, t_f / options.shape_tolerance)


def fit_data(configurations: Sequence[Configuration], options: VerifyOptions, polish):
    """The data and the polish's options as the fit weighs them by the tolerances the
    verification holds them to (`tolerance_weights`, `tolerance_shape_weight`)."""
    weight = tolerance_shape_weight(configurations, options, polish.shape_weight)
    return tolerance_weights(configurations, options), replace(polish, shape_weight=weight)


def tolerance_weights(configurations: Sequence[Configuration], options: VerifyOptions | None = None):
    """The data with each frequency's weight multiplied by ``1 / t^2``, ``t`` its relative
    tolerance (measurement half-width plus the model-form tolerance of its kind, at least
    `WEIGHT_FLOOR`), the multipliers normalized to mean 1 over all frequencies: the fit weighs
    each residual in units of what the verification allows it, and data with equal tolerances
    keep their weights (the same objects are returned then)."""
    options = options or VerifyOptions()
    data = [d for c in configurations for d in (*c.natural, *c.antiresonances)]
    if not data:
        return list(configurations)
    factor = 1.0 / _relative_tolerances(data, options) ** 2
    factor /= factor.mean()
    if np.allclose(factor, 1.0, rtol=1e-12, atol=0.0):
        return list(configurations)
    out, k = [], 0
    for c in configurations:
        n, m = len(c.natural), len(c.antiresonances)
        fn, fa = factor[k:k + n], factor[k + n:k + n + m]
        k += n + m
        out.append(replace(c, natural=tuple(replace(d, weight=d.weight * w) for d, w in zip(c.natural, fn)),
                           antiresonances=tuple(replace(d, weight=d.weight * w)
                                                for d, w in zip(c.antiresonances, fa))))
    return out


def _join(messages: list[str], limit: int = 4) -> str:
    more = len(messages) - limit
    return "; ".join(messages[:limit]) + (f"; and {more} more" if more > 0 else "")


def verify(configurations: Sequence[Configuration], xbar, *, nominal: Sequence[ModelFrequencies],
           updated: Sequence[ModelFrequencies], lower_bound: float | None, n_blocks: int,
           active_bounds: Sequence[str] = (), first_stage: Sequence[ModelFrequencies] | None = None,
           options: VerifyOptions | None = None, reduction_error: float = 0.0) -> tuple[Check, ...]:
    """Check the updated model against the data (module docstring).

    Parameters
    ----------
    configurations : sequence of Configuration
    xbar : ndarray, shape (n_x,)
        The answer.
    nominal, updated : sequence of ModelFrequencies
        Paired model data at the nominal point and at ``xbar``, per configuration.
    lower_bound : float or None
        Optimum of the convex relaxation (None when it was not solved).
    n_blocks : int
        Number of residual blocks of the first stage.
    active_bounds : sequence of str
        Bounds active at the relaxation's optimum, named for the user.
    first_stage : sequence of ModelFrequencies, optional
        Paired model data at the first-stage answer (before the polish).
    options : VerifyOptions, optional
    reduction_error : float
        When the first stage solved a reduced model: the largest relative difference between
        its natural frequencies and the full model's at the nominal point. The relaxation bounds
        the reduced problem, which misses even exact data by about this much, so the
        consistency allowance takes the larger of it and the frequency tolerance.
    """
    options = options or VerifyOptions()
    checks = []
    order = [m for c, f in zip(configurations, updated) for m in _mode_order(c, f)]
    checks.append(Check("mode_order", not order, "error",
                        _join(order) if order else "every measured natural frequency is nearest to its declared mode",
                        float(len(order)), 0.0))
    if any(c.antiresonances for c in configurations):
        zeros = [m for c, f in zip(configurations, updated) for m in _zero_order(c, f)]
        checks.append(Check("zero_order", not zeros, "error",
                            _join(zeros) if zeros else "every measured antiresonance is nearest to its declared zero",
                            float(len(zeros)), 0.0))
    if any(n.shape is not None for c in configurations for n in c.natural):
        found = [_shapes(c, f, options, xbar) for c, f in zip(configurations, updated)]
        bad_mac = [m for b, _, _, _ in found for m in b]
        bad_box = [m for _, b, _, _ in found for m in b]
        by_model = [m for _, _, _, b in found for m in b]
        worst = min(w for _, _, w, _ in found)
        checks.append(Check("mac", not bad_mac, "error",
                            _join(bad_mac) if bad_mac else f"lowest MAC with a measured shape {worst:.4f}",
                            worst, options.mac_min))
        if bad_box:
            text = _join(bad_box)
        elif by_model:
            text = (f"{len(by_model)} measured shape(s) lie outside their measurement intervals and within the "
                    f"{options.shape_tolerance:g} model-form tolerance ({_join(by_model, 6)}): the model's form, not "
                    "the measurement, limits the answer")
        else:
            text = "every model shape ratio lies in its measured interval"
        checks.append(Check("shape_intervals", not bad_box, "error", text, float(len(bad_box)), 0.0,
                            limited_by=None if bad_box else ("model_form" if by_model else "measurement")))
    if any(n.shape is not None and n.shape.mass_normalized for c in configurations for n in c.natural):
        checks.append(_modal_mass_check(configurations, updated, options, xbar))
    fits = [_fit(c, f, options) for c, f in zip(configurations, updated)]
    bad_fit = [m for b, _, _ in fits for m in b]
    by_model = [m for _, _, b in fits for m in b]
    worst = max(w for _, w, _ in fits)
    n_data = sum(len(c.natural) + len(c.antiresonances) for c in configurations)
    tolerances = f"natural {100 * options.natural_tolerance:g} %" + (
        f", antiresonance {100 * options.antiresonance_tolerance:g} %"
        if any(c.antiresonances for c in configurations) else "")
    if bad_fit:
        text = _join(bad_fit)
    elif by_model:
        stated = options.measurement_tolerance > 0 or any(
            d.interval for c in configurations for d in (*c.natural, *c.antiresonances))
        where = "lie outside their measurement intervals" if stated else \
            "differ from their measured values (no measurement interval stated)"
        text = (f"largest frequency miss {100 * worst:.3g} %; {len(by_model)} of {n_data} frequencies {where} and "
                f"lie within the model-form tolerance ({tolerances}): the model's form, not the measurement, limits "
                f"the answer ({_join(by_model, 6)})")
    else:
        text = f"largest frequency miss {100 * worst:.3g} %; every frequency lies in its measurement interval"
    checks.append(Check("fit", not bad_fit, "error", text, 100 * worst, 100 * options.natural_tolerance,
                        limited_by=None if bad_fit else ("model_form" if by_model else "measurement")))
    measured = np.concatenate([[n.omega for n in c.natural] + [a.omega for a in c.antiresonances]
                               for c in configurations])
    nom = np.concatenate([np.r_[f.natural, f.antiresonances] for f in nominal])
    upd = np.concatenate([np.r_[f.natural, f.antiresonances] for f in updated])
    e_nom = float(np.nanmean(percent_error(nom, measured)))
    e_upd = float(np.mean(percent_error(upd, measured)))  # NaN if a declared zero is missing
    better = bool(np.isfinite(e_upd) and e_upd <= e_nom * (1 + 1e-9) + 1e-9)
    checks.append(Check("improvement", better, "error",
                        f"mean frequency error {e_upd:.4g} % updated vs {e_nom:.4g} % nominal"
                        + ("" if better else ": the update is worse than the nominal model"), e_upd, e_nom))
    if first_stage is not None:
        skipped = [m for c, f in zip(configurations, first_stage) for m in _mode_order(c, f)]
        if skipped:
            near = np.concatenate([[np.min(np.abs(f.omega_all - n.omega)) / n.omega for n in c.natural]
                                   for c, f in zip(configurations, first_stage)])
            declared = np.concatenate([np.abs(f.natural - [n.omega for n in c.natural]) / [n.omega for n in c.natural]
                                       for c, f in zip(configurations, updated)])
            e_near, e_decl = 100 * float(np.mean(near)), 100 * float(np.mean(declared))
            ok = bool(e_decl <= 2 * e_near + 0.1 * 100 * (options.natural_tolerance + options.measurement_tolerance))
            text = (f"the first stage fitted the natural frequencies to {e_near:.3g} % mean under another pairing "
                    f"({_join(skipped, 2)}); the declared modes are fitted to {e_decl:.3g} %")
            if not ok:
                text += ": the declared modes are likely wrong (set `mode` of each measured frequency)"
            checks.append(Check("correspondence", ok, "error", text, e_decl, e_near))
    if lower_bound is not None:
        tol = max(options.frequency_tolerance, reduction_error)
        allowance = consistency_allowance(n_blocks, tol)
        ok = bool(lower_bound <= allowance)
        explains = f"what {100 * tol:.3g} % frequency errors explain" + (
            "; the first stage's reduced model misses the full model's frequencies by that much at the nominal "
            "point" if reduction_error > options.frequency_tolerance else "")
        text = (f"relaxation lower bound {lower_bound:.3g} <= {allowance:.3g} ({explains}); a bound near zero "
                "certifies nothing, a positive one proves a misfit")
        if not ok:
            text = (f"relaxation lower bound {lower_bound:.3g} > {allowance:.3g} ({explains}): no parameter set "
                    "inside the boxes fits the data; the data contradict the bounds"
                    + (f"; widen: {', '.join(active_bounds)}" if active_bounds else ""))
        checks.append(Check("consistency", ok, "error", text, float(lower_bound), allowance))
    model = configurations[0].model
    lo, hi = model.bounds()
    span = np.where(hi > lo, hi - lo, 1.0)
    at = [p.name for p, x, a, b, s in zip(model.parameters, xbar, lo, hi, span)
          if min(x - a, b - x) <= 1e-6 * s]
    checks.append(Check("bounds", not at, "warning",
                        ("parameters on a bound: " + ", ".join(at)) if at else "no parameter on a bound",
                        float(len(at)), 0.0))
    return tuple(checks)
