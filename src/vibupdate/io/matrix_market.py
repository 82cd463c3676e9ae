"""Matrix Market files of a run's matrices, written as `scipy.io.mmwrite` writes them.

A small real matrix equal to its transpose (every ``M`` and ``K`` of a small model, and its
Caughey ``C``) is written here, byte for byte what ``scipy.io.mmwrite`` with its default
symmetry detection writes: the ``symmetric`` header, the comment one ``%`` line per line, the
lower triangle in the matrix's own order, each value in the shortest digits that read back
to it (Python's ``repr``), as ``d.dddE<exponent>`` without the exponent when it is 0. Every
other matrix goes to ``scipy.io.mmwrite`` itself. The point is the import: scipy.io loads its
MATLAB, WAV, ARFF, NetCDF and Harwell-Boeing readers (about 0.012 s), which a short run of a
small model never needs (benchmarks/RESULTS.md).
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

__all__ = ["write_matrix", "format_value", "SMALL_ROWS"]

#: Below this many rows and columns `scipy.io.mmwrite` looks for a symmetry (above, it writes
#: every matrix as ``general``); only there is a matrix written here.
SMALL_ROWS = 100


def format_value(value: float) -> str:
    """``value`` as `scipy.io.mmwrite` writes a real entry: ``1.278602614834372E-2``, ``5E-1``,
    ``-2.5`` (exponent 0 left out), ``0``, ``-0``, ``Infinity``, ``NaN``."""
    value = float(value)
    if value != value:
        return "NaN"
    if value in (float("inf"), float("-inf")):
        return ("-" if value < 0 else "") + "Infinity"
    text = repr(value)
    sign = "-" if text.startswith("-") else ""
    if value == 0:
        return sign + "0"
    mantissa, _, exponent = text.lstrip("-").partition("e")
    whole, _, fraction = mantissa.partition(".")
    power = int(exponent) if exponent else 0
    if whole.strip("0"):
        power += len(whole.lstrip("0")) - 1
    else:
        power -= len(fraction) - len(fraction.lstrip("0")) + 1
    digits = (whole + fraction).strip("0")
    return sign + digits[0] + ("." + digits[1:] if len(digits) > 1 else "") + (f"E{power}" if power else "")


def _own(A: sp.coo_matrix) -> bool:
    """True for the matrices written here: small, square, real and equal to their transpose."""
    if max(A.shape) >= SMALL_ROWS or A.shape[0] != A.shape[1] or A.dtype != np.float64:
        return False
    csr = A.tocsr()
    return (csr != csr.T).nnz == 0


def write_matrix(path, matrix, comment: str) -> None:
    """Write ``matrix`` (sparse or dense) to the Matrix Market file ``path`` with ``comment``,
    as ``scipy.io.mmwrite(path, scipy.sparse.coo_matrix(matrix), comment=comment)`` does (which
    adds ``.mtx`` to a name without it)."""
    A = sp.coo_matrix(matrix)
    path = str(path)
    if not _own(A):
        import scipy.io

        scipy.io.mmwrite(path, A, comment=comment)
        return
    if not path.endswith(".mtx"):
        path += ".mtx"
    lower = A.row >= A.col
    rows, cols, values = A.row[lower] + 1, A.col[lower] + 1, A.data[lower]
    lines = ["%%MatrixMarket matrix coordinate real symmetric"]
    lines += ["%" + line for line in comment.split("\n")]
    lines.append(f"{A.shape[0]} {A.shape[1]} {values.size}")
    lines += [f"{r} {c} {format_value(v)}" for r, c, v in zip(rows.tolist(), cols.tolist(), values.tolist())]
    with open(path, "w", encoding="utf-8", newline="\n") as out:
        out.write("\n".join(lines) + "\n")
