"""Which parameters do the data determine? Linearized interval ranges of the parameters (the
rules as the user reads them: docs/polish-and-verification.md, 7.4).

Around the answer ``xbar_hat`` the data map ``d(xbar)`` (`vibupdate.inverse.data_map`) is
linearized, ``d ~ d(xbar_hat) + G dx``, and the range of a parameter is its lowest and highest
value over the ``xbar`` within the bounds whose data stay in windows (two linear programs):

* a frequency within ``h_f + |w(xbar_hat) - w_measured|`` of the answer's, ``h_f`` the half-width
  of its measured ``interval`` or else ``frequency_tolerance * w``;
* a measured mode-shape entry in its interval for some scale of its mode (`_scaled_shapes`), an
  interval the answer misses by ``e`` (a model-form error the verification allowed) widened on
  that side to ``e`` beyond the answer.

A parameter along a null direction of the Jacobian gets its box. On models of up to
`VALLEY_DOFS` DOFs the ranges also hold the points of the valley with the answer's data, and
each end of a linear range is followed by up to `VALLEY_PROGRAMS` relinearized programs
(`_along_the_valley`). Matrices known only to a ``matrix_precision`` widen every window by what
that rounding does to the datum at the answer (`precision_allowance`).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from scipy.optimize import linprog

from vibupdate.inverse.data_map import data_jacobian, measured_shapes
from vibupdate.ranges.highs import highs, solve as solve_highs
from vibupdate.options import default
from vibupdate.inverse.minimum_change import (numerical_rank, undetermined, valley_curve, valley_ends,
                                              valley_points)
from vibupdate.modal.analysis import DENSE_LIMIT
from vibupdate.data.measured import Configuration


#: Models up to this many DOFs (those solved densely) have their ranges widened by the points
#: of the valley of answers with the same data (`vibupdate.inverse.minimum_change.valley_points`,
#: about 12 Gauss-Newton solves per undetermined direction).
VALLEY_DOFS = DENSE_LIMIT
#: A parameter moves along a null direction when its component there exceeds this; its range
#: is then its box (`parameter_ranges`).
NULL_COMPONENT = 1e-3
#: Linear programs relinearized along the valley per range end, at most (`_along_the_valley`):
#: each one data map and Jacobian, on models of up to `VALLEY_DOFS` DOFs.
VALLEY_PROGRAMS = 4


@dataclass(frozen=True)
class ParameterRanges:
    """Consistent ranges of the parameters.

    Attributes
    ----------
    names : tuple of str
    lower, upper : ndarray, shape (n_x,)
        Range of each parameter, physical units; NaN where the linear program failed.
    width_pct : ndarray, shape (n_x,)
        ``upper - lower`` in per cent of the parameter's reference value (its nominal, or the
        normalization value of a parameter with nominal 0).
    singular_values : ndarray
        Of the data Jacobian scaled by the data half-widths: near-zero values mark parameter
        combinations the data do not see.
    """

    names: tuple[str, ...]
    lower: np.ndarray
    upper: np.ndarray
    width_pct: np.ndarray
    singular_values: np.ndarray

    def determined(self, within_pct: float = 5.0) -> list[str]:
        """Parameters whose whole consistent range is narrower than ``within_pct``."""
        return [n for n, w in zip(self.names, self.width_pct) if np.isfinite(w) and w <= within_pct]

    def as_dict(self) -> dict:
        return {n: {"lower": float(lo), "upper": float(hi), "width_pct": float(w)}
                for n, lo, hi, w in zip(self.names, self.lower, self.upper, self.width_pct)}


def _measured(configurations, frequency_tolerance):
    """Measured data in the order of the data map (`vibupdate.inverse.data_map`), their
    half-widths, and a mask of the frequency rows."""
    values, half, is_freq = [], [], []
    for cfg in configurations:
        data = list(cfg.natural) + list(cfg.antiresonances)
        w = np.array([d.omega for d in data])
        values.append(w)
        half.append(np.array([frequency_tolerance * d.omega if d.interval is None
                              else 0.5 * (d.interval[1] - d.interval[0]) for d in data]))
        is_freq.append(np.ones(w.size, dtype=bool))
        shapes = measured_shapes(cfg)
        for shape in shapes:
            values.append(shape.midpoint)
            half.append(shape.half_width)
            is_freq.append(np.zeros(shape.lower.size, dtype=bool))
        masses = np.array([shape.mass for shape in shapes if shape.mass is not None]).reshape(-1, 2)
        values.append(masses.mean(axis=1))
        half.append(0.5 * (masses[:, 1] - masses[:, 0]))
        is_freq.append(np.zeros(len(masses), dtype=bool))
    return np.concatenate(values), np.concatenate(half), np.concatenate(is_freq)


def _eigenvalue_rounding(M, K, lam: float, right: np.ndarray, left: np.ndarray, delta: float) -> float:
    """Largest first-order change of the eigenvalue ``lam`` of the pencil ``(K, M)`` with right
    and left vectors ``right``, ``left`` when every entry of ``K`` and ``M`` moves by up to
    ``delta`` of its magnitude: ``delta (|y|^T |K| |x| + |lam| |y|^T |M| |x|) / |y^T M x|``,
    (rad/s)^2."""
    x, y = np.abs(right), np.abs(left)
    top = y @ (abs(K) @ x) + abs(lam) * (y @ (abs(M) @ x))
    return float(delta * top / max(abs(left @ (M @ right)), 1e-300))


def precision_allowance(configurations: Sequence[Configuration], xbar) -> np.ndarray | None:
    """How far the rounding of matrices known only to their ``matrix_precision`` moves each
    datum of the data map at ``xbar`` (`vibupdate.inverse.data_map` order): a frequency by
    the first-order bound of its eigenvalue under entries moved by up to ``delta`` of their
    magnitude (`_eigenvalue_rounding`, rad/s), a shape ratio by ten times the change of that
    mode's ratios under one unit of that rounding in every entry, plus its vector's own error
    (`vibupdate.modal.refinement.shape_ratio_floor`: one rounding unit per entry with random
    signs, a typical rather than a worst case). None when every model is exact to double
    precision.

    Returns
    -------
    ndarray, shape (n_d,) or None
    """
    if all(cfg.model.matrix_precision is None for cfg in configurations):
        return None
    from vibupdate.inverse.correlation import declared_zeros, model_frequencies
    from vibupdate.inverse.repeated import paired_vector
    from vibupdate.modal.refinement import shape_ratio_floor
    from vibupdate.modal.rigid import unit
    from vibupdate.modal.zeros import adjunct

    out = []
    for cfg in configurations:
        delta = unit(cfg.model.matrix_precision)
        M, K = cfg.model.matrices(xbar)
        f = model_frequencies(cfg, xbar, zeros=False)
        for k in range(len(cfg.natural)):
            w, phi = float(f.natural[k]), f.Phi[:, k]
            out.append(0.5 * _eigenvalue_rounding(M, K, w * w, phi, phi, delta) / max(abs(w), 1e-300))
        if cfg.antiresonances:
            pairs = dict(zip(cfg.receptances(), declared_zeros(cfg, xbar, M, K)[3]))
            for a in cfg.antiresonances:
                eigval, right, left = pairs[a.receptance]
                if a.index > eigval.size:
                    out.append(0.0)
                    continue
                r, c = cfg.model.dof(a.response), cfg.model.dof(a.excitation)
                j = a.index - 1
                lam = float(eigval[j])
                out.append(0.5 * _eigenvalue_rounding(adjunct(M, r, c), adjunct(K, r, c), lam, right[:, j],
                                                      left[:, j], delta) / np.sqrt(lam))
        shapes = measured_shapes(cfg)
        for shape in shapes:
            nat = cfg.natural[shape.position]
            phi, near = paired_vector(cfg, f.Phi_all, f.omega_all, shape.position)
            w = float(f.omega_all[nat.mode - 1])
            rounding, own = shape_ratio_floor(M, K, np.sign(w) * w**2, phi, shape.entries, shape.reference,
                                              basis=f.Phi_all[:, near] if near.size > 1 else None,
                                              precision=cfg.model.matrix_precision)
            allowance = 10.0 * rounding + own
            out += [allowance] * shape.lower.size
        out += [0.0] * sum(shape.mass is not None for shape in shapes)   # modal masses: relative, not rounding-sized
    return np.asarray(out, dtype=float)


def _scaled_shapes(configurations, d_hat, G, rounding, at=None):
    """The shape rows of the ranges' linear program (module docstring): ``s q_j(x)`` in each
    entry's interval, ``q`` the model's ratios (1 at the reference), linearized in ``dx`` and in
    the scale's step about the answer and its least-squares scale ``s0``; an entry known exactly
    has the contract's ``exact_half_width``. Returns the data-map rows they replace and, per
    shape, its rows divided by their half-widths (columns ``dx``, then one per shape's scale)
    and their offsets. ``at = (d, G, shift)``: the same windows, the shapes linearized at
    another point, ``shift`` the answer minus that point."""
    rows, extra, k, n_x = [], [], 0, G.shape[1]
    shapes = [(cfg, s) for cfg in configurations for s in measured_shapes(cfg)]
    n_s = sum(s.lower.size > 0 for _, s in shapes)
    col = 0
    for cfg in configurations:
        k += len(cfg.natural) + len(cfg.antiresonances)
        mine = measured_shapes(cfg)
        for shape in mine:
            idx = np.arange(k, k + shape.lower.size)
            k += shape.lower.size
            if not idx.size:
                continue
            nat = cfg.natural[shape.position].shape
            ref = nat.reference
            order = [ref] + [d for d in nat.bounds if d != ref]
            lo_m, hi_m = np.array([nat.bounds[d] for d in order], dtype=float).T
            q = np.concatenate([[1.0], d_hat[idx]])
            Gq = np.vstack([np.zeros((1, n_x)), G[idx]])
            mid = 0.5 * (lo_m + hi_m)
            s0 = float(q @ mid) / float(q @ q)
            v = s0 * q
            out = np.maximum(np.maximum(lo_m - v, v - hi_m), 0.0)
            low, high = np.minimum(lo_m, v - out), np.maximum(hi_m, v + out)
            exact = np.where(hi_m > lo_m, 0.0, default("verification", "exact_half_width") * abs(mid[0]))
            half = (0.5 * (high - low) + exact) * (1 + 1e-9) + 1e-12 * abs(mid[0])
            if rounding is not None:
                half = half + abs(s0) * np.concatenate([[0.0], rounding[idx]])
            if at is not None:   # the answer's windows, the linearization at the other point
                q = np.concatenate([[1.0], at[0][idx]])
                Gq = np.vstack([np.zeros((1, n_x)), at[1][idx]])
                s0 = float(q @ mid) / float(q @ q)
                v = s0 * (q + Gq @ at[2])
            block = np.zeros((q.size, n_x + n_s))
            block[:, :n_x] = s0 * Gq / half[:, None]
            block[:, n_x + col] = q / half
            extra.append((block, (v - 0.5 * (low + high)) / half))
            rows += list(idx)
            col += 1
        k += sum(s.mass is not None for s in mine)
    return rows, extra


def _holds(A, offset, dx, n_x: int) -> bool:
    """Whether the rows ``|A z + offset| <= 1`` of a range's linear program hold at the step
    ``dx`` for some scale step of each shape (the columns after the first ``n_x``): an
    intersection of intervals per shape, within HiGHS's default primal feasibility tolerance
    (1e-7 of a row's half-width). A row that is not finite does not hold."""
    tol = 1e-7
    r = A[:, :n_x] @ dx + offset
    if not (np.isfinite(r).all() and np.isfinite(A).all()):   # a datum the model lost at the point
        return False
    S = A[:, n_x:]
    g = S.sum(axis=1)          # each row has at most one scale column
    scaled = g != 0
    if np.any(np.abs(r[~scaled]) > 1.0 + tol):
        return False
    if not scaled.any():
        return True
    col = np.argmax(S[scaled] != 0, axis=1)
    a, b = (-1.0 - tol - r[scaled]) / g[scaled], (1.0 + tol - r[scaled]) / g[scaled]
    low, high = np.full(S.shape[1], -np.inf), np.full(S.shape[1], np.inf)
    np.maximum.at(low, col, np.minimum(a, b))
    np.minimum.at(high, col, np.maximum(a, b))
    return bool(np.all(low <= high))


def _along_the_valley(configurations, xbar, step, i: int, sign: float, program, solve) -> float:
    """The extreme of parameter ``i`` (its minimum for ``sign`` 1, maximum for -1) over the
    linear range's end ``xbar + step`` and the points found consistent with the data, by
    successive linear programs: from that end, the data and their Jacobian there, the program
    relinearized about that point (the answer's windows), its extreme the next point, at most
    `VALLEY_PROGRAMS` points. A point counts only where its own data lie in every window (its
    relinearized program holds at the point itself, `_holds`). A program whose answer cannot
    change the result is not solved (docs/polish-and-verification.md, 7.4)."""
    x = xbar + step
    end = float(x[i])
    for k in range(VALLEY_PROGRAMS):
        beyond = sign * (end - x[i]) > 0
        last = k == VALLEY_PROGRAMS - 1
        if last and not beyond:
            break
        d, G = data_jacobian(configurations, x)
        A, offset = program((d, G, xbar - x))
        if beyond and _holds(A, offset, x - xbar, xbar.size):
            end = float(x[i])
        if last:
            break
        c = np.zeros(A.shape[1])
        c[i] = sign
        nxt = solve(c, A, offset)
        if nxt is None or abs(nxt[i] - (x[i] - xbar[i])) <= 1e-9:
            break
        x = xbar + nxt[:xbar.size]
    return end


def parameter_ranges(configurations: Sequence[Configuration], xbar, *,
                     frequency_tolerance: float = 0.0, freqs=None, valley=None) -> ParameterRanges:
    """Consistent range of every parameter around the answer ``xbar`` (module docstring).

    The ranges are linearized at ``xbar``; the certified outer ranges over the consistent set
    of `vibupdate.ranges.consistent` are `vibupdate.certified_ranges`.

    Parameters
    ----------
    configurations : sequence of Configuration
        The measured configurations the answer was updated on.
    xbar : ndarray, shape (n_x,)
        The answer (normalized parameters).
    frequency_tolerance : float
        Relative half-width of the frequency window of every measured frequency without an
        ``interval`` (e.g. 3 sigma of the measurement error); a frequency with an interval uses
        the interval's half-width instead. The answer's own misfit is added to either.
    freqs : sequence of ModelFrequencies, optional
        `vibupdate.inverse.correlation.model_frequencies` of each configuration at ``xbar``
        with ``derivatives=True`` (`UpdateResult.correlation`), when already computed: the
        ranges then repeat no eigen-solve.
    valley : sequence of ndarray, optional
        The points of the set of answers with the answer's data that the update found at this
        ``xbar`` (`UpdateResult.valley`): the ranges read them instead of searching
        the same ends and turns again.

    Returns
    -------
    ParameterRanges
        The range of each parameter (physical units), its width in per cent and the singular
        values of the scaled data Jacobian.
    """
    configurations = list(configurations)
    model = configurations[0].model
    d_hat, G = data_jacobian(configurations, xbar, freqs=freqs)
    d_meas, half, is_freq = _measured(configurations, frequency_tolerance)
    misfit = d_hat - d_meas
    # The windows of the module docstring, |offset + G dx| <= half (a shape's interval widened
    # where the answer misses it: with the answer on the window's edge, many such rows left a
    # point, ranges of 1e-6 % on a bar whose shapes the model misses by 0.004).
    out = np.maximum(np.abs(misfit) - half, 0.0)
    low = np.minimum(-half, misfit - out)          # the shape window about the midpoint
    high = np.maximum(half, misfit + out)
    offset = np.where(is_freq, 0.0, misfit - 0.5 * (low + high))
    half = np.where(is_freq, half + np.abs(misfit), 0.5 * (high - low))
    # A floor against rounding: relative to the datum, and at least 1e-12 for a shape ratio
    # (dimensionless, of order 1 at its reference; a ratio near a node would otherwise get a
    # width of 1e-16).
    half = half * (1 + 1e-9) + 1e-12 * np.maximum(np.abs(d_meas), np.where(is_freq, 0.0, 1.0))
    rounding = precision_allowance(configurations, xbar)
    if rounding is not None:
        half = half + rounding
    lo, hi = model.bounds()
    xbar = np.asarray(xbar, dtype=float)
    # Each row divided by its half-width, |offset / half + (G / half) dx| <= 1, so that data known
    # to 1e-12 and to 1 % weigh alike in the solver's tolerances (unscaled, HiGHS found the refined
    # frame's point data infeasible); the unknown is the step dx from the answer, so that row
    # activities are O(1).
    center = d_hat - offset       # each window's centre, fixed at the answer

    def program(at=None):
        """The linear program's rows in the step ``dx`` from the answer (and each shape's scale
        step), linearized at the answer, or at ``at = (d, G, xbar - x)``, another point ``x``
        (the same windows: at ``dx = x - xbar`` its data rows are the data themselves)."""
        Gp, off = (G, offset) if at is None else (at[1], at[0] + at[1] @ at[2] - center)
        Gs, offs = Gp / half[:, None], off / half
        rows, extra = _scaled_shapes(configurations, d_hat, G, rounding, at)
        keep = np.ones(d_hat.size, dtype=bool)
        keep[rows] = False
        n_s = len(extra)
        A1 = np.vstack([np.hstack([Gs[keep], np.zeros((int(keep.sum()), n_s))])] + [e[0] for e in extra]
                       + [np.zeros((0, xbar.size + n_s))])
        o1 = np.concatenate([offs[keep]] + [e[1] for e in extra])
        return A1, o1       # |A1 z + o1| <= 1

    kept: dict = {}   # role -> (HiGHS instance, the rows it holds)

    def solve(c, A, offset):
        """The step minimizing ``c`` over ``-1 <= A z + offset <= 1`` and the box, by HiGHS's
        simplex kept warm (one instance for the program at the answer, one for those along the
        valley, each from the last basis), else the interior-point method (a badly conditioned
        program: the refined frame's exact data at 2,996 DOFs); None when neither solves it or a
        row is not finite (a datum the model lost at the point)."""
        if not (np.isfinite(A).all() and np.isfinite(offset).all()):
            return None
        role = "answer" if A is A0 else "moved"
        h, rows = kept.get(role, (None, None))
        if rows is None or rows[0] is not A or rows[1] is not offset:   # another program: loaded
            last = kept.get("last")
            h = highs(A, -1.0 - offset, 1.0 - offset, *box, h=h, basis=None if last is None else last.getBasis())
            kept[role] = (h, (A, offset))
        kept["last"] = h
        if solve_highs(h, c):
            return np.asarray(h.getSolution().col_value, dtype=float)
        sol = linprog(c, A_ub=np.vstack([A, -A]), b_ub=np.concatenate([1.0 - offset, 1.0 + offset]),
                      bounds=np.column_stack(box), method="highs-ipm")
        return sol.x if sol.status == 0 else None

    # A parameter along a null direction is bounded by its box alone, its programs not solved
    # (docs/polish-and-verification.md, 7.4; benchmarks/RESULTS.md, "Known-truth acceptance after the fixes").
    _, sv, Vt = np.linalg.svd(G / half[:, None])   # null directions: singular values below RANK_RTOL of the largest
    rank = numerical_rank(sv)
    free = np.any(np.abs(Vt[rank:]) > NULL_COMPONENT, axis=0) if rank < xbar.size else np.zeros(xbar.size, bool)
    A0, o = program()
    free_scales = np.full(A0.shape[1] - xbar.size, np.inf)      # one per shape, the same in every program
    box = (np.concatenate([lo - xbar, -free_scales]), np.concatenate([hi - xbar, free_scales]))
    lower, upper = np.full(xbar.size, np.nan), np.full(xbar.size, np.nan)
    bent = model.n_dofs <= VALLEY_DOFS
    for i in np.flatnonzero(~free):
        c = np.zeros(A0.shape[1])
        c[i] = 1.0
        for sign, target in ((1.0, lower), (-1.0, upper)):
            step = solve(sign * c, A0, o)
            if step is None:
                continue
            target[i] = xbar[i] + step[i]
            at_box = np.isclose(target[i], lo[i] if sign > 0 else hi[i], rtol=0.0, atol=1e-12)
            if bent and not at_box:
                target[i] = _along_the_valley(configurations, xbar, step[:xbar.size], i, sign, program, solve)
    lower, upper = np.where(free, lo, lower), np.where(free, hi, upper)
    if rank < xbar.size and model.n_dofs <= VALLEY_DOFS:
        # the points of the valley with the answer's data, and its ends and turns (the update's, when given)
        found = undetermined(configurations, xbar)   # one evaluation at the answer for the three
        ends = list(valley) if valley else [x for _, _, x in valley_ends(configurations, xbar, found)
                                            + valley_curve(configurations, xbar, found)]
        points = np.vstack([valley_points(configurations, xbar, found=found)] + [np.atleast_2d(x) for x in ends])
        if points.size:
            lower, upper = np.fmin(lower, points.min(axis=0)), np.fmax(upper, points.max(axis=0))
    width = (upper - lower) * 100.0   # xbar is already relative to the reference value
    return ParameterRanges(model.parameter_names, model.physical(lower), model.physical(upper), width, sv)
