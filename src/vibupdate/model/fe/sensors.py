"""Measured points on an FE mesh: a sensor named by node and direction (``"1203:y"``) or by
coordinates and a sensor direction, and the DOF each one reads: the nearest node that moves, that
node's axis within `ALIGN_TOL`, else an oblique DOF ``"<node>:n<k>"`` (`vibupdate.model.fe.oblique`);
at most three independent readings a node (the rules as the user reads them: docs/fe-models.md,
"Sensors along an axis and oblique sensors").
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from itertools import permutations

import numpy as np

from vibupdate.model.fe.oblique import AXES, Oblique


#: Angle (rad): a sensor within it of a node axis reads that axis's DOF; within it of an
#: oblique direction on its node, that direction's DOF; within it of the span of the node's
#: other readings, it is refused.
ALIGN_TOL = 0.01


@dataclass(frozen=True)
class Sensor:
    """Where a sensor measures on the mesh.

    Attributes
    ----------
    name : str
    dof : str
        The DOF it reads, ``"<node>:<dir>"``, or ``"<node>:n<k>"`` for an oblique one.
    sign : float
        +1, or -1 for a sensor pointing against its DOF's direction.
    distance : float
        From the given position to the node, m (0 for a sensor given by DOF).
    direction : ndarray of shape (3,), or None
        Unit vector (x, y, z) the reading is the node's translation projected on: ``sign`` times
        the DOF's direction. None for a sensor named by a rotational or scalar DOF.
    """

    name: str
    dof: str
    sign: float
    distance: float
    direction: np.ndarray | None


@dataclass(frozen=True)
class _Located:
    """A sensor on its node, before its DOF is chosen (``direction`` unit, or None with ``dof``)."""

    name: str
    node: str
    direction: np.ndarray | None
    distance: float
    dof: str | None = None


def _error(key: str, message: str) -> ValueError:
    return ValueError(f"{key}: {message}")


def _translations(label: str, dofs: set) -> list[str]:
    return [a for a in AXES if f"{label}:{a}" in dofs]


def _locate(item: dict, dofs: set, nodes) -> _Located:
    """One ``[[sensor]]`` table (``name`` and ``dof``, or ``position`` and ``direction``) on its node."""
    name, dof = item["name"], item.get("dof")
    if dof is not None:
        if dof not in dofs:
            raise ValueError(f"sensor '{name}': DOF {dof!r} is not in the model (names are '<node>:<dir>', dir in "
                             "x, y, z, rx, ry, rz)")
        node, axis = dof.rsplit(":", 1)
        if axis not in AXES:
            return _Located(name, node, None, 0.0, dof)
        return _Located(name, node, np.eye(3)[AXES.index(axis)], 0.0)
    if item.get("position") is None or item.get("direction") is None:
        raise ValueError(f"sensor '{name}': give a dof, or a position and a direction")
    if not nodes:
        raise ValueError(f"sensor '{name}' is placed by coordinates, but the export holds no node coordinates")
    p, v = np.asarray(item["position"], dtype=float), np.asarray(item["direction"], dtype=float)
    if p.shape != (3,) or v.shape != (3,) or not np.all(np.isfinite(np.r_[p, v])) or not np.linalg.norm(v) > 0:
        raise ValueError(f"sensor '{name}': position and direction are [x, y, z] (finite numbers) with a non-zero "
                         f"direction, got {p.tolist()} and {v.tolist()}")
    labels = list(nodes)       # the nearest node; ties go to a node that moves
    where = np.array([np.resize(np.asarray(nodes[k], dtype=float), 3) for k in labels])
    distance = np.linalg.norm(where - p, axis=1)
    still = np.array([not _translations(k, dofs) for k in labels])
    k = int(np.lexsort((still, distance))[0])
    if still[k]:
        raise ValueError(f"sensor '{name}': the nearest node to {p.tolist()}, {labels[k]} ({distance[k]:.3g} m "
                         "away), has no translational DOF in the model (constrained, or not in the export); "
                         "place the sensor on a node that moves")
    return _Located(name, labels[k], v / np.linalg.norm(v), float(distance[k]))


def _span_residual(n: np.ndarray, basis: list[np.ndarray]) -> float:
    """Length of the part of ``n`` orthogonal to the span of ``basis`` (vectors of shape (3,))."""
    if not basis:
        return float(np.linalg.norm(n))
    B = np.array(basis).T
    return float(np.linalg.norm(n - B @ np.linalg.lstsq(B, n, rcond=None)[0]))


def _slots(kept: set, directions: list[np.ndarray]) -> tuple[int, ...]:
    """The axes the oblique ``directions`` replace, in order: among those no aligned sensor reads
    (``kept``), the assignment of largest ``|det D|``."""
    if not directions:
        return ()
    best, choice = -1.0, ()
    for perm in permutations([a for a in range(3) if a not in kept], len(directions)):
        D = np.eye(3)
        D[list(perm)] = directions
        size = abs(np.linalg.det(D))
        if size > best:
            best, choice = size, perm
    return choice


class _Node:
    """The sensors on one node and the DOFs they read."""

    def __init__(self, label: str, dofs: set):
        self.label, self.dofs = label, dofs
        self.axes: dict[int, str] = {}              # axis read by aligned sensors -> the first one's name
        self.oblique: list[tuple[np.ndarray, str]] = []   # (unit direction, the first sensor's name)
        self.read: list[tuple[_Located, int, float]] = []   # sensor, reading (axis 0..2 or 3 + oblique k), sign

    def add(self, s: _Located) -> None:
        k = int(np.argmax(np.abs(s.direction)))      # an axis within ALIGN_TOL (either sense)?
        if np.arccos(min(1.0, abs(s.direction[k]))) <= ALIGN_TOL:
            if f"{self.label}:{AXES[k]}" not in self.dofs:
                raise ValueError(f"sensor '{s.name}': node {self.label} has no DOF '{self.label}:{AXES[k]}' "
                                 "(constrained?)")
            self.axes.setdefault(k, s.name)
            self.read.append((s, k, float(np.sign(s.direction[k]))))
            return
        missing = [a for a in AXES if f"{self.label}:{a}" not in self.dofs]
        if missing:
            raise ValueError(f"sensor '{s.name}' at node {self.label}: direction {np.round(s.direction, 4).tolist()} "
                             f"is oblique, which needs the node's x, y and z translations; "
                             f"{', '.join(missing)} not in the model (constrained?)")
        for j, (n, _) in enumerate(self.oblique):
            if np.arccos(min(1.0, abs(n @ s.direction))) <= ALIGN_TOL:
                self.read.append((s, 3 + j, float(np.sign(n @ s.direction))))
                return
        self.oblique.append((s.direction, s.name))
        self.read.append((s, 3 + len(self.oblique) - 1, 1.0))

    def check(self) -> None:
        """Refuse an oblique direction within ALIGN_TOL of the span of the node's other readings."""
        basis = [np.eye(3)[k] for k in self.axes]
        names = [f"'{name}' ({AXES[k]})" for k, name in self.axes.items()]
        for n, name in self.oblique:
            if _span_residual(n, basis) < np.sin(ALIGN_TOL):
                angles = ", ".join(f"{np.degrees(np.arccos(np.clip(abs(n @ b), 0.0, 1.0))):.1f}" for b in basis)
                raise ValueError(
                    f"sensor '{name}' at node {self.label}: direction {np.round(n, 4).tolist()} is within "
                    f"{np.degrees(ALIGN_TOL):.2g} degrees of the span of the node's other readings (sensors "
                    f"{', '.join(names)}; angles {angles} degrees): its reading would be a combination of "
                    "theirs. A node holds at most three independent readings, each one DOF: move the sensor "
                    "to another node or give it a direction out of that span")
            basis.append(n)
            names.append(f"'{name}' ({np.round(n, 4).tolist()})")

    def readings(self) -> tuple[list[Sensor], list[Oblique]]:
        """What each sensor reads, in the order added, and the node's oblique DOFs (after `check`)."""
        slots = _slots(set(self.axes), [n for n, _ in self.oblique])
        obliques = [Oblique(f"{self.label}:n{j + 1}", f"{self.label}:{AXES[a]}", n)
                    for j, ((n, _), a) in enumerate(zip(self.oblique, slots))]
        sensors = []
        for s, k, sign in self.read:
            dof, along = (f"{self.label}:{AXES[k]}", np.eye(3)[k]) if k < 3 else \
                (obliques[k - 3].dof, obliques[k - 3].direction)
            sensors.append(Sensor(s.name, dof, sign, s.distance, sign * along))
        return sensors, obliques


def place(items: Sequence[dict], dofs, nodes=None,
          error: Callable[[str, str], Exception] = _error) -> tuple[tuple[Sensor, ...], tuple[Oblique, ...]]:
    """Every sensor of an import file on the mesh, and the oblique DOFs they need.

    Parameters
    ----------
    items : sequence of dict
        The ``[[sensor]]`` tables: ``name`` and either ``dof`` (``"1203:y"``) or ``position``
        (shape (3,), m) and ``direction`` (shape (3,), any length but 0).
    dofs : iterable of str
        The model's DOF names, ``"<node>:<dir>"``.
    nodes : mapping of str to array of shape (3,), optional
        Node label -> coordinates, m.
    error : callable
        ``error(key, message)`` -> the exception to raise; keys ``"sensor[i]"`` (1-based) for
        one sensor, ``"sensor"`` for the sensors of a node together.

    Returns
    -------
    sensors : tuple of Sensor, in the order of ``items``
    obliques : tuple of Oblique
        The DOFs to make (`vibupdate.model.fe.oblique.coordinate_change`), by node.
    """
    dofs, located = set(dofs), []
    for i, item in enumerate(items, start=1):
        try:
            located.append(_locate(item, dofs, nodes))
        except ValueError as exc:
            raise error(f"sensor[{i}]", str(exc)) from None
    groups: dict[str, _Node] = {}
    done: dict[int, Sensor] = {}      # id of a located sensor -> its reading
    for i, s in enumerate(located, start=1):
        if s.dof is not None:
            done[id(s)] = Sensor(s.name, s.dof, 1.0, 0.0, None)
            continue
        try:
            groups.setdefault(s.node, _Node(s.node, dofs)).add(s)
        except ValueError as exc:
            raise error(f"sensor[{i}]", str(exc)) from None
    obliques = []
    for node in groups.values():
        try:
            node.check()
        except ValueError as exc:
            raise error("sensor", str(exc)) from None
        sensors, made = node.readings()
        obliques += made
        done.update({id(s): r for (s, _, _), r in zip(node.read, sensors)})
    return tuple(done[id(s)] for s in located), tuple(obliques)
