"""Abaqus/Standard matrices written by ``*MATRIX GENERATE`` and ``*MATRIX OUTPUT``.

With ``FORMAT=MATRIX INPUT`` (the default) Abaqus writes ``JOB_STIF<step>.mtx`` and
``JOB_MASS<step>.mtx``, text files with one matrix term per line::

    row node, row DOF, column node, column DOF, value

DOFs 1..6 of a node are its translations and rotations. The *MATRIX INPUT layout (Abaqus
Keywords Reference) gives a symmetric matrix as its lower triangle, its upper triangle or the
square, with or without the zeros of its sparsity pattern; all are read, one triangle mirrored,
the two triangles of a square file compared. Lines starting with ``*`` (``**`` comments) are
skipped. Nodes with a
non-positive number are Abaqus's internal nodes (Lagrange multipliers of constraints); they
are refused with a message, as the model they belong to is not a plain K, M pair. Abaqus writes
the matrices before boundary conditions: the DOFs they fix are removed by naming them
(`vibupdate.model.fe.export.without_dofs`, ``fix`` of ``vibupdate import``). The significant
digits of the values give the export's relative precision
(`vibupdate.model.fe.export.precision_of_digits`).
"""

from __future__ import annotations

from collections import Counter
from pathlib import Path

import numpy as np

from vibupdate.model.fe.export import FEExport, dof_name, precision_of_digits, significant_digits, symmetric_from_entries


def read_mtx_terms(path, digits: Counter | None = None):
    """``(row DOF names, column DOF names, values, line numbers)`` of an Abaqus ``.mtx`` file;
    the significant digits of the values as written are counted into ``digits`` when given."""
    path = Path(path)
    if not path.is_file():
        raise ValueError(f"Abaqus matrix file {str(path)!r} does not exist")
    rows, cols, values, lines = [], [], [], []
    for number, line in enumerate(path.read_text(errors="replace").splitlines(), start=1):
        text = line.strip()
        if not text or text.startswith("*"):
            continue
        parts = [p.strip() for p in text.split(",")]
        try:
            if len(parts) != 5:
                raise ValueError(f"{len(parts)} fields")
            n1, d1, n2, d2 = (int(p) for p in parts[:4])
            value = float(parts[4].upper().replace("D", "E"))
        except ValueError as exc:
            raise ValueError(f"{path}: line {number}: expected 'node, dof, node, dof, value', got {text!r} ({exc})") \
                from None
        if n1 <= 0 or n2 <= 0:
            raise ValueError(f"{path}: line {number}: internal node {min(n1, n2)} (a constraint's Lagrange "
                             "multiplier); export the model without such constraints")
        rows.append(dof_name(n1, d1))
        cols.append(dof_name(n2, d2))
        values.append(value)
        lines.append(number)
        if digits is not None:
            digits[significant_digits(parts[4])] += 1
    if not values:
        raise ValueError(f"{path}: no matrix terms; is it a *MATRIX OUTPUT file?")
    return rows, cols, values, lines


def _check_pattern(path, rows: np.ndarray, cols: np.ndarray, lines, names, n: int) -> None:
    """A file that gives both triangles (some off-diagonal term twice, as ``(i, j)`` and
    ``(j, i)``) must give every off-diagonal term twice: a term without its mirror is a line
    missing from a square file. A file of one triangle gives each pair once, in whichever
    order the node numbers fall."""
    off = rows != cols
    key, mirror = rows[off] * n + cols[off], cols[off] * n + rows[off]
    paired = np.isin(mirror, key)
    if paired.any() and not paired.all():
        k = int(np.flatnonzero(~paired)[0])
        r, c = int(rows[off][k]), int(cols[off][k])
        raise ValueError(f"{path}: line {int(np.asarray(lines)[off][k])}: the term ({names[r]}, {names[c]}) has no "
                         f"mirror ({names[c]}, {names[r]}), though the file gives both triangles of the matrix "
                         f"({int((~paired).sum())} term(s) without their mirror): lines are missing from the file")


def read_abaqus(stiffness, mass) -> FEExport:
    """K and M from the ``_STIF`` and ``_MASS`` ``.mtx`` files of one Abaqus job.

    Checked whole: a file giving both triangles must give each off-diagonal term twice, a
    row with couplings must have its diagonal term
    (`vibupdate.model.fe.export.symmetric_from_entries`), and every DOF with mass must have
    stiffness (Abaqus writes the matrices before the boundary conditions, so every DOF of the
    model has a stiffness term): a file with lines missing is refused naming the line."""
    digits = Counter()
    k_terms, m_terms = read_mtx_terms(stiffness, digits), read_mtx_terms(mass, digits)
    names = set(k_terms[0]) | set(k_terms[1]) | set(m_terms[0]) | set(m_terms[1])
    order = sorted(names, key=lambda d: (int(d.split(":")[0]), ("s", "x", "y", "z", "rx", "ry", "rz").index(
        d.split(":")[1])))
    missing = (set(m_terms[0]) | set(m_terms[1])) - (set(k_terms[0]) | set(k_terms[1]))
    if missing:
        line, dof = min((line, r if r in missing else c) for r, c, line in zip(*m_terms[:2], m_terms[3])
                        if r in missing or c in missing)
        raise ValueError(f"{stiffness}: no term of DOF {dof!r}, which the mass file {mass} gives (line {line}); "
                         "Abaqus writes every DOF's stiffness: lines are missing from the stiffness file")
    pos = {d: k for k, d in enumerate(order)}
    mats = []
    for path, (r, c, v, lines) in ((stiffness, k_terms), (mass, m_terms)):
        ri, ci = np.array([pos[d] for d in r], dtype=np.int64), np.array([pos[d] for d in c], dtype=np.int64)
        _check_pattern(path, ri, ci, lines, order, len(order))
        mats.append(symmetric_from_entries(ri, ci, v, len(order), str(path), "the matrix", order, lines))
    return FEExport(mats[0], mats[1], tuple(order), f"{stiffness}, {mass}", precision=precision_of_digits(digits))
