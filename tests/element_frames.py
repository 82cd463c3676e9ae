"""A small braced frame given element by element: its element matrices, written as Abaqus
``*ELEMENT MATRIX OUTPUT, OUTPUT FILE=USER DEFINED`` writes them (the layout of
`vibupdate.model.fe.abaqus_elements`) or as one ``.npz`` per element, and its matrices
assembled by hand (dense loops), the reference of the tests."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from vibupdate.model.elements import frame_matrices

#: Node -> (x, y), m: a two-storey, one-bay planar frame, 4 m wide, 3 m storeys.
NODES = {1: (0.0, 0.0), 2: (4.0, 0.0), 3: (0.0, 3.0), 4: (4.0, 3.0), 5: (0.0, 6.0), 6: (4.0, 6.0)}
#: Element -> (node 1, node 2, group, EA (N), EI (N m^2), mass per length (kg/m)).
ELEMENTS = {
    1: (1, 3, "columns", 2.0e9, 2.0e7, 80.0), 2: (2, 4, "columns", 2.0e9, 2.0e7, 80.0),
    3: (3, 5, "columns", 2.0e9, 2.0e7, 80.0), 4: (4, 6, "columns", 2.0e9, 2.0e7, 80.0),
    5: (3, 4, "beams", 3.0e9, 4.0e7, 900.0), 6: (5, 6, "beams", 3.0e9, 4.0e7, 700.0),
    7: (1, 4, "brace_1", 3.0e8, 1.0e4, 20.0), 8: (2, 3, "brace_1", 3.0e8, 1.0e4, 20.0),
    9: (3, 6, "brace_2", 2.5e8, 1.0e4, 20.0), 10: (4, 5, "brace_2", 2.5e8, 1.0e4, 20.0),
}
#: The base nodes, clamped.
BASE = (1, 2)
#: Abaqus DOF numbers of a planar frame node (B21): x, y and the rotation about z.
PLANAR = (1, 2, 6)
NAMES = {1: "x", 2: "y", 6: "rz"}


def element_dofs(element: int) -> list[str]:
    n1, n2 = ELEMENTS[element][:2]
    return [f"{n}:{NAMES[d]}" for n in (n1, n2) for d in PLANAR]


def element_pair(element: int) -> tuple[np.ndarray, np.ndarray]:
    """Stiffness and mass of one element, shape (6, 6), DOFs `element_dofs`."""
    n1, n2, _, EA, EI, rho_a = ELEMENTS[element]
    (x1, y1), (x2, y2) = NODES[n1], NODES[n2]
    k, m = frame_matrices(EA, EI, rho_a, x2 - x1, y2 - y1)
    return k[0], m[0]


def free_dofs() -> list[str]:
    """DOFs of the model after the base is clamped, in the order the Abaqus reader gives them
    (node, then direction)."""
    return [f"{n}:{NAMES[d]}" for n in sorted(NODES) if n not in BASE for d in PLANAR]


def hand_assembled(factors=None, groups=None, which="K") -> np.ndarray:
    """``K`` (or ``M``) on `free_dofs`, each element's matrix times the factor of its group
    (1 by default), by dense loops over the entries; only the elements of ``groups`` when given."""
    factors = factors or {}
    dofs = free_dofs()
    index = {d: k for k, d in enumerate(dofs)}
    A = np.zeros((len(dofs), len(dofs)))
    for e, (_, _, group, *_rest) in ELEMENTS.items():
        if groups is not None and group not in groups:
            continue
        matrix = element_pair(e)[0 if which == "K" else 1] * (factors.get(group, 1.0) if which == "K" else 1.0)
        names = element_dofs(e)
        for a, da in enumerate(names):
            for b, db in enumerate(names):
                if da in index and db in index:
                    A[index[da], index[db]] += matrix[a, b]
    return A


def _lower_rows(A: np.ndarray) -> list[str]:
    """The lower triangle row by row, each row on new lines, four entries per line."""
    lines = []
    for i in range(A.shape[0]):
        row = [f"{v:.15E}" for v in A[i, :i + 1]]
        for start in range(0, len(row), 4):
            chunk = row[start:start + 4]
            lines.append(" , ".join(chunk) + (" ," if len(chunk) == 1 else ""))   # as Abaqus ends a lone entry
    return lines


def write_abaqus_elements(path: Path, elements=None) -> Path:
    """The elements (all by default) as ``*ELEMENT MATRIX OUTPUT`` writes them to a user file."""
    out = []
    for e in elements or ELEMENTS:
        n1, n2 = ELEMENTS[e][:2]
        k, m = element_pair(e)
        out += ["**", f"** ELEMENT NUMBER {e} STEP NUMBER 1 INCREMENT NUMBER 1", "** ELEMENT TYPE B21",
                "*USER ELEMENT, NODES= 2, LINEAR", "** ELEMENT NODES", f"** {n1}, {n2}",
                ", ".join(str(d) for d in PLANAR), "*MATRIX,TYPE=STIFFNESS", *_lower_rows(k),
                "*MATRIX,TYPE=MASS", *_lower_rows(m)]
    Path(path).write_text("\n".join(out) + "\n")
    return Path(path)


def write_element_table(folder: Path) -> Path:
    """One ``.npz`` per element (arrays K, M, dofs) and ``elements.csv`` naming them, with groups."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    rows = ["element,K,group"]
    for e, (_, _, group, *_rest) in ELEMENTS.items():
        k, m = element_pair(e)
        np.savez(folder / f"e{e}.npz", K=k, M=m, dofs=np.array(element_dofs(e)))
        rows.append(f"{e},e{e}.npz,{group}")
    (folder / "elements.csv").write_text("\n".join(rows) + "\n")
    return folder / "elements.csv"
