"""Optimality-based bound tightening (OBBT) of one box of the consistent set's relaxation (the
passes, their solvers and their economies as docs/notes/ranges.md, "Certified ranges: the
relaxation and its narrowing in full", states them).

A box holds the normalized parameters ``x`` and the free vector entries ``u`` of every block
(`vibupdate.ranges.lp_relaxation`). The safe bounds of ``min z_j`` and ``max z_j`` over the LP
relaxation on the box bound ``z_j`` over every point of S inside it, so the box's ends may be
replaced by them and the envelopes rebuilt, tighter, on the narrower box. Each block alone bounds
its entries ``u_b`` and ``x`` (`tighten_block`: HiGHS, warm, an objective whose variable already
sits on its bound skipped, as in the filtering of Gleixner et al., J. Global Optim. 67 (2017)
731-757); all blocks together bound ``x`` (`tighten_parameters`: Clarabel, HiGHS where its bound
is weak). `Tactics` switches each economy off. A box is proved empty when two safe bounds of a
variable cross, or when a solver reports its relaxation infeasible and the safe phase-1 bound
confirms it (`phase1_bound` > 0).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, replace

import numpy as np
import scipy.sparse as sp

from vibupdate.ranges.consistent import ConsistentSet
from vibupdate.ranges.lp_relaxation import (Lifted, clarabel_model, highs_model, lift, phase1_bound, relax, solve,
                                             solve_clarabel)


#: Largest gap (normalized units) between the safe bound and the LP optimum for which the
#: solver's answer counts as confirmed.
GAP = 1e-6
#: A solution value this close to a bound (absolute plus relative) counts as on the bound.
_ON_BOUND = 1e-9


@dataclass(frozen=True)
class Tactics:
    """How the tightening spends its LPs; each economy can be switched off (`BEFORE`: all
    off, the code before they were measured in `benchmarks/RESULTS.md`). None changes what
    is valid: every bound applied is a safe bound.

    Attributes
    ----------
    reuse_solver : bool
        One Clarabel (and, when needed, one HiGHS) instance per box and pass for the LPs of
        all blocks, objective and parameter bounds updated in place; else one per LP.
    useful_gap : float
        Clarabel's safe bound of a parameter's end is kept, and counts as confirming the
        optimum, when it lies within ``max(GAP, useful_gap * width)`` of Clarabel's optimum
        (``width``: the parameter's range in the box); only a weaker bound is re-solved by
        HiGHS. 0: re-solve whenever it is not within `GAP`.
    parameters_first : bool
        The per-block step bounds ``x`` before the block's vector entries (their LPs then see
        the narrowed ``x`` columns); else after.
    parameter_stall : bool
        The passes end when a pass shrinks the summed relative widths of the *parameters* by
        less than the stall fraction; else (the default) those of the whole box
        (`benchmarks/RESULTS.md`, "Economies of the tightening (branch `certify2`): solver
        reuse, Clarabel's bound kept, stall rule").
    """

    reuse_solver: bool = True
    useful_gap: float = 1e-3
    parameters_first: bool = True
    parameter_stall: bool = False


#: The tightening before these economies (for before / after measurements).
BEFORE = Tactics(reuse_solver=False, useful_gap=0.0, parameters_first=False, parameter_stall=False)


@dataclass(frozen=True)
class Lifts:
    """The lifted operators of all blocks (``full``) and of each block alone (``local``).

    ``u_off[b]:u_off[b + 1]`` are block ``b``'s entries among the free entries of all blocks.
    """

    full: Lifted
    local: tuple[Lifted, ...]
    u_off: np.ndarray
    n_x: int
    t_weight: np.ndarray

    def product_error(self, z) -> np.ndarray:
        """How much the relaxation's point ``z`` of all blocks, shape (n_z,), departs from the
        products it lifts, per parameter, shape (n_x,): ``sum_k w_k |t_k - x_i u_j|`` over the
        products of parameter ``i``, ``w_k`` the weight of ``t_k`` in the eigen rows."""
        L = self.full
        x, u, t = z[:L.n_x], z[L.n_x:L.n_x + L.n_u], z[L.n_x + L.n_u:L.n_x + L.n_u + L.n_t]
        err = self.t_weight * np.abs(t - x[L.tx] * u[L.tu])
        return np.bincount(L.tx, weights=err, minlength=L.n_x)

    def block_slice(self, b: int) -> slice:
        """Block ``b``'s entries in a box ``[x, u]``."""
        return slice(self.n_x + int(self.u_off[b]), self.n_x + int(self.u_off[b + 1]))


def lifts(cs: ConsistentSet) -> Lifts:
    local = tuple(lift(replace(cs, blocks=(blk,), models=(m,), omega_lower=cs.omega_lower[b:b + 1],
                               omega_upper=cs.omega_upper[b:b + 1]))
                  for b, (blk, m) in enumerate(zip(cs.blocks, cs.models)))
    u_off = np.concatenate([[0], np.cumsum([Lb.n_u for Lb in local])]).astype(int)
    full = lift(cs)
    cols = full.n_x + full.n_u + np.arange(full.n_t)
    G = (full.Kz - sp.diags(full.w2) @ full.Mz).tocsc()[:, cols]
    return Lifts(full, local, u_off, cs.n_x, np.asarray(abs(G).sum(axis=0)).ravel())


class Box:
    """A box of ``[x, u]`` under tightening (a working state, changed in place).

    Attributes
    ----------
    lo, hi : ndarray, shape (n_x + n_u,)
        Safe bounds: every point of S in the box this one was cut from lies inside.
    confirmed : ndarray of bool, shape (n_x, 2)
        The lower (0) and upper (1) end of each parameter is the relaxation's optimum, confirmed
        by its safe bound within `GAP` (or exact: a bound of the parameter, a branching point).
    empty : bool
        Proved empty.
    points : dict
        ``(i, side) -> z``: the all-block relaxation's solution at the lower (0) or upper (1)
        end of parameter ``i``, from the last bound of it (for the choice of branching).
    n_lps : int
        LPs solved on this box since it was made.
    """

    def __init__(self, lo, hi, confirmed, n_lps: int = 0):
        self.lo, self.hi = np.array(lo, dtype=float), np.array(hi, dtype=float)
        self.confirmed = np.array(confirmed, dtype=bool)
        self.empty = False
        self.n_lps = n_lps
        self.points = {}   # (i, side) -> the all-block relaxation's point at that end of x_i

    def copy(self) -> "Box":
        """The same box, its LP count at zero."""
        return Box(self.lo, self.hi, self.confirmed)

    def width(self, n: int) -> np.ndarray:
        return self.hi[:n] - self.lo[:n]


def root_box(cs: ConsistentSet, R: Lifts) -> Box:
    return Box(np.concatenate([cs.x_lower, R.full.u_lower]), np.concatenate([cs.x_upper, R.full.u_upper]),
               np.zeros((cs.n_x, 2), dtype=bool))


def _narrow(box: Box, g: int, side: int, value: float, opt: float, bound: float, n_x: int,
            slack: float = GAP) -> bool:
    """Apply a safe bound ``value`` to entry ``g`` of the box; True when it narrowed it. The
    end counts as confirmed when ``bound`` is within ``slack`` of the optimum ``opt``."""
    old = box.lo[g] if side == 0 else box.hi[g]
    better = value > old if side == 0 else value < old
    if g < n_x and (better or abs(value - old) <= GAP):
        box.confirmed[g, side] = bound >= opt - slack
    if better:
        (box.lo if side == 0 else box.hi)[g] = value
        if box.lo[g] > box.hi[g]:
            box.empty = True
    return better


def _infeasible(box: Box, lp) -> bool:
    """Whether ``box``, whose relaxation ``lp`` a solver reported infeasible, is proved empty (a
    positive safe phase-1 bound); marked so when it is."""
    if phase1_bound(lp) > 0:
        box.empty = True
    return box.empty


def tighten_block(R: Lifts, box: Box, b: int, deadline: float, focus: int | None = None,
                  tactics: Tactics = Tactics()) -> bool:
    """Bound block ``b``'s entries and then ``x`` over the relaxation of block ``b`` alone;
    with ``focus``, only the entries that parameter ``focus`` multiplies (whose envelopes a
    split of that parameter changed). False when the deadline stopped it."""
    n_x, sl = R.n_x, R.block_slice(b)
    L = R.local[b]
    if focus is None:
        entries = np.arange(n_x, n_x + L.n_u)
        targets = np.concatenate([np.arange(n_x), entries] if tactics.parameters_first else [entries, np.arange(n_x)])
    else:
        targets = n_x + np.unique(L.tu[L.tx == focus])
        if targets.size == 0:
            return True
    lp = relax(L, box.lo[:n_x], box.hi[:n_x], box.lo[sl], box.hi[sl])
    h = highs_model(lp)
    zl, zu = lp.zl.copy(), lp.zu.copy()
    done = np.zeros((lp.A.shape[1], 2), dtype=bool)
    c = np.zeros(lp.A.shape[1])
    for j in targets:
        g = j if j < n_x else sl.start + (j - n_x)
        for side in (0, 1):
            if done[j, side]:
                if j < n_x:   # the relaxation's optimum is the box's own end: exact
                    box.confirmed[j, side] = True
                continue
            if time.perf_counter() > deadline:
                return False
            sign = 1.0 if side == 0 else -1.0
            c[j] = sign
            status, opt, bound, z = solve(replace(lp, zl=zl, zu=zu), c, h, point=True)
            c[j] = 0.0
            box.n_lps += 1
            if status == "infeasible" and _infeasible(box, replace(lp, zl=zl, zu=zu)):
                return True
            if status != "optimal" or not np.isfinite(bound):
                continue
            if _narrow(box, g, side, sign * bound, opt, bound, n_x):
                if box.empty:
                    return True
                zl[j], zu[j] = box.lo[g], box.hi[g]
                h.changeColBounds(int(j), float(zl[j]), float(zu[j]))
            tol = _ON_BOUND * (1 + np.abs(z))
            done[:, 0] |= z <= zl + tol
            done[:, 1] |= z >= zu - tol
    return True


def tighten_parameters(R: Lifts, box: Box, deadline: float, tactics: Tactics = Tactics()) -> bool:
    """Bound ``x`` over the relaxation of all blocks. False when the deadline stopped it."""
    n_x = R.n_x
    lp = relax(R.full, box.lo[:n_x], box.hi[:n_x], box.lo[n_x:], box.hi[n_x:])
    cla = clarabel_model(lp) if tactics.reuse_solver else None
    highs = None
    done = np.zeros((n_x, 2), dtype=bool)
    for i in range(n_x):
        for side in (0, 1):
            if done[i, side]:
                box.confirmed[i, side] = True
                continue
            if time.perf_counter() > deadline:
                return False
            sign = 1.0 if side == 0 else -1.0
            c = np.zeros(lp.A.shape[1])
            c[i] = sign
            current = replace(lp, zl=np.concatenate([box.lo[:n_x], lp.zl[n_x:]]),
                              zu=np.concatenate([box.hi[:n_x], lp.zu[n_x:]]))
            status, opt, bound, z = solve_clarabel(current, c, cla, point=True)
            box.n_lps += 1
            slack = max(GAP, tactics.useful_gap * (box.hi[i] - box.lo[i]))
            if status == "optimal" and not bound >= opt - slack:
                # The interior-point multipliers give too weak a bound: simplex duals.
                if tactics.reuse_solver and highs is None:
                    highs = highs_model(current)
                status, opt, bound, z = solve(current, c, highs, point=True)
                box.n_lps += 1
                slack = GAP
            if status == "infeasible" and _infeasible(box, current):
                return True
            if status != "optimal" or not np.isfinite(bound):
                continue
            if _narrow(box, i, side, sign * bound, opt, bound, n_x, slack):
                if cla is not None:
                    cla.change_bounds([i], [box.lo[i]], [box.hi[i]])
                if highs is not None:
                    highs.changeColBounds(int(i), float(box.lo[i]), float(box.hi[i]))
            if box.empty:
                return True
            box.points[(i, side)] = z
            x = z[:n_x]
            tol = _ON_BOUND * (1 + np.abs(x))
            done[:, 0] |= x <= box.lo[:n_x] + tol
            done[:, 1] |= x >= box.hi[:n_x] - tol
    return True


def tighten(R: Lifts, box: Box, deadline: float, *, max_passes: int | None = None, stall: float = 1e-3,
            focus: int | None = None, on_pass=None, tactics: Tactics = Tactics()) -> int:
    """Passes of OBBT on ``box`` (every block alone, then ``x`` over all blocks) until one
    narrows the box (summed widths relative to the box's at the start) by less than
    ``stall`` (the parameters' widths only with ``tactics.parameter_stall``), ``max_passes``
    passes, the deadline or a proof that the box is empty. With
    ``focus`` the per-block step bounds only the entries parameter ``focus`` multiplies
    (`tighten_block`). Returns the number of passes completed; ``on_pass(passes)`` is called
    after each."""
    watched = slice(0, R.n_x) if tactics.parameter_stall else slice(None)
    span0 = np.maximum(box.hi[watched] - box.lo[watched], 1e-300)
    passes = 0
    while max_passes is None or passes < max_passes:
        before = np.sum((box.hi[watched] - box.lo[watched]) / span0)
        for b in range(len(R.local)):
            if not tighten_block(R, box, b, deadline, focus, tactics) or box.empty:
                return passes
        if not tighten_parameters(R, box, deadline, tactics) or box.empty:
            return passes
        passes += 1
        if on_pass is not None:
            on_pass(passes)
        if np.sum((box.hi[watched] - box.lo[watched]) / span0) > (1 - stall) * before:
            break
    return passes
