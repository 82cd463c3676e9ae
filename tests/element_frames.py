"""Braced planar frames given element by element: their element matrices, written as Abaqus
``*ELEMENT MATRIX OUTPUT, OUTPUT FILE=USER DEFINED`` writes them (the layout of
`vibupdate.model.fe.abaqus_elements`) or as one ``.npz`` per element, and their matrices
assembled by hand (dense loops), the reference of the tests."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from vibupdate.model.elements import frame_matrices

#: Abaqus DOF numbers of a planar frame node (B21): x, y and the rotation about z.
PLANAR = (1, 2, 6)
NAMES = {1: "x", 2: "y", 6: "rz"}


@dataclass(frozen=True)
class Frame:
    """Nodes ``{label: (x, y)}`` (m), elements ``{label: (node 1, node 2, group, EA (N), EI
    (N m^2), mass per length (kg/m))}`` and the clamped base nodes."""

    nodes: dict
    elements: dict
    base: tuple

    def group(self, name: str) -> list[int]:
        return [e for e, item in self.elements.items() if item[2] == name]

    @property
    def groups(self) -> list[str]:
        return list(dict.fromkeys(item[2] for item in self.elements.values()))

    def element_dofs(self, element: int) -> list[str]:
        n1, n2 = self.elements[element][:2]
        return [f"{n}:{NAMES[d]}" for n in (n1, n2) for d in PLANAR]

    def element_pair(self, element: int) -> tuple[np.ndarray, np.ndarray]:
        """Stiffness and mass of one element, shape (6, 6), DOFs `element_dofs`."""
        n1, n2, _, EA, EI, rho_a = self.elements[element]
        (x1, y1), (x2, y2) = self.nodes[n1], self.nodes[n2]
        k, m = frame_matrices(EA, EI, rho_a, x2 - x1, y2 - y1)
        return k[0], m[0]

    def free_dofs(self) -> list[str]:
        """DOFs after the base is clamped, in the order the Abaqus reader gives them (node,
        then direction)."""
        return [f"{n}:{NAMES[d]}" for n in sorted(self.nodes) if n not in self.base for d in PLANAR]

    def hand_assembled(self, factors=None, groups=None, which="K") -> np.ndarray:
        """``K`` (or ``M``) on `free_dofs`, each element's stiffness times the factor of its
        group (1 by default), by dense loops over the entries; only the elements of ``groups``
        when given."""
        factors = factors or {}
        dofs = self.free_dofs()
        index = {d: k for k, d in enumerate(dofs)}
        A = np.zeros((len(dofs), len(dofs)))
        for e, (_, _, group, *_rest) in self.elements.items():
            if groups is not None and group not in groups:
                continue
            k, m = self.element_pair(e)
            matrix = k * factors.get(group, 1.0) if which == "K" else m
            names = self.element_dofs(e)
            for a, da in enumerate(names):
                for b, db in enumerate(names):
                    if da in index and db in index:
                        A[index[da], index[db]] += matrix[a, b]
        return A

    def write_abaqus_elements(self, path: Path) -> Path:
        """Every element as ``*ELEMENT MATRIX OUTPUT`` writes it to a user file."""
        out = []
        for e, (n1, n2, *_rest) in self.elements.items():
            k, m = self.element_pair(e)
            out += ["**", f"** ELEMENT NUMBER {e} STEP NUMBER 1 INCREMENT NUMBER 1", "** ELEMENT TYPE B21",
                    "*USER ELEMENT, NODES= 2, LINEAR", "** ELEMENT NODES", f"** {n1}, {n2}",
                    ", ".join(str(d) for d in PLANAR), "*MATRIX,TYPE=STIFFNESS", *_lower_rows(k),
                    "*MATRIX,TYPE=MASS", *_lower_rows(m)]
        Path(path).write_text("\n".join(out) + "\n")
        return Path(path)

    def write_element_table(self, folder: Path) -> Path:
        """One ``.npz`` per element (arrays K, M, dofs) and ``elements.csv`` naming them, with groups."""
        folder = Path(folder)
        folder.mkdir(parents=True, exist_ok=True)
        rows = ["element,K,group"]
        for e, (_, _, group, *_rest) in self.elements.items():
            k, m = self.element_pair(e)
            np.savez(folder / f"e{e}.npz", K=k, M=m, dofs=np.array(self.element_dofs(e)))
            rows.append(f"{e},e{e}.npz,{group}")
        (folder / "elements.csv").write_text("\n".join(rows) + "\n")
        return folder / "elements.csv"

    def write_groups_csv(self, path: Path) -> Path:
        rows = ["element,group"] + [f"{e},{item[2]}" for e, item in self.elements.items()]
        Path(path).write_text("\n".join(rows) + "\n")
        return Path(path)


def _lower_rows(A: np.ndarray) -> list[str]:
    """The lower triangle row by row, each row on new lines, four entries per line."""
    lines = []
    for i in range(A.shape[0]):
        row = [f"{v:.15E}" for v in A[i, :i + 1]]
        for start in range(0, len(row), 4):
            chunk = row[start:start + 4]
            lines.append(" , ".join(chunk) + (" ," if len(chunk) == 1 else ""))   # as Abaqus ends a lone entry
    return lines


#: A two-storey, one-bay frame, 4 m wide, 3 m storeys, an X of braces per storey.
SMALL = Frame(
    nodes={1: (0.0, 0.0), 2: (4.0, 0.0), 3: (0.0, 3.0), 4: (4.0, 3.0), 5: (0.0, 6.0), 6: (4.0, 6.0)},
    elements={
        1: (1, 3, "columns", 2.0e9, 2.0e7, 80.0), 2: (2, 4, "columns", 2.0e9, 2.0e7, 80.0),
        3: (3, 5, "columns", 2.0e9, 2.0e7, 80.0), 4: (4, 6, "columns", 2.0e9, 2.0e7, 80.0),
        5: (3, 4, "beams", 3.0e9, 4.0e7, 900.0), 6: (5, 6, "beams", 3.0e9, 4.0e7, 700.0),
        7: (1, 4, "brace_1", 3.0e8, 1.0e4, 20.0), 8: (2, 3, "brace_1", 3.0e8, 1.0e4, 20.0),
        9: (3, 6, "brace_2", 2.5e8, 1.0e4, 20.0), 10: (4, 5, "brace_2", 2.5e8, 1.0e4, 20.0),
    },
    base=(1, 2))


def storey_frame(storeys: int = 4, bays: int = 2, width: float = 4.0, height: float = 3.0) -> Frame:
    """A planar frame of ``storeys`` x ``bays`` with an X of braces in every bay of every
    storey, each brace its own group ``brace_<storey><bay><a|b>`` (4 x 2 x 2 = 16 groups by
    default), columns and beams in groups of their own. Node ``100 level + column``."""
    nodes = {100 * level + c: (c * width, level * height) for level in range(storeys + 1) for c in range(bays + 1)}
    elements, e = {}, 1
    for level in range(1, storeys + 1):
        for c in range(bays + 1):
            elements[e] = (100 * (level - 1) + c, 100 * level + c, "columns", 4.0e9, 4.0e7, 100.0)
            e += 1
        for c in range(bays):
            elements[e] = (100 * level + c, 100 * level + c + 1, "beams", 6.0e9, 8.0e7, 1500.0)
            e += 1
            for side, (a, b) in zip("ab", ((100 * (level - 1) + c, 100 * level + c + 1),
                                           (100 * (level - 1) + c + 1, 100 * level + c))):
                elements[e] = (a, b, f"brace_{level}{c + 1}{side}", 4.0e8 * (1 + 0.1 * level), 1.0e4, 25.0)
                e += 1
    return Frame(nodes, elements, tuple(c for c in range(bays + 1)))
