"""The measured-data map: the model's value of every measured quantity, and its exact Jacobian.

A configuration measures four kinds of quantity: the natural frequencies of its declared
modes, the declared antiresonances of its receptances (`vibupdate.data.pairing`), the shape
ratios ``phi_j / phi_p`` of each measured mode at its measured DOFs or sensors (a sensor's
reading is a combination ``w^T phi``, `vibupdate.model.measurement`), ``p`` the entry of largest
measured magnitude (`vibupdate.data.measured.ShapeInterval.reference`), and, of a
mass-normalized measured shape, the modal mass ``1 / phi_p^2`` at that entry (kg). As functions of the
normalized parameters they are the data map ``d(xbar)``; with its exact Jacobian
``G = d d / d xbar`` (`vibupdate.modal.sensitivities`) it is what the polish fits
(`vibupdate.inverse.admissible.residuals`), what the sensitivity reports (`sensitivity`) and
what the linearized ranges bound (`vibupdate.ranges.identifiability`).

It is evaluated here and nowhere else, so that those three agree on which model value is
paired with which datum, in which order, and from which solves: one eigen-solve for the modes
(`vibupdate.inverse.correlation.model_frequencies`), one adjunct eigen-solve per receptance for
the zeros and their derivatives together, one factorization per measured shape for its ratio
derivatives (kept on large models for the next caller at the same point).

Order of one configuration's data: the natural frequencies as declared, the antiresonances as
declared, then the shape ratios mode by mode in the order of the measured DOFs, without the
reference entry (its ratio is 1 at every point and carries no information), then the modal
masses mode by mode.
"""

from __future__ import annotations

import weakref
from collections.abc import Sequence
from dataclasses import dataclass, field
from functools import partial

import numpy as np
import scipy.sparse as sp

from vibupdate.data.measured import Configuration
from vibupdate.inverse.correlation import ModelFrequencies, declared_zeros, model_frequencies
from vibupdate.inverse.repeated import paired_vector
from vibupdate.modal.readings import ratio_derivatives, readings
from vibupdate.modal.sensitivities import (frequency_derivatives, modal_mass_derivatives, ratio_solutions,
                                           shape_ratio_derivatives)


@dataclass(frozen=True)
class MeasuredShape:
    """A measured mode shape as ratios to its reference entry.

    Attributes
    ----------
    position : int
        Of the mode in ``Configuration.natural`` (0-based).
    reference : ndarray of int, shape (1,), or csr_matrix, shape (1, n)
        Measurement map of the denominator ``p``: its DOF index, or a sensor's weights
        (`_reading_map`; either is read by `vibupdate.modal.readings.readings`).
    entries : ndarray of int, shape (n_e,), or csr_matrix, shape (n_e, n)
        Measurement map of the ratios' numerators ``j``: the other measured DOFs or sensors, in
        their measured order (`vibupdate.model.AffineModel.measurement`): their DOF indices
        where all are DOFs, else the sparse map.
    lower, upper : ndarray, shape (n_e,)
        Measured interval of each ratio (`vibupdate.data.measured.ShapeInterval.ratio_bounds`).
    mass : (float, float) or None
        Of a mass-normalized shape, the measured interval of the modal mass at ``reference``, kg
        (`vibupdate.data.measured.ShapeInterval.modal_mass_bounds`).
    """

    position: int
    reference: sp.csr_matrix
    entries: sp.csr_matrix
    lower: np.ndarray
    upper: np.ndarray
    mass: tuple[float, float] | None = None

    @property
    def midpoint(self) -> np.ndarray:
        return 0.5 * (self.lower + self.upper)

    @property
    def half_width(self) -> np.ndarray:
        return 0.5 * (self.upper - self.lower)


def measured_shapes(cfg: Configuration) -> list[MeasuredShape]:
    """The measured shapes of ``cfg`` that give a ratio (two measured DOFs or more) or a modal
    mass, in the order of ``cfg.natural``.

    They depend on the configuration's data and its model's measurement map only, never on the
    point: built once per configuration and kept while it lives (`_KEPT_SHAPES`), so that every
    evaluation of a run (the polish's, the uniqueness probes', the verification's, the ranges')
    reads the same measurement maps and intervals."""
    kept = _KEPT_SHAPES.get(id(cfg))
    if kept is None or kept[0]() is not cfg:
        kept = (weakref.ref(cfg, partial(_forget_shapes, id(cfg))), tuple(_build_shapes(cfg)))
        _KEPT_SHAPES[id(cfg)] = kept
    return list(kept[1])


#: `measured_shapes` of each living configuration, by its id: (weak reference, shapes). An
#: entry goes when its configuration is collected (a frozen `Configuration` holds dicts, so it
#: cannot be a dict key itself).
_KEPT_SHAPES: dict[int, tuple] = {}


def _forget_shapes(key: int, ref) -> None:
    if _KEPT_SHAPES.get(key, (None,))[0] is ref:
        _KEPT_SHAPES.pop(key, None)


def _build_shapes(cfg: Configuration) -> list[MeasuredShape]:
    out = []
    for k, f in enumerate(cfg.natural):
        if f.shape is None or (len(f.shape.bounds) < 2 and not f.shape.mass_normalized):
            continue
        ratios = f.shape.ratio_bounds()
        lower, upper = np.array(list(ratios.values())).reshape(-1, 2).T
        lower.flags.writeable = upper.flags.writeable = False   # kept and shared: read-only
        out.append(MeasuredShape(k, _reading_map(cfg.model, [f.shape.reference]),
                                 _reading_map(cfg.model, list(ratios)), lower, upper, f.shape.modal_mass_bounds()))
    return out


def _reading_map(model, names: list):
    """The measurement map of ``names`` (`vibupdate.model.AffineModel.measurement`) as
    `vibupdate.modal.readings.readings` takes it: the DOF indices, shape (len(names),), where
    every name is a plain DOF (each row a unit row: reading it is indexing, exact, on a model
    of any size); the sparse map where a sensor combines DOFs."""
    S = model.measurement(names)
    if np.all(np.diff(S.indptr) == 1) and np.all(S.data == 1.0):
        index = S.indices.astype(np.intp)
        index.flags.writeable = False
        return index
    return S


@dataclass(frozen=True)
class DataMap:
    """One configuration's measured quantities as the model gives them at one point.

    Attributes
    ----------
    natural : ndarray, shape (n_p,)
        rad/s, the declared modes of ``Configuration.natural``.
    zeros : ndarray, shape (n_z,)
        rad/s, the declared zeros of ``Configuration.antiresonances``; NaN where the model
        lacks the zero.
    shapes : tuple of MeasuredShape
        The measured shapes the ratios belong to (`measured_shapes`); empty when not asked for.
    ratios : tuple of ndarray
        Per shape, ``(entries @ phi) / (reference @ phi)`` of the paired model mode, shape (n_e,);
        for a mode of a repeated frequency, of the combination of its modes that fits the
        measured shape best (`vibupdate.inverse.repeated.paired_vector`).
    frequencies : ModelFrequencies
        The eigen-solution the values come from.
    natural_jacobian : ndarray, shape (n_p, n_x), or None
        ``d natural / d xbar``, rad/s per unit of normalized parameter; None without a Jacobian.
    zero_jacobian : ndarray, shape (n_z, n_x), or None
        ``d zeros / d xbar``, NaN rows where the model lacks the zero.
    ratio_jacobians : tuple of ndarray
        Per shape, ``d ratios / d xbar``, shape (n_e, n_x); empty without a Jacobian.
    masses : ndarray, shape (n_m,)
        kg, the modal masses of the shapes with a measured ``mass``, in their order.
    mass_jacobian : ndarray, shape (n_m, n_x), or None
        ``d masses / d xbar``; None without a Jacobian.
    vectors : tuple of ndarray
        With ``vectors=True``: the vectors the evaluation computed, each shape (n, .): every
        computed flexible mode, the rigid-body modes, per receptance the right and left
        adjunct vectors (zero at the removed entry), per shape the ratio-derivative solutions
        (`vibupdate.modal.sensitivities.shape_ratio_derivatives`). They span the reduced model
        of the polish's rounds.
    """

    natural: np.ndarray
    zeros: np.ndarray
    shapes: tuple[MeasuredShape, ...]
    ratios: tuple[np.ndarray, ...]
    frequencies: ModelFrequencies
    natural_jacobian: np.ndarray | None = None
    zero_jacobian: np.ndarray | None = None
    ratio_jacobians: tuple[np.ndarray, ...] = ()
    vectors: tuple[np.ndarray, ...] = ()
    masses: np.ndarray = field(default_factory=lambda: np.zeros(0))
    mass_jacobian: np.ndarray | None = None

    @property
    def frequency_values(self) -> np.ndarray:
        """The natural frequencies, then the zeros, shape (n_p + n_z,), rad/s."""
        return np.concatenate([self.natural, self.zeros])

    @property
    def frequency_jacobian(self) -> np.ndarray:
        """Their Jacobian, shape (n_p + n_z, n_x)."""
        return np.concatenate([self.natural_jacobian, self.zero_jacobian])

    def values(self) -> np.ndarray:
        """Every datum in the module's order, shape (n_data,)."""
        return np.concatenate([self.natural, self.zeros, *self.ratios, self.masses])

    def jacobian(self) -> np.ndarray:
        """``d values / d xbar``, shape (n_data, n_x)."""
        n_x = self.natural_jacobian.shape[1]
        return np.vstack([self.natural_jacobian, self.zero_jacobian, *self.ratio_jacobians,
                          np.zeros((0, n_x)) if self.mass_jacobian is None else self.mass_jacobian])


def data_map(cfg: Configuration, xbar, *, jacobian: bool = True, shapes: bool = True, vectors: bool = False,
             freqs: ModelFrequencies | None = None) -> DataMap:
    """The measured quantities of ``cfg`` at ``xbar`` and, with ``jacobian``, their exact
    derivatives.

    Parameters
    ----------
    cfg : Configuration
    xbar : ndarray, shape (n_x,)
    jacobian : bool
        Also the derivatives. Without them the zeros come from the antiresonance solver of
        `vibupdate.modal.analysis`; with them from the adjunct eigen-solve that gives their
        derivatives too.
    shapes : bool
        Also the shape ratios (the polish without shape weight does not need them, nor their
        factorizations).
    vectors : bool
        Keep the vectors the evaluation computed (`DataMap.vectors`); with ``jacobian`` only.
    freqs : ModelFrequencies, optional
        `model_frequencies` of ``cfg`` at ``xbar`` when the caller has them; their zeros and
        zero derivatives are used where present (``derivatives=True``).
    """
    xbar = np.asarray(xbar, dtype=float)
    model = cfg.model
    freqs = freqs or model_frequencies(cfg, xbar, zeros=not jacobian)   # with a Jacobian, zeros come with it
    zeros, natural_jacobian, zero_jacobian = freqs.antiresonances, None, None
    found = [freqs.Phi_all, freqs.rigid] if vectors else []
    if jacobian:
        natural_jacobian = frequency_derivatives(model, freqs.natural, freqs.Phi)
        if freqs.zero_derivatives is not None and not vectors:
            zero_jacobian = freqs.zero_derivatives
        else:
            zeros, zero_jacobian, _, pairs = declared_zeros(cfg, xbar, *model.solver_matrices(xbar))
            for (r, c), (_, right, left) in zip(cfg.receptances(), pairs if vectors else ()):
                found += [np.insert(right, model.dof(r), 0.0, axis=0), np.insert(left, model.dof(c), 0.0, axis=0)]
    measured = tuple(measured_shapes(cfg)) if shapes else ()
    ratios, ratio_jacobians, masses, mass_jacobian = [], [], [], []
    M = model.solver_matrices(xbar)[0] if any(s.mass is not None for s in measured) else None   # once, for the masses
    paired = [paired_vector(cfg, freqs.Phi_all, freqs.omega_all, s.position) for s in measured]
    simple = [k for k, (_, near) in enumerate(paired) if near.size == 1] if jacobian else []
    batch = (ratio_solutions(model, xbar, freqs.natural[[measured[k].position for k in simple]],
                             np.column_stack([paired[k][0] for k in simple])) if len(simple) > 1 else None)
    solved = {} if batch is None else dict(zip(simple, batch))   # every simple mode in one solve (dense models)
    for k, s in enumerate(measured):
        phi, near = paired[k]
        ref = readings(phi, s.reference)
        ratios.append(readings(phi, s.entries) / ref)
        if s.mass is not None and not jacobian:   # q^T M q, q = phi / phi_p: 1 / phi_p^2 of a mass-normalized mode
            q = phi / ref
            masses.append(float(q @ (M @ q)))
        if jacobian:
            basis = freqs.Phi_all[:, near] if near.size > 1 else None
            if k in solved:
                out = (ratio_derivatives(solved[k], phi, s.entries, s.reference), solved[k])
            else:
                out = shape_ratio_derivatives(model, xbar, freqs.natural[s.position], phi, s.entries, s.reference,
                                              vectors=vectors or s.mass is not None, basis=basis)
            D = out[0] if isinstance(out, tuple) else out
            ratio_jacobians.append(D if basis is None else _refitted(D, readings(basis, s.entries),
                                                                       readings(basis, s.reference)[0]))
            if vectors:
                found.append(out[1])
            if s.mass is not None:
                mass, derivative = modal_mass_derivatives(model, M, phi, s.reference, out[1])
                masses.append(mass)
                mass_jacobian.append(derivative)
    n_x = xbar.size
    return DataMap(freqs.natural, zeros, measured, tuple(ratios), freqs, natural_jacobian, zero_jacobian,
                   tuple(ratio_jacobians), tuple(found), np.array(masses, dtype=float),
                   np.array(mass_jacobian).reshape(-1, n_x) if jacobian else None)


def _refitted(D: np.ndarray, U_entries: np.ndarray, u_reference: np.ndarray) -> np.ndarray:
    """The derivative ``D`` (n_e, n_x) of the ratios of a fixed combination of a repeated
    frequency's modes, made that of the best combination's: the combination is chosen again at
    every point, which takes out the part of a change that another combination's ratios can
    follow, the span of ``U_entries N`` (``N``: the combinations keeping the reference entry,
    ``u_reference c = 0``). Exact where the best combination fits its data (the polish's
    solution with point data); the least-squares step's linearization elsewhere."""
    import scipy.linalg as sla

    W = U_entries @ sla.null_space(u_reference[None, :])
    if not W.size:
        return D
    Q = sla.orth(W)
    return D - Q @ (Q.T @ D)


def data_jacobian(configurations: Sequence[Configuration], xbar, *,
                  freqs: Sequence[ModelFrequencies | None] | None = None):
    """The data map of every configuration at ``xbar`` and its exact Jacobian, stacked.

    ``freqs``: `model_frequencies` of each configuration at ``xbar`` with ``derivatives=True``
    when the caller has them (`UpdateResult.correlation`): no eigen-solve is repeated.

    Returns
    -------
    d : ndarray, shape (n_data,)
        Per configuration, in the module's order: frequencies (rad/s), then shape ratios.
    G : ndarray, shape (n_data, n_x)
        ``d d / d xbar``.
    """
    freqs = list(freqs) if freqs is not None else [None] * len(configurations)
    maps = [data_map(c, xbar, freqs=f) for c, f in zip(configurations, freqs)]
    return np.concatenate([m.values() for m in maps]), np.vstack([m.jacobian() for m in maps])


@dataclass(frozen=True)
class Sensitivity:
    """The exact relative sensitivity of the measured data at one point (`sensitivity`).

    Attributes
    ----------
    matrix : ndarray, shape (n_data, n_x)
        ``S``, rows of NaN (a zero the model lacks) left out.
    singular_values : ndarray, shape (min(n_data, n_x),)
    condition : float
        Largest over smallest singular value (inf when fewer than ``n_x`` or a zero one).
    rank : int
    column_norm : ndarray, shape (n_x,)
        Norm of each parameter's column.
    null_directions : ndarray, shape (n_x - rank, n_x)
        Unit combinations of normalized parameters that leave every datum unchanged to first
        order, each with its largest entry positive.
    """

    matrix: np.ndarray
    singular_values: np.ndarray
    condition: float
    rank: int
    column_norm: np.ndarray
    null_directions: np.ndarray


def sensitivity(configurations: Sequence[Configuration], xbar, *, rtol: float = 1e-8,
                freqs: Sequence[ModelFrequencies] | None = None) -> Sensitivity:
    """Sensitivity of the measured data to the normalized parameters.

    ``S[k, i] = d w_k / d xbar_i / w_k`` over every measured natural frequency and
    antiresonance of every configuration, then ``d (phi_j / phi_p) / d xbar_i`` of every
    measured shape ratio, then ``d m / d xbar_i / m`` of every measured modal mass
    (`data_map`); all exact. Its singular values tell how many parameter
    combinations the data determine; the right singular vectors of the (near-)zero singular
    values are the combinations the data cannot see.

    Parameters
    ----------
    rtol : float
        Singular values below ``rtol`` times the largest count as zero (the derivatives are
        exact, so an exact symmetry gives values at rounding level, ~1e-15).
    freqs : sequence of ModelFrequencies, optional
        `model_frequencies` of each configuration at ``xbar``, when already computed.

    Returns
    -------
    Sensitivity
    """
    xbar = np.asarray(xbar, dtype=float)
    n_x = xbar.size
    freqs = list(freqs) if freqs is not None else [None] * len(configurations)
    maps = [data_map(c, xbar, freqs=f) for c, f in zip(configurations, freqs)]
    S = np.vstack([m.frequency_jacobian / m.frequency_values[:, None] for m in maps]
                  + [np.zeros((0, n_x))]   # a block for vstack where nothing was measured
                  + [D for m in maps for D in m.ratio_jacobians]
                  + [m.mass_jacobian / m.masses[:, None] for m in maps if m.masses.size])
    S = S[np.all(np.isfinite(S), axis=1)]
    if S.size:
        _, sv, Vt = np.linalg.svd(S)   # full_matrices: Vt is n_x x n_x, its last rows span the null space
    else:
        sv, Vt = np.array([]), np.eye(n_x)
    rank = int(np.sum(sv > rtol * sv[0])) if sv.size and sv[0] > 0 else 0
    null = Vt[rank:]
    null = null * np.sign(null[np.arange(null.shape[0]), np.argmax(np.abs(null), axis=1)])[:, None]
    return Sensitivity(S, sv, float(sv[0] / sv[-1]) if sv.size and sv[-1] > 0 and sv.size >= n_x else float("inf"),
                       rank, np.linalg.norm(S, axis=0), null)


def describe_direction(names, v, *, threshold: float = 0.05) -> str:
    """A null direction of `sensitivity` as text, e.g. ``+0.58 rho +0.58 E -0.58 m1``
    (normalized units)."""
    terms = [(abs(c), f"{c:+.2f} {n}") for n, c in zip(names, v) if abs(c) >= threshold]
    return " ".join(t for _, t in sorted(terms, reverse=True)) or "(none)"
