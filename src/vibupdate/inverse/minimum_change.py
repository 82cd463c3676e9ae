"""Minimum change along what the data leave undetermined, and the set of answers there.

Where the exact Jacobian of the measured data ``g(x)`` (`_data`: declared frequencies and zeros,
shape ratios) has rank below the number of parameters (`RANK_RTOL`), the fitted parameters form
a set and the polished answer ``x*`` is an accident of the path. `minimum_change` returns the
point of the box nearest the nominal model with exactly the data of ``x*``, ``min ||x||^2 / 2``
subject to ``g(x) = g(x*)`` (`_same_data_nearest`), kept only when its data agree with those of
``x*`` to `DATA_TOL`; `valley_points`, `valley_ends`, `valley_curve` and `onto_data` explore the
set. The iteration, and why not scipy's constrained minimizers: docs/polish-and-verification.md,
section 7.5; the explorations: sections 7.4 and 7.7.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import asdict, dataclass

import numpy as np

from vibupdate.data.measured import Configuration
from vibupdate.inverse.data_map import measured_shapes
from vibupdate.inverse.baseline import classical_residuals


#: Singular values of the data Jacobian below this fraction of the largest count as zero (the
#: derivatives are exact: an exact symmetry gives ~1e-15); the reported sensitivity uses the same.
RANK_RTOL = 1e-8
#: The minimum-change point is kept only when each datum of the model there agrees with the
#: polished answer's to this (relative frequency; shape ratio in its own units).
DATA_TOL = 1e-9
#: Iterations at most (each one evaluation of the model with exact derivatives).
MAX_ITERATIONS = 30
#: The iteration stops once a step moves no normalized parameter by more than this (relative to
#: the largest, where that exceeds 1): below what the data are kept to (`DATA_TOL`), above the
#: precision of a large model's eigenvalue derivatives (docs section 7.5).
STEP_TOL = 1e-9
#: Weight of the shape-ratio rows of `_data` against the frequencies' (the constraint is
#: ``g(x) = g(x*)``, which any positive weight states; the rank's threshold sees it).
SHAPE_WEIGHT = 100.0


@dataclass(frozen=True)
class MinimumChange:
    """Outcome of the minimum-change step.

    Attributes
    ----------
    xbar_start, xbar : ndarray, shape (n_x,)
        The polished answer and the answer returned (equal when not applied or not kept).
    applied : bool
        Whether the data left directions undetermined (rank below the number of parameters).
    kept : bool
        Whether the minimum-change point replaced the polished answer.
    rank : int
        Rank of the data Jacobian at the polished answer.
    norm_start, norm : float
        ``||xbar||`` (Euclidean norm of the normalized parameters) at both points.
    data_change : float
        Largest change of a datum between the two points (relative frequency, shape ratio).
    iterations : int
        SQP iterations (each one evaluation of the model with exact derivatives).
    message : str
    """

    xbar_start: np.ndarray
    xbar: np.ndarray
    applied: bool
    kept: bool
    rank: int
    norm_start: float
    norm: float
    data_change: float
    iterations: int
    message: str

    def as_dict(self) -> dict:
        return {k: v for k, v in asdict(self).items() if k not in ("xbar_start", "xbar")}


def _data(configurations, x):
    """``g(x)`` up to fixed weights and constants, and its exact Jacobian."""
    return classical_residuals(configurations, x, SHAPE_WEIGHT)


def _weights(configurations: Sequence[Configuration]) -> np.ndarray:
    """Per residual row of `_data`, the factor that turns it into a datum change: the inverse
    of a frequency's ``sqrt(weight)``, of `SHAPE_WEIGHT` for a shape ratio, in the order of
    `vibupdate.inverse.baseline.classical_residuals`."""
    out = []
    for cfg in configurations:
        out += [1 / np.sqrt(d.weight) for d in (*cfg.natural, *cfg.antiresonances)]
        out += [1 / SHAPE_WEIGHT] * sum(s.lower.size + (s.mass is not None) for s in measured_shapes(cfg))
    return np.array(out)


def numerical_rank(sv: np.ndarray, rtol: float = RANK_RTOL) -> int:
    """Singular values ``sv`` (descending) above ``rtol`` of the largest."""
    return int(np.sum(sv > rtol * sv[0])) if sv.size and sv[0] > 0 else 0


def undetermined(configurations, x0):
    """`_data` at ``x0``, the rows with finite derivatives, the rank of their Jacobian and its
    right singular vectors (rows ``rank:`` span the directions the data leave undetermined);
    None when no datum has derivatives. The explorations of the set of answers share it."""
    g0, J = _data(configurations, x0)
    if J is None:
        return None
    finite = np.all(np.isfinite(J), axis=1) & np.isfinite(g0)
    if not finite.any():
        return None
    _, sv, Vt = np.linalg.svd(J[finite])
    return g0, J, finite, numerical_rank(sv), Vt


def _start(configurations, xbar, found):
    """The configurations as a list, the box, ``xbar`` as an array and `undetermined` there
    (``found`` when the caller has it)."""
    configurations = list(configurations)
    x0 = np.asarray(xbar, dtype=float)
    return (configurations, *configurations[0].model.bounds(), x0,
            found if found is not None else undetermined(configurations, x0))


def _independent_rows(J, finite, rank):
    """``rank`` rows of ``J`` (among the ``finite`` ones) of full rank, by pivoted QR."""
    from scipy.linalg import qr

    return np.flatnonzero(finite)[qr(J[finite].T, pivoting=True)[2][:rank]]


def _back_step(J, rows, rank, change):
    """The minimum-norm step ``d_n`` that undoes the data ``change`` to first order, from the
    ``rank`` leading singular triplets ``U_k, s_k, V_k`` of the ``rows`` of the Jacobian ``J``,
    and those triplets."""
    U, s, Vt = np.linalg.svd(J[rows], full_matrices=False)
    Uk, sk, Vk = U[:, :rank], s[:rank], Vt[:rank].T
    return -Vk @ ((Uk.T @ change[rows]) / sk), Uk, sk, Vk


def _curvature_update(B, s, y):
    """Powell's damped BFGS update of ``B`` (shape (n_x, n_x)) by the step ``s`` and the change
    ``y`` of the Lagrangian's gradient: ``y`` is blended with ``B s`` so that ``s^T y >= 0.2 s^T
    B s`` and ``B`` stays positive definite where the constraints' curvature is not (Nocedal and
    Wright, Numerical Optimization, 2nd ed., Procedure 18.2)."""
    Bs = B @ s
    sBs, sy = float(s @ Bs), float(s @ y)
    if not sBs > 0:
        return B
    theta = 1.0 if sy >= 0.2 * sBs else 0.8 * sBs / (sBs - sy)
    r = theta * y + (1 - theta) * Bs
    return B - np.outer(Bs, Bs) / sBs + np.outer(r, r) / float(s @ r)


def _same_data_nearest(configurations, x0, target, g0, finite, rank, lo, hi, at_x0=None):
    """The point of the box nearest ``target`` with the data ``g0`` of ``x0`` (``target`` 0 is
    the minimum change), by SQP steps in the null-space form from ``x0`` (docs section 7.5):
    ``d = d_n + Z p``, ``(Z^T B Z) p = -Z^T (x - target + B d_n)``, ``Z`` a basis of the directions
    ``V_k`` leaves out, ``B`` the Lagrangian's Hessian learned by `_curvature_update` from the
    identity. ``at_x0``: `_data` at ``x0`` when the caller has it. Returns the point, the largest
    datum change there (relative, as `DATA_TOL`), the iterations, and whether the model lost a
    declared mode or zero."""
    scale = _weights(configurations)[finite]
    x, iterations = x0.copy(), 0
    g, J = at_x0 if at_x0 is not None else _data(configurations, x0)
    B, before = np.eye(x.size), None
    for iterations in range(1, MAX_ITERATIONS + 1):
        back, Uk, sk, Vk = _back_step(J, finite, rank, g - g0)
        off = x - target
        if before is not None:   # the Lagrangian's gradient change, multipliers of this point
            multipliers = -Uk @ ((Vk.T @ off) / sk)
            B = _curvature_update(B, x - before[0], x - before[0] + (J[finite] - before[1]).T @ multipliers)
        Z = np.linalg.qr(Vk, mode="complete")[0][:, rank:]
        d = back - Z @ np.linalg.solve(Z.T @ B @ Z, Z.T @ (off + B @ back))
        x_new = np.clip(x + d, lo, hi)
        step = float(np.max(np.abs(x_new - x)))
        before, x = (x, J[finite]), x_new
        g, J = _data(configurations, x)
        if J is None or not np.all(np.isfinite(g[finite])):
            return x, float("inf"), iterations, True
        if step <= STEP_TOL * max(1.0, float(np.max(np.abs(x)))):
            break
    return x, float(np.max(np.abs((g[finite] - g0[finite]) * scale))), iterations, False


#: Points per sense of each undetermined direction in `valley_points`.
VALLEY_STEPS = 6


def valley_points(configurations: Sequence[Configuration], xbar, found=None) -> np.ndarray:
    """Points with exactly the data of ``xbar`` along each direction the data leave undetermined
    (docs section 7.4): per null direction ``v`` and sense, the points nearest ``xbar + (k / n) t
    v`` (``t`` to the box, ``k = 1 .. n``, ``n`` = `VALLEY_STEPS`), each keeping every datum to
    `DATA_TOL`; a sense stops at its first that fails. Returns shape (n_points, n_x), empty when
    the data determine every parameter. ``found``: as in `valley_curve`."""
    configurations, lo, hi, x0, found = _start(configurations, xbar, found)
    if found is None:
        return np.zeros((0, x0.size))
    g0, J, finite, rank, Vt = found
    points = []
    for v in Vt[rank:]:
        for sense in (1.0, -1.0):
            d = sense * v
            with np.errstate(divide="ignore", invalid="ignore"):
                reach = np.where(d > 0, (hi - x0) / d, np.where(d < 0, (lo - x0) / d, np.inf))
            t_max = float(np.min(reach))
            if not np.isfinite(t_max) or t_max <= 0:
                continue
            start, at = x0, (g0, J)
            for k in range(1, VALLEY_STEPS + 1):
                x, change, _, lost = _same_data_nearest(configurations, start, x0 + (k / VALLEY_STEPS) * t_max * d, g0,
                                                        finite, rank, lo, hi, at_x0=at)
                if lost or change > DATA_TOL:
                    break
                points.append(x)
                start, at = x, None
    return np.array(points).reshape(-1, x0.size)


#: A parameter moves along the directions the data leave undetermined when its component in
#: their span (the norm of its row of the null basis) exceeds this (`valley_ends`; the ranges'
#: `vibupdate.ranges.identifiability.NULL_COMPONENT` is the same figure).
MOVES = 1e-3
#: Iterations of each SLSQP run of `valley_ends` at most: a run stopped here still ends on a
#: point with the answer's data (checked to `DATA_TOL`), one that is not the extreme.
END_ITERATIONS = 20


def valley_ends(configurations: Sequence[Configuration], xbar, found=None) -> list[tuple[str, int, np.ndarray]]:
    """Where each parameter that the data leave free to move (`MOVES`) is lowest and highest
    among the points of the box with exactly the data of ``xbar`` (docs section 7.7): SLSQP on
    a set of the data's rows of full rank (`END_ITERATIONS`), then back onto every datum by
    `_same_data_nearest`. Returns ``(sense, i, x)`` per end that keeps every datum to `DATA_TOL`
    (``sense`` "lowest" or "highest", ``i`` the parameter). ``found``: as in `valley_curve`."""
    from scipy.optimize import minimize

    configurations, lo, hi, x0, found = _start(configurations, xbar, found)
    if found is None or found[3] >= x0.size:
        return []
    g0, J, finite, rank, Vt = found
    rows = _independent_rows(J, finite, rank)
    memo: dict = {x0.tobytes(): (g0, J)}

    def at(x):
        key = np.asarray(x, dtype=float).tobytes()
        if key not in memo:
            memo.clear()
            memo[key] = _data(configurations, x)
        return memo[key]

    ends = []
    for i in np.flatnonzero(np.linalg.norm(Vt[rank:], axis=0) > MOVES):
        unit = np.zeros(x0.size)
        unit[i] = 1.0
        for sense, sign in (("lowest", 1.0), ("highest", -1.0)):
            try:
                run = minimize(lambda x, i=i, sign=sign: sign * x[i], x0,
                               jac=lambda x, unit=unit, sign=sign: sign * unit, method="SLSQP",
                               bounds=list(zip(lo, hi)),
                               constraints={"type": "eq", "fun": lambda x: at(x)[0][rows] - g0[rows],
                                            "jac": lambda x: at(x)[1][rows]},
                               options={"ftol": 1e-12, "maxiter": END_ITERATIONS})
            except (ValueError, np.linalg.LinAlgError):   # a lost mode or zero on the way
                continue
            if not np.all(np.isfinite(run.x)):
                continue
            x, change, _, lost = _same_data_nearest(configurations, np.clip(run.x, lo, hi), np.clip(run.x, lo, hi),
                                                    g0, finite, rank, lo, hi)
            if not lost and change <= DATA_TOL:
                ends.append((sense, int(i), x))
    return ends


def onto_data(configurations: Sequence[Configuration], xbar, points, found=None) -> list[tuple[str, int, np.ndarray]]:
    """Each ``(sense, i, x)`` of ``points`` (found on another model of the same parameters: a
    reduced one) moved onto the data of ``xbar`` on these configurations by minimum-norm
    Gauss-Newton steps (at most `MAX_ITERATIONS`); those that reach every datum to `DATA_TOL`
    without losing a mode or zero. ``found``: as in `valley_curve`."""
    configurations, lo, hi, x0, found = _start(configurations, xbar, found)
    if found is None:
        return []
    g0, _, finite, rank, _ = found
    scale = _weights(configurations)[finite]
    out = []
    for sense, i, x in points:
        for _ in range(MAX_ITERATIONS):
            g, J = _data(configurations, x)
            if J is None or not np.all(np.isfinite(g[finite])):
                break
            if np.max(np.abs((g[finite] - g0[finite]) * scale)) <= DATA_TOL:
                out.append((sense, i, x))
                break
            x = np.clip(x + _back_step(J, finite, rank, g - g0)[0], lo, hi)
    return out


#: Arclength steps of `valley_curve` (normalized parameters): the first, the largest and the
#: smallest before a sense gives up; each step is a predictor along the tangent and a Newton
#: corrector of at most `CORRECTIONS` evaluations to `TRACE_TOL` (relative frequency).
TRACE_STEP = (0.02, 0.1, 1e-4)
CORRECTIONS = 6
TRACE_TOL = 1e-11
#: Regula falsi steps placing a turning point between two points of the trace (`valley_curve`).
TURN_REFINEMENTS = 4
#: Evaluations of `valley_curve` at most (both senses together).
TRACE_EVALUATIONS = 400


def valley_curve(configurations: Sequence[Configuration], xbar, found=None) -> list[tuple[str, int, np.ndarray]]:
    """The points where a parameter turns (is locally lowest or highest) along the set of
    answers with exactly the data of ``xbar``, where that set is a curve (one direction left
    undetermined among the parameters the data see), traced both ways to the box by
    pseudo-arclength continuation (docs section 7.7; `TRACE_STEP`, `CORRECTIONS`, `TRACE_TOL`),
    each turn placed by regula falsi on the parameter's tangent component. Returns ``(sense, i,
    x)``: the turns ("locally lowest" / "locally highest" parameter ``i``) and each parameter's
    extremes among the points traced ("lowest" / "highest"), each keeping every datum to
    `DATA_TOL`. ``found``: `undetermined` at ``xbar`` when the caller has it."""
    configurations, lo, hi, x0, found = _start(configurations, xbar, found)
    if found is None:
        return []
    g0, J, finite, rank, _ = found
    seen = np.linalg.norm(J[finite], axis=0) > 0
    if rank != int(seen.sum()) - 1:
        return []
    rows = _independent_rows(J[:, seen], finite, rank)
    count = [0]

    def at(y):
        count[0] += 1
        x = x0.copy()
        x[seen] = y
        g, Jy = _data(configurations, x)
        return g[rows] - g0[rows], Jy[rows][:, seen]

    def tangent(Jy, before):
        t = np.linalg.svd(Jy)[2][-1]
        return t if before is None or t @ before >= 0 else -t

    def correct(y_pred, t):
        y = y_pred.copy()
        for _ in range(CORRECTIONS):
            F, Jy = at(y)
            if np.all(np.isfinite(F)) and np.max(np.abs(F)) <= TRACE_TOL:
                return y, Jy
            if not np.all(np.isfinite(F)):
                return None
            y = y - np.linalg.solve(np.vstack([Jy, t]), np.append(F, t @ (y - y_pred)))
        return None

    lo_s, hi_s = lo[seen], hi[seen]
    y0 = x0[seen]
    t0 = tangent(J[rows][:, seen], None)
    turns, points = [], [y0]
    for sense in (1.0, -1.0):
        y, t, h = y0, sense * t0, TRACE_STEP[0]
        while count[0] < TRACE_EVALUATIONS and h >= TRACE_STEP[2]:
            y_pred = y + h * t
            if np.any(y_pred < lo_s) or np.any(y_pred > hi_s):   # past the box: end on its face
                reach = np.where(t > 0, (hi_s - y) / np.where(t > 0, t, 1),
                                 np.where(t < 0, (lo_s - y) / np.where(t < 0, t, 1), np.inf))
                j = int(np.argmin(reach))
                y_pred = y + reach[j] * t
                y_pred[j] = hi_s[j] if t[j] > 0 else lo_s[j]
                face = np.zeros(t.size)
                face[j] = 1.0
                end = correct(y_pred, face)     # on the curve with parameter j on its bound
                if end is not None and np.all(end[0] >= lo_s - 1e-12) and np.all(end[0] <= hi_s + 1e-12):
                    points.append(end[0])
                    break
                h = 0.5 * float(reach[j])
                continue
            step = correct(y_pred, t)
            if step is None or np.any(step[0] < lo_s) or np.any(step[0] > hi_s):   # corrected out of the box
                h /= 2
                continue
            y_new, J_new = step
            t_new = tangent(J_new, t)
            for i in np.flatnonzero(t * t_new < 0):
                mid, a, b, ca, cb = None, 0.0, h, t[i], t_new[i]
                for _ in range(TURN_REFINEMENTS):   # regula falsi on the component, in arclength
                    s_turn = a + (b - a) * ca / (ca - cb)
                    got = correct(y + s_turn * t, t)
                    if got is None:
                        break
                    mid = got[0]
                    c = tangent(got[1], t)[i]
                    a, ca, b, cb = (s_turn, c, b, cb) if c * ca > 0 else (a, ca, s_turn, c)
                if mid is not None:
                    turns.append(("locally lowest" if t[i] < 0 else "locally highest", int(i), mid))
                    points.append(mid)
            y, t, h = y_new, t_new, min(1.5 * h, TRACE_STEP[1])
            points.append(y)
    along = np.array(points)
    for i in range(along.shape[1]):
        turns += [("lowest", i, along[np.argmin(along[:, i])]), ("highest", i, along[np.argmax(along[:, i])])]
    out = []
    for sense, i, y in turns:   # each back on the data to DATA_TOL
        x = x0.copy()
        x[seen] = y
        x, change, _, lost = _same_data_nearest(configurations, x, x, g0, finite, rank, lo, hi)
        if not lost and change <= DATA_TOL:
            out.append((sense, int(np.flatnonzero(seen)[i]), x))
    return out


def minimum_change(configurations: Sequence[Configuration], xbar) -> MinimumChange:
    """The answer nearest the nominal point with the same data as ``xbar`` (module docstring).

    Parameters
    ----------
    configurations : sequence of Configuration
    xbar : ndarray, shape (n_x,)
        The polished answer, normalized parameters.
    """
    configurations, lo, hi, x0, found = _start(configurations, xbar, None)
    norm0 = float(np.linalg.norm(x0))

    def outcome(x, applied, rank, change, iterations, message):
        return MinimumChange(x0, x, applied, x is not x0, rank, norm0, float(np.linalg.norm(x)), change,
                             iterations, message)

    if found is None:
        return outcome(x0, False, 0, 0.0, 0, "no data with derivatives")
    g0, J, finite, rank, _ = found
    if rank >= x0.size:
        return outcome(x0, False, rank, 0.0, 0, "the data determine every parameter")
    if norm0 == 0.0:
        return outcome(x0, True, rank, 0.0, 0, "the answer is the nominal point")
    x, change, iterations, lost = _same_data_nearest(configurations, x0, np.zeros(x0.size), g0, finite, rank,
                                                     lo, hi, at_x0=(g0, J))
    if lost:
        return outcome(x0, True, rank, float("inf"), iterations,
                       "not kept: the model lost a declared mode or zero on the way")
    if change > DATA_TOL:
        return outcome(x0, True, rank, change, iterations,
                       f"not kept: the data moved by {change:.2e} (> {DATA_TOL:g}) on the way to the nominal point")
    if not np.linalg.norm(x) < norm0:
        return outcome(x0, True, rank, change, iterations, "the answer is already the minimum change")
    return outcome(x, True, rank, change, iterations,
                   f"{x0.size - rank} direction(s) undetermined by the data: the answer moved along them to the "
                   f"point nearest the nominal model (||xbar|| {norm0:.4g} -> {np.linalg.norm(x):.4g}), every "
                   f"datum unchanged within {change:.1e}")
