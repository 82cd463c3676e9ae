"""Assembly of built-in elements into sparse mass and stiffness matrices with named DOFs.

DOF names are the DOF kind followed by the node label: ``"y3"``, ``"phi3"`` for a beam node
labelled 3, ``"x3"``, ``"y3"``, ``"phi3"`` for a frame node. Measured data refer to DOFs by
these names.

An `Assembly` is filled with numbers inside a model builder (complex values kept, for the
complex step of Eq. 15), or once with `LinearExpression` properties and assembled directly into
the affine form (`Assembly.affine_parts`); supports and the DOF order are the same either way
(`vibupdate.model.build` lists the routes).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
import scipy.sparse as sp

from vibupdate.model import elements
from vibupdate.model.expressions import LinearExpression
from vibupdate.model.parameters import Parameter


_KINDS = {"beam": ("y", "phi"), "frame": ("x", "y", "phi")}


class NamedDofs:
    """A model whose DOFs are named: ``dofs``, the names in the order of the matrices' rows."""

    dofs: tuple[str, ...]

    def dof(self, name: str) -> int:
        """Position (0-based) of the DOF called ``name``: its row in the matrices.

        Parameters
        ----------
        name : str
            A name of ``dofs``.

        Returns
        -------
        int
            Its row in the matrices.

        Raises
        ------
        ValueError
            ``name`` is not a DOF of the model (the message lists some that are).
        """
        return dof_index(self.dofs, name)


@dataclass(frozen=True)
class System(NamedDofs):
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
        # Element batches and lumped items, evaluated in `system` (element batches of one
        # kind together, by the batched element functions) or in `affine_parts`.
        self._elements: list[_Batch] = []
        self._lumped: list[_Lumped] = []

    # -- nodes and supports -------------------------------------------------------------
    def node(self, label, x: float, y: float = 0.0) -> None:
        """Add a node at (x, y).

        Parameters
        ----------
        label : hashable
            The node's label; its DOFs are named after it (``"y2"``, ``"phi2"`` for node 2).
        x, y : float
            Coordinates, m. A beam assembly uses only ``x``.

        Raises
        ------
        ValueError
            The label is already a node.
        """
        self.nodes([label], [x], [y])

    def nodes(self, labels: Sequence, x, y=None) -> None:
        """Add many nodes at once.

        Parameters
        ----------
        labels : sequence of hashable, length n_n
            The nodes' labels, each new.
        x : float or array_like, shape (n_n,)
            Coordinates along x, m.
        y : float or array_like, shape (n_n,), optional
            Coordinates along y, m; 0 when omitted.

        Raises
        ------
        ValueError
            A label is repeated or is already a node.
        """
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
        """Fix every DOF of a node.

        Parameters
        ----------
        label : hashable
            The node's label.

        Raises
        ------
        ValueError
            The node does not exist.
        """
        self._node_dofs(label)
        self._fixed.update(f"{kind}{label}" for kind in self._dof_kinds)

    def pin(self, label) -> None:
        """Fix the translations of a node and leave its rotation free.

        Parameters
        ----------
        label : hashable
            The node's label.

        Raises
        ------
        ValueError
            The node does not exist.
        """
        self._node_dofs(label)
        self._fixed.update(f"{kind}{label}" for kind in self._dof_kinds if kind != "phi")

    def fix(self, dof: str) -> None:
        """Fix a single named DOF.

        Parameters
        ----------
        dof : str
            The DOF's name (``"y2"``, ``"phi3"``).

        Raises
        ------
        ValueError
            The DOF does not exist.
        """
        self._dof(dof)
        self._fixed.add(dof)

    # -- contributions ------------------------------------------------------------------
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

    def beam(self, n1, n2, *, EI, mass_per_length, rotary_inertia=0.0) -> None:
        """Euler-Bernoulli beam element between two nodes of a beam assembly.

        The length is the distance of the nodes along x.

        Parameters
        ----------
        n1, n2 : hashable
            The labels of the element's end nodes.
        EI : float or LinearExpression
            Bending stiffness, N m^2.
        mass_per_length : float or LinearExpression
            Mass per unit length ``rho A``, kg/m.
        rotary_inertia : float or LinearExpression
            Rotary inertia of the section per unit length ``rho I``, kg m; 0 (none) by default.

        Raises
        ------
        ValueError
            The assembly is a frame, a node does not exist, or a property is not a number.
        """
        self.beams([n1], [n2], EI=EI, mass_per_length=mass_per_length, rotary_inertia=rotary_inertia)

    def beams(self, first: Sequence, second: Sequence, *, EI, mass_per_length, rotary_inertia=0.0) -> None:
        """Many beam elements at once, element ``i`` from node ``first[i]`` to ``second[i]``.

        Each property is a scalar or an array of shape (n_e,), real or complex (a complex
        value is a complex step), or one `LinearExpression` of the parameters for all the
        elements.

        Parameters
        ----------
        first, second : sequence of hashable, length n_e
            The labels of the elements' end nodes.
        EI : float, array_like or LinearExpression
            Bending stiffness, N m^2.
        mass_per_length : float, array_like or LinearExpression
            Mass per unit length ``rho A``, kg/m.
        rotary_inertia : float, array_like or LinearExpression
            Rotary inertia of the section per unit length ``rho I``, kg m; 0 (none) by default.

        Raises
        ------
        ValueError
            The assembly is a frame, a node does not exist, or a property is not a number.
        """
        self._add("beam", first, second, EI=EI, mass_per_length=mass_per_length, rotary_inertia=rotary_inertia)

    def frame(self, n1, n2, *, EA, EI, mass_per_length, rotary_inertia=0.0) -> None:
        """Planar frame element (axial + bending) between two nodes of a frame assembly.

        Parameters
        ----------
        n1, n2 : hashable
            The labels of the element's end nodes.
        EA : float or LinearExpression
            Axial stiffness, N.
        EI : float or LinearExpression
            Bending stiffness, N m^2.
        mass_per_length : float or LinearExpression
            Mass per unit length ``rho A``, kg/m.
        rotary_inertia : float or LinearExpression
            Rotary inertia of the section per unit length ``rho I``, kg m; 0 (none) by default.

        Raises
        ------
        ValueError
            The assembly is a beam, a node does not exist, or a property is not a number.
        """
        self.frames([n1], [n2], EA=EA, EI=EI, mass_per_length=mass_per_length, rotary_inertia=rotary_inertia)

    def frames(self, first: Sequence, second: Sequence, *, EA, EI, mass_per_length, rotary_inertia=0.0) -> None:
        """Many frame elements at once, element ``i`` from node ``first[i]`` to ``second[i]``.

        Each property is a scalar or an array of shape (n_e,), real or complex (a complex
        value is a complex step), or one `LinearExpression` of the parameters for all the
        elements.

        Parameters
        ----------
        first, second : sequence of hashable, length n_e
            The labels of the elements' end nodes.
        EA : float, array_like or LinearExpression
            Axial stiffness, N.
        EI : float, array_like or LinearExpression
            Bending stiffness, N m^2.
        mass_per_length : float, array_like or LinearExpression
            Mass per unit length ``rho A``, kg/m.
        rotary_inertia : float, array_like or LinearExpression
            Rotary inertia of the section per unit length ``rho I``, kg m; 0 (none) by default.

        Raises
        ------
        ValueError
            The assembly is a beam, a node does not exist, or a property is not a number.
        """
        self._add("frame", first, second, EA=EA, EI=EI, mass_per_length=mass_per_length, rotary_inertia=rotary_inertia)

    def _add(self, kind: str, first: Sequence, second: Sequence, **properties) -> None:
        """A batch of elements of ``kind``, their ``properties`` in the order of the element function."""
        if self.kind != kind:
            other = "frame" if kind == "beam" else "beam"
            raise ValueError(f"{kind}() needs a {kind} assembly; use {other}() in a {other} assembly")
        idx = self._element_dofs(first, second)
        dx, dy = self._deltas(first, second)
        props = tuple(_property(value, idx.shape[0], what) for what, value in properties.items())
        self._elements.append(_Batch(kind, idx, props, (np.abs(dx),) if kind == "beam" else (dx, dy)))

    def mass(self, dof: str, value) -> None:
        """Add a lumped mass on a translational DOF or a rotary inertia on a rotation.

        Parameters
        ----------
        dof : str
            The DOF's name.
        value : float or LinearExpression
            The mass, kg (rotary inertia, kg m^2), or a `LinearExpression` of the parameters.

        Raises
        ------
        ValueError
            The DOF does not exist or ``value`` is not a number.
        """
        self._lumped.append(_Lumped("M", np.array([self._dof(dof)]), _POINT, _scalar(value, "mass")))

    def spring(self, dof: str, stiffness, other: str | None = None) -> None:
        """Add a spring to ground, or between two DOFs.

        Parameters
        ----------
        dof : str
            The DOF's name.
        stiffness : float or LinearExpression
            The stiffness, N/m (N m/rad on rotations), or a `LinearExpression` of the
            parameters.
        other : str, optional
            The DOF at the spring's other end; ground when omitted.

        Raises
        ------
        ValueError
            A DOF does not exist or ``stiffness`` is not a number.
        """
        value = _scalar(stiffness, "spring stiffness")
        if other is None:
            self._lumped.append(_Lumped("K", np.array([self._dof(dof)]), _POINT, value))
        else:
            idx = np.array([self._dof(dof), self._dof(other)])
            self._lumped.append(_Lumped("K", idx, _LINK, value))

    # -- result -------------------------------------------------------------------------
    def _matrices(self, batches, lumped, value, position: np.ndarray, n_free: int):
        """``M``, ``K`` over the free DOFs (``position`` from `_free_map`) of element ``batches``
        and ``lumped`` items, every property or lumped value mapped by ``value(prop)`` to a
        number (one for the batch) or an array (n_e,); the elements of one kind are evaluated
        together by the batched element functions."""
        parts = {"K": [], "M": []}
        for kind in ("beam", "frame"):
            chosen = [b for b in batches if b.kind == kind]
            if not chosen:
                continue
            idx = np.concatenate([b.idx for b in chosen])
            sizes = [b.idx.shape[0] for b in chosen]
            props = [_column([value(b.props[j]) for b in chosen], sizes) for j in range(len(chosen[0].props))]
            geometry = [np.concatenate(col) for col in zip(*(b.geometry for b in chosen))]
            # the element functions take the section properties, the geometry, then the rotary
            # inertia (the last property, optional there)
            k, m = getattr(elements, f"{kind}_matrices")(*props[:-1], *geometry, props[-1])
            d = idx.shape[1]
            rows = np.repeat(idx, d, axis=1).ravel()
            cols = np.tile(idx, (1, d)).ravel()
            parts["K"].append((rows, cols, k.ravel()))
            parts["M"].append((rows, cols, m.ravel()))
        for item in lumped:
            d = item.idx.size
            parts[item.matrix].append((np.repeat(item.idx, d), np.tile(item.idx, d),
                                       item.pattern * value(item.value)))
        return self._matrix(parts["M"], position, n_free), self._matrix(parts["K"], position, n_free)

    def _free_map(self) -> tuple[np.ndarray, np.ndarray]:
        """Position of every DOF among the free ones (-1 where fixed), shape (n_all,), and the
        indices of the free DOFs in assembly order."""
        fixed = np.zeros(len(self._dofs), dtype=bool)
        fixed[[self._index[name] for name in self._fixed]] = True
        free = np.flatnonzero(~fixed)
        position = np.full(len(self._dofs), -1, dtype=np.int64)
        position[free] = np.arange(free.size)
        return position, free

    @staticmethod
    def _matrix(parts, position: np.ndarray, n_free: int) -> sp.csr_matrix:
        """Sum of COO ``parts`` over the free DOFs (``position`` from `_free_map`)."""
        if not parts:
            return sp.csr_matrix((n_free, n_free))
        rows = position[np.concatenate([p[0] for p in parts])]
        cols = position[np.concatenate([p[1] for p in parts])]
        vals = np.concatenate([p[2] for p in parts])
        keep = (rows >= 0) & (cols >= 0)
        A = sp.coo_matrix((vals[keep], (rows[keep], cols[keep])), shape=(n_free, n_free)).tocsr()
        A.eliminate_zeros()
        return A

    @property
    def parameter_names(self) -> tuple[str, ...]:
        """Names of the parameters that the assembly's expressions involve.

        These are the names in its `LinearExpression` properties and lumped values, in order
        of first appearance.
        """
        names = {}
        for item in [*self._elements, *self._lumped]:
            for prop in (item.props if isinstance(item, _Batch) else (item.value,)):
                if isinstance(prop, LinearExpression):
                    names.update(dict.fromkeys(prop.names))
        return tuple(names)

    def system(self, values=None) -> System:
        """Sparse ``M``, ``K`` over the free DOFs (supports removed), with their names.

        Parameters
        ----------
        values : mapping of str to float or complex, optional
            Parameter values at which `LinearExpression` properties are evaluated (complex
            values give the complex step of Eq. 15); needed when the assembly has any.

        Returns
        -------
        System
            ``M``, ``K`` (csr, over the free DOFs) and the free DOFs' names in matrix order.

        Raises
        ------
        ValueError
            The assembly depends on a parameter that ``values`` does not give.
        """
        needed = self.parameter_names
        missing = [n for n in needed if values is None or n not in values]
        if missing:
            raise ValueError(f"the assembly depends on parameters without a value: {', '.join(missing)}")

        def value(prop):
            return prop(values) if isinstance(prop, LinearExpression) else prop

        position, free = self._free_map()
        M, K = self._matrices(self._elements, self._lumped, value, position, free.size)
        return System(M, K, tuple(np.array(self._dofs, dtype=object)[free]))

    def affine_parts(self, parameters: Sequence[Parameter]):
        """Nominal and normalized parameter matrices of the assembly (Eqs. 13-14).

        ``dK/dp_i`` is the assembly of the elements and lumped values whose expressions involve
        ``p_i``, each property set to its coefficient of ``p_i`` (docs/notes/model-build.md,
        "The elements model: the mechanism in full"); likewise ``dM/dp_i``.

        Parameters
        ----------
        parameters : sequence of Parameter, length n_x
            Must include every parameter the expressions name.

        Returns
        -------
        nominal : System
            ``M0``, ``K0`` at the nominal values, DOFs and supports as `system`.
        M_par, K_par : list of csr_matrix, each shape (n, n), length n_x
            ``dM/dxbar_i``, ``dK/dxbar_i``.
        """
        known = {p.name for p in parameters}
        unknown = [n for n in self.parameter_names if n not in known]
        if unknown:
            raise ValueError(f"the assembly depends on {', '.join(map(repr, unknown))}, which "
                             f"{'is' if len(unknown) == 1 else 'are'} not a parameter")
        nominal = self.system({p.name: p.nominal for p in parameters})
        position, free = self._free_map()
        touching = {name: ([], []) for name in known}
        for batch in self._elements:
            for name in dict.fromkeys(n for prop in batch.props if isinstance(prop, LinearExpression)
                                      for n in prop.names):
                touching[name][0].append(batch)
        for item in self._lumped:
            if isinstance(item.value, LinearExpression):
                for name in item.value.names:
                    touching[name][1].append(item)
        M_par, K_par = [], []
        for p in parameters:
            def value(prop, name=p.name, scale=p.reference):
                return prop.coefficient(name) * scale if isinstance(prop, LinearExpression) else 0.0

            M, K = self._matrices(*touching[p.name], value, position, free.size)
            M_par.append(M)
            K_par.append(K)
        return nominal, M_par, K_par


class _Batch(NamedTuple):
    """Elements of one kind added together: DOF indices (n_e, n_d), properties (each an
    array (n_e,) or one `LinearExpression`) in the order of the element function, geometry."""

    kind: str
    idx: np.ndarray
    props: tuple
    geometry: tuple


class _Lumped(NamedTuple):
    """A lumped mass or spring: matrix ``"M"`` or ``"K"``, DOF indices (d,), the pattern
    (d * d,) that multiplies the value, and the value (a number or a `LinearExpression`)."""

    matrix: str
    idx: np.ndarray
    pattern: np.ndarray
    value: object


_POINT = np.array([1.0])
_LINK = np.array([1.0, -1.0, -1.0, 1.0])


def _property(value, n: int, what: str):
    """A property as an array of shape (n,), complex values kept (complex step), or a
    `LinearExpression` as it is."""
    if isinstance(value, LinearExpression):
        return value
    a = np.asarray(value)
    if a.dtype == object or a.dtype.kind not in "biufc":
        raise ValueError(f"{what} must be a number, an array of numbers or a LinearExpression, got {value!r}")
    return np.broadcast_to(a.astype(np.result_type(a, float)), (n,)).copy()


def _column(values: list, sizes: list[int]) -> np.ndarray:
    """One property of consecutive batches as an array (sum(sizes),): each item a number
    for its whole batch or an array of its batch's size."""
    if not any(isinstance(v, np.ndarray) and v.ndim for v in values):
        return np.repeat(np.array(values), sizes)
    return np.concatenate([np.broadcast_to(v, (n,)) for v, n in zip(values, sizes)])


def _scalar(value, what: str):
    """A lumped value: a `LinearExpression` or a number (real or complex) as an array ()."""
    if isinstance(value, LinearExpression):
        return value
    a = np.asarray(value)
    if a.size != 1 or a.dtype == object or a.dtype.kind not in "biufc":
        raise ValueError(f"{what} must be a number or a LinearExpression, got {value!r}")
    return a.reshape(()).astype(np.result_type(a, float))
