"""Sensors that read linear combinations of a model's DOFs, and the measurement map (the rules as
the user reads them: docs/sensors.md).

A sensor reads ``y = w^T u``, a weight ``w_d`` on each DOF it sees (on a rigid body:
`rigid_weights`); it is data, not a DOF, and the model is not transformed. Everything that
compares a model vector with measured entries goes through the measurement map of a list of
names (`measurement_rows`); `dof_box` gives the box on DOFs that sensor intervals imply.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp


#: The reference DOFs a rigid body can name: translations x, y, z and rotations rx, ry, rz.
RIGID_DOFS = ("x", "y", "z", "rx", "ry", "rz")


@dataclass(frozen=True)
class Sensor:
    """A named reading ``sum_d weight_d * u_d`` of a model's DOFs.

    Attributes
    ----------
    name : str
    weights : tuple of (str, float)
        DOF name and weight of each DOF the sensor reads; at least one non-zero weight, each
        DOF once.
    """

    name: str
    weights: tuple[tuple[str, float], ...]

    def __post_init__(self):
        if not isinstance(self.name, str) or not self.name.strip():
            raise ValueError(f"a sensor needs a non-empty name, got {self.name!r}")
        pairs = tuple(self.weights.items()) if isinstance(self.weights, Mapping) else tuple(self.weights)
        if not pairs:
            raise ValueError(f"sensor {self.name!r} has no DOF weights; expected at least one DOF and its weight")
        clean, seen = [], set()
        for pair in pairs:
            try:
                dof, w = pair
            except (TypeError, ValueError):
                raise ValueError(f"sensor {self.name!r}: a weight is (DOF, number), got {pair!r}") from None
            if isinstance(w, bool) or not isinstance(w, (int, float, np.integer, np.floating)) \
                    or not math.isfinite(float(w)):
                raise ValueError(f"sensor {self.name!r}: the weight of {dof!r} must be a finite number, got {w!r}")
            if dof in seen:
                raise ValueError(f"sensor {self.name!r} names DOF {dof!r} twice; give each DOF one weight")
            seen.add(dof)
            clean.append((str(dof), float(w)))
        if not any(w != 0 for _, w in clean):
            raise ValueError(f"sensor {self.name!r} has only zero weights: it reads nothing")
        object.__setattr__(self, "weights", tuple(clean))


def rigid_weights(reference: Mapping[str, str], offset, direction) -> dict[str, float]:
    """The DOF weights of a sensor on a rigid body (module docstring).

    Parameters
    ----------
    reference : mapping of str to str
        The body's reference DOFs by kind: keys among `RIGID_DOFS` (e.g. ``{"x": "f1:x",
        "y": "f1:y", "rz": "f1:rz"}`` for a floor moving in its plane), values DOF names.
    offset : sequence of 2 or 3 float
        Position of the sensor from the reference point, m (``z`` 0 when two are given).
    direction : sequence of 2 or 3 float
        Direction the sensor reads, normalized here.

    Returns
    -------
    dict
        DOF name to weight, the zero weights (below 1e-12 of the offset's largest component,
        or of 1 m) left out. A reading that needs a DOF the body does
        not name (a rotation about x of a sensor off the plane, say) raises ValueError.
    """
    unknown = [k for k in reference if k not in RIGID_DOFS]
    if unknown:
        raise ValueError(f"a rigid body's reference DOFs are named by {', '.join(RIGID_DOFS)}; got {unknown}")
    r, n = (_vector3(v, what) for v, what in ((offset, "offset"), (direction, "direction")))
    if not np.linalg.norm(n) > 0:
        raise ValueError(f"a sensor's direction must not be zero, got {list(direction)!r}")
    n = n / np.linalg.norm(n)
    w = np.concatenate([n, np.cross(r, n)])
    scale = max(1.0, float(np.max(np.abs(r))))
    out = {}
    for kind, value in zip(RIGID_DOFS, w):
        if abs(value) <= 1e-12 * scale:
            continue
        if kind not in reference:
            raise ValueError(f"a sensor at offset {r.tolist()} along {n.tolist()} reads the body's {kind!r} "
                             f"(weight {value:.6g}), which its reference DOFs ({', '.join(reference)}) do not name")
        out[reference[kind]] = float(value)
    return out


def _vector3(values, what: str) -> np.ndarray:
    try:
        v = np.array([float(x) for x in values])
    except (TypeError, ValueError):
        raise ValueError(f"a sensor's {what} is 2 or 3 numbers, got {values!r}") from None
    if v.size not in (2, 3) or not np.all(np.isfinite(v)):
        raise ValueError(f"a sensor's {what} is 2 or 3 finite numbers, got {values!r}")
    return np.append(v, 0.0) if v.size == 2 else v


def check_sensors(dofs: Sequence[str], sensors: Sequence[Sensor]) -> tuple[Sensor, ...]:
    """``sensors`` checked against a model's ``dofs``: each name once and not a DOF's, each
    DOF a weight names one of the model's; raises ValueError naming the bad value."""
    known = set(dofs)
    seen = set()
    for s in sensors:
        if s.name in seen:
            raise ValueError(f"sensor {s.name!r} is declared twice; give each sensor one name")
        if s.name in known:
            raise ValueError(f"sensor {s.name!r} has the name of a DOF of the model; a DOF is measured by its own "
                             "name, so give the sensor another")
        seen.add(s.name)
        for d, _ in s.weights:
            if d not in known:
                shown = ", ".join(list(dofs)[:12]) + (", ..." if len(dofs) > 12 else "")
                raise ValueError(f"sensor {s.name!r} reads DOF {d!r}, which does not exist; the model's DOFs are "
                                 f"{shown}")
    return tuple(sensors)


def measurement_rows(dofs: Sequence[str], sensors: Sequence[Sensor], names: Sequence[str]) -> sp.csr_matrix:
    """The measurement map ``S``, shape (len(names), len(dofs)): the row of a DOF name is its
    unit row, the row of a sensor its weights; a name that is neither raises ValueError.
    ``dofs``: the model's DOF names in order, or a mapping of each to its position."""
    index = dofs if isinstance(dofs, Mapping) else {d: i for i, d in enumerate(dofs)}
    by_name = {s.name: s for s in sensors}
    rows, cols, vals = [], [], []
    for k, name in enumerate(names):
        if name in by_name:
            pairs = by_name[name].weights
        elif name in index:
            pairs = ((name, 1.0),)
        else:
            shown = ", ".join(list(index)[:12]) + (", ..." if len(index) > 12 else "")
            extra = (f"; its sensors are {', '.join(list(by_name)[:12])}" + (", ..." if len(by_name) > 12 else "")
                     if by_name else "")
            raise ValueError(f"DOF {name!r} does not exist; the model's DOFs are {shown}{extra}")
        rows += [k] * len(pairs)
        cols += [index[d] for d, _ in pairs]
        vals += [w for _, w in pairs]
    return sp.csr_matrix((vals, (rows, cols)), shape=(len(names), len(index)))


def dof_box(S: sp.csr_matrix, lower, upper) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The box on DOF entries that intervals on the readings ``S u`` imply (docs/sensors.md).

    A DOF ``i`` that the least-squares combination ``c = (S^+)^T e_i`` of the readings gives
    exactly lies in ``c^T y_mid +- |c|^T y_half``; ``S^+`` is formed group by group of readings
    that share DOFs (a plain DOF's reading is a group of one: its own interval). DOFs no
    combination of the readings gives are not bounded.

    Parameters
    ----------
    S : csr_matrix, shape (n_s, n)
    lower, upper : ndarray, shape (n_s,)

    Returns
    -------
    idx : ndarray of int, shape (n_b,)
        The DOFs bounded.
    lo, hi : ndarray, shape (n_b,)
    """
    from scipy.sparse.csgraph import connected_components

    S = sp.csr_matrix(S, dtype=float, copy=True)
    S.eliminate_zeros()
    lower, upper = np.asarray(lower, float), np.asarray(upper, float)
    first = np.unique(S.indices, return_index=True)[1]
    touched = S.indices[np.sort(first)]                            # in the order the readings name them
    A = S[:, touched].tocsr()
    n_s, n_t = A.shape
    # readings and DOFs that share no weight are independent: the least-squares inverse is
    # that of each connected group of them (a plain DOF's reading is a group of one)
    pattern = sp.csr_matrix((np.ones(A.nnz), A.indices, A.indptr), shape=A.shape)
    _, label = connected_components(sp.bmat([[None, pattern], [pattern.T, None]]), directed=False)
    row_label, col_label = label[:n_s], label[n_s:]
    n_rows = np.bincount(row_label, minlength=label.max() + 1)
    n_cols = np.bincount(col_label, minlength=label.max() + 1)
    single = np.flatnonzero((n_rows[row_label] == 1) & (n_cols[row_label] == 1))   # one reading of one DOF
    at = A.indptr[single]
    w = A.data[at]
    box_lo, box_hi = np.full(n_t, np.nan), np.full(n_t, np.nan)
    ends = np.sort(np.stack([lower[single] / w, upper[single] / w]), axis=0)   # exact: a DOF's own interval
    box_lo[A.indices[at]], box_hi[A.indices[at]] = ends
    exact = np.zeros(n_t, dtype=bool)
    exact[A.indices[at]] = True
    pi, pj, pv = [np.zeros(0, int)], [np.zeros(0, int)], [np.zeros(0)]
    row_order, col_order = np.argsort(row_label, kind="stable"), np.argsort(col_label, kind="stable")
    row_start, col_start = np.concatenate([[0], np.cumsum(n_rows)]), np.concatenate([[0], np.cumsum(n_cols)])
    for c in np.flatnonzero((n_rows > 0) & (n_cols > 0) & ~((n_rows == 1) & (n_cols == 1))):   # coupled groups
        r, t = row_order[row_start[c]:row_start[c + 1]], col_order[col_start[c]:col_start[c + 1]]
        block = A[r][:, t].toarray()
        P = np.linalg.pinv(block)                                 # (len(t), len(r))
        PA = P @ block
        ok = np.linalg.norm(PA - np.eye(t.size), axis=1) <= 1e-10 * max(1.0, np.linalg.norm(PA))
        exact[t[ok]] = True
        pi.append(np.repeat(t[ok], r.size))
        pj.append(np.tile(r, int(ok.sum())))
        pv.append(P[ok].ravel())
    P = sp.csr_matrix((np.concatenate(pv), (np.concatenate(pi), np.concatenate(pj))), shape=(n_t, n_s))
    coupled = np.unique(np.concatenate(pi))
    mid, half = 0.5 * (lower + upper), 0.5 * (upper - lower)
    centre, spread = P[coupled] @ mid, abs(P[coupled]) @ half
    box_lo[coupled], box_hi[coupled] = centre - spread, centre + spread
    return touched[exact], box_lo[exact], box_hi[exact]
