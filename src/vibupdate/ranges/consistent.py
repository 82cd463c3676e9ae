"""What the data allow: the consistent set S of the certified ranges, and points of it (the set as
the user reads it: docs/polish-and-verification.md, 7.4, "The set").

    S = { xbar in its box : for every block b there are s_b in [wL_b^2, wU_b^2] and a vector
          v_b in the block's box with (K(xbar) - s_b M(xbar))[rows_b, cols_b] v_b = 0 }

up to a relative eigen-residual of `RESIDUAL_FLOOR`, row by row. A block per measured natural
frequency (the full pencil) and antiresonance (the adjunct pencil of ``h_rc``, Eqs. 7 and 9)
has the first stage's vector box (`vibupdate.inverse.formulation`), a measured shape's reference
entry freed to its own interval (`_scale_free`), and the window of its datum's interval or of
``frequency_tolerance`` (`_windows`); with ``include`` the windows and boxes hold the reported
answers (`vibupdate.ranges.inclusion`). Any eigenpair in a window counts, not only the paired mode.

This module states S (`consistent_set`), decides membership by eigen-analysis (`is_consistent`)
and finds points of S by local NLP solves at each parameter's bounds (`inner_ranges`): an inner
estimate of the ranges, to compare with the certified outer enclosure of `vibupdate.ranges.certify`.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace

import numpy as np

from vibupdate.inverse.correlation import model_frequencies
from vibupdate.inverse.formulation import formulate
from vibupdate.inverse.formulation.blocks import VectorBlock
from vibupdate.inverse.formulation.options import FormulationOptions
from vibupdate.inverse.interlacing import sign_bounds
from vibupdate.data.measured import Configuration
from vibupdate.ranges.inclusion import Inclusion, anchor, into_box, widen


#: Relative eigen-residual allowed in S: ``|((K - s M) v)_k| <= RESIDUAL_FLOOR * (|K| |v| + s |M| |v|)_k``
#: row by row, so that rounding in building the operators cannot exclude an exact eigenpair.
RESIDUAL_FLOOR = 1e-9


@dataclass(frozen=True)
class ConsistentSet:
    """The consistent set S (module docstring).

    Attributes
    ----------
    configurations : tuple of Configuration
    blocks : tuple of VectorBlock
        One per measured frequency, with the vector boxes (scaled coordinates).
    models : tuple of AffineModel
        The model of each block's configuration.
    omega_lower, omega_upper : ndarray, shape (n_blocks,)
        Frequency window of each block, rad/s.
    x_lower, x_upper : ndarray, shape (n_x,)
        Box of the normalized parameters.
    frequency_tolerance : float
        Relative half-width used where the data carry no interval.
    own_interval : ndarray of bool, shape (n_blocks,)
        The block's window is its datum's measured interval (else the global tolerance).
    inclusion : Inclusion, optional
        How the windows and boxes were widened to hold the included points.
    """

    configurations: tuple[Configuration, ...]
    blocks: tuple[VectorBlock, ...]
    models: tuple
    omega_lower: np.ndarray
    omega_upper: np.ndarray
    x_lower: np.ndarray
    x_upper: np.ndarray
    frequency_tolerance: float
    own_interval: np.ndarray | None = None
    inclusion: Inclusion | None = None

    @property
    def n_x(self) -> int:
        return self.x_lower.size

    def definition(self) -> str:
        """One paragraph stating S, for reports."""
        rel = np.max((self.omega_upper - self.omega_lower) / (self.omega_upper + self.omega_lower))
        own = int(np.count_nonzero(self.own_interval)) if self.own_interval is not None else 0
        n = len(self.blocks)
        if own == n:
            windows = f"each datum's own measured interval ({n} of {n} frequencies)"
        elif own:
            windows = (f"each datum's own measured interval ({own} of {n} frequencies), +-"
                       f"{100 * self.frequency_tolerance:.3g} % of the measured frequency for the others")
        else:
            windows = f"+-{100 * self.frequency_tolerance:.3g} % of the measured frequency (no datum has an interval)"
        shapes = sum(1 for b in self.blocks if not b.fixed.any())
        return (
            "Consistent set S: parameters within their bounds such that, for every measured natural "
            "frequency (and antiresonance), the model (its adjunct pencil) has an eigenvalue w^2 with w in "
            "the frequency window and an eigenvector inside the vector box of the first stage, up to the "
            "eigenvector's scale: each measured mode-shape entry (the reference entry included) in its own "
            "interval divided by the reference entry's midpoint, default margins on unmeasured entries, "
            "interlacing signs, and one entry fixed to 1 where no shape was measured "
            f"({shapes} of {n} vectors carry a measured shape). Windows: {windows}; widest half-window "
            f"{100 * rel:.3g} % after widening. Any eigenpair counts, not only the paired mode. "
            + (self.inclusion.text() if self.inclusion is not None else "S is not widened for any answer.")
        )


def _windows(configurations, blocks, tol):
    """The data's window of each block, rad/s, and whether it is the datum's own interval."""
    by_name = {c.name: c for c in configurations}
    lo, hi, own = [], [], []
    for blk in blocks:
        cfg = by_name[blk.configuration]
        data = (cfg.natural if blk.kind == "natural" else cfg.antiresonances)[blk.index - 1]
        own.append(data.interval is not None)
        a, b = data.interval if data.interval is not None else (data.omega * (1 - tol), data.omega * (1 + tol))
        lo.append(a)
        hi.append(b)
    return np.array(lo), np.array(hi), np.array(own, dtype=bool)


def _scale_free(blk: VectorBlock, cfg: Configuration) -> VectorBlock:
    """A natural block with a measured shape, its reference entry freed to its own interval
    (module docstring); other blocks unchanged. A reference interval reaching zero cannot
    exclude the trivial vector, and the entry stays fixed."""
    if blk.kind != "natural" or blk.measured is None or not blk.measured.any():
        return blk
    shape = cfg.natural[blk.index - 1].shape.on_dofs(cfg.model)   # the DOF box the block was built from
    ref = shape.reference
    j = int(np.flatnonzero(blk.cols == cfg.model.dof(ref))[0])
    if not blk.fixed[j]:
        return blk
    lo, hi = shape.bounds[ref]
    mid = shape.midpoint[ref]
    a, b = sorted((lo / mid, hi / mid))
    if not a > 0:
        return blk
    lower, upper, fixed = blk.lower.copy(), blk.upper.copy(), blk.fixed.copy()
    lower[j], upper[j], fixed[j] = a, b, False
    return replace(blk, lower=lower, upper=upper, fixed=fixed)


def consistent_set(configurations: Sequence[Configuration], *, frequency_tolerance: float = 0.0,
                   include=None, include_labels: Sequence[str] | None = None,
                   options: FormulationOptions | None = None) -> ConsistentSet:
    """State the consistent set S of ``configurations`` (module docstring).

    Parameters
    ----------
    configurations : sequence of Configuration
    frequency_tolerance : float
        Relative half-width of the frequency windows where the data carry no interval.
    include : ndarray, shape (n_x,) or (n_points, n_x), optional
        Normalized parameters (the answer first, then any other reported answers) that S must
        hold: windows and vector boxes are widened for them (`vibupdate.ranges.inclusion`).
    include_labels : sequence of str, optional
        A name per included point for the messages; default ``"the answer"`` for the first,
        ``"point i"`` for the others.
    options : FormulationOptions, optional
        Vector boxes as in the first stage (interlacing signs when ``options.interlacing``).
    """
    if not (np.isfinite(frequency_tolerance) and 0 <= frequency_tolerance < 1):
        raise ValueError(f"frequency_tolerance must be in [0, 1), got {frequency_tolerance!r}")
    configurations = tuple(configurations)
    options = options or FormulationOptions()
    transforms = [sign_bounds] if options.interlacing else []
    problem = formulate(configurations, options, transforms=transforms)
    by_name = {c.name: c for c in configurations}
    blocks = tuple(_scale_free(b, by_name[b.configuration]) for b in problem.blocks)
    models = tuple(by_name[b.configuration].model for b in blocks)
    lo, hi, own = _windows(configurations, blocks, frequency_tolerance)
    x_lower, x_upper, inclusion = problem.x_lower.copy(), problem.x_upper.copy(), None
    if include is not None:
        points = np.atleast_2d(np.asarray(include, dtype=float))
        if points.shape[1] != x_lower.size:
            raise ValueError(f"include must hold points of {x_lower.size} normalized parameters, got shape "
                             f"{np.shape(include)}")
        labels = list(include_labels) if include_labels is not None else (
            ["the answer"] + [f"point {i}" for i in range(1, len(points))])
        if len(labels) != len(points):
            raise ValueError(f"include_labels has {len(labels)} names for {len(points)} points")
        blocks, lo, hi, x_lower, x_upper, inclusion = widen(configurations, blocks, lo, hi, x_lower, x_upper,
                                                            points, labels)
    return ConsistentSet(configurations, blocks, models, lo, hi, x_lower, x_upper, float(frequency_tolerance), own,
                         inclusion)


def _eigenpairs(K, M):
    """Real eigenpairs (w^2, v) of the pencil (K, M), square."""
    import scipy.linalg as sla

    lam, V = sla.eig(K, M)
    keep = np.isfinite(lam) & (np.abs(lam.imag) <= 1e-10 * np.abs(lam)) & (lam.real > 0)
    return lam[keep].real, V[:, keep].real


def witness(cs: ConsistentSet, xbar, margin: float = 1e-7):
    """Eigenpairs that put ``xbar`` in S with a margin, one per block, or None.

    Every block needs a real eigenpair whose frequency is inside its window shrunk by
    ``margin`` (relative; an exact datum within the residual floor) and whose vector,
    scaled to the block's fixed entry (or by any scale, for a block without one), lies inside
    its box shrunk by ``margin`` (absolute, scaled coordinates). The margin absorbs the
    eigensolver's rounding, so a point with a witness is a point of S.

    Parameters
    ----------
    cs : ConsistentSet
    xbar : ndarray, shape (n_x,)
    margin : float

    Returns
    -------
    list of (float, ndarray) or None
        Per block ``(w^2, v)`` with ``v`` the block's vector in scaled coordinates, shape
        (len(cols),), fixed entries included.
    """
    xbar = np.asarray(xbar, dtype=float)
    if np.any(xbar < cs.x_lower) or np.any(xbar > cs.x_upper):
        return None
    pairs, dense, solved = [], {}, {}
    for b, (blk, model) in enumerate(zip(cs.blocks, cs.models)):
        if id(model) not in dense:  # assembled once per model, not once per block
            M, K = model.matrices(xbar)
            dense[id(model)] = (K.toarray(), M.toarray())
        key = (id(model), blk.rows.tobytes(), blk.cols.tobytes())
        if key not in solved:       # one eigen-solve per pencil: every mode block shares the full one
            solved[key] = _eigenpairs(*(A[np.ix_(blk.rows, blk.cols)] for A in dense[id(model)]))
        lam, V = solved[key]
        w = np.sqrt(lam)
        inside = (w >= cs.omega_lower[b] * (1 + margin)) & (w <= cs.omega_upper[b] * (1 - margin))
        if cs.omega_lower[b] == cs.omega_upper[b]:  # exact datum: within the residual floor
            inside = np.abs(w - cs.omega_lower[b]) <= 0.01 * RESIDUAL_FLOOR * cs.omega_lower[b]
        found = None
        for k in np.flatnonzero(inside):
            v = into_box(blk, V[:, k] / blk.scale, margin)
            if v is not None:
                found = (float(lam[k]), v)
                break
        if found is None:
            return None
        pairs.append(found)
    return pairs


def is_consistent(cs: ConsistentSet, xbar, margin: float = 1e-7) -> bool:
    """Whether ``xbar`` lies in S with a margin (`witness`)."""
    return witness(cs, xbar, margin) is not None


def _paired_slack(cs: ConsistentSet, xbar, mid, half) -> np.ndarray:
    """Constraints of the inner-estimate NLP, >= 0 when met: each paired frequency inside its
    window and each paired mode (normalized at the block's fixed entry, or at the midpoint of
    its freed reference entry, which then holds a subset of S) inside its box,
    relative to the window's half-width and the box width."""
    freqs = {c.name: model_frequencies(c, xbar) for c in cs.configurations}
    w, g = [], []
    for blk in cs.blocks:
        f = freqs[blk.configuration]
        if blk.kind != "natural":
            w.append(f.antiresonances[blk.index - 1])
            continue
        w.append(f.natural[blk.index - 1])
        v = f.Phi[blk.cols, blk.index - 1] / blk.scale
        j = anchor(blk)
        free = ~blk.fixed & (blk.measured if blk.measured is not None else True)
        free[j] = False
        ref = 0.5 * (blk.lower[j] + blk.upper[j])
        v = v / v[j] * ref if abs(v[j]) > 1e-12 * np.max(np.abs(v)) else np.full(v.size, 1e300)
        width = np.maximum(blk.upper[free] - blk.lower[free], 1e-12)
        g += [(v[free] - blk.lower[free]) / width, (blk.upper[free] - v[free]) / width]
    w = np.where(np.isfinite(w), w, 1e300)
    return np.concatenate([1.0 - np.abs(w - mid) / half] + g)


@dataclass(frozen=True)
class InnerRanges:
    """Inner estimate of the parameter ranges over S: the hull of the points found in S.

    Attributes
    ----------
    lower, upper : ndarray, shape (n_x,)
        Normalized; NaN when no point of S was found.
    points : ndarray, shape (n_points, n_x)
        Every point found and confirmed by `is_consistent`.
    seconds : float
    """

    lower: np.ndarray
    upper: np.ndarray
    points: np.ndarray
    seconds: float


def inner_ranges(cs: ConsistentSet, starts, *, max_iter: int = 50) -> InnerRanges:
    """Points of S at each parameter's extremes by local NLP solves (SLSQP).

    For each parameter and direction, from each start, maximize or minimize ``xbar_i`` subject
    to every paired frequency (mode k for the k-th natural frequency,
    `vibupdate.inverse.correlation.model_frequencies`) inside its window and every measured entry of
    the paired mode inside its interval; each solution is kept only if `is_consistent` confirms it, so the hull is an
    inner estimate of the ranges over S.

    Parameters
    ----------
    cs : ConsistentSet
    starts : ndarray, shape (n_starts, n_x)
        Starting points (e.g. the answer, the truth), normalized.
    max_iter : int
    """
    import time

    from scipy.optimize import minimize

    t0 = time.perf_counter()
    starts = np.atleast_2d(np.asarray(starts, dtype=float))
    mid = 0.5 * (cs.omega_lower + cs.omega_upper)
    half = np.maximum(0.5 * (cs.omega_upper - cs.omega_lower), 1e-9 * mid)
    constraints = [{"type": "ineq", "fun": lambda x: _paired_slack(cs, x, mid, half)}]
    points = [s for s in starts if is_consistent(cs, s)]
    bounds = list(zip(cs.x_lower, cs.x_upper))
    for i in range(cs.n_x):
        for sign in (1.0, -1.0):
            for s in starts:
                grad = np.zeros(cs.n_x)
                grad[i] = sign
                sol = minimize(lambda x: sign * x[i], s, jac=lambda x, g=grad: g, method="SLSQP", bounds=bounds,
                               constraints=constraints, options={"maxiter": max_iter, "ftol": 1e-12})
                x = np.clip(sol.x, cs.x_lower, cs.x_upper)
                # Step back towards the start until the point is confirmed (SLSQP ends on the
                # constraint boundary, where the margin of is_consistent rejects it).
                for theta in (1.0, 0.999, 0.99, 0.9):
                    y = s + theta * (x - s)
                    if is_consistent(cs, y):
                        points.append(y)
                        break
    P = np.array(points) if points else np.empty((0, cs.n_x))
    lo = P.min(axis=0) if len(P) else np.full(cs.n_x, np.nan)
    hi = P.max(axis=0) if len(P) else np.full(cs.n_x, np.nan)
    return InnerRanges(lo, hi, P, time.perf_counter() - t0)
