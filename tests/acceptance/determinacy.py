"""What the data of a known-truth problem determine, computed by the judge alone.

The library's own ranges (`vibupdate.ranges`) are not used: a widening there would widen the
judge too. Instead:

* `data_map`: every datum of the problem as a function of the physical parameters, evaluated by
  the independent dense kernels of `acceptance.truth` (natural frequencies and antiresonances in
  Hz; each shape entry as the model entry times a free scaling of that shape, which the data
  leave open; a mass-normalized shape's entries as they are, up to the sign);
* `jacobian`: its central finite-difference Jacobian at a point, in normalized parameters
  ``(x - nominal) / reference``;
* `consistent_ranges`: the linearized consistent set at that point, ``lower_i <= d_i(x0) +
  J_i dx <= upper_i`` for every datum, inside the parameter box, and per parameter its least and
  largest value over that set: two small linear programs per parameter
  (`scipy.optimize.linprog`, HiGHS). A parameter is determined when that range is narrower than
  `DETERMINED_PCT` of its reference value.

Exact data are widened to the judge's numerical meaning of exact
(`acceptance.emit.EXACT_SLACK`). The ranges are linear: they hold near the point where they are
computed, which is where the judge uses them (the truth and its mirror images); the judge allows
`MARGIN` of a range's width beyond it for the second-order terms.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import linprog

from acceptance import structures as S
from acceptance import truth as T
from acceptance.emit import EXACT_SLACK

__all__ = ["DETERMINED_PCT", "MARGIN", "STEP", "Datum", "Ranges", "data_map", "evaluate", "jacobian",
           "consistent_ranges", "at_truth"]

#: A parameter is determined when its consistent range is narrower than this (% of its reference).
DETERMINED_PCT = 5.0
#: Allowance beyond a linearized range, as a fraction of its width (second-order terms).
MARGIN = 0.1
#: Finite-difference step, in normalized parameters (a fraction of each reference value): well
#: above the 1e-14 rounding of the refined eigenvalues, its second-order error 1e-10 far below
#: `EXACT_SLACK`.
STEP = 1e-5

TWO_PI = 2.0 * np.pi


@dataclass(frozen=True)
class Datum:
    """One measured datum: ``kind`` ``"natural"``, ``"zero"`` or ``"shape"``; ``config`` the
    configuration's index; ``mode`` (model mode, 1-based, rigid modes counted) or ``zero``
    ``(response, excitation, index)``; ``dof`` and ``shape`` (index of the shape among the
    problem's shapes) for a shape entry; the interval ``[lower, upper]``."""

    kind: str
    config: int
    lower: float
    upper: float
    mode: int = 0
    zero: tuple = ()
    dof: str = ""
    shape: int = -1

    @property
    def label(self) -> str:
        if self.kind == "natural":
            return f"cfg{self.config} mode {self.mode}"
        if self.kind == "zero":
            return f"cfg{self.config} zero {self.zero[2]} of h_{self.zero[0]},{self.zero[1]}"
        return f"cfg{self.config} mode {self.mode} shape at {self.dof}"


def data_map(problem) -> tuple[list[Datum], int]:
    """The problem's data as `Datum` s and the number of shapes (each a free scaling)."""
    rel = problem.tolerance if problem.tolerance > 0 else EXACT_SLACK
    out, n_shapes = [], 0
    for c, cfg in enumerate(problem.data):
        for n in cfg.natural:
            out.append(Datum("natural", c, n.hz * (1 - rel), n.hz * (1 + rel), mode=n.mode))
            if n.shape:
                widen = EXACT_SLACK if problem.shape_noise == 0 else 0.0
                kind = "massnorm" if problem.mass_normalized else "shape"
                out += [Datum(kind, c, lo - widen, hi + widen, mode=n.mode, dof=d, shape=n_shapes)
                        for d, (lo, hi) in n.shape.items()]
                n_shapes += 1
        out += [Datum("zero", c, z.hz * (1 - rel), z.hz * (1 + rel), zero=(z.response, z.excitation, z.index))
                for z in cfg.zeros]
    return out, n_shapes


def _values(problem, x: np.ndarray) -> dict:
    return {p.name: p.nominal + p.reference * xi for p, xi in zip(problem.parameters, x)}


def evaluate(problem, data: list[Datum], x: np.ndarray, scale: np.ndarray | None = None) -> np.ndarray:
    """Every datum of the model at normalized parameters ``x``; a shape entry is the model entry
    over the model's entry at the shape's reference DOF (the one whose interval is nearest 1),
    times ``scale`` of that shape (1 when None)."""
    values = _values(problem, x)
    out = np.full(len(data), np.nan)
    cache: dict = {}
    for c, cfg in enumerate(problem.data):
        spec = problem.structure.with_mass(*cfg.extra_mass) if cfg.extra_mass else problem.structure
        cache[c] = S.matrices_at(spec, values)
    solved: dict = {}
    refs: dict = {}   # each shape's reference entry
    for d in data:
        if d.kind == "massnorm":   # the largest measured entry
            best = refs.get(d.shape)
            refs[d.shape] = d if best is None or abs(d.lower + d.upper) > abs(best.lower + best.upper) else best
        elif d.kind == "shape":    # the one whose interval is nearest 1
            best = refs.get(d.shape)
            key = abs(0.5 * (d.lower + d.upper) - 1.0)
            refs[d.shape] = d if best is None or key < abs(0.5 * (best.lower + best.upper) - 1.0) else best
    for i, d in enumerate(data):
        M, K, dofs = cache[d.config]
        if d.kind == "zero":
            key = (d.config, d.zero[:2])
            if key not in solved:
                solved[key] = T.zeros(M, K, dofs.index(d.zero[0]), dofs.index(d.zero[1]))[0]
            z = solved[key]
            out[i] = z[d.zero[2] - 1] / TWO_PI if d.zero[2] <= z.size else np.nan
            continue
        if d.config not in solved:
            solved[d.config] = T.modes(M, K)
        w, Phi = solved[d.config]
        if d.mode > w.size:
            continue
        if d.kind == "natural":
            out[i] = w[d.mode - 1] / TWO_PI
        elif d.kind == "massnorm":   # the sign that puts the largest measured entry positive
            ref = refs[d.shape]
            phi = Phi[:, d.mode - 1]
            sign = np.sign(phi[dofs.index(ref.dof)]) * np.sign(ref.lower + ref.upper)
            out[i] = sign * phi[dofs.index(d.dof)]
        else:
            ref = refs[d.shape]
            phi = Phi[:, d.mode - 1]
            out[i] = phi[dofs.index(d.dof)] / phi[dofs.index(ref.dof)] * (1.0 if scale is None else scale[d.shape])
    return out


def jacobian(problem, data: list[Datum], x0: np.ndarray, step: float = STEP) -> tuple[np.ndarray, np.ndarray]:
    """The data at ``x0`` and their central finite-difference Jacobian (normalized parameters)."""
    f0 = evaluate(problem, data, x0)
    J = np.empty((len(data), x0.size))
    for j in range(x0.size):
        e = np.zeros(x0.size)
        e[j] = step
        J[:, j] = (evaluate(problem, data, x0 + e) - evaluate(problem, data, x0 - e)) / (2 * step)
    return f0, J


@dataclass(frozen=True)
class Ranges:
    """Consistent ranges at one point, physical units (``lower``, ``upper``), their widths in %
    of each reference value, and whether the linearized data admit the point at all."""

    lower: np.ndarray
    upper: np.ndarray
    width_pct: np.ndarray
    feasible: bool


def consistent_ranges(problem, x0: np.ndarray, data: list[Datum] | None = None,
                      n_shapes: int | None = None) -> Ranges:
    """Linearized consistent ranges at normalized ``x0`` (module docstring)."""
    if data is None:
        data, n_shapes = data_map(problem)
    f0, J = jacobian(problem, data, x0)
    n = x0.size
    lo = np.array([d.lower for d in data])
    hi = np.array([d.upper for d in data])
    half = np.maximum(0.5 * (hi - lo), 1e-15)
    # variables: dx (n) and, per shape, dc (the change of its free scaling, around 1)
    G = np.zeros((len(data), n + n_shapes))
    G[:, :n] = J
    for i, d in enumerate(data):
        if d.kind == "shape":
            G[i, n + d.shape] = f0[i]
    finite = np.all(np.isfinite(G), axis=1) & np.isfinite(f0)
    box = [((p.lower - p.nominal) / p.reference - xi, (p.upper - p.nominal) / p.reference - xi)
           for p, xi in zip(problem.parameters, x0)]
    bounds = box + [(None, None)] * n_shapes
    # rows scaled by their half-widths: lo <= f0 + G z <= hi
    A = np.vstack([G[finite] / half[finite, None], -G[finite] / half[finite, None]])
    b = np.concatenate([(hi - f0)[finite] / half[finite], (f0 - lo)[finite] / half[finite]])
    refs = np.array([p.reference for p in problem.parameters])
    lower, upper = np.empty(n), np.empty(n)
    feasible = bool(np.all(finite))
    for j in range(n):
        c = np.zeros(n + n_shapes)
        for sign, target in ((1.0, lower), (-1.0, upper)):
            c[j] = sign
            sol = linprog(c, A_ub=A, b_ub=b, bounds=bounds, method="highs")
            if sol.status != 0:
                feasible = False
                target[j] = np.nan
            else:
                target[j] = sign * sol.fun
    nominal = np.array([p.nominal for p in problem.parameters])
    lower_p, upper_p = nominal + refs * (x0 + lower), nominal + refs * (x0 + upper)
    return Ranges(lower_p, upper_p, 100.0 * (upper - lower), feasible)


def at_truth(problem, values: dict) -> Ranges:
    """`consistent_ranges` at physical parameter ``values`` (the truth or a mirror image)."""
    x0 = np.array([(values[p.name] - p.nominal) / p.reference for p in problem.parameters])
    return consistent_ranges(problem, x0)
