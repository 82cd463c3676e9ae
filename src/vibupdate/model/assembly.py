"""Assembly of built-in elements into sparse mass and stiffness matrices with named DOFs.

DOF names are the DOF kind followed by the node label: ``"y3"``, ``"phi3"`` for a beam node
labelled 3, ``"x3"``, ``"y3"``, ``"phi3"`` for a frame node. Measured data refer to DOFs by
these names.

An `Assembly` is filled inside a model builder (a function ``params -> System``) and is
evaluated once per call, so a builder can be called with complex parameter values for the
complex-step derivative (Eq. 15): every stored value keeps its complex type.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from vibupdate.model import elements

__all__ = ["Assembly", "System", "dof_index"]

_KINDS = {"beam": ("y", "phi"), "frame": ("x", "y", "phi")}


@dataclass(frozen=True)
class System:
    """Mass and stiffness matrices of a model with named DOFs.

    Attributes
    ----------
    M, K : scipy.sparse.csr_matrix, shape (n, n)
        Mass (kg, kg m, kg m^2) and stiffness (N/m, N, N m/rad) matrices.
    dofs : tuple of str, length n
        DOF names in matrix order.
    """

    M: sp.csr_matrix
    K: sp.csr_matrix
    dofs: tuple[str, ...]

    def dof(self, name: str) -> int:
        """Position (0-based) of the DOF called ``name``, as `AffineModel.dof`."""
        return dof_index(self.dofs, name)


def dof_index(dofs: Sequence[str], name: str) -> int:
    """Position of ``name`` in ``dofs``, with a clear error when it does not exist."""
    try:
        return list(dofs).index(name)
    except ValueError:
        shown = ", ".join(list(dofs)[:12]) + (", ..." if len(dofs) > 12 else "")
        raise ValueError(f"DOF {name!r} does not exist; the model's DOFs are {shown}") from None


class Assembly:
    """Collects element and lumped contributions, then builds sparse ``M``, ``K``.

    Parameters
    ----------
    kind : {"beam", "frame"}
        ``"beam"``: planar Euler-Bernoulli beam along x, DOFs ``y``, ``phi`` per node.
        ``"frame"``: planar frame, DOFs ``x``, ``y``, ``phi`` per node.

    Examples
    --------
    >>> asm = Assembly("beam")
    >>> for i, x in enumerate([0.0, 0.5, 1.0], start=1):
    ...     asm.node(i, x)
    >>> asm.beam(1, 2, EI=10.0, mass_per_length=1.0)
    >>> asm.beam(2, 3, EI=10.0, mass_per_length=1.0)
    >>> asm.clamp(1)
    >>> asm.system().dofs
    ('y2', 'phi2', 'y3', 'phi3')
    """

    def __init__(self, kind: str = "beam"):
        if kind not in _KINDS:
            raise ValueError(f"assembly kind must be one of {sorted(_KINDS)}, got {kind!r}")
        self.kind = kind
        self._dof_kinds = _KINDS[kind]
        self._coords: dict[object, tuple[float, float]] = {}
        self._dofs: list[str] = []
        self._index: dict[str, int] = {}
        self._base: dict[object, int] = {}  # node label -> index of its first DOF
        self._fixed: set[str] = set()
        self._m: list[tuple[np.ndarray, np.ndarray, np.ndarray]] = []
        self._k: list[tuple[np.ndarray, np.ndarray, np.ndarray]] = []
        # Element batches: (DOF indices (n_e, n_d), properties..., geometry...), evaluated
        # together in `system` by the batched element functions.
        self._elements: list[tuple] = []

    # -- nodes and supports -------------------------------------------------------------
    def node(self, label, x: float, y: float = 0.0) -> None:
        """Add a node at (x, y), m. For a beam assembly only x is used."""
        self.nodes([label], [x], [y])

    def nodes(self, labels: Sequence, x, y=None) -> None:
        """Add many nodes at once: ``labels`` (length n_n) at coordinates ``x``, ``y`` (m)."""
        labels = list(labels)
        x = np.broadcast_to(np.asarray(x, dtype=float), (len(labels),)).tolist()
        y = [0.0] * len(labels) if y is None else np.broadcast_to(np.asarray(y, dtype=float), (len(labels),)).tolist()
        if len(set(labels)) != len(labels) or any(label in self._coords for label in labels):
            seen = set(self._coords)
            for label in labels:
                if label in seen:
                    raise ValueError(f"node {label!r} is defined twice")
                seen.add(label)
        kinds = self._dof_kinds
        names = [f"{kind}{label}" for label in labels for kind in kinds]
        start = len(self._dofs)
        self._coords.update(zip(labels, zip(x, y)))
        self._base.update(zip(labels, range(start, start + len(names), len(kinds))))
        self._index.update(zip(names, range(start, start + len(names))))
        self._dofs.extend(names)

    def _node_dofs(self, label) -> list[int]:
        if label not in self._coords:
            raise ValueError(f"node {label!r} does not exist; nodes are {list(self._coords)}")
        return [self._index[f"{kind}{label}"] for kind in self._dof_kinds]

    def _dof(self, name: str) -> int:
        return self._index[name] if name in self._index else dof_index(self._dofs, name)

    def clamp(self, label) -> None:
        """Fix every DOF of a node."""
        self._node_dofs(label)
        self._fixed.update(f"{kind}{label}" for kind in self._dof_kinds)

    def pin(self, label) -> None:
        """Fix the translations of a node and leave its rotation free."""
        self._node_dofs(label)
        self._fixed.update(f"{kind}{label}" for kind in self._dof_kinds if kind != "phi")

    def fix(self, dof: str) -> None:
        """Fix a single named DOF."""
        self._dof(dof)
        self._fixed.add(dof)

    # -- contributions ------------------------------------------------------------------
    def _add(self, target, idx, block) -> None:
        idx = np.asarray(idx)
        rows = np.repeat(idx, idx.size)
        cols = np.tile(idx, idx.size)
        target.append((rows, cols, np.asarray(block).ravel()))

    def _element_dofs(self, first: Sequence, second: Sequence) -> np.ndarray:
        """DOF indices (n_e, 2 * n_kinds) of the elements between ``first[i]`` and ``second[i]``."""
        try:
            b1 = np.array([self._base[a] for a in first], dtype=np.int64)
            b2 = np.array([self._base[b] for b in second], dtype=np.int64)
        except KeyError:
            for label in list(first) + list(second):
                self._node_dofs(label)
            raise
        offsets = np.arange(len(self._dof_kinds))
        return np.concatenate([b1[:, None] + offsets, b2[:, None] + offsets], axis=1)

    def _deltas(self, first: Sequence, second: Sequence) -> tuple[np.ndarray, np.ndarray]:
        xy1 = np.array([self._coords[a] for a in first], dtype=float).reshape(-1, 2)
        xy2 = np.array([self._coords[b] for b in second], dtype=float).reshape(-1, 2)
        return xy2[:, 0] - xy1[:, 0], xy2[:, 1] - xy1[:, 1]

    def beam(self, n1, n2, *, EI, mass_per_length) -> None:
        """Euler-Bernoulli beam element between two nodes of a beam assembly.

        ``EI`` in N m^2, ``mass_per_length`` (rho A) in kg/m; the length is the distance of
        the nodes along x.
        """
        self.beams([n1], [n2], EI=EI, mass_per_length=mass_per_length)

    def beams(self, first: Sequence, second: Sequence, *, EI, mass_per_length) -> None:
        """Many beam elements at once, element ``i`` from node ``first[i]`` to ``second[i]``.

        ``EI`` (N m^2) and ``mass_per_length`` (kg/m): scalars or arrays of shape (n_e,).
        """
        if self.kind != "beam":
            raise ValueError("beam() needs a beam assembly; use frame() in a frame assembly")
        idx = self._element_dofs(first, second)
        dx, _ = self._deltas(first, second)
        n = idx.shape[0]
        self._elements.append(("beam", idx, _values(EI, n), _values(mass_per_length, n), np.abs(dx)))

    def frame(self, n1, n2, *, EA, EI, mass_per_length) -> None:
        """Planar frame element (axial + bending) between two nodes of a frame assembly.

        ``EA`` in N, ``EI`` in N m^2, ``mass_per_length`` (rho A) in kg/m.
        """
        self.frames([n1], [n2], EA=EA, EI=EI, mass_per_length=mass_per_length)

    def frames(self, first: Sequence, second: Sequence, *, EA, EI, mass_per_length) -> None:
        """Many frame elements at once, element ``i`` from node ``first[i]`` to ``second[i]``.

        ``EA`` (N), ``EI`` (N m^2) and ``mass_per_length`` (kg/m): scalars or arrays of shape
        (n_e,), real or complex.
        """
        if self.kind != "frame":
            raise ValueError("frame() needs a frame assembly; use beam() in a beam assembly")
        idx = self._element_dofs(first, second)
        dx, dy = self._deltas(first, second)
        n = idx.shape[0]
        self._elements.append(("frame", idx, _values(EA, n), _values(EI, n), _values(mass_per_length, n), dx, dy))

    def mass(self, dof: str, value) -> None:
        """Lumped mass (kg) on a translational DOF or rotary inertia (kg m^2) on a rotation."""
        self._add(self._m, [self._dof(dof)], np.reshape(value, (1, 1)))

    def spring(self, dof: str, stiffness, other: str | None = None) -> None:
        """Spring (N/m, or N m/rad on rotations) to ground, or between ``dof`` and ``other``."""
        if other is None:
            self._add(self._k, [self._dof(dof)], np.reshape(stiffness, (1, 1)))
        else:
            idx = [self._dof(dof), self._dof(other)]
            self._add(self._k, idx, stiffness * np.array([[1.0, -1.0], [-1.0, 1.0]]))

    # -- result -------------------------------------------------------------------------
    def _element_parts(self):
        """Stiffness and mass COO triplets of all element batches, evaluated kind by kind."""
        k_parts, m_parts = [], []
        for kind in ("beam", "frame"):
            batches = [b[1:] for b in self._elements if b[0] == kind]
            if not batches:
                continue
            idx, *columns = (np.concatenate(col) for col in zip(*batches))
            if kind == "beam":
                EI, mpl, length = columns
                k, m = elements.beam_matrices(EI, mpl, length)
            else:
                EA, EI, mpl, dx, dy = columns
                k, m = elements.frame_matrices(EA, EI, mpl, dx, dy)
            d = idx.shape[1]
            rows = np.repeat(idx, d, axis=1).ravel()
            cols = np.tile(idx, (1, d)).ravel()
            k_parts.append((rows, cols, k.ravel()))
            m_parts.append((rows, cols, m.ravel()))
        return k_parts, m_parts

    def _matrix(self, parts) -> sp.csr_matrix:
        n = len(self._dofs)
        if not parts:
            return sp.csr_matrix((n, n))
        rows = np.concatenate([p[0] for p in parts])
        cols = np.concatenate([p[1] for p in parts])
        vals = np.concatenate([p[2] for p in parts])
        return sp.coo_matrix((vals, (rows, cols)), shape=(n, n)).tocsr()

    def system(self) -> System:
        """Sparse ``M``, ``K`` over the free DOFs (supports removed), with their names."""
        fixed = np.zeros(len(self._dofs), dtype=bool)
        fixed[[self._index[name] for name in self._fixed]] = True
        free = np.flatnonzero(~fixed)
        k_parts, m_parts = self._element_parts()
        M = self._matrix(m_parts + self._m)[free][:, free]
        K = self._matrix(k_parts + self._k)[free][:, free]
        M.eliminate_zeros()
        K.eliminate_zeros()
        return System(M.tocsr(), K.tocsr(), tuple(np.array(self._dofs, dtype=object)[free]))


def _values(value, n: int) -> np.ndarray:
    """A property as an array of shape (n,), complex values kept (complex step)."""
    a = np.asarray(value)
    return np.broadcast_to(a.astype(np.result_type(a, float)), (n,)).copy()
