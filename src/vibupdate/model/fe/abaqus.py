"""Abaqus/Standard matrices written by ``*MATRIX GENERATE`` and ``*MATRIX OUTPUT`` (what is read and
refused: docs/fe/abaqus.md, "What to export from Abaqus").

``JOB_STIF<step>.mtx`` and ``JOB_MASS<step>.mtx`` hold one term a line, ``row node, row DOF,
column node, column DOF, value`` (DOFs 1..6 of a node: its translations and rotations), in any
layout the *MATRIX INPUT format allows; internal nodes (a constraint's Lagrange multiplier) are
refused. The matrices come before the boundary conditions: the DOFs they fix are removed by
naming them (``fix``, `vibupdate.model.fe.export.without_dofs`).
"""

from __future__ import annotations

import io
from collections import Counter

import numpy as np

from vibupdate.model.fe.export import (FEExport, digit_counts, dof_name, existing_file, precision_of_digits,
                                       symmetric_from_entries)

#: One line of a ``.mtx`` file: row node, row DOF, column node, column DOF, value.
_TERM = np.dtype([("n1", np.int64), ("d1", np.int64), ("n2", np.int64), ("d2", np.int64), ("value", float)])


def read_mtx_terms(path, digits: Counter | None = None):
    """The terms of an Abaqus ``.mtx`` file: ``(row DOFs, column DOFs, values, line numbers)``,
    arrays of shape (n_terms,), a DOF as the integer ``8 * node + component`` (`dof_key`); the
    significant digits of the values as written are counted into ``digits`` when given.

    Parsed whole by numpy (`numpy.loadtxt`, `numpy.char`), not line by line; a line that does
    not read as ``node, dof, node, dof, value``, an internal node and a component outside 0..6
    are refused naming the line.
    """
    path = existing_file(path, "Abaqus matrix file")
    texts = np.char.strip(np.array(path.read_bytes().splitlines(), dtype=bytes))
    kept = (np.char.str_len(texts) > 0) & ~np.char.startswith(texts, b"*")
    numbers, data = np.flatnonzero(kept) + 1, texts[kept]
    if not numbers.size:
        raise ValueError(f"{path}: no matrix terms; is it a *MATRIX OUTPUT file?")

    def refuse(k, why):
        raise ValueError(f"{path}: line {numbers[k]}: expected 'node, dof, node, dof, value', got "
                         f"{data[k].decode(errors='replace')!r} ({why})")

    fields = np.char.count(data, b",") + 1
    if np.any(fields != 5):
        k = int(np.flatnonzero(fields != 5)[0])
        refuse(k, f"{fields[k]} fields")
    # numpy's C text parser over the data lines, D exponents made E (data lines hold no other letter)
    blob = b"\n".join(data.tolist()).upper().replace(b"D", b"E")
    try:
        table = np.loadtxt(io.BytesIO(blob), delimiter=",", comments=None, dtype=_TERM, ndmin=1)
    except ValueError as exc:   # the first line that does not convert, with Python's own message
        for k, t in enumerate(data.tolist()):
            parts = [p.strip() for p in t.decode(errors="replace").split(",")]
            try:
                [int(p) for p in parts[:4]], float(parts[4].upper().replace("D", "E"))
            except ValueError as why:
                refuse(k, why)
        raise ValueError(f"{path}: {exc}") from None
    if digits is not None:
        digits.update(digit_counts(np.char.rpartition(data, b",")[..., 2]))
    n1, d1, n2, d2, values = (table[name] for name in _TERM.names)
    inner = np.flatnonzero((n1 <= 0) | (n2 <= 0))
    if inner.size:
        k = int(inner[0])
        raise ValueError(f"{path}: line {numbers[k]}: internal node {min(n1[k], n2[k])} (a constraint's Lagrange "
                         "multiplier); export the model without such constraints")
    wrong = np.flatnonzero((d1 < 0) | (d1 > 6) | (d2 < 0) | (d2 > 6))
    if wrong.size:
        k = int(wrong[0])
        node, component = (n1[k], d1[k]) if not 0 <= d1[k] <= 6 else (n2[k], d2[k])
        raise ValueError(f"{path}: line {numbers[k]}: DOF component {component} of node {node}; 0 to 6 is expected")
    return dof_key(n1, d1), dof_key(n2, d2), values, numbers


def dof_key(node, component):
    """``8 * node + component``: a DOF as one integer, ordered by node then component (0, a
    scalar point, first); `dof_name` of ``(key // 8, key % 8)`` is its name."""
    return np.asarray(node, dtype=np.int64) * 8 + np.asarray(component, dtype=np.int64)


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
    """K and M from the ``_STIF`` and ``_MASS`` ``.mtx`` files of one Abaqus job, checked whole:
    a file with lines missing is refused naming the line (the checks: docs/fe/abaqus.md)."""
    digits = Counter()
    k_terms, m_terms = read_mtx_terms(stiffness, digits), read_mtx_terms(mass, digits)
    keys = np.unique(np.concatenate([k_terms[0], k_terms[1], m_terms[0], m_terms[1]]))
    order = [dof_name(int(key) // 8, int(key) % 8) for key in keys]
    stiff = np.unique(np.concatenate([k_terms[0], k_terms[1]]))
    mr, mc, _, mlines = m_terms
    row_missing, col_missing = ~np.isin(mr, stiff), ~np.isin(mc, stiff)
    if np.any(row_missing | col_missing):
        k = int(np.flatnonzero(row_missing | col_missing)[0])
        key = int(mr[k] if row_missing[k] else mc[k])
        raise ValueError(f"{stiffness}: no term of DOF {dof_name(key // 8, key % 8)!r}, which the mass file {mass} "
                         f"gives (line {mlines[k]}); Abaqus writes every DOF's stiffness: lines are missing from the "
                         "stiffness file")
    mats = []
    for path, (r, c, v, lines) in ((stiffness, k_terms), (mass, m_terms)):
        ri, ci = np.searchsorted(keys, r), np.searchsorted(keys, c)
        _check_pattern(path, ri, ci, lines, order, len(order))
        mats.append(symmetric_from_entries(ri, ci, v, len(order), str(path), "the matrix", order, lines))
    return FEExport(mats[0], mats[1], tuple(order), f"{stiffness}, {mass}", precision=precision_of_digits(digits))
