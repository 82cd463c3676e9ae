"""One validation path for ``vibupdate check`` and ``vibupdate run``.

`validate_case` does everything a run would reject before and after solving that can be known
beforehand, so that ``check`` accepts exactly the cases ``run`` accepts: what is checked is
``docs/case-file.md`` ("What `check` and `run` validate"); the options were checked where they
were made (`vibupdate.options`). Errors are ValueErrors of the form ``"FILE: KEY: what is
wrong"``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from vibupdate.data.measured import TWO_PI
from vibupdate.options import finite


#: Damping ratios above this get a warning.
HIGH_DAMPING = 0.2
#: Largest magnitude of a Caughey exponent.
MAX_EXPONENT = 10.0
#: Largest magnitude of a normalized bound (Eq. 12): a parameter may move this many reference values.
MAX_NORMALIZED_BOUND = 1e6
#: Largest user weight of a measured frequency.
MAX_WEIGHT = 1e6
#: Measured / nominal frequency ratios within this factor of 2 pi look like rad/s given as Hz.
RAD_S_FACTOR = 1.3
#: A parameter whose unit starts with this (kg, kg/m, kg/m^3, kg m^2) is a mass, a mass per
#: length or volume, or an inertia: `_check_mass_scale` takes the model's mass as linear in it.
MASS_UNIT = "kg"
#: The mass the mass-like parameters carry at the nominal point may exceed the model's own mass
#: on a DOF by at most this factor (`_check_mass_scale`): more than rounding and linearization,
#: less than a unit mistake (1000 for tonnes or grams against kilograms, 14.6 for slugs).
MASS_SHARE_FACTOR = 2.0
#: With no mode declared, a measured natural frequency this many times the nominal frequency of
#: the model mode it is paired with (the k-th measured with mode k) is taken as a pairing
#: mistake, not a model to update: a near-rigid or suspension mode counted first. It assumes a
#: nominal model within a factor of 10 of the data in frequency (100 in stiffness over mass).
PAIRING_FACTOR = 10.0


@dataclass(frozen=True)
class CaseCheck:
    """What `validate_case` found in a valid case.

    Attributes
    ----------
    sizes : dict
        Problem size (`vibupdate.inverse.formulation.problem.BilinearProblem.sizes`).
    notes : tuple of str
        Facts worth printing: rigid-body modes, massless DOFs, what was checked.
    warnings : tuple of str
        Suspicious but admissible input.
    prepared : vibupdate.inverse.update.Prepared or None
        The problem built to check the case, for `update` to use instead of building it again.
    case : vibupdate.io.case.Case or None
        The case the run solves: the one checked, with the parameter bounds narrowed where
        they reach models that are not physical (``warnings`` say which and to what).
    """

    sizes: dict
    notes: tuple[str, ...]
    warnings: tuple[str, ...]
    prepared: object = field(default=None, repr=False, compare=False)
    case: object = field(default=None, repr=False, compare=False)


def _check_damping(case, rigid: int, error) -> list[str]:
    """Damping options and ratios; returns warnings."""
    warnings = []
    ratios = [(c.name, f.mode, f.damping_ratio) for c in case.configurations for f in c.natural
              if f.damping_ratio is not None]   # by model mode, as the damping stage labels them
    for cfg, mode, xi in ratios:
        key = f"configuration '{cfg}'.damping_ratios"
        if not 0 < xi < 1:
            raise error(key, f"mode {mode}: a damping ratio must be in (0, 1) (0 is undamped, 1 critically "
                             f"damped), got {xi!r}")
        if xi > HIGH_DAMPING:
            warnings.append(f"configuration '{cfg}', mode {mode}: damping ratio {xi:g} is above {HIGH_DAMPING:g}; "
                            "is it a ratio (not per cent) of a lightly damped mode?")
    options = case.damping
    if options is None:
        return warnings
    exponents = list(options.exponents)
    if not exponents:
        raise error("damping.exponents", "needs at least one exponent")
    bad = [y for y in exponents if not finite(y)]
    if bad:
        raise error("damping.exponents", f"must be finite numbers, got {bad[0]!r}")
    if max(abs(y) for y in exponents) > MAX_EXPONENT:
        raise error("damping.exponents",
                    f"must lie within +-{MAX_EXPONENT:g} (w^(2h) overflows beyond), got {exponents}")
    if len(set(exponents)) != len(exponents):
        raise error("damping.exponents", f"must be distinct, got {exponents}")
    if rigid and min(exponents) < 0:
        raise error("damping.exponents", f"negative exponents ({min(exponents):g}) make C infinite on the "
                                         f"model's {rigid} rigid-body mode(s); use exponents >= 0")
    measured = {m for _, m, _ in ratios}
    for mode, weight in options.mode_weights:
        if not finite(weight) or weight <= 0:
            raise error(f"damping.mode_weights.{mode}", f"must be a positive finite number, got {weight!r}")
        if mode not in measured:
            warnings.append(f"damping.mode_weights names mode {mode}, which has no measured damping ratio")
    if not ratios:
        warnings.append("a [damping] table is given but no damping ratio is measured: the second stage is skipped")
    return warnings


def _check_order(cfg, error) -> None:
    """Natural frequencies ascend with their mode numbers (where modes are given)."""
    modes = [(f.mode, f.omega) for f in cfg.natural if getattr(f, "mode", None) is not None]
    modes.sort()
    for (m1, w1), (m2, w2) in zip(modes, modes[1:]):
        if m1 == m2:
            raise error(f"configuration '{cfg.name}'", f"mode {m1} is measured twice")
        if w2 < w1:   # equal: a repeated frequency, one measured value per mode
            raise error(f"configuration '{cfg.name}'",
                        f"mode {m2} at {w2 / TWO_PI:.6g} Hz is below mode {m1} at {w1 / TWO_PI:.6g} Hz")


def _check_data(cfg, error) -> None:
    """User weights in range, first_sign on DOFs of the model."""
    key = f"configuration '{cfg.name}'"
    for k, f in enumerate(cfg.natural, start=1):
        if f.weight > MAX_WEIGHT:
            raise error(f"{key}.natural_weights", f"mode {k}: weight {f.weight:g} is above {MAX_WEIGHT:g}; weights are "
                                                  "relative, scale them down")
    for k, a in enumerate(cfg.antiresonances, start=1):
        if a.weight > MAX_WEIGHT:
            raise error(f"{key}.antiresonances[{k}].weight", f"weight {a.weight:g} is above {MAX_WEIGHT:g}")
    for rc in dict(cfg.first_sign):
        for dof in rc:
            try:
                cfg.model.dof(dof)
            except ValueError as exc:
                raise error(f"{key}.first_sign", str(exc)) from None
        if rc not in cfg.receptances():
            raise error(f"{key}.first_sign", f"h_{rc[0]},{rc[1]} has no measured antiresonance, so its sign is "
                                              "not used")


def _check_mass_scale(cfg, error) -> None:
    """The mass matrix's unit scale against the values of the case's mass-like parameters
    (`MASS_UNIT`): the rule of ``docs/case-file.md`` ("Unit scale of `M`"), with
    `MASS_SHARE_FACTOR`, on the diagonals only (no solve)."""
    model = cfg.model
    carried = np.zeros(model.n_dofs)
    names = []
    for p, dM in zip(model.parameters, model.M_par):
        if p.unit.strip().startswith(MASS_UNIT) and dM.nnz:
            carried += p.nominal * dM.diagonal() / p.reference   # p0 dM/dp: M_par is per normalized unit
            names.append(f"{p.name} = {p.nominal:g} {p.unit.strip()}")
    if not names:
        return
    own = model.M0.diagonal()
    excess = carried - MASS_SHARE_FACTOR * np.abs(own)
    k = int(np.argmax(excess))
    if excess[k] > 0:
        key = f"configuration '{cfg.name}'"
        raise error(key, f"at DOF {model.dofs[k]} the mass-like parameters ({', '.join(names)}) carry "
                         f"{carried[k]:.4g} at the nominal point, {carried[k] / max(abs(own[k]), 1e-300):.3g} times "
                         f"the model's own mass there ({own[k]:.4g}); is the mass matrix in other units than the "
                         "parameters (tonnes or grams for kg)? Give M and its derivatives in SI units")


def _check_bounds(model, error) -> None:
    lower, upper = model.bounds()
    for p, lo, hi in zip(model.parameters, lower, upper):
        if max(abs(lo), abs(hi)) > MAX_NORMALIZED_BOUND:
            raise error(f"parameter '{p.name}'", f"the bounds [{p.lower:g}, {p.upper:g}] span more than "
                                                 f"{MAX_NORMALIZED_BOUND:g} reference values ({p.reference:g}); "
                                                 "give a reference value near the expected size (Eq. 12)")


def _nominal_figures(cfg, directions: dict, n_modes: int = 6) -> str:
    """The nominal model's first flexible frequencies and, when its DOFs are named by node and
    direction (``"1203:y"``, an imported FE model), the mass moving with each translation: what
    to compare with the FE code's own modal analysis. ``directions``: oblique DOF -> unit
    vector (3,) (`_oblique_directions`)."""
    from vibupdate.modal.analysis import flexible_modes
    from vibupdate.model.fe.oblique import translation_masses

    M, K = cfg.model.matrices()
    try:
        # one above the highest mode the data name, as `model_frequencies` asks of the nominal
        # model later in the run: its sparse solve then reuses this one (`vibupdate.modal.eigen`)
        top = max([len(cfg.natural)] + [f.mode or 0 for f in cfg.natural])
        omega = flexible_modes(M, K, max(n_modes, top + 1), precision=cfg.model.matrix_precision)[0][:n_modes]
        text = (f"{cfg.name}: nominal model's first flexible frequencies "
                + ", ".join(f"{w / TWO_PI:.6g}" for w in omega) + " Hz")
    except (ValueError, np.linalg.LinAlgError) as exc:
        text = f"{cfg.name}: nominal frequencies not computed ({exc})"
    try:
        masses = {a: m for a, m in translation_masses(M, cfg.model.dofs, directions).items() if m is not None}
    except ValueError as exc:
        return text + f"; mass moving with a unit translation not computed: {exc}"
    if masses:
        text += "; mass moving with a unit translation " + ", ".join(f"{a} {m:.6g} kg" for a, m in masses.items())
    return text


def _oblique_directions(sensors) -> dict:
    """Oblique DOF -> unit vector (3,) from the sensor map (``[model] sensors``): the direction
    a sensor reads divided by its sign."""
    from vibupdate.model.fe.oblique import OBLIQUE_DOF

    return {s["dof"]: s["sign"] * np.asarray(s["direction"], dtype=float) for s in sensors
            if OBLIQUE_DOF.match(s["dof"]) and s.get("direction") is not None}


def _nominal_natural(cfg):
    """The nominal model's frequencies (rad/s) of the modes ``cfg``'s natural frequencies are
    paired with; None without data or when they cannot be computed."""
    from vibupdate.inverse.correlation import model_frequencies

    if not cfg.natural:
        return None
    try:
        return model_frequencies(cfg, zeros=False).natural   # the natural frequencies only
    except (ValueError, np.linalg.LinAlgError):
        return None


def _rad_s_warning(cfg, nominal) -> str | None:
    """A warning when the measured frequencies are ~2 pi times the nominal model's (``nominal``:
    `_nominal_natural`)."""
    if nominal is None:
        return None
    measured = np.array([f.omega for f in cfg.natural])
    n = min(len(measured), len(nominal))
    ratio = measured[:n] / np.where(nominal[:n] > 0, nominal[:n], np.nan)
    ratio = ratio[np.isfinite(ratio)]
    if not ratio.size:
        return None
    typical = float(np.median(ratio))
    if abs(math.log(typical / TWO_PI)) < math.log(RAD_S_FACTOR):
        return (f"configuration '{cfg.name}': the measured natural frequencies are {typical:.2f} times the "
                "nominal model's, close to 2 pi: are they in rad/s? The case file takes Hz")
    return None


def _check_pairing(cfg, nominal, error) -> None:
    """Natural frequencies that declare no mode (read as modes 1, 2, ...) paired with model
    modes far below them (`PAIRING_FACTOR`; ``nominal``: `_nominal_natural`)."""
    for k, (f, w) in enumerate(zip(cfg.natural, nominal), start=1):
        if w > 0 and f.omega > PAIRING_FACTOR * w:
            raise error(f"configuration '{cfg.name}'",
                        f"natural frequency {k} ({f.freq_hz:.6g} Hz) declares no model mode, so it is read as mode "
                        f"{k}, which the nominal model has at {w / TWO_PI:.3g} Hz ({f.omega / w:.0f} times lower: a "
                        "near-rigid or suspension mode?); say which model mode each frequency is (natural_modes, or "
                        "a mode column in the CSV table)")


def _repeated_warnings(cfg) -> list[str]:
    """A note per pair of equal measured natural frequencies: they are read as the two modes of
    a repeated frequency, which a frequency typed twice also looks like."""
    out = []
    for a, b in zip(cfg.natural, cfg.natural[1:]):
        if a.omega == b.omega:
            out.append(f"configuration '{cfg.name}': modes {a.mode} and {b.mode} are both measured at "
                       f"{a.freq_hz:.6g} Hz, equal frequencies taken as the modes of a repeated frequency; "
                       "if one value was given twice, remove it")
    return out


def _physical(case, error) -> tuple[list[str], list[str], int, object]:
    """M and K at the nominal point and at corners of the box; returns notes, warnings, the
    most rigid-body modes of a configuration, and the case with the solver's bounds (the same
    case unless a corner is not admissible, `vibupdate.model.physical.physical_box`)."""
    from dataclasses import replace

    from vibupdate.model.physical import box_corners, definiteness, physical_box

    notes, warnings, rigid_all = [], [], 0
    lower, upper = case.configurations[0].model.bounds()
    lower, upper = lower.copy(), upper.copy()
    for cfg in case.configurations:
        model = cfg.model
        key = f"configuration '{cfg.name}'" if len(case.configurations) > 1 else "model"
        found = definiteness(*model.matrices(), model.matrix_precision)
        if found.problem:
            raise error(key, f"the nominal model is not physical: {found.problem}")
        box = physical_box(model, found.rigid_body_modes, lambda up, m=model: _describe(m, up))
        if box.changed:
            warnings.append(f"{key}: the parameter bounds reach models that are not physical; "
                            + "; ".join(box.findings))
            lower, upper = np.maximum(lower, box.lower), np.minimum(upper, box.upper)
        rigid_all = max(rigid_all, found.rigid_body_modes)
        text = (f"{cfg.name}: {model.n_dofs} DOFs"
                + (f" and {len(model.sensors)} sensor(s) reading combinations of them" if model.sensors else "")
                + f", {found.rigid_body_modes} rigid-body mode(s)"
                + (f", {len(found.massless)} DOF(s) without mass ({_massless_path(model.n_dofs)})"
                   if found.massless else ", M positive definite")
                + f"; M, K checked at the nominal point and {len(box_corners(*model.bounds()))} corners of the "
                  "parameter box")
        notes.append(text)
        notes.append(_nominal_figures(cfg, _oblique_directions(getattr(case, "sensors", ()))))
    if not warnings:
        return notes, warnings, rigid_all, case
    parameters = tuple(replace(p, lower=min(p.nominal + lo * p.reference, p.nominal),
                               upper=max(p.nominal + hi * p.reference, p.nominal))
                       for p, lo, hi in zip(case.configurations[0].model.parameters, lower, upper))
    configurations = tuple(replace(c, model=replace(c.model, parameters=parameters)) for c in case.configurations)
    return notes, warnings, rigid_all, replace(case, configurations=configurations)


def _massless_path(n_dofs: int) -> str:
    """How the eigen-solvers treat massless DOFs at this model size."""
    from vibupdate.modal.analysis import DENSE_LIMIT

    if n_dofs <= DENSE_LIMIT:
        return f"condensed statically by the dense eigen-solver, up to {DENSE_LIMIT} DOFs"
    return "shift-invert eigen-solves: only K - sigma M is factorized, M is never inverted"


def _describe(model, up) -> str:
    names = model.parameter_names
    if up.all():
        return "every parameter at its upper bound"
    if not up.any():
        return "every parameter at its lower bound"
    high = [n for n, u in zip(names, up) if u]
    low = [n for n, u in zip(names, up) if not u]
    few, side = (high, "upper") if len(high) <= len(low) else (low, "lower")
    other = "lower" if side == "upper" else "upper"
    shown = ", ".join(few[:8]) + (", ..." if len(few) > 8 else "")
    return f"{shown} at the {side} bound and the others at the {other}"


def validate_case(case) -> CaseCheck:
    """Validate a loaded case as a run would, without solving.

    Parameters
    ----------
    case : vibupdate.io.case.Case

    Returns
    -------
    CaseCheck

    Raises
    ------
    ValueError
        ``"FILE: KEY: message"`` for the first problem found.
    """
    from vibupdate.data.measured import validate_configurations
    from vibupdate.inverse.update import prepare_first_stage

    from pathlib import Path

    from vibupdate.io.case_keys import Where

    error = Where(case.path if case.path is not None else Path("case")).error
    if case.configurations and not case.configurations[0].model.n_parameters:   # none: validate_configurations says
        raise error("parameter", "the case updates no parameter: declare a [[parameter]], or let `vibupdate suggest` "
                                 f"choose among its {len(case.candidates)} [[candidate]]s")
    tol = case.frequency_tolerance
    if not finite(tol) or not 0 <= tol < 1:
        raise error("frequency_tolerance", f"must be a finite relative half-width in [0, 1), got {tol!r}")
    try:
        validate_configurations(case.configurations)
    except ValueError as exc:
        raise error("configuration", str(exc)) from None
    _check_bounds(case.configurations[0].model, error)
    for cfg in case.configurations:
        _check_order(cfg, error)
        _check_data(cfg, error)
        _check_mass_scale(cfg, error)
    notes, physical_warnings, rigid, case = _physical(case, error)
    nominal = {cfg.name: _nominal_natural(cfg) for cfg in case.configurations}
    for cfg in case.configurations:
        if cfg.name in getattr(case, "undeclared_modes", ()) and nominal[cfg.name] is not None:
            _check_pairing(cfg, nominal[cfg.name], error)
    warnings = physical_warnings + _check_damping(case, rigid, error)
    warnings += [w for w in (_rad_s_warning(c, nominal[c.name]) for c in case.configurations) if w]
    warnings += [w for c in case.configurations for w in _repeated_warnings(c)]
    warnings += [f"configuration '{name}' FRFs: {note}" for name, notes in case.frf_notes.items()
                 for note in notes]
    warnings += [f"configuration '{name}': {note}" for name, notes in case.frequency_notes.items()
                 for note in notes]
    try:
        prepared = prepare_first_stage(case.configurations, case.formulation, case.verify_options())
    except ValueError as exc:
        raise error("configuration", str(exc)) from None
    return CaseCheck(prepared.problem.sizes(), tuple(notes), tuple(warnings), prepared, case)
