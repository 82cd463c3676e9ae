"""What the first-stage problem is: the bilinear least-squares problem of Eqs. 7, 9, 10, 16.

For every measured natural frequency (a *natural* block, Eq. 7) and every measured
antiresonance (an *antiresonance* block on the adjunct system, Eq. 9) there is one unknown
vector ``u``, and the residual

    R = D_r ( K(xbar) - w^2 M(xbar) )[rows, cols] S u
      = A0 u + sum_i xbar_i A_i u                      (M, K affine in xbar, Eq. 16)

is linear in ``u`` for fixed ``xbar`` and vice versa. Stacking every block gives

    R = A_u u + A_x xbar + A_b (xbar[prod_x] * u[prod_u]) + r0,   min sum_k w_k R_k^2

where the products ``xbar_i u_j`` are listed only for the columns ``j`` on which the matrix
of parameter ``i`` is non-zero and only for free entries (a product with a fixed entry is
linear and sits in ``A_x``). Those products are what the relaxation lifts (Section 3.3).

Choices the paper leaves open (docs/method.md, section 4):

* normalization against ``u = 0``: one entry of each vector is fixed (item 1, 2);
* rotational entries are scaled by a characteristic length ``S`` (item 3) and residual rows
  by ``D_r = diag(K0)^(-1/2)`` (Jacobi);
* default weight ``alpha = 1 / (w^2 ||D_r M0 S v0||)^2`` so that each residual approximates
  the relative eigenvalue error (item 4), times the user's weight.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field, replace

import numpy as np
import scipy.sparse as sp

from vibupdate.options import check, default
from vibupdate.modal.analysis import antiresonances
from vibupdate.inverse.correlation import model_frequencies
from vibupdate.data.measured import Configuration, validate_configurations
from vibupdate.model.parameters import Parameter

__all__ = ["FormulationOptions", "VectorBlock", "BilinearProblem", "formulate", "length_scale"]

ROTATION_PREFIXES = ("phi", "rx", "ry", "rz", "theta")


@dataclass(frozen=True)
class FormulationOptions:
    """Options of the first-stage formulation.

    Attributes
    ----------
    shape_margin : float
        Unmeasured mode entries are bounded by ``+- shape_margin * max|v0|`` with ``v0`` the
        nominal mode in the block's normalization (the paper uses [-1, 1]).
    adjunct_margin : float
        Adjunct entries are bounded by ``+- adjunct_margin`` around a fixed unit entry.
    sign_delta : float
        Distance from zero of a sign bound from interlacing (Section 3.6), in the block's
        normalization.
    length_scale : float, optional
        Characteristic length (m) that scales rotational entries; default from ``K0``
        (`length_scale`).
    rotation_prefixes : tuple of str
        DOF-name prefixes that mark rotations.
    weighting : {"relative", "unit"}
        ``"relative"``: relative eigenvalue error (docs/method.md, "Default weights"); ``"unit"``: alpha = 1 (paper test case 1).
    interlacing : bool
        Apply the sign bounds derived from the pole/zero pattern (Eq. 11).
    reduction : {"auto", "none", "craig-bampton"}
        Solve on a Craig-Bampton reduced model (`vibupdate.inverse.reduction`) that keeps the measured
        DOFs; ``"auto"`` does so above `reduction_threshold` DOFs when there are DOFs to keep.
    reduction_modes : int
        Fixed-interface modes of the reduction.
    reduction_threshold : int
        DOFs above which ``"auto"`` reduces (measured on the frame example: the full
        formulation took 6.9 s at 110 DOFs and 331 s at 305, the reduced one 15 s at both).
    """

    shape_margin: float = default("formulation", "shape_margin")
    adjunct_margin: float = default("formulation", "adjunct_margin")
    sign_delta: float = default("formulation", "sign_delta")
    length_scale: float | None = default("formulation", "length_scale")
    rotation_prefixes: tuple[str, ...] = ROTATION_PREFIXES
    weighting: str = default("formulation", "weighting")
    interlacing: bool = default("formulation", "interlacing")
    reduction: str = default("formulation", "reduction")
    reduction_modes: int = default("formulation", "reduction_modes")
    reduction_threshold: int = default("formulation", "reduction_threshold")

    def __post_init__(self):
        check("formulation", self)      # types and ranges: vibupdate.options


@dataclass(frozen=True)
class VectorBlock:
    """One unknown vector: a mode (natural block) or an adjunct eigenvector.

    Entries are in scaled coordinates: physical value = ``scale * entry``.

    Attributes
    ----------
    configuration : str
    kind : {"natural", "antiresonance"}
    index : int
        1-based within kind and configuration.
    omega : float
        Measured frequency, rad/s.
    alpha : float
        Weight of the block's squared residual.
    rows, cols : ndarray of int
        DOF indices of the residual rows and of the vector entries.
    scale : ndarray, shape (len(cols),)
    lower, upper, start : ndarray, shape (len(cols),)
        Bounds and starting value of every entry; ``lower == upper`` for fixed entries.
    fixed : ndarray of bool, shape (len(cols),)
    receptance : tuple of str, optional
        ``(r, c)`` of an antiresonance block.
    measured : ndarray of bool, shape (len(cols),), optional
        Entries whose bounds come from a measured interval (the others from a margin).
    """

    configuration: str
    kind: str
    index: int
    omega: float
    alpha: float
    rows: np.ndarray
    cols: np.ndarray
    scale: np.ndarray
    lower: np.ndarray
    upper: np.ndarray
    start: np.ndarray
    fixed: np.ndarray
    receptance: tuple[str, str] | None = None
    measured: np.ndarray | None = None

    @property
    def n_free(self) -> int:
        return int(np.count_nonzero(~self.fixed))

    def with_bounds(self, lower, upper) -> "VectorBlock":
        lower, upper = np.asarray(lower, float), np.asarray(upper, float)
        return replace(self, lower=lower, upper=upper, start=np.clip(self.start, lower, upper))


@dataclass(frozen=True)
class BilinearProblem:
    """The stacked bilinear least-squares problem (module docstring).

    Attributes
    ----------
    parameters : tuple of Parameter, length n_x
    x_lower, x_upper : ndarray, shape (n_x,)
        Box of the normalized parameters.
    blocks : tuple of VectorBlock
    u_offsets : ndarray of int, shape (n_blocks + 1,)
        Block ``b`` owns free unknowns ``u[u_offsets[b]:u_offsets[b+1]]``.
    u_lower, u_upper, u_start : ndarray, shape (n_u,)
    A_u : csr_matrix, shape (n_R, n_u)
    A_x : csr_matrix, shape (n_R, n_x)
    A_b : csr_matrix, shape (n_R, n_b)
    r0 : ndarray, shape (n_R,)
    prod_x, prod_u : ndarray of int, shape (n_b,)
        The bilinear products are ``xbar[prod_x] * u[prod_u]``.
    row_weight : ndarray, shape (n_R,)
        ``alpha`` of the block of each residual row.
    row_offsets : ndarray of int, shape (n_blocks + 1,)
    """

    parameters: tuple[Parameter, ...]
    x_lower: np.ndarray
    x_upper: np.ndarray
    blocks: tuple[VectorBlock, ...]
    u_offsets: np.ndarray
    u_lower: np.ndarray
    u_upper: np.ndarray
    u_start: np.ndarray
    A_u: sp.csr_matrix
    A_x: sp.csr_matrix
    A_b: sp.csr_matrix
    r0: np.ndarray
    prod_x: np.ndarray
    prod_u: np.ndarray
    row_weight: np.ndarray
    row_offsets: np.ndarray
    options: FormulationOptions = field(default_factory=FormulationOptions)

    @property
    def n_x(self) -> int:
        return len(self.parameters)

    @property
    def n_u(self) -> int:
        return self.u_lower.size

    @property
    def n_b(self) -> int:
        return self.prod_x.size

    @property
    def n_r(self) -> int:
        return self.r0.size

    def residual(self, x, u) -> np.ndarray:
        """Exact residual (lambda = 1), shape (n_R,)."""
        return self.A_u @ u + self.A_x @ x + self.A_b @ (x[self.prod_x] * u[self.prod_u]) + self.r0

    def objective(self, x, u) -> float:
        """``sum_k w_k R_k^2`` at the exact products."""
        R = self.residual(x, u)
        return float(np.sum(self.row_weight * R**2))

    def block_vector(self, b: int, u) -> np.ndarray:
        """Physical vector of block ``b`` (fixed entries included) from the free unknowns."""
        blk = self.blocks[b]
        full = blk.lower.copy()
        full[~blk.fixed] = u[self.u_offsets[b]:self.u_offsets[b + 1]]
        return blk.scale * full

    def sizes(self) -> dict:
        """Counts comparable with Table 1 of the paper."""
        nat = sum(b.n_free for b in self.blocks if b.kind == "natural")
        adj = sum(b.n_free for b in self.blocks if b.kind == "antiresonance")
        return {
            "n_parameters": self.n_x,
            "n_mode_unknowns": nat,
            "n_adjunct_unknowns": adj,
            "n_lifted": self.n_b,
            "n_residuals": self.n_r,
            "n_fixed_entries": int(sum(np.count_nonzero(b.fixed) for b in self.blocks)),
        }


def length_scale(model, prefixes: Sequence[str] = ROTATION_PREFIXES) -> float:
    """Characteristic length from the stiffness diagonal: ``sqrt(3 median(K_rot) / median(K_tr))``.

    For a uniform Euler-Bernoulli mesh (``K_yy = 24 EI / l^3``, ``K_phiphi = 8 EI / l``) this
    is the element length ``l``. Returns 1 when the model has no rotational DOF.
    """
    rot = _rotation_mask(model.dofs, prefixes)
    if not rot.any() or rot.all():
        return 1.0
    d = np.abs(model.K0.diagonal())
    kr, kt = np.median(d[rot]), np.median(d[~rot])
    return float(np.sqrt(3.0 * kr / kt)) if kr > 0 and kt > 0 else 1.0


def _rotation_mask(dofs, prefixes) -> np.ndarray:
    return np.array([d.startswith(tuple(prefixes)) for d in dofs], dtype=bool)


@dataclass(frozen=True)
class _Scaling:
    s: np.ndarray    # physical entry = s * scaled entry, per DOF
    dr: np.ndarray   # residual row scaling, per DOF


def _scaling(model, options: FormulationOptions) -> _Scaling:
    lc = options.length_scale or length_scale(model, options.rotation_prefixes)
    rot = _rotation_mask(model.dofs, options.rotation_prefixes)
    s = np.where(rot, 1.0 / lc, 1.0)
    kd = np.abs(model.K0.diagonal())
    kd = np.where(kd > 0, kd, kd.max() if kd.max() > 0 else 1.0)
    return _Scaling(s=s, dr=1.0 / np.sqrt(kd))


def _natural_block(cfg: Configuration, k: int, v0_phys: np.ndarray, scaling: _Scaling,
                   options: FormulationOptions) -> VectorBlock:
    """Block of the k-th (0-based) natural frequency of a configuration."""
    model, f = cfg.model, cfg.natural[k]
    n = model.n_dofs
    cols = np.arange(n)
    v0 = v0_phys / scaling.s
    lower = np.full(n, -np.inf)
    upper = np.full(n, np.inf)
    measured = np.zeros(n, dtype=bool)
    if f.shape is not None:
        idx = np.array([model.dof(d) for d in f.shape.bounds])
        lo = np.array([b[0] for b in f.shape.bounds.values()]) / scaling.s[idx]
        hi = np.array([b[1] for b in f.shape.bounds.values()]) / scaling.s[idx]
        mid = 0.5 * (lo + hi)
        j_local = int(np.argmax(np.abs(mid)))
        ref = mid[j_local]
        if ref == 0:
            raise ValueError(f"configuration {cfg.name!r}, mode {k + 1}: the measured mode shape is zero")
        lo, hi = np.minimum(lo / ref, hi / ref), np.maximum(lo / ref, hi / ref)
        lower[idx], upper[idx] = lo, hi
        measured[idx] = True
        j = int(idx[j_local])
    else:
        j = _default_normalization_entry(cfg, v0)
    if v0[j] == 0:
        raise ValueError(f"configuration {cfg.name!r}, mode {k + 1}: the nominal mode is zero at its normalization entry")
    v0n = v0 / v0[j]
    bound = options.shape_margin * max(1.0, np.max(np.abs(v0n)))
    lower = np.where(np.isfinite(lower), lower, -bound)
    upper = np.where(np.isfinite(upper), upper, bound)
    lower[j] = upper[j] = 1.0
    fixed = lower == upper
    return VectorBlock(cfg.name, "natural", k + 1, f.omega, f.weight, cols, cols, scaling.s.copy(),
                       lower, upper, np.clip(v0n, lower, upper), fixed, measured=measured)


def _default_normalization_entry(cfg: Configuration, v0: np.ndarray) -> int:
    """The response DOF of the first receptance when antiresonances are used and the nominal
    mode is not near a node there; otherwise the nominal mode's largest entry."""
    largest = int(np.argmax(np.abs(v0)))
    receptances = cfg.receptances()
    if receptances:
        r = cfg.model.dof(receptances[0][0])
        if abs(v0[r]) >= 1e-3 * abs(v0[largest]):
            return r
    return largest


def _adjunct_block(cfg: Configuration, k: int, index: int, scaling: _Scaling,
                   options: FormulationOptions) -> VectorBlock:
    """Block of the k-th (0-based) antiresonance of a configuration."""
    model, a = cfg.model, cfg.antiresonances[k]
    r, c = model.dof(a.response), model.dof(a.excitation)
    n = model.n_dofs
    rows, cols = np.delete(np.arange(n), c), np.delete(np.arange(n), r)
    zs, V = antiresonances(model.M0, model.K0, r, c, with_vectors=True)
    if zs.size == 0:
        raise ValueError(
            f"configuration {cfg.name!r}: the nominal model has no antiresonance of "
            f"h_{a.response},{a.excitation}, so no start vector for the measured {a.freq_hz:.4g} Hz"
        )
    if a.index > zs.size:
        raise ValueError(
            f"configuration {cfg.name!r}: the measured {a.freq_hz:.4g} Hz is declared antiresonance {a.index} of "
            f"h_{a.response},{a.excitation}, but the nominal model has only {zs.size} such zeros")
    m = a.index - 1
    v0 = V[:, m] / scaling.s[cols]
    j = int(np.argmax(np.abs(v0)))
    v0n = v0 / v0[j]
    bound = options.adjunct_margin * max(1.0, np.max(np.abs(v0n)))
    lower, upper = np.full(n - 1, -bound), np.full(n - 1, bound)
    lower[j] = upper[j] = 1.0
    return VectorBlock(cfg.name, "antiresonance", index, a.omega, a.weight, rows, cols,
                       scaling.s[cols].copy(), lower, upper, np.clip(v0n, lower, upper),
                       lower == upper, (a.response, a.excitation))


@dataclass(frozen=True)
class _ScaledTerms:
    """Every term of a configuration's affine form on its scaled coordinates, as one list of
    entries: term ``term`` (0 nominal, ``i + 1`` parameter ``i``) has ``D K S`` = ``k`` and
    ``D M S`` = ``m`` at ``(row, col)`` (``D`` the row scaling, ``S`` the entry scaling). The
    pattern of a term is the union of its ``K`` and ``M`` patterns."""

    n: int
    term: np.ndarray
    row: np.ndarray
    col: np.ndarray
    k: np.ndarray
    m: np.ndarray


def _scaled_terms(model, scaling: _Scaling) -> _ScaledTerms:
    parts = []
    for term, (M, K) in enumerate(zip([model.M0, *model.M_par], [model.K0, *model.K_par])):
        # K + iM keeps the union pattern: its real and imaginary parts cannot cancel.
        C = sp.coo_matrix(sp.csr_matrix(K, dtype=complex) + 1j * sp.csr_matrix(M, dtype=complex))
        parts.append((np.full(C.nnz, term), C.row, C.col, C.data))
    term, row, col, val = (np.concatenate(a) for a in zip(*parts))
    factor = scaling.dr[row] * scaling.s[col]
    return _ScaledTerms(model.n_dofs, term, row.astype(np.int64), col.astype(np.int64), factor * val.real, factor * val.imag)

def _blocks(configurations, options: FormulationOptions, nominal=None):
    """The blocks of every configuration, the index of the configuration of each block, and
    the scaling of each block."""
    blocks, owners, scalings = [], [], []
    for i, cfg in enumerate(configurations):
        scaling = _scaling(cfg.model, options)
        modes = nominal[i] if nominal is not None else model_frequencies(cfg, zeros=False)
        for k in range(len(cfg.natural)):
            blocks.append(_natural_block(cfg, k, modes.Phi[:, k], scaling, options))
        for k in range(len(cfg.antiresonances)):
            blocks.append(_adjunct_block(cfg, k, k + 1, scaling, options))
        owners.extend([i] * (len(cfg.natural) + len(cfg.antiresonances)))
        scalings.extend([scaling] * (len(cfg.natural) + len(cfg.antiresonances)))
    return blocks, owners, scalings


def formulate(configurations: Sequence[Configuration], options: FormulationOptions | None = None,
              transforms: Sequence = (), nominal: Sequence | None = None) -> BilinearProblem:
    """Build the bilinear problem of all configurations.

    Parameters
    ----------
    configurations : sequence of Configuration
        Sharing one parameter vector.
    options : FormulationOptions, optional
    transforms : sequence of callables ``(blocks, configurations, options) -> blocks``
        Bound transformations applied to the blocks before stacking, e.g.
        `vibupdate.inverse.interlacing.sign_bounds`.
    nominal : sequence of ModelFrequencies, optional
        The nominal models' modes (`vibupdate.inverse.correlation.model_frequencies` at
        ``xbar = None``), one per configuration, when the caller has them already.
    """
    options = options or FormulationOptions()
    configurations = list(configurations)
    validate_configurations(configurations)
    blocks, owners, scalings = _blocks(configurations, options, nominal)
    for transform in transforms:
        blocks = transform(blocks, configurations, options)
    terms = {}
    for k, scaling in zip(owners, scalings):
        if k not in terms:
            terms[k] = _scaled_terms(configurations[k].model, scaling)
    return _stack(configurations[0].model.parameters, configurations[0].model.bounds(),
                  blocks, [terms[k] for k in owners], options)


def _block_rows(blk: VectorBlock, terms: _ScaledTerms) -> dict:
    """The block's entries of every term, in block-local indices: rows, columns, value of
    ``D (K - w^2 M) S`` and term, for the entries on the block's rows and columns."""
    row_of = np.full(terms.n, -1)
    row_of[blk.rows] = np.arange(len(blk.rows))
    col_of = np.full(terms.n, -1)
    col_of[blk.cols] = np.arange(len(blk.cols))
    lr, lc = row_of[terms.row], col_of[terms.col]
    keep = (lr >= 0) & (lc >= 0)
    value = terms.k[keep] - blk.omega**2 * terms.m[keep]
    return {"row": lr[keep], "col": lc[keep], "value": value, "term": terms.term[keep],
            "m": terms.m[keep]}


def _weight(blk: VectorBlock, e: dict, options: FormulationOptions) -> float:
    """Eqs. 7, 9 weight of a block: ``alpha / (w^2 ||D M0 S v0||)^2`` (docs/method.md,
    "Default weights"), or the user's ``alpha`` alone with ``weighting = "unit"``."""
    if options.weighting == "unit":
        return blk.alpha
    nominal = e["term"] == 0
    Mv = np.bincount(e["row"][nominal], weights=e["m"][nominal] * blk.start[e["col"][nominal]],
                     minlength=len(blk.rows))
    return blk.alpha / (blk.omega**2 * np.linalg.norm(Mv)) ** 2


def _stack(parameters, x_bounds, blocks, terms, options) -> BilinearProblem:
    """Stack the blocks (module docstring): one pass of array operations per block."""
    n_x = len(parameters)
    Au, Ax, Ab, r0, px, pu, wrow, weighted = [], [], [], [], [], [], [], []
    u_off, r_off, n_prod = [0], [0], 0
    for blk, term in zip(blocks, terms):
        e = _block_rows(blk, term)
        blk = replace(blk, alpha=_weight(blk, e, options))
        weighted.append(blk)
        n_rows, fixed = len(blk.rows), blk.fixed[e["col"]]
        free_of = np.cumsum(~blk.fixed) - 1              # local column -> free position
        n_free = int(np.count_nonzero(~blk.fixed))
        row_glob = r_off[-1] + e["row"]
        nominal = e["term"] == 0
        # Nominal term: free columns into A_u, fixed columns (their fixed value) into r0.
        sel = nominal & ~fixed
        Au.append((row_glob[sel], u_off[-1] + free_of[e["col"][sel]], e["value"][sel]))
        sel = nominal & fixed
        r0.append(np.bincount(e["row"][sel], weights=e["value"][sel] * blk.lower[e["col"][sel]],
                              minlength=n_rows))
        # Parameter terms: fixed columns into A_x; free columns are the bilinear products.
        sel = ~nominal & fixed
        Ax.append((row_glob[sel], e["term"][sel] - 1, e["value"][sel] * blk.lower[e["col"][sel]]))
        sel = ~nominal & ~fixed
        key = (e["term"][sel] - 1) * max(n_free, 1) + free_of[e["col"][sel]]
        products, local = np.unique(key, return_inverse=True)
        Ab.append((row_glob[sel], n_prod + local, e["value"][sel]))
        px.append(products // max(n_free, 1))
        pu.append(u_off[-1] + products % max(n_free, 1))
        n_prod += products.size
        wrow.append(np.full(n_rows, blk.alpha))
        u_off.append(u_off[-1] + n_free)
        r_off.append(r_off[-1] + n_rows)
    blocks = weighted
    n_r, n_u = r_off[-1], u_off[-1]

    def assemble(parts, n_cols):
        rows, cols, vals = (np.concatenate(a) if a else np.zeros(0) for a in zip(*parts))
        return sp.csr_matrix((vals, (rows.astype(np.int64), cols.astype(np.int64))), shape=(n_r, n_cols))

    u_lower = np.concatenate([b.lower[~b.fixed] for b in blocks])
    u_upper = np.concatenate([b.upper[~b.fixed] for b in blocks])
    u_start = np.concatenate([b.start[~b.fixed] for b in blocks])
    return BilinearProblem(
        parameters=tuple(parameters),
        x_lower=x_bounds[0], x_upper=x_bounds[1],
        blocks=tuple(blocks),
        u_offsets=np.array(u_off), u_lower=u_lower, u_upper=u_upper, u_start=u_start,
        A_u=assemble(Au, n_u),
        A_x=assemble(Ax, n_x),
        A_b=assemble(Ab, n_prod),
        r0=np.concatenate(r0),
        prod_x=np.concatenate(px).astype(int), prod_u=np.concatenate(pu).astype(int),
        row_weight=np.concatenate(wrow), row_offsets=np.array(r_off),
        options=options,
    )
