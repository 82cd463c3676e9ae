"""Oblique DOFs: the reading of a sensor that is not along a node axis, as a DOF of the model (the
rules as the user reads them: docs/fe-models.md, "Sensors along an axis and oblique sensors").

The node's translations are replaced by ``u' = D u``, ``D`` the identity with the row of one
axis per oblique direction replaced by that direction (`Oblique.replaces`); with ``T`` the
identity except ``D^-1`` in the rows and columns of each such node's x, y, z (``q = T q'``),
every matrix becomes ``T^T A T`` (`congruent`): a congruence by a constant invertible ``T``
keeps the eigenvalues, the definiteness and the affinity in the parameters, and a mode shape
becomes ``D u`` at those nodes, the oblique readings. A rigid translation along axis ``a`` is
``D e_a`` in the new coordinates (`rigid_translations`).
"""

from __future__ import annotations

import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp


#: An oblique DOF's name: ``"<node>:n1"``, ``n2`` or ``n3``.
OBLIQUE_DOF = re.compile(r"^(.+):n([123])$")
AXES = ("x", "y", "z")


@dataclass(frozen=True)
class Oblique:
    """One oblique DOF of the model.

    Attributes
    ----------
    dof : str
        Its name, ``"<node>:n<k>"``.
    replaces : str
        The translation whose place (row and column of the matrices) it takes, ``"<node>:x"``.
    direction : ndarray, shape (3,)
        Unit vector (x, y, z): the DOF is the node's translation projected on it, m.
    """

    dof: str
    replaces: str
    direction: np.ndarray


def coordinate_change(dofs: Sequence[str], obliques: Sequence[Oblique]) -> tuple[sp.csr_matrix, tuple[str, ...]]:
    """``T`` (n, n), with ``q = T q'`` from the new coordinates ``q'`` to the exported ones,
    and the names of the new coordinates (``dofs`` with each `Oblique.replaces` renamed)."""
    index = {d: i for i, d in enumerate(dofs)}
    by_node: dict[str, list[Oblique]] = {}
    for o in obliques:
        by_node.setdefault(o.replaces.rsplit(":", 1)[0], []).append(o)
    n = len(dofs)
    kept = np.ones(n, dtype=bool)
    rows, cols, vals = [], [], []
    for node, group in by_node.items():
        slots = np.array([index[f"{node}:{a}"] for a in AXES])       # the node's x, y, z
        D = np.eye(3)
        for o in group:
            D[AXES.index(o.replaces.rsplit(":", 1)[1])] = o.direction
        kept[slots] = False
        rows.append(np.repeat(slots, 3))
        cols.append(np.tile(slots, 3))
        vals.append(np.linalg.inv(D).ravel())
    identity = np.flatnonzero(kept)
    T = sp.csr_matrix((np.concatenate([np.ones(identity.size)] + vals),
                       (np.concatenate([identity] + rows), np.concatenate([identity] + cols))), shape=(n, n))
    T.eliminate_zeros()
    names = list(dofs)
    for o in obliques:
        names[index[o.replaces]] = o.dof
    return T, tuple(names)


def congruent(A, T: sp.csr_matrix) -> sp.csr_matrix:
    """``T^T A T`` (both (n, n), sparse), made exactly symmetric (A is)."""
    B = sp.csr_matrix(T.T @ sp.csr_matrix(A) @ T)
    B = sp.csr_matrix((B + B.T) * 0.5)
    B.eliminate_zeros()
    return B


def rigid_translations(dofs: Sequence[str], directions: Mapping[str, np.ndarray] | None = None) -> np.ndarray:
    """A rigid translation of 1 m along x, y and z in the coordinates ``dofs``, shape (n, 3):
    1 on the ``"<node>:x"`` DOFs for x, the direction cosines of each oblique DOF (``directions``,
    DOF name -> unit vector (3,)) on it. Raises ValueError naming an oblique DOF
    (`OBLIQUE_DOF`) whose direction is not given."""
    directions = dict(directions or {})
    E = np.array([[d.endswith(f":{a}") for a in AXES] for d in dofs], dtype=float).reshape(len(dofs), 3)
    unknown = [d for d in dofs if OBLIQUE_DOF.match(d) and d not in directions]
    if unknown:
        shown = ", ".join(unknown[:4]) + (" ..." if len(unknown) > 4 else "")
        raise ValueError(f"the directions of the oblique DOFs {shown} are not known (the sensors file gives them)")
    index = {d: i for i, d in enumerate(dofs)}
    for dof, n in directions.items():
        if dof in index:
            E[index[dof]] = n
    return E


def translation_masses(M, dofs: Sequence[str], directions: Mapping[str, np.ndarray] | None = None) -> dict:
    """Mass moving with a unit translation along ``"x"``, ``"y"``, ``"z"``, kg: ``e^T M e`` with
    ``e`` from `rigid_translations` (M (n, n), kg); None for an axis no DOF moves along."""
    E = rigid_translations(dofs, directions)
    ME = sp.csr_matrix(M) @ E
    return {a: float(E[:, k] @ ME[:, k]) if E[:, k].any() else None for k, a in enumerate(AXES)}


def direction_text(direction) -> str:
    """A unit direction (3,) as text, ``"(0.7071, 0.7071, 0)"``; ``"-"`` when None."""
    if direction is None:
        return "-"
    return "(" + ", ".join(f"{float(c) + 0.0:.4g}" for c in direction) + ")"
