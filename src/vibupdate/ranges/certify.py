"""Certified outer bounds of the parameters over the consistent set S (the rules as the user reads
them: docs/polish-and-verification.md, 7.4; in full: docs/notes/ranges.md, "Certified ranges:
the relaxation and its narrowing in full").

The minimum and maximum of each parameter over the linear relaxation of S
(`vibupdate.ranges.lp_relaxation`, bounded safely) bound it over S: the root ranges, then bound
tightening (`vibupdate.ranges.tightening`), then branching (`_Branching`), for as long as the time
budget allows. Each step removes only parts of the box that hold no point of S, so the result is
an outer range whenever it stops. An end is *confirmed* (the range flagged ``certified``) when its
safe bound is within `GAP` of the solver's optimum (Clarabel's bound of a parameter: within
``Tactics.useful_gap`` of its width). S holds every answer the run reports
(`vibupdate.ranges.inclusion`) and each must lie inside the final ranges (`_check_included`): a
range is never flagged certified while it misses a reported answer.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace

import numpy as np

from vibupdate.extras import require
from vibupdate.data.measured import Configuration
from vibupdate.inverse.formulation.options import FormulationOptions
from vibupdate.modal.eigen import DENSE_LIMIT
from vibupdate.ranges.consistent import ConsistentSet, consistent_set, is_consistent
from vibupdate.ranges.inclusion import Inclusion
from vibupdate.ranges.tightening import Box, Lifts, Tactics, lifts, root_box, tighten, tighten_parameters


#: A pass that narrows the boxes (summed relative widths) by less than this ends the tightening.
STALL = 1e-3
#: The same when branching follows: passes that gain less are worth less than splits
#: (`benchmarks/RESULTS.md`, "After (branch `certify`): bound tightening rebuilt, branching,
#: scale-free shapes").
ROOT_STALL = 0.02


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
        Both ends are safe bounds that confirm the LP solver's optimum (within `GAP`, or
        within 1e-3 of the parameter's width, `Tactics.useful_gap`). Where
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
        Completed bound-tightening passes over the whole box (before branching).
    splits : int
        Splits of the parameter box (branching).
    leaves : int
        Parts of the parameter box not proved empty; the ranges are their hull.
    n_lps : int
    history : tuple of (float, float)
        (seconds, mean width in per cent) after the root and after each pass.
    definition : str
        The consistent set, for reports.
    message : str
    inclusion : Inclusion, optional
        How S was widened to hold the answer and the other reported answers.
    uncovered : tuple of str
        Why a reported answer is not held by S or not inside the ranges, with the figure (then
        no range, or not the parameters it escapes, is flagged certified).
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
    splits: int
    leaves: int
    n_lps: int
    history: tuple
    definition: str
    message: str
    inclusion: Inclusion | None = None
    uncovered: tuple[str, ...] = ()

    @property
    def included(self) -> int:
        """Points S was widened to hold."""
        return len(self.inclusion.labels) if self.inclusion is not None else 0

    def record(self) -> dict:
        """The ``identifiability.certified`` section of ``results.json`` (NaN as None)."""
        def num(v):
            return float(v) if np.isfinite(v) else None

        return {
            "definition": self.definition, "message": self.message, "empty": self.empty,
            "seconds": self.seconds, "root_seconds": self.root_seconds, "passes": self.passes,
            "splits": self.splits, "leaves": self.leaves, "n_lps": self.n_lps,
            "history": [[num(t), num(w)] for t, w in self.history],
            "included": self.inclusion.record() if self.inclusion is not None else None,
            "uncovered": list(self.uncovered),
            "ranges": {n: {"lower": num(lo), "upper": num(hi), "width_pct": num(w), "certified": bool(c),
                           "root_lower": num(rl), "root_upper": num(ru)}
                       for n, lo, hi, w, c, rl, ru in zip(self.names, self.lower, self.upper, self.width_pct,
                                                          self.certified, self.root_lower, self.root_upper)},
        }


def _hull(leaves, n_x):
    lo = np.min([leaf.lo[:n_x] for leaf in leaves], axis=0)
    hi = np.max([leaf.hi[:n_x] for leaf in leaves], axis=0)
    return lo, hi


class _Branching:
    """Spatial branching of the parameter box (docs/notes/ranges.md, "Certified ranges: the
    relaxation and its narrowing in full"): the leaves cover every point of S, their hull is
    the outer range. The leaf split is one that sets the end of the hull reaching farthest past
    the points known to lie in S (``known``; the hull's centre when there are none), relative to
    the root width, halved after each split that did not move it; the split is along
    `_direction` (branching on the widest range was measured to split parameters that S fills
    anyway: benchmarks/RESULTS.md)."""

    def __init__(self, cs: ConsistentSet, R: Lifts, root: Box, known, tactics: Tactics = Tactics()):
        self.cs, self.R, self.n_x, self.tactics = cs, R, cs.n_x, tactics
        self.leaves = [root]
        self.width0 = np.maximum(root.width(cs.n_x), 1e-12)
        self.known = [np.asarray(k, dtype=float) for k in (known or [])]
        self.stale = np.zeros((cs.n_x, 2))
        self.splits = 0
        self.n_lps = 0
        # Centres of new parts are checked for membership (a dense eigen-analysis per block)
        # only on models small enough for dense work.
        self.check = max(m.n_dofs for m in cs.models) <= DENSE_LIMIT

    def _pick(self):
        n_x = self.n_x
        lo, hi = _hull(self.leaves, n_x)
        if self.known:
            K = np.array(self.known)
            klo, khi = K.min(axis=0), K.max(axis=0)
        else:
            klo = khi = 0.5 * (lo + hi)
        gap = np.column_stack([np.maximum(klo - lo, 0), np.maximum(hi - khi, 0)]) / self.width0[:, None]
        score = gap * 0.5**self.stale
        while True:
            i, side = np.unravel_index(int(np.argmax(score)), score.shape)
            if not score[i, side] > 1e-9:
                return None
            end = lo[i] if side == 0 else hi[i]
            at = [leaf for leaf in self.leaves if (leaf.lo[i] if side == 0 else leaf.hi[i]) == end]
            leaf = max(at, key=lambda lf: float(np.sum(lf.width(n_x) / self.width0)))
            rel = leaf.width(n_x) / self.width0
            if rel.max() > 1e-6:
                return (i, side), end, leaf, self._direction(leaf, (i, side), rel)
            score[i, side] = 0.0   # nothing left to split there

    def _direction(self, leaf: Box, end, rel):
        """The parameter to split and where: the one whose lifted products the relaxation's
        solution at this end violates most (weighted), at that solution's value kept within
        the middle half of its range; the widest relative range, at its midpoint, when there
        is no solution to read."""
        splittable = rel > 1e-6
        z = leaf.points.get(end)
        if z is not None:
            err = np.where(splittable, self.R.product_error(z), 0.0)
            if err.max() > 0:
                d = int(np.argmax(err))
                a, b = leaf.lo[d], leaf.hi[d]
                return d, float(np.clip(z[d], a + 0.25 * (b - a), b - 0.25 * (b - a)))
        d = int(np.argmax(np.where(splittable, rel, -1.0)))
        return d, 0.5 * (leaf.lo[d] + leaf.hi[d])

    def split(self, deadline: float) -> bool:
        """One split and the tightening of both halves; False when there is nothing to split."""
        picked = self._pick()
        if picked is None:
            return False
        (i, side), end, leaf, (d, mid) = picked
        low, high = leaf.copy(), leaf.copy()
        low.hi[d], high.lo[d] = mid, mid
        low.confirmed[d, 1] = high.confirmed[d, 0] = True   # a branching point is exact
        self.leaves.remove(leaf)
        for child in (low, high):
            tighten(self.R, child, deadline, max_passes=1, focus=d, tactics=self.tactics)
            self.n_lps += child.n_lps
            if not child.empty:
                self.leaves.append(child)
                centre = 0.5 * (child.lo[:self.n_x] + child.hi[:self.n_x])
                if self.check and time.perf_counter() < deadline and is_consistent(self.cs, centre):
                    self.known.append(centre)
        self.splits += 1
        if self.leaves:
            lo, hi = _hull(self.leaves, self.n_x)
            moved = (lo[i] > end) if side == 0 else (hi[i] < end)
            self.stale[i, side] = 0.0 if moved else self.stale[i, side] + 1.0
        return bool(self.leaves)


def enclosure(cs: ConsistentSet, *, seconds: float = 30.0, max_passes: int | None = None,
              max_splits: int | None = None, known=None,
              progress: Callable[[str], None] | None = None, tactics: Tactics = Tactics()) -> CertifiedRanges:
    """Certified outer ranges of the parameters over ``cs`` (module docstring).

    The root ranges are always computed. Then, while the elapsed time is below ``seconds``:
    bound-tightening passes until one narrows the box by less than `STALL` (`ROOT_STALL` when
    branching follows, then within half the budget) or ``max_passes`` passes; then branching,
    each half tightened by one pass, until the budget or ``max_splits`` splits. Without a finite
    budget there is no branching unless ``max_splits`` is given.

    Parameters
    ----------
    cs : ConsistentSet
    seconds : float
    max_passes, max_splits : int, optional
    known : sequence of ndarray, shape (n_x,), optional
        Points believed to lie in S (e.g. the answer): they steer the branching only.
    progress : callable, optional
    tactics : Tactics
        How the tightening spends its LPs (`vibupdate.ranges.tightening.Tactics`).
    """
    if not seconds >= 0:
        raise ValueError(f"the time budget must be >= 0 seconds, got {seconds!r}")
    if max_splits is None and not np.isfinite(seconds):
        max_splits = 0
    say = progress or (lambda message: None)
    t0 = time.perf_counter()
    end = t0 + seconds
    R = lifts(cs)
    n_x = cs.n_x
    box = root_box(cs, R)
    tighten_parameters(R, box, np.inf, tactics)
    root = (box.lo[:n_x].copy(), box.hi[:n_x].copy())
    root_seconds = time.perf_counter() - t0
    history = [(root_seconds, float(np.mean(box.width(n_x)) * 100))]
    say(f"certified ranges: root {root_seconds:.1f} s, mean width {history[-1][1]:.3g} %")

    def on_pass(k):
        history.append((time.perf_counter() - t0, float(np.mean(box.width(n_x)) * 100)))
        say(f"certified ranges: pass {k}, {history[-1][0]:.1f} s, mean width {history[-1][1]:.3g} %")

    passes = 0
    if not box.empty:
        branching = max_splits != 0
        share = t0 + (0.5 * seconds if branching else seconds)
        passes = tighten(R, box, min(share, end), max_passes=max_passes, stall=ROOT_STALL if branching else STALL,
                         on_pass=on_pass, tactics=tactics)
    B = _Branching(cs, R, box, known, tactics)
    if not box.empty:
        while (max_splits is None or B.splits < max_splits) and time.perf_counter() < end:
            if not B.split(end):
                break
            lo, hi = _hull(B.leaves, n_x) if B.leaves else (box.lo[:n_x], box.lo[:n_x])
            history.append((time.perf_counter() - t0, float(np.mean(hi - lo) * 100)))
            if B.splits % 10 == 0 or not B.leaves:
                say(f"certified ranges: {B.splits} splits, {len(B.leaves)} leaves, {history[-1][0]:.1f} s, "
                    f"mean width {history[-1][1]:.3g} %")
            if not B.leaves:
                break
    empty = box.empty or not B.leaves
    n_lps = box.n_lps + B.n_lps
    if empty:
        message = "S is empty: every part of the parameter box was proved to hold no point of S"
    elif time.perf_counter() >= end:
        message = f"time budget of {seconds:g} s reached after {passes} pass(es) and {B.splits} split(s)"
    else:
        message = f"stopped after {passes} pass(es) and {B.splits} split(s)"
    return _result(cs, B, root, root_seconds, time.perf_counter() - t0, passes, history, empty, message, n_lps)


def _physical(model, lo, hi):
    a, b = model.physical(lo), model.physical(hi)
    return np.minimum(a, b), np.maximum(a, b)


def _result(cs, B, root, root_seconds, seconds, passes, history, empty, message, n_lps) -> CertifiedRanges:
    n_x = cs.n_x
    model = cs.models[0]
    if empty:
        lo = hi = np.full(n_x, np.nan)
        certified = np.ones(n_x, dtype=bool)
    else:
        lo, hi = _hull(B.leaves, n_x)
        ends = np.zeros((n_x, 2), dtype=bool)
        for leaf in B.leaves:
            ends[:, 0] |= (leaf.lo[:n_x] == lo) & leaf.confirmed[:, 0]
            ends[:, 1] |= (leaf.hi[:n_x] == hi) & leaf.confirmed[:, 1]
        certified = ends.all(axis=1)
    plo, phi = _physical(model, lo, hi)
    rlo, rhi = _physical(model, *root)
    return CertifiedRanges(model.parameter_names, plo, phi, (hi - lo) * 100.0, certified, rlo, rhi, empty,
                           root_seconds, seconds, passes, B.splits, len(B.leaves), n_lps, tuple(history),
                           cs.definition(), message)


def certified_ranges(configurations: Sequence[Configuration], xbar=None, *, include=(),
                     frequency_tolerance: float = 0.0, seconds: float = 30.0,
                     max_passes: int | None = None, max_splits: int | None = None,
                     options: FormulationOptions | None = None,
                     progress: Callable[[str], None] | None = None) -> CertifiedRanges:
    """Certified outer ranges of every parameter over the consistent set of the data.

    Parameters
    ----------
    configurations : sequence of Configuration
        The measured configurations whose data define the consistent set S.
    xbar : ndarray, shape (n_x,), optional
        The answer (normalized); S is widened to hold it (`vibupdate.ranges.inclusion`).
    include : sequence of (str, ndarray of shape (n_x,))
        Further answers the run reports (verified sampled answers, line ends), each with a
        label; S is widened to hold them too.
    frequency_tolerance : float
        Relative half-width of the frequency windows where the data carry no interval.
    seconds : float
        Time budget of the bound tightening (the root ranges are always computed).
    max_passes, max_splits : int, optional
        Work limits of the tightening and the branching (`enclosure`); with ``seconds=np.inf``
        they make the outcome independent of the machine's speed.
    options : FormulationOptions, optional
        The vector boxes, as in the first stage.
    progress : callable, optional
        Receives one line after the root ranges, each pass of the tightening and the
        branching.

    Returns
    -------
    CertifiedRanges
        The outer range of each parameter (physical units) that every point of S lies in,
        with a flag per parameter saying whether both ends are certified, or S certified
        empty.

    Raises
    ------
    vibupdate.extras.MissingExtra
        Without the optional extra ``[certify]`` (HiGHS, Clarabel), before any work.
    """
    require("certify", "computing certified ranges")
    labels = (["the answer"] if xbar is not None else []) + [label for label, _ in include]
    points = ([np.asarray(xbar, dtype=float)] if xbar is not None else []) + [np.asarray(p, dtype=float)
                                                                            for _, p in include]
    cs = consistent_set(configurations, frequency_tolerance=frequency_tolerance, include=points or None,
                        include_labels=labels if points else None, options=options)
    cert = enclosure(cs, seconds=seconds, max_passes=max_passes, max_splits=max_splits, known=points or None,
                     progress=progress)
    return _check_included(cs, cert, points, labels)


def _check_included(cs: ConsistentSet, cert: CertifiedRanges, points, labels) -> CertifiedRanges:
    """``cert`` with its flags withdrawn where a reported answer is not held (module docstring)."""
    if not points:
        return cert
    uncovered = list(cs.inclusion.uncovered)
    certified = cert.certified & (not uncovered)
    model = cs.models[0]
    for p, label in zip(points, labels):
        if any(u.startswith(f"{label}:") for u in cs.inclusion.uncovered):
            continue
        value = model.physical(p)
        out = ~((cert.lower <= value) & (value <= cert.upper))
        if cert.empty or out.any():
            i = int(np.argmax(out)) if out.any() else 0
            uncovered.append(f"{label}: {cert.names[i]} = {value[i]:.6g} outside the range "
                             f"[{cert.lower[i]:.6g}, {cert.upper[i]:.6g}]")
            certified = certified & ~out if not cert.empty else np.zeros_like(certified)
    if not uncovered:
        return replace(cert, inclusion=cs.inclusion)
    withdrawn = [n for n, c, was in zip(cert.names, certified, cert.certified) if was and not c]
    which = "NOT certified" if not certified.any() else "not certified for " + ", ".join(withdrawn)
    message = (f"{cert.message}; {which}: {len(uncovered)} reported answer(s) not held: "
               + "; ".join(uncovered[:3]) + (f"; and {len(uncovered) - 3} more" if len(uncovered) > 3 else ""))
    return replace(cert, certified=certified, inclusion=cs.inclusion, uncovered=tuple(uncovered), message=message)
