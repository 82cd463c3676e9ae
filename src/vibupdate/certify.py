"""Certified outer bounds of the parameters over the consistent set S (issue 11, item 0).

S is stated in `vibupdate.consistent`: parameters in their box, and for every measured
frequency an eigenpair ``(s, v)`` of the block's pencil with ``s`` in the frequency window
and ``v`` in the block's box. Writing the block's equation with the measured ``w^2``,

    k(x, v) - w^2 m(x, v) - delta m(x, v) = 0,   k = D K(x) S v,  m = D M(x) S v,
    delta = s - w^2 in [wL^2 - w^2, wU^2 - w^2],

both ``k`` and ``m`` are linear in ``(x, u, t)`` once every product ``x_i u_j`` is lifted to
``t`` (Section 3.3), and the frequency uncertainty enters as one more product ``e = delta m``
per residual row. Replacing each product by its McCormick envelope (Eq. 19) on the current
boxes gives a linear program whose feasible set holds every point of S. The minimum and
maximum of ``x_i`` over it bound ``x_i`` over S; tightening the boxes of the vector entries
and parameters by the same LPs (optimality-based bound tightening, OBBT) and rebuilding the
envelopes narrows the enclosure, for as long as the time budget allows.

Safe bounds. The LP solver (HiGHS, through highspy so that a relaxation is built once and solved
warm for every objective) is inexact, so its optimum is never used as a bound.
Every variable of the LP is boxed, so for *any* row multipliers ``y`` (signs projected so
that each term is valid) the Lagrangian bound

    c^T z >= sum_j min_{z_j in [l_j, u_j]} (c - A^T y)_j z_j + sum_r min_{a_r in [lo_r, hi_r]} y_r a_r

holds for every feasible ``z`` (Neumaier and Shcherbina, Math. Program. 99 (2004) 283-296).
It is evaluated from the solver's multipliers with the rounding of the products and sums
bounded and subtracted, and the constants of the envelopes are rounded outward. A bound is
*confirmed* (the parameter's range flagged ``certified``) when this safe value is within
`GAP` of the solver's optimum; otherwise the weaker safe value is still what is reported.
A positive safe bound of the phase-1 problem (least total eigen-residual violation)
certifies that S is empty.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace

import numpy as np
import scipy.sparse as sp

from vibupdate.consistent import RESIDUAL_FLOOR, ConsistentSet, consistent_set
from vibupdate.formulation import FormulationOptions
from vibupdate.measured import Configuration

__all__ = ["CertifiedRanges", "certified_ranges", "enclosure", "range_disagreements"]

#: Largest gap (normalized parameter units) between the safe bound and the LP optimum for
#: which the solver's answer counts as confirmed.
GAP = 1e-6
#: A pass that narrows the boxes (summed relative widths) by less than this ends the tightening.
STALL = 1e-3
_EPS = np.finfo(float).eps


@dataclass(frozen=True)
class _Lifted:
    """``k(z) = Kz z + k0`` and ``m(z) = Mz z + m0`` over ``z = [x, u, t, delta, e]``."""

    n_x: int
    n_u: int
    n_t: int
    n_blk: int
    n_r: int
    Kz: sp.csr_matrix
    k0: np.ndarray
    Mz: sp.csr_matrix
    m0: np.ndarray
    w2: np.ndarray          # measured w^2 of each row's block, (n_r,)
    row_block: np.ndarray   # (n_r,)
    tx: np.ndarray          # parameter of each product, (n_t,)
    tu: np.ndarray          # vector entry of each product, (n_t,)
    u_lower: np.ndarray
    u_upper: np.ndarray
    d_lower: np.ndarray     # box of delta, (n_blk,)
    d_upper: np.ndarray

    @property
    def n_z(self) -> int:
        return self.n_x + self.n_u + self.n_t + self.n_blk + self.n_r


def _block_triplets(mats, free, fixed, vfix, supports, u_col, t_col):
    """COO triplets (row, column of z, value) and constant of one block's ``k`` or ``m``."""
    R, C, V = [], [], []

    def add(A, cols):
        A = sp.coo_matrix(A)
        R.append(A.row)
        C.append(cols[A.col])
        V.append(A.data)

    add(mats[0][:, free], u_col + np.arange(free.size))
    for i, support in enumerate(supports):
        add(sp.csc_matrix((mats[i + 1][:, fixed] @ vfix)[:, None]), np.array([i]))
        add(mats[i + 1][:, free][:, support], t_col[i] + np.arange(support.size))
    return np.concatenate(R), np.concatenate(C), np.concatenate(V), mats[0][:, fixed] @ vfix


def _lift(cs: ConsistentSet) -> _Lifted:
    n_x, n_blk = cs.n_x, len(cs.blocks)
    n_u = sum(b.n_free for b in cs.blocks)
    trip = {"K": [], "M": []}
    const = {"K": [], "M": []}
    w2, rb, tx, tu = [], [], [], []
    u_off = r_off = n_t = 0
    for b, (blk, model) in enumerate(zip(cs.blocks, cs.models)):
        kd = np.abs(model.K0.diagonal())
        d = 1.0 / np.sqrt(np.where(kd > 0, kd, kd.max()))
        D, S = sp.diags(d[blk.rows]), sp.diags(blk.scale)

        def op(A):
            return sp.csc_matrix(D @ sp.csr_matrix(A)[blk.rows][:, blk.cols] @ S)

        mats = {"K": [op(model.K0)] + [op(A) for A in model.K_par],
                "M": [op(model.M0)] + [op(A) for A in model.M_par]}
        free, fixed = np.flatnonzero(~blk.fixed), np.flatnonzero(blk.fixed)
        supports = [np.flatnonzero((np.diff(mats["K"][i + 1][:, free].indptr) > 0)
                                   | (np.diff(mats["M"][i + 1][:, free].indptr) > 0)) for i in range(n_x)]
        t_col = n_x + n_u + n_t + np.concatenate([[0], np.cumsum([s.size for s in supports])[:-1]]).astype(int)
        for key in ("K", "M"):
            r, c, v, k = _block_triplets(mats[key], free, fixed, blk.lower[fixed], supports, n_x + u_off, t_col)
            trip[key].append((r + r_off, c, v))
            const[key].append(k)
        for i, support in enumerate(supports):
            tx.append(np.full(support.size, i))
            tu.append(u_off + support)
            n_t += support.size
        n_rows = len(blk.rows)
        w2.append(np.full(n_rows, blk.omega**2))
        rb.append(np.full(n_rows, b))
        u_off += free.size
        r_off += n_rows
    n_z = n_x + n_u + n_t + n_blk + r_off

    def matrix(key):
        r, c, v = (np.concatenate(a) for a in zip(*trip[key]))
        return sp.csr_matrix((v, (r, c)), shape=(r_off, n_z))

    omega = np.array([b.omega for b in cs.blocks])
    return _Lifted(
        n_x, n_u, n_t, n_blk, r_off, matrix("K"), np.concatenate(const["K"]), matrix("M"),
        np.concatenate(const["M"]), np.concatenate(w2), np.concatenate(rb).astype(int),
        np.concatenate(tx).astype(int), np.concatenate(tu).astype(int),
        np.concatenate([b.lower[~b.fixed] for b in cs.blocks]),
        np.concatenate([b.upper[~b.fixed] for b in cs.blocks]),
        np.minimum(cs.omega_lower**2 - omega**2, 0.0), np.maximum(cs.omega_upper**2 - omega**2, 0.0),
    )


@dataclass(frozen=True)
class _LP:
    """``lo <= A z <= hi``, ``zl <= z <= zu``; the first ``n_eig`` rows are the eigen rows."""

    A: sp.csr_matrix
    lo: np.ndarray
    hi: np.ndarray
    zl: np.ndarray
    zu: np.ndarray
    n_eig: int


def _hull(*corners):
    c = np.stack(corners)
    lo, hi = c.min(axis=0), c.max(axis=0)
    return lo - 4 * _EPS * np.abs(lo), hi + 4 * _EPS * np.abs(hi)   # outward past the rounding


def _rows(coo_parts, n_rows, n_z):
    r, c, v = (np.concatenate(a) for a in zip(*coo_parts))
    return sp.csr_matrix((v, (r, c)), shape=(n_rows, n_z))


def _mccormick_t(L: _Lifted, xl, xu, ul, uu):
    """Eq. 19 for every ``t = x[tx] u[tu]``: 4 n_t rows."""
    n_t, p = L.n_t, np.arange(L.n_t)
    al, au, bl, bu = xl[L.tx], xu[L.tx], ul[L.tu], uu[L.tu]
    t_col, u_col, x_col = L.n_x + L.n_u + p, L.n_x + L.tu, L.tx
    parts, lo, hi = [], [], []
    for q, (a, b, lower) in enumerate(((al, bl, True), (au, bu, True), (au, bl, False), (al, bu, False))):
        rows = q * n_t + p
        parts.append((np.concatenate([rows, rows, rows]), np.concatenate([t_col, u_col, x_col]),
                      np.concatenate([np.ones(n_t), -a, -b])))
        rhs = -a * b
        pad = 4 * _EPS * np.abs(rhs)
        lo.append(rhs - pad if lower else np.full(n_t, -np.inf))
        hi.append(np.full(n_t, np.inf) if lower else rhs + pad)
    return parts, np.concatenate(lo), np.concatenate(hi)


def _mccormick_e(L: _Lifted, mL, mU, mmag):
    """McCormick rows of ``e = delta m(z)`` for the rows whose block has a frequency window."""
    windowed = np.flatnonzero((L.d_lower < 0) | (L.d_upper > 0))
    k = np.flatnonzero(np.isin(L.row_block, windowed))
    dL, dU = L.d_lower[L.row_block[k]], L.d_upper[L.row_block[k]]
    Mk = sp.coo_matrix(L.Mz[k])
    e_col = L.n_x + L.n_u + L.n_t + L.n_blk + k
    d_col = L.n_x + L.n_u + L.n_t + L.row_block[k]
    n, parts, lo, hi = k.size, [], [], []
    pad = 1e-12 * np.maximum(np.abs(dL), np.abs(dU)) * (mmag[k] + np.maximum(np.abs(mL[k]), np.abs(mU[k])))
    for q, (d, mb, lower) in enumerate(((dL, mL[k], True), (dU, mU[k], True), (dU, mL[k], False),
                                        (dL, mU[k], False))):
        base = q * n
        # e - d m(z) - mb delta  (>= or <=)  -d mb, with m(z) = Mz z + m0
        parts.append((np.concatenate([base + np.arange(n), base + Mk.row, base + np.arange(n)]),
                      np.concatenate([e_col, Mk.col, d_col]),
                      np.concatenate([np.ones(n), -d[Mk.row] * Mk.data, -mb])))
        rhs = -d * mb + d * L.m0[k]
        lo.append(rhs - pad if lower else np.full(n, -np.inf))
        hi.append(np.full(n, np.inf) if lower else rhs + pad)
    return parts, np.concatenate(lo) if lo else np.empty(0), np.concatenate(hi) if hi else np.empty(0), 4 * n


def _relaxation(L: _Lifted, xl, xu, ul, uu) -> _LP:
    """The LP relaxation of S on the boxes ``[xl, xu]`` and ``[ul, uu]`` (module docstring)."""
    n_z = L.n_z
    tl, tu = _hull(xl[L.tx] * ul[L.tu], xl[L.tx] * uu[L.tu], xu[L.tx] * ul[L.tu], xu[L.tx] * uu[L.tu])
    pad = np.zeros(L.n_blk + L.n_r)
    zl0, zu0 = np.concatenate([xl, ul, tl, pad]), np.concatenate([xu, uu, tu, pad])
    absM = abs(L.Mz)
    zmag0 = np.maximum(np.abs(zl0), np.abs(zu0))
    mmag = absM @ zmag0 + np.abs(L.m0)
    Mp, Mn = L.Mz.maximum(0), L.Mz.minimum(0)
    mL = L.m0 + Mp @ zl0 + Mn @ zu0 - 1e-13 * mmag
    mU = L.m0 + Mp @ zu0 + Mn @ zl0 + 1e-13 * mmag
    dL, dU = L.d_lower[L.row_block], L.d_upper[L.row_block]
    el, eu = _hull(dL * mL, dL * mU, dU * mL, dU * mU)
    zl = np.concatenate([xl, ul, tl, L.d_lower, el])
    zu = np.concatenate([xu, uu, tu, L.d_upper, eu])
    zmag = np.maximum(np.abs(zl), np.abs(zu))
    # Eigen rows: (Kz - w^2 Mz) z - e = -(k0 - w^2 m0), up to the residual floor.
    G = sp.csr_matrix(L.Kz - sp.diags(L.w2) @ L.Mz) + sp.csr_matrix((-np.ones(L.n_r), (np.arange(L.n_r), n_z - L.n_r + np.arange(L.n_r))),
                                         shape=(L.n_r, n_z))
    c0 = L.k0 - L.w2 * L.m0
    floor = RESIDUAL_FLOOR * (abs(L.Kz) @ zmag + np.abs(L.k0) + (L.w2 + dU) * mmag)
    t_parts, t_lo, t_hi = _mccormick_t(L, xl, xu, ul, uu)
    e_parts, e_lo, e_hi, n_e = _mccormick_e(L, mL, mU, mmag)
    A = sp.vstack([G, _rows(t_parts, 4 * L.n_t, n_z)] + ([_rows(e_parts, n_e, n_z)] if n_e else []), format="csr")
    return _LP(A, np.concatenate([-c0 - floor, t_lo, e_lo]), np.concatenate([-c0 + floor, t_hi, e_hi]),
               zl, zu, L.n_r)


def _safe_bound(c, lp: _LP, y) -> float:
    """A lower bound of ``c^T z`` over the LP valid for any multipliers ``y`` (module
    docstring), with the rounding of its own evaluation subtracted.

    Parameters
    ----------
    c : ndarray, shape (n_z,)
    lp : _LP
    y : ndarray, shape (n_rows,)
        Row multipliers; signs that would use an infinite row bound are set to zero.
    """
    y = np.where(((y > 0) & ~np.isfinite(lp.lo)) | ((y < 0) & ~np.isfinite(lp.hi)), 0.0, y)
    absA = abs(lp.A)
    r = c - lp.A.T @ y
    n_col = int(np.max(np.diff(sp.csc_matrix(lp.A).indptr), initial=0)) + 2
    err = 2 * n_col * _EPS * (np.abs(c) + absA.T @ np.abs(y))
    rl, ru = r - err, r + err
    tz = np.minimum.reduce([rl * lp.zl, rl * lp.zu, ru * lp.zl, ru * lp.zu])
    ta = np.zeros_like(y)
    pos, neg = y > 0, y < 0
    ta[pos] = y[pos] * lp.lo[pos]
    ta[neg] = y[neg] * lp.hi[neg]
    total = tz.sum() + ta.sum()
    n_sum = tz.size + ta.size + 2
    return float(total - 2 * n_sum * _EPS * (np.abs(tz).sum() + np.abs(ta).sum()))


def _highs(lp: _LP):
    """A HiGHS instance holding the LP (objective set per solve by `_solve`)."""
    import highspy

    h = highspy.Highs()
    h.setOptionValue("output_flag", False)
    model = highspy.HighsLp()
    A = sp.csc_matrix(lp.A)
    inf = highspy.kHighsInf
    model.num_col_, model.num_row_ = A.shape[1], A.shape[0]
    model.col_cost_ = np.zeros(A.shape[1])
    model.col_lower_, model.col_upper_ = lp.zl, lp.zu
    model.row_lower_ = np.where(np.isfinite(lp.lo), lp.lo, -inf)
    model.row_upper_ = np.where(np.isfinite(lp.hi), lp.hi, inf)
    model.a_matrix_.format_ = highspy.MatrixFormat.kColwise
    model.a_matrix_.start_, model.a_matrix_.index_, model.a_matrix_.value_ = A.indptr, A.indices, A.data
    h.passModel(model)
    return h


def _solve(lp: _LP, c, h=None):
    """HiGHS (dual simplex, warm from the previous solve of ``h``) on the LP with objective
    ``c``; returns (status, optimum, safe bound from the solver's row duals)."""
    import highspy

    h = h if h is not None else _highs(lp)
    n = lp.A.shape[1]
    h.changeColsCost(n, np.arange(n, dtype=np.int32), np.asarray(c, dtype=float))
    h.run()
    status = h.getModelStatus()
    if status in (highspy.HighsModelStatus.kInfeasible, highspy.HighsModelStatus.kUnboundedOrInfeasible):
        return "infeasible", np.nan, np.nan
    if status != highspy.HighsModelStatus.kOptimal:
        return "failed", np.nan, np.nan
    y = np.asarray(h.getSolution().row_dual, dtype=float)
    return "optimal", float(h.getInfo().objective_function_value), _safe_bound(c, lp, y)


def _lifted_point(L: _Lifted, cs: ConsistentSet, xbar, pairs) -> np.ndarray:
    """The point ``z`` of the LP that a point of S with eigenpairs ``pairs`` (`witness`)
    lifts to, shape (n_z,)."""
    xbar = np.asarray(xbar, dtype=float)
    u = np.concatenate([v[~blk.fixed] for blk, (_, v) in zip(cs.blocks, pairs)])
    # An exact datum (a zero-width window) puts the eigensolver's rounding of s into the
    # residual floor, not into delta.
    delta = np.clip([s - blk.omega**2 for blk, (s, _) in zip(cs.blocks, pairs)], L.d_lower, L.d_upper)
    t = xbar[L.tx] * u[L.tu]
    z = np.concatenate([xbar, u, t, delta, np.zeros(L.n_r)])
    e = delta[L.row_block] * (L.Mz @ z + L.m0)
    z[L.n_z - L.n_r:] = e
    return z


def _phase1(lp: _LP):
    """Safe lower bound of the least total violation of the eigen rows; > 0 proves S empty."""
    n, n_z = lp.n_eig, lp.A.shape[1]
    zmag = np.maximum(np.abs(lp.zl), np.abs(lp.zu))
    P = 2 * (abs(lp.A[:n]) @ zmag + np.maximum(np.abs(lp.lo[:n]), np.abs(lp.hi[:n]))) + 1.0
    I = sp.eye(lp.A.shape[0], n, format="csr")
    A = sp.hstack([lp.A, I, -I], format="csr")
    ext = _LP(A, lp.lo, lp.hi, np.concatenate([lp.zl, np.zeros(2 * n)]), np.concatenate([lp.zu, P, P]), n)
    c = np.concatenate([np.zeros(n_z), np.ones(2 * n)])
    status, _, bound = _solve(ext, c)
    return bound if status == "optimal" else np.nan


@dataclass(frozen=True)
class CertifiedRanges:
    """Certified outer ranges of the parameters over the consistent set S.

    Attributes
    ----------
    names : tuple of str
    lower, upper : ndarray, shape (n_x,)
        Outer range of each parameter, physical units: every point of S lies inside. NaN when
        S is certified empty.
    width_pct : ndarray, shape (n_x,)
        Width in per cent of the parameter's reference value.
    certified : ndarray of bool, shape (n_x,)
        Both ends are safe bounds that confirm the LP solver's optimum (within `GAP`). Where
        False, the range is still valid but may be looser than the relaxation allows (a failed
        or unconfirmed solve, or the time budget ran out before the parameter was bounded).
    root_lower, root_upper : ndarray, shape (n_x,)
        Range before any bound tightening (physical units).
    empty : bool
        S is certified empty (a positive safe phase-1 bound): no parameter set in the bounds
        reproduces the data within the windows.
    root_seconds, seconds : float
        Wall time to the root ranges and in all.
    passes : int
        Completed bound-tightening passes over every vector entry and parameter.
    n_lps : int
    history : tuple of (float, float)
        (seconds, mean width in per cent) after the root and after each pass.
    definition : str
        The consistent set, for reports.
    message : str
    """

    names: tuple[str, ...]
    lower: np.ndarray
    upper: np.ndarray
    width_pct: np.ndarray
    certified: np.ndarray
    root_lower: np.ndarray
    root_upper: np.ndarray
    empty: bool
    root_seconds: float
    seconds: float
    passes: int
    n_lps: int
    history: tuple
    definition: str
    message: str

    def determined(self, within_pct: float = 5.0) -> list[str]:
        """Parameters whose whole certified range is narrower than ``within_pct``."""
        return [n for n, w in zip(self.names, self.width_pct) if np.isfinite(w) and w <= within_pct]

    def as_dict(self) -> dict:
        return {n: {"lower": float(lo), "upper": float(hi), "width_pct": float(w), "certified": bool(c)}
                for n, lo, hi, w, c in zip(self.names, self.lower, self.upper, self.width_pct, self.certified)}

    def record(self) -> dict:
        """The ``identifiability.certified`` section of ``results.json`` (NaN as None)."""
        def num(v):
            return float(v) if np.isfinite(v) else None

        return {
            "definition": self.definition, "message": self.message, "empty": self.empty,
            "seconds": self.seconds, "root_seconds": self.root_seconds, "passes": self.passes,
            "n_lps": self.n_lps, "history": [[num(t), num(w)] for t, w in self.history],
            "ranges": {n: {"lower": num(lo), "upper": num(hi), "width_pct": num(w), "certified": bool(c),
                           "root_lower": num(rl), "root_upper": num(ru)}
                       for n, lo, hi, w, c, rl, ru in zip(self.names, self.lower, self.upper, self.width_pct,
                                                          self.certified, self.root_lower, self.root_upper)},
        }


def range_disagreements(certified: dict, others: dict, wider: float = 2.0) -> list[str]:
    """Where other ranges disagree with the certified outer ranges.

    Parameters
    ----------
    certified : dict
        ``{name: {"lower", "upper", ...}}`` (`CertifiedRanges.record` ``["ranges"]``).
    others : dict
        ``{label: {name: {"lower", "upper"}}}``, e.g. the linearized and the sampled ranges
        (``"min"``/``"max"`` are read too).
    wider : float
        A certified range wider than ``wider`` times another is reported.

    Returns
    -------
    list of str
        One sentence per disagreement: another range reaching outside the certified one (its
        values are not consistent with the data as S states them), or a certified range much
        wider than another (the other misses what the data allow).
    """
    notes = []
    for label, ranges in others.items():
        for name, c in certified.items():
            o = ranges.get(name)
            if not o or c.get("lower") is None or c.get("upper") is None:
                continue
            lo, hi = o.get("lower", o.get("min")), o.get("upper", o.get("max"))
            if lo is None or hi is None or not (np.isfinite(lo) and np.isfinite(hi)):
                continue
            tol = 1e-9 * max(abs(c["lower"]), abs(c["upper"]), 1e-300)
            if lo < c["lower"] - tol or hi > c["upper"] + tol:
                notes.append(f"{name}: the {label} range [{lo:.4g}, {hi:.4g}] reaches outside the certified range "
                             f"[{c['lower']:.4g}, {c['upper']:.4g}]")
            elif (c["upper"] - c["lower"]) > wider * (hi - lo):
                notes.append(f"{name}: the certified range [{c['lower']:.4g}, {c['upper']:.4g}] is "
                             f"{(c['upper'] - c['lower']) / max(hi - lo, 1e-300):.3g}x the {label} range "
                             f"[{lo:.4g}, {hi:.4g}]")
    return notes


class _Tightener:
    """Boxes of the parameters and vector entries, tightened by safe LP bounds.

    The relaxation of all blocks bounds the parameters; the vector entries of block ``b``
    are bounded by the relaxation of block ``b`` alone (the other blocks' rows dropped: a
    weaker but valid relaxation, and a small LP), which also bounds the parameters.
    """

    def __init__(self, cs: ConsistentSet, L: _Lifted):
        self.L = L
        self.n_x = cs.n_x
        self.local = [_lift(replace(cs, blocks=(blk,), models=(m,), omega_lower=cs.omega_lower[b:b + 1],
                                    omega_upper=cs.omega_upper[b:b + 1]))
                      for b, (blk, m) in enumerate(zip(cs.blocks, cs.models))]
        self.u_off = np.concatenate([[0], np.cumsum([Lb.n_u for Lb in self.local])]).astype(int)
        self.box = [np.concatenate([cs.x_lower, L.u_lower]), np.concatenate([cs.x_upper, L.u_upper])]
        self.confirmed = np.zeros((cs.n_x, 2), dtype=bool)
        self.lps = {}
        self.n_lps, self.infeasible = 0, None

    def relaxation(self, block: int | None = None) -> _LP:
        """LP of all blocks (``None``) or of one block, on the current boxes (cached)."""
        if block not in self.lps:
            n_x, (lo, hi) = self.n_x, self.box
            if block is None:
                L, sl = self.L, slice(n_x, None)
            else:
                L, sl = self.local[block], slice(n_x + self.u_off[block], n_x + self.u_off[block + 1])
            lp = _relaxation(L, lo[:n_x], hi[:n_x], lo[sl], hi[sl])
            self.lps[block] = (lp, _highs(lp))
        return self.lps[block]

    def _invalidate(self, j: int) -> None:
        if j < self.n_x:
            self.lps.clear()
            return
        self.lps.pop(None, None)
        self.lps.pop(int(np.searchsorted(self.u_off, j - self.n_x, side="right")) - 1, None)

    def tighten(self, j: int, side: int, block: int | None = None) -> None:
        """Bound variable ``j`` of the box (x then u) from below (side 0) or above (side 1)
        over the relaxation of all blocks or of ``block``."""
        lp, h = self.relaxation(block)
        local = j if j < self.n_x or block is None else j - self.u_off[block]
        sign = 1.0 if side == 0 else -1.0
        c = np.zeros(lp.A.shape[1])
        c[local] = sign
        status, opt, bound = _solve(lp, c, h)
        self.n_lps += 1
        if status == "infeasible":
            self.infeasible = (block,)
        if status != "optimal" or not np.isfinite(bound):
            return
        value = sign * bound
        old = self.box[side][j]
        better = value > old if side == 0 else value < old
        if j < self.n_x and (better or abs(value - old) <= GAP):
            self.confirmed[j, side] = bound >= opt - GAP
        if better:
            self.box[side][j] = value
            self._invalidate(j)

    def crossed(self) -> bool:
        return bool(np.any(self.box[0] > self.box[1]))

    def sweep(self, deadline: float, full: bool) -> bool:
        """One pass: every block's vector entries and the parameters over that block (or, with
        ``full``, the vector entries over all blocks), then the parameters over all blocks.
        False when stopped by the deadline or an infeasible LP."""
        n_x, blocks = self.n_x, range(len(self.local))
        tasks = [(n_x + self.u_off[b] + k, None if full else b) for b in blocks for k in range(self.local[b].n_u)]
        tasks += ([] if full else [(i, b) for b in blocks for i in range(n_x)]) + [(i, None) for i in range(n_x)]
        for j, block in tasks:
            for side in (0, 1):
                if time.perf_counter() > deadline:
                    return False
                self.tighten(j, side, block)
                if self.infeasible is not None or self.crossed():
                    return False
        return True


def enclosure(cs: ConsistentSet, *, seconds: float = 30.0, max_passes: int | None = None,
              progress: Callable[[str], None] | None = None) -> CertifiedRanges:
    """Certified outer ranges of the parameters over ``cs`` (module docstring).

    The root ranges (two LPs per parameter over all blocks) are always computed; bound-
    tightening passes (`_Tightener.sweep`) follow while the elapsed time is below ``seconds``:
    per-block passes (small LPs) until one narrows the boxes by less than `STALL`, then passes
    over all blocks until one does too, and at most ``max_passes`` passes when given.
    """
    if not seconds >= 0:
        raise ValueError(f"the time budget must be >= 0 seconds, got {seconds!r}")
    say = progress or (lambda message: None)
    t0 = time.perf_counter()
    T = _Tightener(cs, _lift(cs))
    n_x = cs.n_x

    def width():
        return float(np.mean(T.box[1][:n_x] - T.box[0][:n_x]) * 100.0)

    for i in range(n_x):
        for side in (0, 1):
            if T.infeasible is None and not T.crossed():
                T.tighten(i, side)
    root = (T.box[0][:n_x].copy(), T.box[1][:n_x].copy())
    root_seconds = time.perf_counter() - t0
    history = [(root_seconds, width())]
    say(f"certified ranges: root {root_seconds:.1f} s, mean width {history[-1][1]:.3g} %")
    passes, complete, full = 0, T.infeasible is None and not T.crossed(), False
    span0 = np.maximum(T.box[1] - T.box[0], 1e-300)
    while complete and (max_passes is None or passes < max_passes):
        before = np.sum((T.box[1] - T.box[0]) / span0)
        complete = T.sweep(t0 + seconds, full)
        if not complete:
            break
        passes += 1
        history.append((time.perf_counter() - t0, width()))
        say(f"certified ranges: pass {passes} ({'all blocks' if full else 'per block'}), {history[-1][0]:.1f} s, "
            f"mean width {history[-1][1]:.3g} %")
        if np.sum((T.box[1] - T.box[0]) / span0) > (1 - STALL) * before:
            if full:
                break
            full = True
    empty, message = False, "bounded"
    if T.crossed():
        empty, message = True, "S is empty: the safe bounds of a variable cross"
    elif T.infeasible is not None:
        lb = _phase1(T.relaxation(T.infeasible[0])[0])
        empty = bool(lb > 0)
        message = (f"S is empty: the least eigen-residual violation is at least {lb:.3g} > 0" if empty else
                   "the LP solver reported the relaxation infeasible, which the safe bound does not confirm; "
                   "the ranges are the last proven boxes")
    elif not complete:
        message = f"time budget of {seconds:g} s reached after {passes} pass(es)"
    elif max_passes is not None and passes == max_passes:
        message = f"stopped after {passes} pass(es) as asked"
    return _result(cs, T, root, root_seconds, time.perf_counter() - t0, passes, history, empty, message)


def _physical(model, lo, hi):
    a, b = model.physical(lo), model.physical(hi)
    return np.minimum(a, b), np.maximum(a, b)


def _result(cs, T, root, root_seconds, seconds, passes, history, empty, message) -> CertifiedRanges:
    n_x = cs.n_x
    model = cs.models[0]
    lo, hi = T.box[0][:n_x], T.box[1][:n_x]
    certified = T.confirmed.all(axis=1) & (T.infeasible is None or empty)
    if empty:
        lo = hi = np.full(n_x, np.nan)
        certified = np.ones(n_x, dtype=bool)
    plo, phi = _physical(model, lo, hi)
    rlo, rhi = _physical(model, *root)
    return CertifiedRanges(model.parameter_names, plo, phi, (hi - lo) * 100.0, certified, rlo, rhi, empty,
                           root_seconds, seconds, passes, T.n_lps, tuple(history), cs.definition(), message)


def certified_ranges(configurations: Sequence[Configuration], xbar=None, *, frequency_tolerance: float = 0.0,
                     seconds: float = 30.0, options: FormulationOptions | None = None,
                     progress: Callable[[str], None] | None = None) -> CertifiedRanges:
    """Certified outer ranges of every parameter over the consistent set of the data.

    Parameters
    ----------
    configurations : sequence of Configuration
    xbar : ndarray, shape (n_x,), optional
        The answer (normalized); the frequency windows are widened to hold its frequencies.
    frequency_tolerance : float
        Relative half-width of the frequency windows where the data carry no interval.
    seconds : float
        Time budget of the bound tightening (the root ranges are always computed).
    options : FormulationOptions, optional
        The vector boxes, as in the first stage.
    progress : callable, optional
    """
    cs = consistent_set(configurations, frequency_tolerance=frequency_tolerance, include=xbar, options=options)
    return enclosure(cs, seconds=seconds, progress=progress)
