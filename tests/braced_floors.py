"""The 4-storey, 2 x 2-bay braced frame of `benchmarks/braced_frame.py` (the IASC-ASCE
benchmark class) given element by element on its 12 rigid-floor DOFs, with four accelerometers
per floor: what a user of that benchmark has, written as files a case reads as they are.

Each member's 12 x 12 matrices (the benchmark module's) are written on the DOFs its nodes
follow: ``f<k>:x``, ``f<k>:y``, ``f<k>:rz`` of floor ``k`` about the plan centre (the base,
floor 0, is clamped and left out), as the benchmark's own 12-DOF model makes them. The braces
are 16 groups, one inverted V per face and storey (``brace_<storey><face>``, faces ``s``, ``e``,
``n``, ``w``); columns, beams and the floor masses are in no group. The sensors (a layout
assumed here): on each floor, x at the middle of the south and north faces, y at the middle
of the west and east faces, each at its offset from the plan centre.
"""

from __future__ import annotations

import importlib.util
from pathlib import Path

import numpy as np

_SPEC = importlib.util.spec_from_file_location(
    "braced_frame", Path(__file__).resolve().parents[1] / "benchmarks" / "braced_frame.py")
bf = importlib.util.module_from_spec(_SPEC)
_SPEC.loader.exec_module(bf)

FACES = "senw"   # the order of the benchmark's inverted Vs: south (y = 0), east, north, west
L = bf.L
#: (name, offset from the plan centre (m), direction) of each floor's four accelerometers
LAYOUT = (("xs", (0.0, -L), "x"), ("xn", (0.0, L), "x"), ("yw", (-L, 0.0), "y"), ("ye", (L, 0.0), "y"))


def _groups(elements) -> list:
    """The group of each member (None for those in no group)."""
    out, count = [], {}
    for _, _, kind, storey, _ in elements:
        if kind != "brace":
            out.append(None)
            continue
        k = count.get(storey, 0)
        count[storey] = k + 1
        out.append(f"brace_{storey}{FACES[k // 2]}")
    return out


def floor_dofs(full: bool = False) -> list[str]:
    """The model's DOFs: the floors' (12); with ``full``, then each floor node's ``z``, ``rx``,
    ``ry`` (120, the benchmark's larger model)."""
    own = [f"{node}:{q}" for node in range(9, 9 * (bf.N_STOREYS + 1)) for q in ("z", "rx", "ry")] if full else []
    return [f"f{f}:{q}" for f in range(1, bf.N_STOREYS + 1) for q in ("x", "y", "rz")] + own


def elements(full: bool = False):
    """``(label, dofs, K, M, group)`` of every member and floor mass on `floor_dofs`."""
    xyz = bf._nodes()
    members = bf._elements()
    Ke, Me, i, j = bf._member_matrices(xyz, members)
    T = bf._rigid_floors(xyz, full).toarray()   # node DOFs of floors 1-4 -> model DOFs, (216, 12 or 120)
    names = floor_dofs(full)
    out = []
    for e, (group, a, b) in enumerate(zip(_groups(members), i, j)):
        rows = np.zeros((12, T.shape[1]))
        for q, node in enumerate((a, b)):
            if node >= 9:   # the base nodes (0-8) are clamped
                rows[6 * q:6 * q + 6] = T[6 * (node - 9):6 * (node - 9) + 6]
        used = np.flatnonzero(np.any(rows != 0, axis=0))
        Te = rows[:, used]
        out.append((e + 1, [names[c] for c in used], Te.T @ Ke[e] @ Te, Te.T @ Me[e] @ Te, group))
    floors = bf._floor_masses().toarray()
    for f in range(bf.N_STOREYS):
        block = floors[3 * f:3 * f + 3, 3 * f:3 * f + 3]
        out.append((f"floor{f + 1}", names[3 * f:3 * f + 3], np.zeros((3, 3)), block, None))
    return out


def matrices(truth: dict, full: bool = False):
    """``K`` at the brace factors ``truth`` (1 for a group not named) and ``M``, dense, on
    `floor_dofs`, summed from `elements` by loops (the reference)."""
    names = floor_dofs(full)
    K, M = np.zeros((len(names), len(names))), np.zeros((len(names), len(names)))
    for _, dofs, k, m, group in elements(full):
        at = [names.index(d) for d in dofs]
        K[np.ix_(at, at)] += truth.get(group, 1.0) * k
        M[np.ix_(at, at)] += m
    return K, M


def sensor_weights() -> dict[str, dict[str, float]]:
    """Each accelerometer's weights on the floor DOFs (reading = x - y_offset rz, y + x_offset rz)."""
    out = {}
    for f in range(1, bf.N_STOREYS + 1):
        for name, (dx, dy), axis in LAYOUT:
            out[f"f{f}{name}"] = ({f"f{f}:x": 1.0, f"f{f}:rz": -dy} if axis == "x"
                                  else {f"f{f}:y": 1.0, f"f{f}:rz": dx})
    return out


def write_elements(folder: Path, full: bool = False) -> Path:
    """One ``.npz`` per element and ``elements.csv`` listing them with their groups."""
    folder.mkdir(parents=True, exist_ok=True)
    rows = ["element,K,group"]
    for label, dofs, k, m, group in elements(full):
        np.savez(folder / f"e{label}.npz", K=k, M=m, dofs=np.array(dofs))
        rows.append(f"{label},e{label}.npz,{group or ''}")
    (folder / "elements.csv").write_text("\n".join(rows) + "\n")
    return folder / "elements.csv"


def sensor_tables() -> str:
    """The ``[[sensor]]`` tables of the layout, as a user writes them: rigid body and offset."""
    out = []
    for f in range(1, bf.N_STOREYS + 1):
        for name, (dx, dy), axis in LAYOUT:
            out.append(f'[[sensor]]\nname = "f{f}{name}"\nrigid = {{ x = "f{f}:x", y = "f{f}:y", rz = "f{f}:rz" }}\n'
                       f'offset = [{dx!r}, {dy!r}]\ndirection = "{axis}"\n')
    return "\n".join(out)
