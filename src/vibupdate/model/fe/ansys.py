"""ANSYS Mechanical APDL matrices: ``HBMAT`` Harwell-Boeing files with their ``.mapping``,
or the binary ``.full`` file.

HBMAT
-----
``HBMAT, K, matrix, , ASCII, STIFF, NO, YES`` (and ``MASS``) writes the assembled matrix of the
``.full`` file in Harwell-Boeing form and, with ``Mapping = YES``, a text file with one line per
equation: the equation number, the node and the DOF label (``UX, UY, UZ, ROTX, ROTY, ROTZ``).
The matrices are read with `scipy.io.hb_read`, which takes unsymmetric assembled real
matrices (``RUA``); a symmetric file (``RSA``, one triangle) is read the same way and mirrored.
The equations are those ANSYS solved: constrained DOFs are not written. The significant digits
of the values as written give the export's relative precision
(`vibupdate.model.fe.export.precision_of_digits`); the binary ``.full`` file holds doubles.

``.full``
---------
Read through ``ansys-mapdl-reader`` (the optional extra ``vibupdate[fe]``), which returns each
equation's node and DOF and the constrained DOFs. Its ``load_km`` (0.56.0) keeps the constrained
DOFs as zero rows and columns of K and M (the sample ``file.full`` it ships: 963 equations, 63
of them constrained and all zero), so they are removed here: left in, they would be massless
DOFs without stiffness, a singular model.
"""

from __future__ import annotations

import io
import re
from collections import Counter
from pathlib import Path

import numpy as np
import scipy.sparse as sp

from vibupdate.model.fe.export import (DIRECTIONS, FEExport, dof_name, precision_of_digits, significant_digits,
                                       symmetric_from_entries)

__all__ = ["read_hbmat", "read_mapping", "read_full", "ANSYS_LABELS"]

#: ANSYS DOF labels -> component 1..6.
ANSYS_LABELS = {"UX": 1, "UY": 2, "UZ": 3, "ROTX": 4, "ROTY": 5, "ROTZ": 6}


def read_mapping(path) -> tuple[str, ...]:
    """DOF names of the equations of an HBMAT ``.mapping`` file, in equation order."""
    path = Path(path)
    if not path.is_file():
        raise ValueError(f"ANSYS mapping file {str(path)!r} does not exist")
    names = {}
    for number, line in enumerate(path.read_text(errors="replace").splitlines(), start=1):
        parts = line.split()
        if len(parts) < 3 or not parts[0].isdigit():
            continue     # the header line
        label = parts[2].upper()
        if label not in ANSYS_LABELS:
            raise ValueError(f"{path}: line {number}: DOF label {parts[2]!r}, expected one of "
                             f"{', '.join(ANSYS_LABELS)}")
        try:
            names[int(parts[0])] = dof_name(int(parts[1]), ANSYS_LABELS[label])
        except ValueError:
            raise ValueError(f"{path}: line {number}: expected 'equation node label', got {line.strip()!r}") from None
    if not names:
        raise ValueError(f"{path}: no equation lines ('equation node label'); is it an HBMAT .mapping file?")
    if sorted(names) != list(range(1, len(names) + 1)):
        raise ValueError(f"{path}: equations must be numbered 1 to {len(names)}")
    return tuple(names[k] for k in range(1, len(names) + 1))


#: A real in a Harwell-Boeing value line (Fortran E, D or F format; fields may touch).
_REAL = re.compile(r"[+-]?(?:[0-9]+\.[0-9]*|\.[0-9]+|[0-9]+)(?:[EeDd][+-]?[0-9]+|[+-][0-9]+)?")


def _value_digits(lines: list[str], digits: Counter) -> None:
    """Count the significant digits of the values of a Harwell-Boeing file (its ``VALCRD``
    value lines, after the header and the pointer and index lines) into ``digits``."""
    try:
        _, ptrcrd, indcrd, valcrd = (int(lines[1][14 * k:14 * (k + 1)]) for k in range(4))
        rhscrd = int(lines[1][56:70] or 0)
    except ValueError:
        return
    start = 4 + (rhscrd > 0) + ptrcrd + indcrd
    for line in lines[start:start + valcrd]:
        for number in _REAL.findall(line):
            digits[significant_digits(number)] += 1


def _read_hb(path: Path, digits: Counter | None = None) -> sp.csr_matrix:
    import scipy.io

    if not path.is_file():
        raise ValueError(f"ANSYS matrix file {str(path)!r} does not exist")
    lines = path.read_text(errors="replace").splitlines(keepends=True)
    if len(lines) < 4:
        raise ValueError(f"{path}: too short for a Harwell-Boeing file")
    kind = lines[2][:3].upper()
    if kind not in ("RUA", "RSA"):
        raise ValueError(f"{path}: Harwell-Boeing type {kind!r}; a real assembled matrix (RUA or RSA) is expected")
    lines[2] = "RUA" + lines[2][3:]
    if digits is not None:
        _value_digits(lines, digits)
    try:
        A = sp.csr_matrix(scipy.io.hb_read(io.StringIO("".join(lines))), dtype=float)
    except (ValueError, IndexError, TypeError) as exc:
        raise ValueError(f"{path}: not a readable Harwell-Boeing file: {exc}") from None
    if A.shape[0] != A.shape[1]:
        raise ValueError(f"{path}: matrix of shape {A.shape}, a square one is expected")
    if kind == "RSA":
        coo = A.tocoo()
        A = symmetric_from_entries(coo.row, coo.col, coo.data, A.shape[0], str(path), "the matrix")
    return A


def read_hbmat(stiffness, mass, mapping) -> FEExport:
    """K and M written by ``HBMAT`` and the ``.mapping`` of their equations.

    Parameters
    ----------
    stiffness, mass : path
        Harwell-Boeing files of K and M.
    mapping : path
        The ``.mapping`` file (both matrices share the equations of the ``.full`` file).
    """
    dofs = read_mapping(mapping)
    digits = Counter()
    K, M = _read_hb(Path(stiffness), digits), _read_hb(Path(mass), digits)
    for path, A in ((stiffness, K), (mass, M)):
        if A.shape[0] != len(dofs):
            raise ValueError(f"{path}: {A.shape[0]} equations, but the mapping {str(mapping)!r} lists {len(dofs)}")
    return FEExport(K, M, dofs, f"{stiffness}, {mass}", precision=precision_of_digits(digits))


def read_full(path) -> FEExport:
    """K and M of an ANSYS ``.full`` file (needs ``ansys-mapdl-reader``: ``pip install "vibupdate[fe]"``)."""
    from vibupdate._extras import require

    require("fe", f"reading the ANSYS .full file {str(path)!r}", modules=("ansys.mapdl.reader",))
    from ansys.mapdl import reader as pymapdl_reader
    path = Path(path)
    if not path.is_file():
        raise ValueError(f"ANSYS .full file {str(path)!r} does not exist")
    full = pymapdl_reader.read_binary(str(path))
    dof_ref, k, m = full.load_km(as_sparse=True, sort=True)
    dofs = tuple(_full_dof(node, d) for node, d in np.asarray(dof_ref))
    constrained = {_full_dof(node, d) for node, d in np.asarray(full.const).reshape(-1, 2)}
    keep = np.array([i for i, name in enumerate(dofs) if name not in constrained], dtype=int)
    K, M = _mirrored(k)[keep][:, keep], _mirrored(m)[keep][:, keep]
    return FEExport(sp.csr_matrix(K), sp.csr_matrix(M), tuple(dofs[i] for i in keep), str(path))


def _full_dof(node, d) -> str:
    """The name of DOF ``d`` (0-based: ``UX`` ... ``ROTZ``) of ``node`` in a ``.full`` file."""
    return f"{int(node)}:{DIRECTIONS[int(d)]}"


def _mirrored(A) -> sp.csr_matrix:
    """The full symmetric matrix of one stored as its upper triangle (as the reader returns it)."""
    A = sp.csr_matrix(A, dtype=float)
    return A if sp.tril(A, -1).nnz else sp.csr_matrix(A + sp.triu(A, 1).T)
