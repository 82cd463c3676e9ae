"""Measured points on an FE mesh: a sensor named by node and direction (``"1203:y"``) or by
coordinates and a sensor direction.

A sensor given by coordinates sits on the nearest node; its direction (a vector, normalized
here) is projected on that node's three translations. A case file measures single DOFs, so a
sensor whose direction is within `ALIGN_TOL` of an axis becomes that DOF with the sign of the
projection (a sensor pointing along -y measures ``-1 x "1203:y"``); an oblique sensor is
refused with its projection, which says which axes it mixes.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["Sensor", "locate", "ALIGN_TOL"]

#: Largest angle (rad) between a sensor and a node axis for it to measure that axis's DOF.
ALIGN_TOL = 0.01
_AXES = ("x", "y", "z")


@dataclass(frozen=True)
class Sensor:
    """Where a sensor measures on the mesh.

    Attributes
    ----------
    name : str
    dof : str
        The DOF it measures, ``"<node>:<dir>"``.
    sign : float
        +1, or -1 for a sensor pointing along the negative axis.
    distance : float
        From the given position to the node, m (0 for a sensor given by node).
    projection : ndarray, shape (3,)
        Direction cosines of the sensor on the node's x, y, z.
    """

    name: str
    dof: str
    sign: float
    distance: float
    projection: np.ndarray


def locate(name: str, dofs, nodes=None, *, dof: str | None = None, position=None, direction=None) -> Sensor:
    """Place one sensor: by ``dof`` (``"1203:y"``), or by ``position`` (shape (3,), m) and
    ``direction`` (shape (3,)) on the nearest of ``nodes`` (label -> coordinates, m) that has
    translational DOFs in ``dofs``."""
    dofs = set(dofs)
    if dof is not None:
        if dof not in dofs:
            raise ValueError(f"sensor '{name}': DOF {dof!r} is not in the model (names are '<node>:<dir>', dir in "
                             "x, y, z, rx, ry, rz)")
        axis = dof.split(":")[1]
        proj = np.array([float(a == axis) for a in _AXES])
        return Sensor(name, dof, 1.0, 0.0, proj)
    if position is None or direction is None:
        raise ValueError(f"sensor '{name}': give a dof, or a position and a direction")
    if not nodes:
        raise ValueError(f"sensor '{name}' is placed by coordinates, but the export holds no node coordinates")
    p, v = np.asarray(position, dtype=float), np.asarray(direction, dtype=float)
    if p.shape != (3,) or v.shape != (3,) or not np.linalg.norm(v) > 0:
        raise ValueError(f"sensor '{name}': position and direction are [x, y, z] with a non-zero direction, got "
                         f"{list(p)} and {list(v)}")
    candidates = [(label, xyz) for label, xyz in nodes.items() if any(f"{label}:{a}" in dofs for a in _AXES)]
    if not candidates:
        raise ValueError(f"sensor '{name}': no node with translational DOFs in the model")
    label, xyz = min(candidates, key=lambda item: float(np.linalg.norm(np.resize(item[1], 3) - p)))
    proj = v / np.linalg.norm(v)
    k = int(np.argmax(np.abs(proj)))
    if np.arccos(min(1.0, abs(proj[k]))) > ALIGN_TOL:
        raise ValueError(f"sensor '{name}' at node {label}: direction {list(np.round(proj, 4))} mixes the node's "
                         f"axes x, y, z; a case file measures one DOF per sensor: align it with an axis")
    target = f"{label}:{_AXES[k]}"
    if target not in dofs:
        raise ValueError(f"sensor '{name}': node {label} has no DOF {target!r} (constrained?)")
    return Sensor(name, target, float(np.sign(proj[k])), float(np.linalg.norm(np.resize(xyz, 3) - p)), proj)
