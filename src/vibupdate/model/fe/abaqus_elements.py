"""Element matrices written by Abaqus/Standard ``*ELEMENT MATRIX OUTPUT`` (the export and the
groups as the user reads them: docs/fe-models.md, "Element groups").

``name.mtx`` holds, per element of the ``ELSET``, a block in the input format of a linear user
element (``*USER ELEMENT, LINEAR`` and ``*MATRIX``, Abaqus Keywords Reference Guide)::

    ** ELEMENT NUMBER 11 STEP NUMBER 1 INCREMENT NUMBER 1
    *USER ELEMENT, NODES= 2, LINEAR
    ** ELEMENT NODES
    ** 101, 102
    1, 2, 6
    *MATRIX,TYPE=STIFFNESS
    k11 ,
    k21 , k22
    ...

The first data line lists the active DOFs (1-6: x, y, z, rx, ry, rz) at the element's first
node; a further data line ``position, dof, dof, ...`` changes them from the node at that position
of the element's node list on. The variables are ordered node by node (the Abaqus results-file
format). A symmetric matrix is its lower triangle row by row, each row starting a new line and
wrapped at four entries per line, in the global directions and before the boundary conditions.
The element sets of the input file (``*ELSET``, ``ELSET=`` of ``*ELEMENT``) give the groups the
parameters follow (`read_abaqus_element_sets`).
"""

from __future__ import annotations

import re
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from vibupdate.model.element_groups import ElementMatrices, element_matrices
from vibupdate.model.fe.export import DIRECTIONS, digit_counts, dof_name, dof_order, existing_file, precision_of_digits


_ELEMENT = re.compile(r"\*\*\s*ELEMENT NUMBER\s+(-?\d+)(?:\s+STEP NUMBER\s+(\d+))?", re.I)
_NODES = re.compile(r"NODES\s*=\s*(\d+)", re.I)
_MATRIX = re.compile(r"\*MATRIX\s*,\s*TYPE\s*=\s*(\w+)", re.I)


class _Block:
    """One element's block as read: label, nodes, DOF lines, matrices' numbers as text."""

    def __init__(self, label: int, line: int, step: str | None):
        self.label, self.line, self.step = label, line, step
        self.n_nodes: int | None = None
        self.nodes: list[int] = []
        self.dof_lines: list[list[int]] = []
        self.matrices: dict[str, list[str]] = {}


def _blocks(path: Path) -> list[_Block]:
    """The element blocks of one file, in file order (module docstring)."""
    blocks: list[_Block] = []
    current, reading_nodes, matrix = None, False, None
    for number, raw in enumerate(path.read_text(errors="replace").splitlines(), start=1):
        text = raw.strip()
        if not text:
            continue
        head = _ELEMENT.match(text)
        if head:
            current, reading_nodes, matrix = _Block(int(head.group(1)), number, head.group(2)), False, None
            blocks.append(current)
            continue
        if current is None:
            continue
        upper = text.upper()
        if upper.startswith("**"):
            matrix = None
            if "ELEMENT NODES" in upper:
                reading_nodes = True
            elif reading_nodes and current.n_nodes is not None and len(current.nodes) < current.n_nodes:
                try:
                    current.nodes += [int(t) for t in re.split(r"[,\s]+", text[2:].strip()) if t]
                except ValueError:
                    raise ValueError(f"{path}: line {number}: expected the node numbers of element {current.label}, "
                                     f"got {text!r}") from None
            continue
        if upper.startswith("*"):
            reading_nodes, matrix = False, None
            kind = _MATRIX.match(text)
            if upper.startswith("*USER ELEMENT"):
                nodes = _NODES.search(text)
                if not nodes:
                    raise ValueError(f"{path}: line {number}: *USER ELEMENT without NODES=")
                current.n_nodes = int(nodes.group(1))
            elif kind:
                matrix = kind.group(1).upper()
                if matrix in current.matrices:
                    raise ValueError(f"{path}: line {number}: element {current.label} has a second {matrix} matrix")
                current.matrices[matrix] = []
            continue
        fields = [t.strip() for t in text.split(",") if t.strip()]
        if matrix is not None:
            current.matrices[matrix] += fields
        else:
            try:
                current.dof_lines.append([int(t) for t in fields])
            except ValueError:
                raise ValueError(f"{path}: line {number}: expected the active DOFs of element {current.label} "
                                 f"(integers), got {text!r}") from None
    return blocks


def _element_dofs(block: _Block, path: Path) -> list[str]:
    """The DOF names of an element's variables, node by node (module docstring)."""
    where = f"{path}: element {block.label} (line {block.line})"
    if block.n_nodes is not None and block.n_nodes < 1:
        raise ValueError(f"{where}: *USER ELEMENT has NODES={block.n_nodes}; an element has at least one node")
    if block.n_nodes is None or len(block.nodes) != block.n_nodes:
        raise ValueError(f"{where}: expected {block.n_nodes} node numbers on the '** ELEMENT NODES' lines, got "
                         f"{block.nodes}")
    if not block.dof_lines:
        raise ValueError(f"{where}: no line of active DOFs after *USER ELEMENT")
    active = [None] * block.n_nodes
    active[0] = block.dof_lines[0]
    for line in block.dof_lines[1:]:
        if len(line) < 2 or not 2 <= line[0] <= block.n_nodes:
            raise ValueError(f"{where}: a DOF change line is 'node position, dof, ...' with a position 2 to "
                             f"{block.n_nodes}, got {line}")
        active[line[0] - 1] = line[1:]
    names, dofs = [], active[0]
    for node, change in zip(block.nodes, active):
        dofs = dofs if change is None else change      # a node without a change line: the previous node's DOFs
        for d in dofs:
            if not 1 <= d <= len(DIRECTIONS):
                raise ValueError(f"{where}: DOF {d} is not a displacement or rotation (1-6)")
            names.append(dof_name(node, d))
    return names


def _matrix(values: list[str], n: int, label: int, kind: str, path: Path, written: list) -> np.ndarray:
    """The symmetric ``n x n`` matrix from its lower triangle row by row; its values as written
    are added to ``written`` (their digits are counted once for all elements)."""
    if len(values) != n * (n + 1) // 2:
        raise ValueError(f"{path}: element {label}: the {kind} matrix has {len(values)} entries; a symmetric matrix "
                         f"of {n} DOFs has {n * (n + 1) // 2} (its lower triangle)")
    try:
        numbers = np.array([float(v.upper().replace("D", "E")) for v in values])
    except ValueError as exc:
        raise ValueError(f"{path}: element {label}: {kind} matrix: {exc}") from None
    written += values
    A = np.zeros((n, n))
    A[np.tril_indices(n)] = numbers
    return A + np.tril(A, -1).T


def read_abaqus_elements(paths: Sequence) -> ElementMatrices:
    """Every element of the ``*ELEMENT MATRIX OUTPUT`` files ``paths`` (module docstring).

    An element needs its stiffness matrix; its mass matrix counts as zero when the file has
    none (``MASS=NO``, or an element without mass). An element written twice (two steps or
    increments, or two files) is refused: export one step.
    """
    paths = [existing_file(p, "Abaqus element matrix file") for p in paths]
    written = []
    elements = []
    for path in paths:
        blocks = _blocks(path)
        if not blocks:
            raise ValueError(f"{path}: no '** ELEMENT NUMBER' block; is it written by *ELEMENT MATRIX OUTPUT, "
                             "OUTPUT FILE=USER DEFINED?")
        for block in blocks:
            if "STIFFNESS" not in block.matrices:
                raise ValueError(f"{path}: element {block.label} has no *MATRIX,TYPE=STIFFNESS (STIFFNESS=YES)")
            names = _element_dofs(block, path)
            K = _matrix(block.matrices["STIFFNESS"], len(names), block.label, "stiffness", path, written)
            M = (_matrix(block.matrices["MASS"], len(names), block.label, "mass", path, written)
                 if "MASS" in block.matrices else None)
            elements.append((block.label, names, K, M))
    seen: dict = {}
    for label, *_ in elements:
        if label in seen:
            raise ValueError(f"element {label} is written twice ({seen[label]} and again): export the element matrices "
                             "of one step and increment (FREQUENCY) from one request per element")
        seen[label] = ", ".join(map(str, paths))
    order = sorted(dict.fromkeys(d for e in elements for d in e[1]), key=dof_order)
    return element_matrices(elements, dofs=order, precision=precision_of_digits(digit_counts(written)),
                            source=", ".join(map(str, paths)))


_PARAMETER = re.compile(r"(\w+)\s*(?:=\s*(\"[^\"]*\"|[^,]*))?")


def _keyword(text: str) -> tuple[str, dict]:
    """``("*ELSET", {"ELSET": "brace_1x", "GENERATE": ""})`` of a keyword line (parameter names
    upper case, values as written, quotes removed)."""
    name, _, rest = text.partition(",")
    params = {}
    for item in rest.split(","):
        m = _PARAMETER.match(item.strip())
        if m:
            params[m.group(1).upper()] = (m.group(2) or "").strip().strip('"')
    return name.strip().upper(), params


def read_abaqus_element_sets(path) -> dict[str, list[int]]:
    """Element sets of an Abaqus input file: ``*ELSET, ELSET=name`` (element numbers, ``GENERATE``
    ranges ``first, last, step``, or names of other sets) and ``*ELEMENT, ELSET=name`` (the
    elements it defines). Set names are kept as written and matched regardless of case, as
    Abaqus does. Only a flat input file is read: a model of parts and instances numbers its
    elements per part, and is refused."""
    path = existing_file(path, "Abaqus input file")
    sets: dict[str, list[int]] = {}
    named: dict[str, str] = {}              # upper-case name -> name as first written
    target, mode = None, None
    for number, raw in enumerate(path.read_text(errors="replace").splitlines(), start=1):
        text = raw.strip()
        if not text or text.startswith("**"):
            continue
        if text.startswith("*"):
            keyword, params = _keyword(text)
            target, mode = None, None
            if keyword in ("*PART", "*INSTANCE"):
                raise ValueError(f"{path}: line {number}: {keyword.title()}: the element sets of parts and "
                                 "instances are numbered per part; give the groups as a CSV of element and group")
            if keyword in ("*ELSET", "*ELEMENT") and params.get("ELSET"):
                name = params["ELSET"]
                target = named.setdefault(name.upper(), name)
                sets.setdefault(target, [])
                mode = "element" if keyword == "*ELEMENT" else ("generate" if "GENERATE" in params else "list")
            continue
        if target is None:
            continue
        fields = [f.strip() for f in text.split(",") if f.strip()]
        try:
            if mode == "element":
                sets[target].append(int(fields[0]))
            elif mode == "generate":
                first, last, step = (int(f) for f in (fields + ["1"])[:3])
                sets[target] += list(range(first, last + 1, step))
            else:
                for f in fields:
                    if f.lstrip("-").isdigit():
                        sets[target].append(int(f))
                    elif f.upper() in named:
                        sets[target] += sets[named[f.upper()]]
                    else:
                        raise ValueError(f"{f!r} is neither an element number nor a set defined above")
        except ValueError as exc:
            raise ValueError(f"{path}: line {number}: element set {target!r}: {exc}") from None
    if not sets:
        raise ValueError(f"{path}: no element set (*ELSET, or *ELEMENT with ELSET=)")
    return {name: list(dict.fromkeys(labels)) for name, labels in sets.items()}
