"""Correlation of a model with measured data: paired frequencies, errors (Eq. 26), MAC.

Pairing follows the declared correspondence (`vibupdate.data.pairing`): the measured natural
frequency of mode ``m`` is compared with the model's ``m``-th flexible mode (rigid-body modes,
at 0 rad/s, are not counted), the measured
antiresonance ``j`` of ``h_rc`` with the model's ``j``-th zero of ``h_rc``; never by nearness.
Where the model has no such zero the paired value is NaN.

The same pairing as a vector of data with its exact Jacobian, for the polish, the sensitivity
and the ranges: `vibupdate.inverse.data_map`.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from vibupdate.modal.analysis import DENSE_LIMIT, antiresonances, flexible_modes, mac, modes
from vibupdate.modal.kept import Kept
from vibupdate.data.measured import TWO_PI, Configuration
from vibupdate.data.names import frequency_name, receptance_name


@dataclass(frozen=True)
class ModelFrequencies:
    """Model frequencies paired with one configuration's measured data.

    Attributes
    ----------
    natural : ndarray, shape (n_p,)
        rad/s, the declared modes of ``Configuration.natural``.
    antiresonances : ndarray, shape (n_z,)
        rad/s, the declared zeros of ``Configuration.antiresonances`` (NaN where missing).
    Phi : ndarray, shape (n, n_p)
        Mass-normalized model modes paired with the natural frequencies.
    omega_all : ndarray, shape (n_m,)
        Every computed flexible model frequency, rad/s, ascending (at least one above the
        highest declared mode when the model has it); ``omega_all[m - 1]`` is mode ``m``.
    Phi_all : ndarray, shape (n, n_m)
    zeros_all : dict of (str, str) to ndarray
        Every real zero of each measured receptance, rad/s, ascending.
    spectrum : (ndarray, ndarray) or None
        Every finite mode, ``(omega, Phi)`` of shapes (n_f,) rad/s and (n, n_f), on the dense
        path, where the eigen-solve computes them all anyway (later stages that need the whole
        spectrum, such as the Caughey ``C``, read it instead of solving again); None on the
        sparse path.
    zero_derivatives : ndarray, shape (n_z, n_x), or None
        ``d antiresonances / d xbar`` (rad/s per unit of normalized parameter, NaN rows where
        the model lacks the zero), when asked for (``derivatives=True``).
    rigid : ndarray, shape (n, n_r)
        The model's rigid-body modes (0 rad/s, mass-normalized), which the mode numbers skip.
    """

    natural: np.ndarray
    antiresonances: np.ndarray
    Phi: np.ndarray
    omega_all: np.ndarray = field(default_factory=lambda: np.zeros(0))
    Phi_all: np.ndarray = field(default_factory=lambda: np.zeros((0, 0)))
    zeros_all: dict = field(default_factory=dict)
    spectrum: tuple | None = None
    zero_derivatives: np.ndarray | None = None
    rigid: np.ndarray = field(default_factory=lambda: np.zeros((0, 0)))


@dataclass(frozen=True)
class Correlation:
    """An answer's model and the nominal model, each paired with the measured data of every
    configuration: what the tables of the results (Hz rows, MAC, modal masses) are built from
    (`vibupdate.io.results`) and what later stages read instead of solving the same matrices
    again.

    Attributes
    ----------
    configurations : tuple of Configuration
    xbar : ndarray, shape (n_x,)
        The answer (normalized parameters, Eq. 12).
    nominal : tuple of ModelFrequencies
        `model_frequencies` of each configuration at the nominal point, in their order.
    updated : tuple of ModelFrequencies
        The same at ``xbar``, with the zeros' derivatives (modes, every mode on the dense path
        in ``spectrum``).
    """

    configurations: tuple[Configuration, ...]
    xbar: np.ndarray
    nominal: tuple[ModelFrequencies, ...]
    updated: tuple[ModelFrequencies, ...]

    def errors(self, kind: str | None = None, *, which: str = "updated", finite: bool = True) -> np.ndarray:
        """`percent_error` of the ``"updated"`` (or ``"nominal"``) model's declared frequencies,
        of one ``kind`` (``"natural"``, ``"antiresonance"``) when given, in the order of the
        frequency table; only the finite ones unless ``finite=False`` (then NaN where the model
        lacks a zero)."""
        if which not in ("updated", "nominal"):
            raise ValueError(f"which model's errors: 'updated' or 'nominal', got {which!r}")
        out = [np.zeros(0)]
        for cfg, f in zip(self.configurations, getattr(self, which)):
            for name, data, model in (("natural", cfg.natural, f.natural),
                                      ("antiresonance", cfg.antiresonances, f.antiresonances)):
                if kind in (None, name) and data:
                    out.append(percent_error(model, [d.omega for d in data]))
        e = np.concatenate(out)
        return e[np.isfinite(e)] if finite else e


def percent_error(model, measured) -> np.ndarray:
    """Absolute relative error in per cent, Eqs. 26-27."""
    model, measured = np.asarray(model, dtype=float), np.asarray(measured, dtype=float)
    return 100.0 * np.abs(model - measured) / np.abs(measured)


def declared_errors(configurations, freqs) -> dict[str, np.ndarray]:
    """`percent_error` of the declared natural frequencies and zeros (``freqs``: the paired
    `ModelFrequencies` per configuration), by kind, ``inf`` where the model lacks one."""
    out = {}
    for kind, data, model in (("natural", "natural", "natural"), ("antiresonance", "antiresonances", "antiresonances")):
        measured = np.array([d.omega for c in configurations for d in getattr(c, data)], dtype=float)
        values = np.concatenate([np.asarray(getattr(f, model), dtype=float) for f in freqs] or [np.zeros(0)])
        errors = percent_error(values, measured) if measured.size else measured
        out[kind] = np.where(np.isfinite(errors), errors, np.inf)
    return out


def mean_max(errors) -> tuple[float, float]:
    """Mean and largest of per-cent errors; NaN, NaN without any."""
    errors = np.asarray(errors, dtype=float)
    return (float(np.mean(errors)), float(np.max(errors))) if errors.size else (float("nan"), float("nan"))


def zeros_wanted(cfg: Configuration, rc) -> int | None:
    """How many of the lowest zeros of ``h_rc`` a large model must give (one above the highest
    declared); None (all) for models on the dense path."""
    if cfg.model.n_dofs <= DENSE_LIMIT:
        return None
    top = max(a.index for a in cfg.antiresonances if a.receptance == rc)
    return min(top + 1, cfg.model.n_dofs - 1)


#: The most recent spectra of models on the dense path, by (model, point): one run asks
#: `model_frequencies` for the same point in several stages (the polish's answer again in the
#: verification and the sensitivity, the nominal model in the validation, the formulation and
#: the update), and for configurations that share a model (the diagnosis's data without one
#: group, `vibupdate.inverse.diagnosis.without`). Their arrays are read-only.
_SPECTRA = Kept(32, 64 * 2**20)


def _spectrum(cfg: Configuration, xbar, M, K) -> tuple:
    """``modes(M, K)`` of ``cfg.model`` at ``xbar`` (every mode of the dense path), solved once
    among the most recent of the same model object at the same point (`_SPECTRA`): the spectrum
    is the model's, whichever data a configuration pairs with it."""
    model = cfg.model
    point = np.zeros(model.n_parameters) if xbar is None else np.asarray(xbar, dtype=float)
    key = (id(model), point.tobytes())
    kept = _SPECTRA.get(key)
    if kept is not None and kept[0] is model:   # the object itself: its id is not reused while it is kept
        return kept[1]
    spectrum = modes(M, K, precision=model.matrix_precision)
    for part in spectrum:
        part.flags.writeable = False
    _SPECTRA.put(key, (model, spectrum), spectrum[0].nbytes + spectrum[1].nbytes)
    return spectrum


def model_frequencies(cfg: Configuration, xbar=None, *, zeros: bool = True,
                      derivatives: bool = False) -> ModelFrequencies:
    """Frequencies of ``cfg.model`` at ``xbar`` (nominal if None), paired with the data by the
    declared modes and zero indices. ``zeros=False`` skips the antiresonances (NaN, and
    ``zeros_all`` empty): for callers that take them with their derivatives from
    `declared_zeros`, which solves the same adjunct eigenproblem. ``derivatives=True`` takes
    the zeros from that solve and keeps their derivatives (``zero_derivatives``): one adjunct
    eigen-solve per receptance for both. On the dense path the modes of the same model object at
    the same point are solved once among the most recent (`_spectrum`; the ``spectrum`` arrays
    read-only)."""
    M, K = cfg.model.solver_matrices(xbar)
    precision = cfg.model.matrix_precision
    declared = [f.mode for f in cfg.natural]
    mode_index = np.array(declared, dtype=int) - 1
    top = max(declared, default=0)
    n_modes = min(cfg.model.n_dofs, max(top + 1, 2))
    spectrum = None
    if cfg.model.n_dofs <= DENSE_LIMIT:    # the dense solve gives every mode: keep them
        spectrum = _spectrum(cfg, xbar, M, K)
        flexible = spectrum[0] != 0        # rigid-body modes are exactly 0 (`vibupdate.modal.rigid`)
        rigid = spectrum[1][:, ~flexible]
        if top > np.count_nonzero(flexible):
            raise ValueError(f"configuration {cfg.name!r}: mode {top} is declared, but the model has "
                             f"{np.count_nonzero(flexible)} finite modes besides its {rigid.shape[1]} rigid-body "
                             f"mode(s) ({cfg.model.n_dofs} DOFs, some perhaps without mass)")
        omega, Phi = spectrum[0][flexible][:n_modes], spectrum[1][:, flexible][:, :n_modes]
    else:
        omega, Phi, rigid = flexible_modes(M, K, n_modes, precision=precision)
    paired = np.full(len(cfg.antiresonances), np.nan)
    slopes = None
    zeros_all = {}
    if derivatives:
        paired, slopes, zeros_all, _ = declared_zeros(cfg, xbar, M, K)
    for rc in (cfg.receptances() if zeros and not derivatives else ()):
        wanted = zeros_wanted(cfg, rc)
        if (rc[1], rc[0]) in zeros_all and wanted == zeros_wanted(cfg, (rc[1], rc[0])):
            model_z = zeros_all[(rc[1], rc[0])]   # h_cr = h_rc: the same zeros (`declared_zeros`)
        else:
            model_z = antiresonances(M, K, cfg.model.dof(rc[0]), cfg.model.dof(rc[1]), n_zeros=wanted,
                                     precision=precision)
        zeros_all[rc] = model_z
        for i, a in enumerate(cfg.antiresonances):
            if a.receptance == rc and a.index <= model_z.size:
                paired[i] = model_z[a.index - 1]
    return ModelFrequencies(omega[mode_index], paired, Phi[:, mode_index], omega, Phi, zeros_all, spectrum, slopes,
                            rigid)


def shape_mac(cfg: Configuration, Phi: np.ndarray) -> np.ndarray:
    """MAC of each measured mode shape (interval midpoints on measured DOFs or sensors) with its paired
    model mode; NaN where no shape was measured. Shape (n_p,)."""
    out = np.full(len(cfg.natural), np.nan)
    for k, f in enumerate(cfg.natural):
        if f.shape is None or k >= Phi.shape[1]:
            continue
        mid = f.shape.midpoint
        out[k] = mac(np.array(list(mid.values())), cfg.model.measurement(list(mid)) @ Phi[:, k])[0, 0]
    return out


def frequency_rows(configurations: Sequence[Configuration], nominal: Sequence[ModelFrequencies],
                   updated: Sequence[ModelFrequencies] | None = None) -> list[dict]:
    """Rows of the ``frequencies`` table of ``results.json`` (docs/outputs.md), Hz at the edge."""
    rows = []
    for i, cfg in enumerate(configurations):
        for kind, data, attr in (("natural", cfg.natural, "natural"),
                                 ("antiresonance", cfg.antiresonances, "antiresonances")):
            nom = getattr(nominal[i], attr)
            upd = getattr(updated[i], attr) if updated is not None else None
            for k, d in enumerate(data):
                w = d.omega
                row = {
                    "configuration": cfg.name,
                    "kind": kind,
                    "index": k + 1,
                    "model_index": d.mode if kind == "natural" else d.index,
                    "receptance": None if kind == "natural" else receptance_name(*d.receptance),
                    "measured_lower_hz": None if d.interval is None else d.interval[0] / TWO_PI,
                    "measured_upper_hz": None if d.interval is None else d.interval[1] / TWO_PI,
                    "measured_hz": w / TWO_PI,
                    "nominal_hz": float(nom[k]) / TWO_PI,
                    "updated_hz": None if upd is None else float(upd[k]) / TWO_PI,
                    "error_nominal_pct": float(percent_error(nom[k], w)),
                    "error_updated_pct": None if upd is None else float(percent_error(upd[k], w)),
                }
                rows.append({**row, "name": frequency_name(row)})
    return rows


def modal_mass_rows(configurations: Sequence[Configuration], nominal: Sequence[ModelFrequencies],
                    updated: Sequence[ModelFrequencies], xbar) -> list[dict]:
    """Rows of the ``modal_masses`` table of ``results.json`` (docs/outputs.md), kg: per
    mass-normalized measured shape, the modal mass ``1 / phi_p^2`` at its reference entry
    measured (interval), nominal and updated (at ``xbar``), the errors against the interval's
    midpoint."""
    from vibupdate.inverse.repeated import paired_vector

    def modal_mass(cfg, M, m, k):   # q^T M q, q the paired vector at 1 on the reference (1 / phi_p^2)
        phi = paired_vector(cfg, m.Phi_all, m.omega_all, k)[0]
        ref = float((cfg.model.measurement([cfg.natural[k].shape.reference]) @ phi)[0])
        if ref == 0:
            return float("inf")
        q = phi / ref
        return float(q @ (M @ q))

    rows = []
    for cfg, nom, upd in zip(configurations, nominal, updated):
        if not any(f.shape is not None and f.shape.mass_normalized for f in cfg.natural):
            continue
        mass_matrices = (cfg.model.matrices()[0], cfg.model.matrices(xbar)[0])
        for k, f in enumerate(cfg.natural):
            if f.shape is None or not f.shape.mass_normalized:
                continue
            lo, hi = f.shape.modal_mass_bounds()
            mid = 0.5 * (lo + hi)
            masses = [modal_mass(cfg, M, m, k) for M, m in zip(mass_matrices, (nom, upd))]
            rows.append({"configuration": cfg.name, "mode": f.mode, "dof": f.shape.reference,
                         "measured_lower_kg": lo, "measured_upper_kg": hi, "nominal_kg": masses[0],
                         "updated_kg": masses[1], "error_nominal_pct": 100 * (masses[0] / mid - 1),
                         "error_updated_pct": 100 * (masses[1] / mid - 1)})
    return rows


def declared_zeros(cfg: Configuration, xbar, M, K):
    """The declared zeros of ``cfg`` at ``xbar`` with their exact derivatives: one adjunct
    eigen-solve per receptance for both (`vibupdate.modal.sensitivities`), one for a
    reciprocal pair ``h_rc``, ``h_cr`` measured both ways.

    Parameters
    ----------
    M, K : ndarray or sparse matrix, shape (n, n)
        ``cfg.model.solver_matrices(xbar)``.

    Returns
    -------
    values : ndarray, shape (n_z,)
        rad/s, paired with ``cfg.antiresonances``; NaN where the model lacks the zero.
    D : ndarray, shape (n_z, n_x)
        ``d values / d xbar``, rad/s per unit of normalized parameter; NaN rows likewise.
    zeros_all : dict of (str, str) to ndarray
        Every computed zero of each receptance (``zeros_all`` of `ModelFrequencies`).
    pairs : list of tuple
        Per receptance of ``cfg.receptances()``, its `adjunct_eigenpairs` (squared zeros, right
        and left vectors).
    """
    from vibupdate.modal.sensitivities import adjunct_eigenpairs, antiresonance_derivatives

    model = cfg.model
    values = np.full(len(cfg.antiresonances), np.nan)
    out = np.full((len(cfg.antiresonances), model.n_parameters), np.nan)
    zeros_all, pairs = {}, []
    done: dict = {}
    for rc in cfg.receptances():
        r, c = model.dof(rc[0]), model.dof(rc[1])
        wanted = zeros_wanted(cfg, rc)
        mirror = done.get((rc[1], rc[0]))
        if mirror is not None and mirror[0] == wanted:
            # h_cr = h_rc (M, K symmetric): the adjunct pencil of one is the transpose of the
            # other's, the same zeros with right and left vectors swapped, the same derivatives
            (eigval, right, left), z, D = mirror[1:]
            pairs.append((eigval, left, right))
        else:
            pairs.append(adjunct_eigenpairs(M, K, r, c, wanted, model.matrix_precision))
            z, D = antiresonance_derivatives(model, xbar, r, c, pairs=pairs[-1])
        done[rc] = (wanted, pairs[-1], z, D)
        zeros_all[rc] = z
        for i, a in enumerate(cfg.antiresonances):
            if a.receptance == rc and a.index <= z.size:
                values[i], out[i] = z[a.index - 1], D[a.index - 1]
    return values, out, zeros_all, pairs
