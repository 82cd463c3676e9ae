"""Bounded nonlinear least squares with an exact Jacobian, each point evaluated once, watched
for limits and stalls (`Monitor`, which ends a run by raising `Stop`): the solver of the polish
(`vibupdate.inverse.polish`) and of the classical peers (`vibupdate.inverse.baseline`).
"""

from __future__ import annotations

import time

import numpy as np
from scipy.optimize import least_squares, lsq_linear


#: A run has stalled when its best objective fell by less than this fraction over the last
#: ``window`` evaluations (`Monitor`); it then stops with the best point.
STALL_DECREASE = 1e-3
#: A run evaluated at a point within this distance (largest normalized parameter difference)
#: of a known answer, or whose bounded Gauss-Newton step from that point lands this close to one
#: (`gauss_newton_point`), has found that answer again and stops (`Monitor`, ``answers``): a tenth
#: of the distance at which two answers count as distinct (`vibupdate.inverse.search.Search.distinct`;
#: `benchmarks/RESULTS.md`, "The uniqueness probe stops on answers found again" and "Starts whose
#: Gauss-Newton step lands on a known answer").
SAME_ANSWER = 1e-4


#: How far `inside` keeps a point from a bound: this fraction of the box's width, or of the
#: bound's magnitude (at least of 1) where that is more (at most half the box); a point this close
#: is on the bound (`gauss_newton_decrease`). scipy's trf moves a point it starts from that far
#: in (the same product) when it is nearer: a point `inside` gives is the point trf evaluates.
INSIDE = 1e-10


def _edges(lower, upper) -> tuple[np.ndarray, np.ndarray]:
    """The innermost points `inside` allows, ``(lower + e_lower, upper - e_upper)`` (`INSIDE`);
    both the box's midpoint where they would cross."""
    span = upper - lower
    lo = lower + INSIDE * np.maximum(span, np.maximum(1.0, np.abs(lower)))
    hi = upper - INSIDE * np.maximum(span, np.maximum(1.0, np.abs(upper)))
    crossed = lo > hi
    if crossed.any():
        mid = 0.5 * (lower + upper)
        lo, hi = np.where(crossed, mid, lo), np.where(crossed, mid, hi)
    return lo, hi


def inside(x, lower, upper) -> np.ndarray:
    """``x`` nudged strictly inside the box (trf needs it; parameters with nominal 0 often sit
    on a bound) by `INSIDE`; idempotent."""
    return np.clip(np.asarray(x, dtype=float), *_edges(lower, upper))


class Stop(Exception):
    """Raised by `Monitor` to end a least-squares run (``reason``: a limit, a stall, a known
    answer reached again, or convergence)."""

    def __init__(self, reason: str, message: str):
        super().__init__(message)
        self.reason = reason


class Monitor:
    """Counts the evaluations of a least squares, keeps the best point seen, and raises `Stop`
    on ``limit`` evaluations (what is left of ``budget``), the time limit, a stall
    (`STALL_DECREASE`) over ``window`` evaluations (by default twice the unknowns plus one, at
    least 20: scipy's trust region may need several rejected steps in a row), a point near
    one of ``answers`` (shape (n_a, n_x); none by default; a run that only finds a known answer
    again need not converge on it), or, given ``stationary = (lower, upper, ftol)``, a point
    whose bounded Gauss-Newton step lands near one of ``answers`` (`gauss_newton_point`) and a
    best point from which the Gauss-Newton step would lower the objective by at most ``ftol`` of
    itself (`gauss_newton_decrease`; reason ``"convergence"``)."""

    def __init__(self, x, value, limit: int, budget: int, started: float, max_seconds: float | None,
                 answers=None, window: int | None = None, stationary: tuple | None = None):
        self.best = (np.asarray(x, dtype=float), value, 0.5 * float(value[0] @ value[0]))
        self.limit, self.budget, self.window = limit, budget, window or max(20, 2 * (self.best[0].size + 1))
        self.started, self.max_seconds = started, max_seconds
        self.answers = None if answers is None or not len(answers) else np.atleast_2d(np.asarray(answers, float))
        self.stationary = stationary
        # the bounds active where the last point's Gauss-Newton step landed; before the first
        # landing, those a landing near the first known answer holds (`gauss_newton_point`)
        self.held = None if self.answers is None or stationary is None else \
            near_bounds(self.answers[0], *stationary[:2], SAME_ANSWER)
        self.count = 0
        self.history = [self.best[2]]

    def seen(self, x, value) -> None:
        self.count += 1
        cost = 0.5 * float(value[0] @ value[0])
        better = cost < self.best[2]
        if better:
            self.best = (np.array(x, dtype=float), value, cost)
        self.history.append(self.best[2])
        if self.answers is not None:
            gap = np.abs(self.answers - np.asarray(x, dtype=float)).max(axis=1)
            if gap.min() <= SAME_ANSWER:
                raise Stop("known answer", f"reached known answer {int(gap.argmin()) + 1} again (within "
                                           f"{gap.min():.1e}) after {self.count} evaluations")
            if self.stationary is not None and value[1] is not None and may_land_near(
                    x, *value, *self.stationary[:2], self.answers, SAME_ANSWER).any():
                landing, self.held = gauss_newton_point(x, *value, *self.stationary[:2], self.held)
                gap = np.abs(self.answers - landing).max(axis=1)
                if gap.min() <= SAME_ANSWER:
                    raise Stop("known answer", f"heading for known answer {int(gap.argmin()) + 1}: the Gauss-Newton"
                                               f" step lands within {gap.min():.1e} of it after {self.count} "
                                               "evaluations")
        if better and self.stationary is not None and value[1] is not None:
            lower, upper, ftol = self.stationary
            if gauss_newton_decrease(self.best[0], *value, lower, upper) <= ftol:
                raise Stop("convergence", f"converged: the Gauss-Newton step from the best point would lower the "
                                          f"objective by at most {ftol:g} of itself (to {cost:.4g})")
        if self.count >= self.limit:
            raise Stop("evaluations", f"stopped on the limit of {self.budget} evaluations of the full model, "
                                       f"objective {self.best[2]:.4g} (set polish.max_evaluations to allow more)")
        if self.max_seconds is not None and time.perf_counter() - self.started > self.max_seconds:
            raise Stop("time", f"stopped on the time limit of {self.max_seconds:g} s after {self.count} evaluations, "
                                f"objective {self.best[2]:.4g} (polish.max_seconds)")
        if len(self.history) > self.window:
            before = self.history[-1 - self.window]
            if self.best[2] > (1 - STALL_DECREASE) * before:
                raise Stop("stall", f"stalled: the objective fell by less than {STALL_DECREASE:g} of itself over "
                                     f"the last {self.window} evaluations (to {self.best[2]:.4g})")


def gauss_newton_decrease(x, r, J, lower, upper) -> float:
    """The decrease of ``0.5 |r|^2`` that the Gauss-Newton step from ``x`` predicts, as a
    fraction of it: ``|P r|^2 / |r|^2``, ``P`` the projection on the span of the Jacobian's
    columns of the parameters free to move (not on a bound, within `INSIDE`, that their
    gradient pushes against).

    It is what scipy's cost test (``ftol``) asks of an accepted step, read off the model at the
    best point instead: where a trust region's steps are all rejected (the polish's optimum on
    the kink of an interval's end, where the objective's curvature jumps), the step test is met
    only after its radius has shrunk to ``xtol``, about twenty rejections later. Independent of
    the parameters' scaling; 1 for a residual in the Jacobian's span (a zero-residual fit not
    reached yet) and 0 for ``r = 0``.

    Parameters
    ----------
    x : ndarray, shape (n_x,)
    r : ndarray, shape (n_r,)
        Residual at ``x``.
    J : ndarray, shape (n_r, n_x)
        Its Jacobian.
    lower, upper : ndarray, shape (n_x,)
        The box.

    Returns
    -------
    float
        Between 0 and 1.
    """
    total = float(r @ r)
    if not total > 0:
        return 0.0
    g = J.T @ r
    lo, hi = _edges(lower, upper)
    held = ((x <= lo) & (g > 0)) | ((x >= hi) & (g < 0))
    free = J[:, ~held]
    if not free.size:
        return 0.0
    step = np.linalg.lstsq(free, r, rcond=None)[0]
    moved = free @ step
    return float(moved @ moved) / total


def _step_box(x, lower, upper) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The box of a step ``d`` from ``x`` (``x`` kept inside it) and which parameters it lets
    move: a parameter its box fixes stays."""
    lo, hi = np.minimum(lower - x, 0.0), np.maximum(upper - x, 0.0)
    return lo, hi, lo < hi


def near_bounds(a, lower, upper, distance: float) -> np.ndarray:
    """The bounds within ``distance`` of the point ``a``, as `gauss_newton_point` takes its
    guess ``held``: -1 for the lower bound, 1 for the upper, 0 for neither."""
    return np.where(a - lower <= distance, -1, np.where(upper - a <= distance, 1, 0))


def gauss_newton_point(x, r, J, lower, upper, held=None) -> tuple[np.ndarray, np.ndarray]:
    """Where the Gauss-Newton step from ``x`` lands in the box: ``x + d``, ``d`` minimizing
    ``|r + J d|`` with ``lower <= x + d <= upper``; ``x`` itself where ``r`` or ``J`` is not
    finite; a parameter whose box is a point stays. The point the trust region's steps head for
    while the linear model holds: a run whose point is a known answer only finds that answer
    again.

    Given ``held``, a guess of the bounds active there (those at the last point of the run, or
    at its first point those of the known answer, `near_bounds`), one least squares with
    those parameters on their bounds gives the point when it is one: the others inside the box
    and the residual's gradient pushing each held one out (the optimality conditions of this
    convex program); else scipy's ``bvls`` solves it, one bound added or dropped per pass
    (`benchmarks/RESULTS.md`, "Starts whose Gauss-Newton step lands on a known answer").

    Parameters
    ----------
    x, r, J, lower, upper
        As in `gauss_newton_decrease`.
    held : ndarray of int, shape (n_x,), optional
        -1 for a parameter on its lower bound, 1 on its upper bound, 0 free: what this function
        returned for the last point, or any other guess.

    Returns
    -------
    point : ndarray, shape (n_x,)
    held : ndarray of int, shape (n_x,)
        The bounds active at ``point``, as ``held`` above.
    """
    x = np.asarray(x, dtype=float)
    lo, hi, free = _step_box(x, lower, upper)
    if not (free.any() and np.all(np.isfinite(r)) and np.all(np.isfinite(J))):
        return x, np.zeros(x.size, dtype=int)
    if held is not None:
        d = np.where(held < 0, lo, np.where(held > 0, hi, 0.0))
        inner = free & (held == 0)
        if inner.any():
            d[inner] = np.linalg.lstsq(J[:, inner], -(r + J[:, ~inner] @ d[~inner]), rcond=None)[0]
        g = J.T @ (r + J @ d)
        tol = 1e-10 * float(np.abs(g).max())   # a free parameter's gradient is zero to rounding of this scale
        if (np.all((d[inner] >= lo[inner]) & (d[inner] <= hi[inner])) and np.all(g[free & (held < 0)] >= -tol)
                and np.all(g[free & (held > 0)] <= tol)):
            return x + d, held
    d = np.zeros(x.size)
    d[free] = lsq_linear(J[:, free], -r, bounds=(lo[free], hi[free]), method="bvls").x
    edge = INSIDE * (hi - lo)   # bvls leaves an active parameter within rounding of its bound
    return x + d, np.where(free & (d <= lo + edge), -1, np.where(free & (d >= hi - edge), 1, 0))


#: Rounding allowance of `may_land_near`: a gradient entry within this share of the gradient's
#: scale (the largest sum of the magnitudes of an entry's terms) counts as zero, far more than
#: the optimality check of `gauss_newton_point` (1e-10 of the largest entry) or bvls leave.
LANDING_ROUNDING = 1e-6


def may_land_near(x, r, J, lower, upper, answers, distance: float) -> np.ndarray:
    """Which ``answers`` (shape (n_a, n_x)) the landing point `gauss_newton_point` may lie
    within ``distance`` of (largest entry), from the optimality conditions alone: False proves it
    does not, at the cost of a few products, without solving for the point.

    Every minimizer ``d`` of ``|r + J d|`` in the box satisfies, per parameter free to move, a
    gradient ``g(d) = J^T (r + J d)`` of 0 inside its bounds, >= 0 on the lower one, <= 0 on the
    upper one. Within ``distance`` of ``d* = a - x``, ``g(d)`` differs from ``g(d*)`` by at most
    ``distance`` times the row sums of ``|J^T J|``; so ``g(d*)`` below minus that bound needs
    ``d`` on the upper bound (``d*`` within ``distance`` of it), above it on the lower one. An
    answer whose ``g(d*)`` breaks this for some parameter is out of reach
    (`LANDING_ROUNDING` for the rounding of both sides). Arguments as in `gauss_newton_point`.

    Returns
    -------
    ndarray of bool, shape (n_a,)
    """
    x = np.asarray(x, dtype=float)
    answers = np.atleast_2d(answers)
    if not (np.all(np.isfinite(r)) and np.all(np.isfinite(J))):
        return np.ones(answers.shape[0], dtype=bool)   # `gauss_newton_point` stays at x: test it
    lo, hi, free = _step_box(x, lower, upper)
    H = J.T @ J
    step = answers - x                                   # d*, one row per answer
    g = J.T @ r + step @ H
    scale = np.abs(J).T @ np.abs(r) + np.abs(step) @ np.abs(H)   # of each gradient entry's terms
    reach = distance * np.abs(H).sum(axis=1) + LANDING_ROUNDING * scale.max(axis=1, keepdims=True)
    up = (g < -reach) & (step < hi - distance)           # needs the upper bound it cannot be on
    down = (g > reach) & (step > lo + distance)          # needs the lower bound it cannot be on
    return ~np.any((up | down) & free, axis=1)


def bounded_least_squares(evaluate, x0, lower, upper, known=None, monitor=None, evaluated: dict | None = None,
                          **options):
    """`scipy.optimize.least_squares` (trf, ``x_scale="jac"``) of ``evaluate`` from ``x0`` in
    the box ``[lower, upper]`` (all shape (n_x,)). ``evaluate(x)`` returns the residual and its
    exact Jacobian from one eigen-solve; it is called once per point. ``x0`` is nudged strictly
    inside the box (`inside`). ``known = (x, evaluate(x))`` saves the first evaluation when
    ``x`` is that start. ``evaluated``, a dict, holds the values of points evaluated before
    (by ``x.tobytes()``) and receives every new one: runs that share it (a restart from where
    the last one stopped, which retraces its rejected steps) solve no point twice. ``monitor``
    (a `Monitor`) hears of every new evaluation and may end the run by raising `Stop`.
    ``options`` go to ``least_squares``."""
    cache: dict = {} if evaluated is None else evaluated
    if known is not None:
        cache[np.asarray(known[0], dtype=float).tobytes()] = known[1]

    def at(x):
        key = x.tobytes()
        if key not in cache:
            value = evaluate(x)
            if evaluated is None:   # the last point only (scipy asks for its Jacobian right after)
                cache.clear()
            cache[key] = value
            if monitor is not None:
                monitor.seen(x, value)
        return cache[key]

    x_in = inside(x0, lower, upper)
    return least_squares(lambda x: at(x)[0], x_in, jac=lambda x: at(x)[1], bounds=(lower, upper),
                         method="trf", x_scale="jac", **options)
