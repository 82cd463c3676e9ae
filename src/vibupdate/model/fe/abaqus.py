"""Abaqus/Standard matrices written by ``*MATRIX GENERATE`` and ``*MATRIX OUTPUT``.

With ``FORMAT=MATRIX INPUT`` (the default) Abaqus writes ``JOB_STIF<step>.mtx`` and
``JOB_MASS<step>.mtx``, text files with one matrix term per line::

    row node, row DOF, column node, column DOF, value

DOFs 1..6 of a node are its translations and rotations; a term is written once, from one
triangle of the symmetric matrix (both triangles are accepted if they agree). Nodes with a
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

__all__ = ["read_abaqus", "read_mtx_terms"]


def read_mtx_terms(path, digits: Counter | None = None):
    """``(row DOF names, column DOF names, values)`` of an Abaqus ``.mtx`` file; the significant
    digits of the values as written are counted into ``digits`` when given."""
    path = Path(path)
    if not path.is_file():
        raise ValueError(f"Abaqus matrix file {str(path)!r} does not exist")
    rows, cols, values = [], [], []
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
        if digits is not None:
            digits[significant_digits(parts[4])] += 1
    if not values:
        raise ValueError(f"{path}: no matrix terms; is it a *MATRIX OUTPUT file?")
    return rows, cols, values


def read_abaqus(stiffness, mass) -> FEExport:
    """K and M from the ``_STIF`` and ``_MASS`` ``.mtx`` files of one Abaqus job."""
    digits = Counter()
    k_terms, m_terms = read_mtx_terms(stiffness, digits), read_mtx_terms(mass, digits)
    names = set(k_terms[0]) | set(k_terms[1]) | set(m_terms[0]) | set(m_terms[1])
    order = sorted(names, key=lambda d: (int(d.split(":")[0]), ("s", "x", "y", "z", "rx", "ry", "rz").index(
        d.split(":")[1])))
    pos = {d: k for k, d in enumerate(order)}
    mats = []
    for path, (r, c, v) in ((stiffness, k_terms), (mass, m_terms)):
        mats.append(symmetric_from_entries(np.array([pos[d] for d in r]), np.array([pos[d] for d in c]), v,
                                           len(order), str(path), "the matrix"))
    return FEExport(mats[0], mats[1], tuple(order), f"{stiffness}, {mass}", precision=precision_of_digits(digits))
