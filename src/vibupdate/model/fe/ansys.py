"""ANSYS Mechanical APDL matrices: ``HBMAT`` Harwell-Boeing files with their ``.mapping``, or the
binary ``.full`` file (what is read and checked: docs/fe/ansys.md, "What the reader takes from an
HBMAT file" and "The ``.full`` file instead").

The Harwell-Boeing layout (Duff, Grimes and Lewis, 1992) is read by this module's own reader, of
any repeat count, width, exponent letter and scale factor (`scipy.io.hb_read` reads only the
layout scipy's ``hb_write`` produces); a file that does not match its header is refused naming
the line, never read in part. The ``.mapping`` names each equation's node and DOF label; the
constrained DOFs are not written. The ``.full`` file is read through ``ansys-mapdl-reader`` (the
extra ``vibupdate[fe]``), whose ``load_km`` keeps the constrained DOFs as zero rows and columns,
removed here.
"""

from __future__ import annotations

import re
from collections import Counter
from pathlib import Path

import numpy as np
import scipy.sparse as sp

from vibupdate.model.fe.export import (DIRECTIONS, FEExport, dof_name, existing_file, precision_of_digits,
                                       significant_digits, symmetric_from_entries)


#: ANSYS DOF labels -> component 1..6.
ANSYS_LABELS = {"UX": 1, "UY": 2, "UZ": 3, "ROTX": 4, "ROTY": 5, "ROTZ": 6}


def read_mapping(path) -> tuple[str, ...]:
    """DOF names of the equations of an HBMAT ``.mapping`` file, in equation order."""
    path = existing_file(path, "ANSYS mapping file")
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


#: A Fortran edit descriptor of a Harwell-Boeing format field: optional scale factor ``kP``,
#: repeat count, letter, width, decimals (``(I14)``, ``(16I5)``, ``(1P,4D20.12)``, ``(d25.15)``).
_DESCRIPTOR = re.compile(r"^(?:([+-]?[0-9]+)P,?)?([0-9]*)([IEDFG])([0-9]+)(?:\.([0-9]+))?(?:E[0-9]+)?$")
#: A Fortran real on a value line: mantissa, then an exponent with a letter (E, D) or only its
#: sign (``1.0-100``, written when a three-digit exponent leaves no room for the letter).
_FORTRAN_REAL = re.compile(r"([+-]?)([0-9]*)\.?([0-9]*)(?:[EeDd]([+-]?[0-9]+)|([+-][0-9]+))?")


def _descriptor(text: str, path: Path, number: int, what: str, kinds: str) -> tuple[int, int, int, int]:
    """``(repeat, width, scale, decimals)`` of the Fortran format ``text`` of a Harwell-Boeing header."""
    inner = text.strip().upper().replace(" ", "").replace("(", "").replace(")", "")
    m = _DESCRIPTOR.match(inner)
    if not m or m.group(3) not in kinds:
        raise ValueError(f"{path}: line {number}: the format of the {what} is {text.strip()!r}; a Fortran format of "
                         f"one {'/'.join(kinds)} field with an optional repeat count (e.g. (I14), (8I10), (d25.15), "
                         "(1P,4E20.12)) is expected")
    return int(m.group(2) or 1), int(m.group(4)), int(m.group(1) or 0), int(m.group(5) or 0)


_ONE = {"pointers": "pointer", "row indices": "row index", "values": "value",
        "right-hand side": "right-hand side value"}


def _reals(line: str, fmt: tuple[int, int, int, int], path: Path, number: int, what: str) -> list[tuple[str, float]]:
    """The reals of a value line with their text: the numbers on the line, not fixed columns
    (``scipy.io.hb_write`` writes 24-character fields under a ``(3E25.16)`` format; an exponent
    letter or sign ends a number, so fields that touch are still split). A number with fewer
    decimals than the format's or a one-digit exponent is refused: a cut line (Fortran writes
    every decimal of ``Ew.d`` and a two-digit exponent)."""
    repeat, _, scale, decimals = fmt
    out, end = [], 0
    text = line.rstrip()
    while end < len(text):
        if text[end].isspace():
            end += 1
            continue
        m = _FORTRAN_REAL.match(text, end)
        after = text[m.end():m.end() + 1]
        if not (m.group(2) or m.group(3)) or not (after == "" or after.isspace() or after in "+-"):
            raise ValueError(f"{path}: line {number}: {text[end:].split()[0]!r} is not a Fortran real "
                             f"({_ONE[what]} {len(out) + 1} of the line)")
        exponent = m.group(4) or m.group(5)
        if len(m.group(3)) < decimals or (exponent is not None and len(exponent.lstrip("+-")) < 2):
            raise ValueError(f"{path}: line {number}: {_ONE[what]} {m.group(0)!r} has {len(m.group(3))} decimal(s) and "
                             f"{'no' if exponent is None else len(exponent.lstrip('+-'))} exponent digit(s); the "
                             f"format writes {decimals} and two: is the line cut?")
        mantissa = f"{m.group(1)}{m.group(2) or '0'}.{m.group(3) or '0'}"
        value = float(mantissa) * 10.0 ** (-scale) if exponent is None else float(f"{mantissa}E{exponent}")
        out.append((m.group(0), value))
        end = m.end()
    if len(out) > repeat:
        raise ValueError(f"{path}: line {number}: {len(out)} numbers; the format of the {what} allows {repeat} a line")
    return out


def _section(lines: list[str], first: int, count: int, fmt: tuple[int, int, int, int], expected: int, path: Path,
             what: str, digits: Counter | None = None) -> tuple[np.ndarray, np.ndarray]:
    """The numbers of the ``count`` lines from line index ``first`` and the 1-based line number
    of each; exactly ``expected`` numbers or an error naming the line. Integers unless
    ``digits`` is given (reals, their significant digits counted into it)."""
    numbers, where = [], []
    for k in range(first, first + count):
        line = lines[k].rstrip("\r\n")
        if digits is None:     # integers: fixed width, as Fortran reads them, blank trailing fields dropped
            fields = [line[fmt[1] * j:fmt[1] * (j + 1)].strip() for j in range(fmt[0])]
            while fields and not fields[-1]:
                fields.pop()
            for t in fields:
                if not t.lstrip("+-").isdigit():
                    raise ValueError(f"{path}: line {k + 1}: {_ONE[what]} {t!r} is not an integer")
            found = [int(t) for t in fields]
        else:
            pairs = _reals(line, fmt, path, k + 1, what)
            for t, _ in pairs:
                digits[significant_digits(t)] += 1
            found = [v for _, v in pairs]
        if not found:
            raise ValueError(f"{path}: line {k + 1}: a blank line among the {what} lines (lines {first + 1} to "
                             f"{first + count})")
        numbers += found
        where += [k + 1] * len(found)
    if len(numbers) != expected:
        raise ValueError(f"{path}: lines {first + 1} to {first + count} hold {len(numbers)} {what}, the header "
                         f"(lines 2-3) declares {expected}; the file is inconsistent or truncated")
    return np.asarray(numbers, dtype=float if digits is not None else np.int64), np.asarray(where)


def _header_ints(line: str, path: Path, number: int, names: tuple[str, ...], required: int) -> list[int]:
    parts = line.split()
    try:
        values = [int(p) for p in parts[:len(names)]]
    except ValueError:
        values = []
    if len(values) < required:
        raise ValueError(f"{path}: line {number}: expected the integers {', '.join(names)} of a Harwell-Boeing "
                         f"header, got {line.strip()!r}")
    return values + [0] * (len(names) - len(values))


def _read_hb(path: Path, digits: Counter | None = None) -> sp.csr_matrix:
    """The matrix of a Harwell-Boeing file (module docstring): header and counts checked, a
    symmetric (``RSA``) file mirrored."""
    lines = existing_file(path, "ANSYS matrix file").read_text(errors="replace").splitlines()
    if len(lines) < 4:
        raise ValueError(f"{path}: {len(lines)} line(s); a Harwell-Boeing file has a header of at least 4 lines")
    totcrd, ptrcrd, indcrd, valcrd, rhscrd = _header_ints(
        lines[1], path, 2, ("TOTCRD", "PTRCRD", "INDCRD", "VALCRD", "RHSCRD"), 4)
    kind = lines[2][:3].upper()
    if kind not in ("RUA", "RSA"):
        raise ValueError(f"{path}: line 3: matrix type {kind!r}; a real assembled matrix (RUA or RSA) is expected")
    nrow, ncol, nnz, _ = _header_ints(lines[2][3:], path, 3, ("NROW", "NCOL", "NNZERO", "NELTVL"), 3)
    if totcrd != ptrcrd + indcrd + valcrd + rhscrd:
        raise ValueError(f"{path}: line 2: TOTCRD = {totcrd} but PTRCRD + INDCRD + VALCRD + RHSCRD = "
                         f"{ptrcrd + indcrd + valcrd + rhscrd}; the header is inconsistent")
    if nrow != ncol or nrow < 1:
        raise ValueError(f"{path}: line 3: a matrix of {nrow} rows and {ncol} columns; a square one is expected")
    formats = re.findall(r"\([^()]*(?:\([^()]*\)[^()]*)*\)", lines[3])
    if len(formats) < 3 or (rhscrd > 0 and len(formats) < 4):
        raise ValueError(f"{path}: line 4: {len(formats)} Fortran format(s) {lines[3].strip()!r}; expected those "
                         "of the pointers, the row indices and the values" + (", and of the right-hand side"
                                                                             if rhscrd > 0 else ""))
    ptrfmt = _descriptor(formats[0], path, 4, "pointers", "I")
    indfmt = _descriptor(formats[1], path, 4, "row indices", "I")
    valfmt = _descriptor(formats[2], path, 4, "values", "EDFG")
    start = 4
    nrhs = 0
    if rhscrd > 0:
        if len(lines) < 5:
            raise ValueError(f"{path}: the header declares {rhscrd} right-hand side line(s) but line 5 is missing")
        rhstyp = lines[4][:3].upper()
        nrhs = _header_ints(lines[4][3:], path, 5, ("NRHS", "NRHSIX"), 1)[0]
        if not rhstyp.startswith("F"):
            raise ValueError(f"{path}: line 5: right-hand side type {rhstyp!r}; a full (F) right-hand side is "
                             "expected")
        rhsfmt = _descriptor(formats[3], path, 4, "right-hand side", "EDFG")
        start = 5
    if len(lines) < start + totcrd:
        raise ValueError(f"{path}: the file ends at line {len(lines)}; its header (line 2) declares {start} header "
                         f"lines and {totcrd} data lines ({start + totcrd} in all): it is truncated")
    extra = [k for k in range(start + totcrd, len(lines)) if lines[k].strip()]
    if extra:
        raise ValueError(f"{path}: line {extra[0] + 1}: more data than the {totcrd} lines its header (line 2) "
                         "declares; the header is inconsistent with the data")
    pointers, where = _section(lines, start, ptrcrd, ptrfmt, ncol + 1, path, "pointers")
    rows, rwhere = _section(lines, start + ptrcrd, indcrd, indfmt, nnz, path, "row indices")
    values, vwhere = _section(lines, start + ptrcrd + indcrd, valcrd, valfmt, nnz, path, "values",
                         Counter() if digits is None else digits)
    if rhscrd > 0:
        _section(lines, start + ptrcrd + indcrd + valcrd, rhscrd, rhsfmt, nrow * nrhs, path, "right-hand side",
                 Counter())
    steps = np.diff(pointers)
    if pointers[0] != 1 or pointers[-1] != nnz + 1 or np.any(steps < 0):
        k = 0 if pointers[0] != 1 else (ncol if pointers[-1] != nnz + 1 else int(np.flatnonzero(steps < 0)[0]) + 1)
        raise ValueError(f"{path}: line {where[k]}: column pointer {k + 1} is {pointers[k]}; the pointers must rise "
                         f"from 1 to NNZERO + 1 = {nnz + 1}")
    bad = np.flatnonzero((rows < 1) | (rows > nrow))
    if bad.size:
        raise ValueError(f"{path}: line {rwhere[bad[0]]}: row index {rows[bad[0]]} outside 1 to {nrow}")
    cols = np.repeat(np.arange(ncol), steps)
    # RSA holds one triangle, RUA both (which must agree): the same symmetric matrix either way
    return symmetric_from_entries(rows - 1, cols, values, nrow, str(path), "the matrix", lines=vwhere)


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
    from vibupdate.extras import require

    require("fe", f"reading the ANSYS .full file {str(path)!r}", modules=("ansys.mapdl.reader",))
    from ansys.mapdl import reader as pymapdl_reader
    path = existing_file(path, "ANSYS .full file")
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
