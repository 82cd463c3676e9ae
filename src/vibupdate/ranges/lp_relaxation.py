"""The linear relaxation of the consistent set S and its safe bounds (`vibupdate.ranges.certify`;
in words: docs/notes/ranges.md, "Certified ranges: the relaxation and its narrowing in full").

Each block's eigen-equation of S (`vibupdate.ranges.consistent`) with the measured ``w^2``,

    k(x, v) - w^2 m(x, v) - delta m(x, v) = 0,   k = D K(x) S v,  m = D M(x) S v,
    delta = s - w^2 in [wL^2 - w^2, wU^2 - w^2],

is linear in ``z = [x, u, t, delta, e]`` once every product ``x_i u_j`` is lifted to ``t``
(Section 3.3) and ``delta m`` to ``e`` per residual row (``D``: Jacobi row scaling, ``S``: the
block's entry scaling). Each product is replaced by its McCormick envelope (Eq. 19) on the
current boxes, constants rounded outward; every point of S lifted (`lifted_point`) is feasible,
the eigen rows keeping the residual floor of S. No LP optimum is used as a bound: every variable
is boxed, so for *any* row multipliers ``y`` (signs projected so that each term is valid)

    c^T z >= sum_j min_{z_j in [l_j, u_j]} (c - A^T y)_j z_j + sum_r min_{a_r in [lo_r, hi_r]} y_r a_r

(Neumaier and Shcherbina, Math. Program. 99 (2004) 283-296), evaluated by `safe_bound` from the
solver's multipliers with its own rounding subtracted. A positive safe bound of the phase-1
problem (`phase1_bound`) proves the relaxation, hence S, empty.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from vibupdate.extras import require
from vibupdate.ranges.highs import highs, solve as solve_highs
from vibupdate.ranges.consistent import RESIDUAL_FLOOR, ConsistentSet


_EPS = np.finfo(float).eps


@dataclass(frozen=True)
class Lifted:
    """The scaled block operators as linear maps of the LP variables.

    ``k(z) = Kz z + k0`` and ``m(z) = Mz z + m0`` over ``z = [x, u, t, delta, e]`` with
    ``n_x`` parameters, ``n_u`` free vector entries, ``n_t`` lifted products, ``n_blk``
    frequency offsets and ``n_r`` lifted ``e = delta m`` (one per residual row).

    Attributes
    ----------
    Kz, Mz : csr_matrix, shape (n_r, n_z)
    k0, m0 : ndarray, shape (n_r,)
    w2 : ndarray, shape (n_r,)
        Measured ``w^2`` of each row's block, (rad/s)^2.
    row_block : ndarray of int, shape (n_r,)
    tx, tu : ndarray of int, shape (n_t,)
        Product ``t_k = x[tx_k] * u[tu_k]``.
    u_lower, u_upper : ndarray, shape (n_u,)
        Initial boxes of the free vector entries (scaled coordinates).
    d_lower, d_upper : ndarray, shape (n_blk,)
        Box of ``delta = s - w^2`` of each block, (rad/s)^2.
    """

    n_x: int
    n_u: int
    n_t: int
    n_blk: int
    n_r: int
    Kz: sp.csr_matrix
    k0: np.ndarray
    Mz: sp.csr_matrix
    m0: np.ndarray
    w2: np.ndarray
    row_block: np.ndarray
    tx: np.ndarray
    tu: np.ndarray
    u_lower: np.ndarray
    u_upper: np.ndarray
    d_lower: np.ndarray
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


def lift(cs: ConsistentSet) -> Lifted:
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
    omega = np.array([b.omega for b in cs.blocks])
    return Lifted(
        n_x, n_u, n_t, n_blk, r_off, _rows(trip["K"], r_off, n_z), np.concatenate(const["K"]),
        _rows(trip["M"], r_off, n_z), np.concatenate(const["M"]), np.concatenate(w2), np.concatenate(rb).astype(int),
        np.concatenate(tx).astype(int), np.concatenate(tu).astype(int),
        np.concatenate([b.lower[~b.fixed] for b in cs.blocks]),
        np.concatenate([b.upper[~b.fixed] for b in cs.blocks]),
        np.minimum(cs.omega_lower**2 - omega**2, 0.0), np.maximum(cs.omega_upper**2 - omega**2, 0.0),
    )


@dataclass(frozen=True)
class RelaxedLP:
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


def _envelope(w_col, f1_col, f2, f1_bounds, f2_bounds, pad=None, const=None):
    """McCormick rows (Eq. 19) of ``w = f1 f2``, one product per row of ``w_col``: ``f1`` the
    variable of column ``f1_col`` in ``f1_bounds``, ``f2 = F z (+ const)`` in ``f2_bounds`` with
    ``F`` given as COO triplets ``f2`` (row, column, value); the rows' ends padded outward by
    ``pad`` (default ``4 eps |rhs|``). Returns the 4 n rows' COO parts, lower and upper ends."""
    n, (r, c, v) = w_col.size, f2
    parts, lo, hi = [], [], []
    for q, (a, b, lower) in enumerate(((f1_bounds[0], f2_bounds[0], True), (f1_bounds[1], f2_bounds[1], True),
                                       (f1_bounds[1], f2_bounds[0], False), (f1_bounds[0], f2_bounds[1], False))):
        rows = q * n + np.arange(n)
        # w - a f2 - b f1  (>= or <=)  -a b
        parts.append((np.concatenate([rows, q * n + r, rows]), np.concatenate([w_col, c, f1_col]),
                      np.concatenate([np.ones(n), -a[r] * v, -b])))
        rhs = -a * b if const is None else -a * b + a * const
        width = 4 * _EPS * np.abs(rhs) if pad is None else pad
        lo.append(rhs - width if lower else np.full(n, -np.inf))
        hi.append(np.full(n, np.inf) if lower else rhs + width)
    return parts, np.concatenate(lo), np.concatenate(hi)


def relax(L: Lifted, xl, xu, ul, uu) -> RelaxedLP:
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
    slack = sp.csr_matrix((-np.ones(L.n_r), (np.arange(L.n_r), n_z - L.n_r + np.arange(L.n_r))), shape=(L.n_r, n_z))
    G = sp.csr_matrix(L.Kz - sp.diags(L.w2) @ L.Mz) + slack
    c0 = L.k0 - L.w2 * L.m0
    floor = RESIDUAL_FLOOR * (abs(L.Kz) @ zmag + np.abs(L.k0) + (L.w2 + dU) * mmag)
    p = np.arange(L.n_t)       # every t = x[tx] u[tu]
    t_parts, t_lo, t_hi = _envelope(L.n_x + L.n_u + p, L.tx, (p, L.n_x + L.tu, np.ones(L.n_t)),
                                    (xl[L.tx], xu[L.tx]), (ul[L.tu], uu[L.tu]))
    # e = delta m(z), m(z) = Mz z + m0, on the rows whose block has a frequency window
    k = np.flatnonzero(np.isin(L.row_block, np.flatnonzero((L.d_lower < 0) | (L.d_upper > 0))))
    Mk = sp.coo_matrix(L.Mz[k])
    width = 1e-12 * np.maximum(np.abs(dL[k]), np.abs(dU[k])) * (mmag[k] + np.maximum(np.abs(mL[k]), np.abs(mU[k])))
    e_parts, e_lo, e_hi = _envelope(n_z - L.n_r + k, L.n_x + L.n_u + L.n_t + L.row_block[k], (Mk.row, Mk.col, Mk.data),
                                    (dL[k], dU[k]), (mL[k], mU[k]), width, L.m0[k])
    blocks = [G, _rows(t_parts, 4 * L.n_t, n_z)] + ([_rows(e_parts, 4 * k.size, n_z)] if k.size else [])
    A = sp.vstack(blocks, format="csr")
    return RelaxedLP(A, np.concatenate([-c0 - floor, t_lo, e_lo]), np.concatenate([-c0 + floor, t_hi, e_hi]),
               zl, zu, L.n_r)


def safe_bound(c, lp: RelaxedLP, y) -> float:
    """A lower bound of ``c^T z`` over the LP valid for any multipliers ``y`` (module
    docstring), with the rounding of its own evaluation subtracted.

    Parameters
    ----------
    c : ndarray, shape (n_z,)
    lp : RelaxedLP
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


def highs_model(lp: RelaxedLP):
    """A HiGHS instance holding the LP (objective set per solve by `solve`)."""
    require("certify", "computing certified ranges")
    return highs(lp.A, lp.lo, lp.hi, lp.zl, lp.zu)


def solve(lp: RelaxedLP, c, h=None, *, point: bool = False):
    """HiGHS (dual simplex, warm from the previous solve of ``h``) on the LP with objective
    ``c``; returns (status, optimum, safe bound from the solver's row duals), and with
    ``point`` the solver's primal solution, shape (n_z,), as a fourth item (None unless
    optimal).

    ``h`` may hold tighter column bounds than ``lp`` (`vibupdate.ranges.certify` narrows them in
    place between solves); ``lp.zl``, ``lp.zu`` must then be those bounds or wider, which keeps
    the safe bound valid (it holds over the wider box too)."""
    require("certify", "computing certified ranges")
    import highspy

    h = h if h is not None else highs_model(lp)
    solve_highs(h, c)
    status = h.getModelStatus()
    if status in (highspy.HighsModelStatus.kInfeasible, highspy.HighsModelStatus.kUnboundedOrInfeasible):
        out = ("infeasible", np.nan, np.nan, None)
    elif status != highspy.HighsModelStatus.kOptimal:
        out = ("failed", np.nan, np.nan, None)
    else:
        sol = h.getSolution()
        out = ("optimal", float(h.getInfo().objective_function_value),
               safe_bound(c, lp, np.asarray(sol.row_dual, dtype=float)), np.asarray(sol.col_value, dtype=float))
    return out if point else out[:3]


@dataclass(frozen=True)
class ClarabelModel:
    """A Clarabel instance holding the LP as ``G z <= h`` (rows of ``A`` with a finite upper,
    then lower, end; then the column bounds), re-solved by `solve_clarabel` with a new
    objective or narrower column bounds through Clarabel's data update, without rebuilding
    (or refactoring the pattern of) its KKT system."""

    solver: object
    up: np.ndarray
    dn: np.ndarray
    n: int

    def change_bounds(self, cols, zl, zu) -> None:
        """Column bounds ``zl <= z[cols] <= zu`` (the `RelaxedLP` given to `solve_clarabel`
        must hold these bounds or wider ones)."""
        cols = np.asarray(cols, dtype=int)
        k = int(self.up.sum()) + int(self.dn.sum())
        self.solver.update(b=(np.concatenate([k + cols, k + self.n + cols]),
                              np.concatenate([np.asarray(zu, dtype=float), -np.asarray(zl, dtype=float)])))


def clarabel_model(lp: RelaxedLP, c=None) -> ClarabelModel:
    """A Clarabel instance of the LP (objective ``c``, zero when not given)."""
    require("certify", "computing certified ranges")
    import clarabel

    A = sp.csc_matrix(lp.A)
    up, dn = np.isfinite(lp.hi), np.isfinite(lp.lo)
    n = A.shape[1]
    eye = sp.eye(n, format="csc")
    G = sp.vstack([A[up], -A[dn], eye, -eye], format="csc")
    h = np.concatenate([lp.hi[up], -lp.lo[dn], lp.zu, -lp.zl])
    settings = clarabel.DefaultSettings()
    settings.verbose = False
    q = np.zeros(n) if c is None else np.asarray(c, dtype=float)
    solver = clarabel.DefaultSolver(sp.csc_matrix((n, n)), q, G, h, [clarabel.NonnegativeConeT(G.shape[0])],
                                    settings)
    return ClarabelModel(solver, up, dn, n)


def solve_clarabel(lp: RelaxedLP, c, model: ClarabelModel | None = None, *, point: bool = False):
    """Clarabel (interior point) on the LP with objective ``c``; returns (status, optimum,
    safe bound from its multipliers), and with ``point`` its primal solution as a fourth
    item (None unless optimal). It solves the large LPs of all blocks, where it is the faster
    (`benchmarks/RESULTS.md`, "Certified outer parameter ranges", the frame's LPs).

    ``model`` (`clarabel_model`) is re-solved with the objective ``c`` instead of building a
    new instance; it may hold narrower column bounds than ``lp`` (`ClarabelModel.change_bounds`),
    which keeps the safe bound valid, as in `solve`."""
    c = np.asarray(c, dtype=float)
    if model is None:
        model = clarabel_model(lp, c)
    else:
        model.solver.update(q=c)
    sol = model.solver.solve()
    status = str(sol.status)
    if "Infeasible" in status or status not in ("Solved", "AlmostSolved"):
        out = ("infeasible" if "Infeasible" in status else "failed", np.nan, np.nan)
        return out + (None,) if point else out
    up, dn = model.up, model.dn
    z = np.asarray(sol.z)   # G x + s = h, s >= 0; z >= 0 multiplies G x <= h
    k, m = int(up.sum()), int(dn.sum())
    y = np.zeros(lp.A.shape[0])
    y[up] -= z[:k]
    y[dn] += z[k:k + m]
    out = ("optimal", float(sol.obj_val), safe_bound(c, lp, y))
    return out + (np.asarray(sol.x, dtype=float),) if point else out


def lifted_point(L: Lifted, cs: ConsistentSet, xbar, pairs) -> np.ndarray:
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


def phase1_bound(lp: RelaxedLP):
    """Safe lower bound of the least total violation of the eigen rows; > 0 proves S empty."""
    n, n_z = lp.n_eig, lp.A.shape[1]
    zmag = np.maximum(np.abs(lp.zl), np.abs(lp.zu))
    P = 2 * (abs(lp.A[:n]) @ zmag + np.maximum(np.abs(lp.lo[:n]), np.abs(lp.hi[:n]))) + 1.0
    I = sp.eye(lp.A.shape[0], n, format="csr")
    A = sp.hstack([lp.A, I, -I], format="csr")
    ext = RelaxedLP(A, lp.lo, lp.hi, np.concatenate([lp.zl, np.zeros(2 * n)]), np.concatenate([lp.zu, P, P]), n)
    c = np.concatenate([np.zeros(n_z), np.ones(2 * n)])
    status, _, bound = solve(ext, c)
    return bound if status == "optimal" else np.nan
