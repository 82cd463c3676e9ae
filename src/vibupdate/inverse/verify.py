"""Verification: is the returned model the one the data describe?

A solver that reaches ``lam = 1`` has found a small objective; that does not make the model
right. `verify` returns one `Check` per property with its measured figure and limit; a failed
error check makes the status ``not_verified``. Each check, what it passes on and its default
limit: docs/polish-and-verification.md, section 7.3.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import asdict, dataclass

import numpy as np

from vibupdate.modal.analysis import mac, subspace_mac
from vibupdate.inverse.admissible import Admissible, VerifyOptions, misses
from vibupdate.inverse.correlation import ModelFrequencies, percent_error
from vibupdate.inverse.data_map import data_map
from vibupdate.inverse.repeated import cluster
from vibupdate.data.measured import TWO_PI, Configuration


@dataclass(frozen=True)
class Check:
    """One verification check.

    Attributes
    ----------
    name : str
        The check (``fit``, ``modal_mass``, ``shape_intervals``, ...; the table of
        docs/polish-and-verification.md, section 7.3).
    passed : bool
        Whether the answer passed it.
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
        """The record as its ``results.json`` document.

        Returns
        -------
        dict
            Each field under its name.
        """
        return asdict(self)


def consistency_allowance(n_blocks: int, tolerance: float) -> float:
    """Largest relaxation lower bound that frequency errors of ``tolerance`` explain."""
    return n_blocks * (2.0 * tolerance) ** 2


def _nearest(values: np.ndarray, target: float) -> int:
    return int(np.argmin(np.abs(values - target) / target))


def _measured(datum, value: float) -> bool:
    """Whether ``value`` lies in the datum's measurement interval (`Admissible`): the data
    cannot tell it from a nearer model value there."""
    return datum is not None and datum.measured[0] <= value <= datum.measured[1]


def _mode_order(cfg: Configuration, f: ModelFrequencies, data=()) -> list[str]:
    """A measured natural frequency nearer another model mode than its declared one, unless the
    declared mode lies in its measurement interval (``data``: the configuration's `Datum`s)."""
    bad = []
    for k, nat in enumerate(cfg.natural):
        j = _nearest(f.omega_all, nat.omega)
        if j not in cluster(f.omega_all, nat.mode - 1) and not _measured(data[k] if data else None, f.natural[k]):
            bad.append(f"configuration {cfg.name!r}: measured {nat.freq_hz:.5g} Hz (declared mode {nat.mode}) is "
                       f"nearest to model mode {j + 1} at {f.omega_all[j] / TWO_PI:.5g} Hz; its mode {nat.mode} "
                       f"is at {f.natural[k] / TWO_PI:.5g} Hz (a mode skipped or inserted)")
    return bad


def _nearest_modes(configurations, first_stage) -> str:
    """What to state instead of the declared modes: per configuration, the model mode of each
    measured frequency that best matches it, where they rise: by the MAC of its shape with the
    nominal model's modes (which the wrong modes did not distort), else the nearest frequency
    at the first stage's answer."""
    from vibupdate.data.pairing import shape_macs

    found = []
    for c, f in zip(configurations, first_stage):
        shaped = [n for n in c.natural if n.shape is not None]
        top = 2 * max(n.mode for n in c.natural) + 2   # twice the declared modes: a skipped one is among them
        best = iter(shape_macs([n.shape.bounds for n in shaped], c.model, top).argmax(axis=1) + 1 if shaped else ())
        near = [int(next(best)) if n.shape is not None else _nearest(f.omega_all, n.omega) + 1 for n in c.natural]
        if near != [n.mode for n in c.natural] and all(b > a for a, b in zip(near, near[1:])):
            found.append(f"natural_modes = {near} in configuration {c.name!r}")
    return ("state " + "; ".join(found) + " (by the MAC of each measured shape with the nominal model's modes, by "
            "frequency where no shape is measured)" if found else "state the model mode of each measured frequency") \
        + ": `natural_modes`, in [configuration.frf] for FRF data, or a frequency table's `mode` column"


def _zero_order(cfg: Configuration, f: ModelFrequencies, data=()) -> list[str]:
    """As `_mode_order`, for the declared zeros (``data``: the configuration's `Datum`s, the
    antiresonances after the natural frequencies)."""
    bad = []
    for i, a in enumerate(cfg.antiresonances):
        z = f.zeros_all.get(a.receptance, np.zeros(0))
        label = f"configuration {cfg.name!r}: antiresonance of h_{a.response},{a.excitation} at {a.freq_hz:.5g} Hz"
        if a.index > z.size:
            bad.append(f"{label} is declared zero {a.index}, but the model has {z.size} zeros")
            continue
        j = _nearest(z, a.omega)
        if j != a.index - 1 and not _measured(data[len(cfg.natural) + i] if data else None, z[a.index - 1]):
            bad.append(f"{label} (declared zero {a.index}) is nearest to model zero {j + 1} at "
                       f"{z[j] / TWO_PI:.5g} Hz; zero {a.index} is at {z[a.index - 1] / TWO_PI:.5g} Hz")
    return bad


def _macs(cfg: Configuration, f: ModelFrequencies, options: VerifyOptions):
    """Messages of the MAC check and the lowest MAC of a measured shape with its declared mode
    (or the best combination of a repeated frequency's modes)."""
    bad, worst = [], 1.0
    for k, nat in enumerate(cfg.natural):
        if nat.shape is None:
            continue
        dofs = list(nat.shape.bounds)
        idx = cfg.model.measurement(dofs)   # the readings of DOFs and sensors (`vibupdate.model.measurement`)
        mid = np.array([nat.shape.midpoint[d] for d in dofs])
        macs = mac(mid, idx @ f.Phi_all)[0]
        near = cluster(f.omega_all, nat.mode - 1)
        own = subspace_mac(mid, idx @ f.Phi_all[:, near]) if near.size > 1 else float(macs[nat.mode - 1])
        macs[near] = -np.inf   # the other modes of a repeated frequency are this one's
        worst = min(worst, own)
        label = f"configuration {cfg.name!r}, mode {nat.mode} ({nat.freq_hz:.5g} Hz)"
        of = "" if near.size == 1 else f" (best combination of the repeated modes {near[0] + 1}-{near[-1] + 1})"
        if own < options.mac_min:
            bad.append(f"{label}: MAC {own:.3f} with the measured shape{of}, below {options.mac_min}")
        other = int(np.argmax(macs))
        if macs[other] > own + 1e-9:
            bad.append(f"{label}: the measured shape matches model mode {other + 1} better "
                       f"(MAC {macs[other]:.3f} vs {own:.3f}{of})")
    return bad, worst


#: The membership checks and the kinds of data each holds.
_KINDS = {"fit": ("natural", "antiresonance"), "shape_intervals": ("shape",), "modal_mass": ("modal_mass",)}


def _membership(name: str, found: list, options: VerifyOptions) -> Check:
    """One membership check (module docstring) from the `misses` of its kinds of data."""
    out = [m for m in found if m.miss > 0]
    by_model = [m for m in found if m.miss == 0 and not m.measured]
    worst = max((100 * m.relative if name == "fit" else m.miss for m in found), default=0.0)
    if out:
        text = _join([f"{m.text}: {m.miss:.3g} half-widths outside" for m in out])
    elif by_model:
        text = (f"{len(by_model)} of {len(found)} data lie outside their measurement intervals and within the "
                f"model-form tolerance ({_join([m.label for m in by_model], 6)}): the model's form, not the "
                "measurement, limits the answer")
    else:
        text = f"every one of {len(found)} data lies in its measurement interval"
    if name == "fit":
        text = f"largest frequency miss {worst:.3g} %; " + text
    tolerance = {"fit": 100 * options.natural_tolerance, "shape_intervals": options.shape_tolerance,
                 "modal_mass": options.modal_mass_tolerance}[name]
    return Check(name, not out, "error", text, float(worst), tolerance,
                 limited_by=None if out else ("model_form" if by_model else "measurement"))


def _join(messages: list[str], limit: int = 4) -> str:
    more = len(messages) - limit
    return "; ".join(messages[:limit]) + (f"; and {more} more" if more > 0 else "")


def verify(configurations: Sequence[Configuration], xbar, *, nominal: Sequence[ModelFrequencies],
           updated: Sequence[ModelFrequencies], lower_bound: float | None, n_blocks: int,
           active_bounds: Sequence[str] = (), first_stage: Sequence[ModelFrequencies] | None = None,
           options: VerifyOptions | None = None, reduction_error: float = 0.0,
           contract: Admissible | None = None) -> tuple[Check, ...]:
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
        When the first stage solved a reduced model: the largest relative difference of its
        natural frequencies from the full model's at the nominal point; the consistency
        allowance takes the larger of it and the frequency tolerance.
    """
    options = options or VerifyOptions()
    contract = contract or Admissible.of(configurations, options)
    checks = []
    order = [m for c, f, d in zip(configurations, updated, contract.frequencies) for m in _mode_order(c, f, d)]
    checks.append(Check("mode_order", not order, "error",
                        _join(order) if order else "every measured natural frequency is nearest to its declared mode",
                        float(len(order)), 0.0))
    if any(c.antiresonances for c in configurations):
        zeros = [m for c, f, d in zip(configurations, updated, contract.frequencies) for m in _zero_order(c, f, d)]
        checks.append(Check("zero_order", not zeros, "error",
                            _join(zeros) if zeros else "every measured antiresonance is nearest to its declared zero",
                            float(len(zeros)), 0.0))
    if any(n.shape is not None for c in configurations for n in c.natural):
        found = [_macs(c, f, options) for c, f in zip(configurations, updated)]
        bad_mac = [m for b, _ in found for m in b]
        worst = min(w for _, w in found)
        checks.append(Check("mac", not bad_mac, "error",
                            _join(bad_mac) if bad_mac else f"lowest MAC with a measured shape {worst:.4f}",
                            worst, options.mac_min))
    found = misses(contract, [data_map(c, xbar, jacobian=False, freqs=f) for c, f in zip(configurations, updated)])
    for name, kinds in _KINDS.items():
        mine = [m for m in found if m.kind in kinds]
        if mine or name == "fit":
            checks.append(_membership(name, mine, options))
    measured = np.array([d.value for row in contract.frequencies for d in row])   # as declared
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
                text += ": the declared modes are likely wrong (" + _nearest_modes(configurations, first_stage) + ")"
            checks.append(Check("correspondence", ok, "error", text, e_decl, e_near))
    if lower_bound is not None:
        tol = max(options.frequency_tolerance, reduction_error)
        allowance = consistency_allowance(n_blocks, tol)
        ok = bool(lower_bound <= allowance)
        explains = f"what {100 * tol:.3g} % frequency errors explain" + (
            "; the first stage's reduced model misses the full model's frequencies by that much at the nominal "
            "point" if reduction_error > options.frequency_tolerance else "")
        sits = f"; the relaxed solution sits on: {', '.join(active_bounds)}" if active_bounds else ""
        text = f"relaxation lower bound {lower_bound:.3g} {'<=' if ok else '>'} {allowance:.3g} ({explains})" + (
            "; a bound near zero certifies nothing" if ok
            else ": a heuristic allowance, not a certificate; the data may contradict the bounds" + sits)
        checks.append(Check("consistency", ok, "warning", text, float(lower_bound), allowance))
    model = configurations[0].model
    lo, hi = model.bounds()
    span = np.where(hi > lo, hi - lo, 1.0)
    at = [p.name for p, x, a, b, s in zip(model.parameters, xbar, lo, hi, span)
          if min(x - a, b - x) <= 1e-6 * s]
    checks.append(Check("bounds", not at, "warning",
                        ("parameters on a bound: " + ", ".join(at)) if at else "no parameter on a bound",
                        float(len(at)), 0.0))
    return tuple(checks)
