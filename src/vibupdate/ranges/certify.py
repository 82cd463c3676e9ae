"""Certified outer bounds of the parameters over the consistent set S (issue 11, item 0).

S is stated in `vibupdate.ranges.consistent`; `vibupdate.ranges.lp_relaxation` relaxes it to a linear
program (McCormick envelopes of the lifted products, Eq. 19) on boxes of the parameters and
vector entries, and bounds any linear objective over it safely (a Lagrangian bound from the
solver's multipliers, valid although the solver is inexact). Here the minimum and maximum of
each parameter over the relaxation bound it over S; tightening the boxes of the vector
entries and parameters by the same LPs (optimality-based bound tightening, OBBT) and
rebuilding the envelopes narrows the enclosure, for as long as the time budget allows.
Vector entries are first bounded over the relaxation of their own block alone (a weaker but
valid relaxation, and a small LP), then over all blocks.

A bound is *confirmed* (the parameter's range flagged ``certified``) when the safe value is
within `GAP` of the solver's optimum; otherwise the weaker safe value is still what is
reported. A positive safe phase-1 bound certifies that S is empty.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace

import numpy as np

from vibupdate.ranges.consistent import ConsistentSet, consistent_set
from vibupdate.inverse.formulation import FormulationOptions
from vibupdate.ranges.lp_relaxation import Lifted, highs_model, lift, phase1_bound, relax, solve, solve_clarabel
from vibupdate.data.measured import Configuration

__all__ = ["CertifiedRanges", "certified_ranges", "enclosure", "range_disagreements"]

#: Largest gap (normalized parameter units) between the safe bound and the LP optimum for
#: which the solver's answer counts as confirmed.
GAP = 1e-6
#: A pass that narrows the boxes (summed relative widths) by less than this ends the tightening.
STALL = 1e-3


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

    def __init__(self, cs: ConsistentSet, L: Lifted):
        self.L = L
        self.n_x = cs.n_x
        self.local = [lift(replace(cs, blocks=(blk,), models=(m,), omega_lower=cs.omega_lower[b:b + 1],
                                    omega_upper=cs.omega_upper[b:b + 1]))
                      for b, (blk, m) in enumerate(zip(cs.blocks, cs.models))]
        self.u_off = np.concatenate([[0], np.cumsum([Lb.n_u for Lb in self.local])]).astype(int)
        self.box = [np.concatenate([cs.x_lower, L.u_lower]), np.concatenate([cs.x_upper, L.u_upper])]
        self.confirmed = np.zeros((cs.n_x, 2), dtype=bool)
        self.lps = {}
        self.n_lps, self.infeasible = 0, None

    def relaxation(self, block: int | None = None):
        """LP of all blocks (``None``, solved by Clarabel) or of one block (with its HiGHS
        instance), on the current boxes: ``(lp, highs or None)``, cached."""
        if block not in self.lps:
            n_x, (lo, hi) = self.n_x, self.box
            if block is None:
                L, sl = self.L, slice(n_x, None)
            else:
                L, sl = self.local[block], slice(n_x + self.u_off[block], n_x + self.u_off[block + 1])
            lp = relax(L, lo[:n_x], hi[:n_x], lo[sl], hi[sl])
            self.lps[block] = (lp, None if block is None else highs_model(lp))
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
        status, opt, bound = solve_clarabel(lp, c) if h is None else solve(lp, c, h)
        if h is None and status == "optimal" and not bound >= opt - GAP:
            # Interior-point multipliers too loose to confirm the optimum: simplex duals.
            status, opt, bound = solve(lp, c)
            self.n_lps += 1
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
    T = _Tightener(cs, lift(cs))
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
        lb = phase1_bound(T.relaxation(T.infeasible[0])[0])
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
