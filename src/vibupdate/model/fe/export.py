"""The one object every FE-code reader returns: an exported model.

`FEExport` holds the stiffness and mass matrices of one export as the code wrote them (after
the constrained DOFs are removed), the name of each DOF, ``"<node>:<dir>"`` with ``dir`` in
``x, y, z, rx, ry, rz`` (`DIRECTIONS`; a scalar point is ``"<id>:s"``), the node coordinates
when the export holds them, and the relative precision of the numbers as written: the text
readers count the significant digits they parse (`digit_counts`) and `precision_of_digits`
turns the counts into it (the rule: docs/fe-models.md, "Precision of the exports"). The helpers
here turn the entries a code writes (one triangle or both) into symmetric CSR matrices and check
what every reader must check.
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import re

import numpy as np
import scipy.sparse as sp


#: The directions of a node's six DOFs, in the order FE codes number them (1..6).
DIRECTIONS = ("x", "y", "z", "rx", "ry", "rz")
#: Relative asymmetry above which a matrix is refused as not symmetric.
SYMMETRY_TOL = 1e-10
#: Numbers with up to this many significant digits fewer than the widest of an export are taken
#: as written to the same width (a sign or a longer exponent takes a character of the field).
DIGIT_SPREAD = 2
#: Significant digits from which a number is a double written in full.
DOUBLE_DIGITS = 17

_EXPONENT_START = re.compile(r"[EeDd]|(?<=[0-9.])[+-]")


def existing_file(path, what: str) -> Path:
    """``path`` as a `Path`; a ValueError naming it (``what``: "Nastran file") when no such file exists."""
    path = Path(path)
    if not path.is_file():
        raise ValueError(f"{what} {str(path)!r} does not exist")
    return path


def significant_digits(text: str) -> int:
    """Significant digits of a real as written: ``"-1.234567890D+05"`` 10, ``"1.5+3"`` 2,
    ``"0.00120"`` 3 (trailing zeros count, leading ones do not), ``"0."`` 0."""
    mantissa = _EXPONENT_START.split(text.strip().lstrip("+-"), maxsplit=1)[0]
    return len(mantissa.replace(".", "").lstrip("0"))


def digit_counts(texts) -> Counter:
    """`significant_digits` of many reals at once, counted: the mapping `precision_of_digits`
    takes.

    Parameters
    ----------
    texts : array_like of str or bytes, shape (n,)
        Reals as written, each a number the reader has parsed (a sign, a mantissa, an optional
        exponent with a letter or only its sign).

    Returns
    -------
    collections.Counter
        Significant digits -> how many of ``texts`` have them.
    """
    s = np.asarray(texts)
    if not s.size:
        return Counter()
    raw = s.dtype.kind == "S"
    text = (lambda t: t.encode()) if raw else (lambda t: t)
    # every exponent letter or sign becomes "E"; the mantissa is what comes before the first (a sign
    # after a number's first character follows a digit, a point or the letter: `significant_digits`'s rule)
    marks = (bytes if raw else str).maketrans(text("eEdD+-"), text("EEEEEE"))
    s = np.char.translate(np.char.lstrip(np.char.strip(s), text("+-")), marks)
    mantissa = np.char.replace(np.char.partition(s, text("E"))[..., 0], text("."), text(""))
    lengths = np.char.str_len(np.char.lstrip(mantissa, text("0")))
    found, counts = np.unique(lengths, return_counts=True)
    return Counter(dict(zip(found.tolist(), counts.tolist())))


def precision_of_digits(counts) -> float | None:
    """Relative precision of the numbers of an export from their significant digits (module
    docstring).

    Parameters
    ----------
    counts : mapping of int to int
        Significant digits -> how many numbers were written with them (zeros, 0 digits, are
        ignored).

    Returns
    -------
    float or None
        ``0.5 * 10^(1 - digits)``; None for doubles written in full or no number at all.
    """
    written = [d for d, k in counts.items() if d > 0 and k > 0]
    if not written or max(written) >= DOUBLE_DIGITS:
        return None
    fewest = min(d for d in written if d >= max(written) - DIGIT_SPREAD)
    return 0.5 * 10.0 ** (1 - fewest)


def coarser(*precisions) -> float | None:
    """The coarsest of several relative precisions (None: double precision)."""
    given = [float(p) for p in precisions if p is not None]
    return max(given) if given else None


def dof_name(node, component: int) -> str:
    """``"<node>:<dir>"`` of component 1..6 (0: a scalar point, ``"<node>:s"``)."""
    if component == 0:
        return f"{node}:s"
    if not 1 <= component <= 6:
        raise ValueError(f"DOF component of node {node} must be 0 to 6, got {component}")
    return f"{node}:{DIRECTIONS[component - 1]}"


def dof_order(name: str) -> tuple[int, int]:
    """Sort key of a DOF name ``"<node>:<dir>"`` of a numbered node: node, then component (``s`` first)."""
    node, direction = name.split(":")
    return int(node), (("s",) + DIRECTIONS).index(direction)


@dataclass(frozen=True)
class FEExport:
    """Stiffness and mass exported by an FE code.

    Attributes
    ----------
    K, M : scipy.sparse.csr_matrix, shape (n, n)
        Stiffness (N/m, N m/rad) and mass (kg, kg m^2), symmetric.
    dofs : tuple of str, length n
        DOF names in matrix order, ``"<node>:<dir>"``.
    source : str
        The file(s) read, for messages.
    nodes : mapping of str to ndarray of shape (3,), optional
        Node label -> coordinates, m, when the export holds them.
    precision : float, optional
        Relative precision of the entries as written (module docstring); None: exact to double
        precision (a binary export, a model built in memory, doubles written in full).
    notes : tuple of str
        What the reader left out of the file (e.g. further DMIG matrices), for the import's summary.
    """

    K: sp.csr_matrix
    M: sp.csr_matrix
    dofs: tuple
    source: str
    nodes: Mapping = field(default_factory=dict)
    precision: float | None = None
    notes: tuple = ()

    def __post_init__(self):
        n = len(self.dofs)
        for label, A in (("K", self.K), ("M", self.M)):
            if A.shape != (n, n):
                raise ValueError(f"{self.source}: {label} has shape {A.shape}, expected ({n}, {n}) for the "
                                 f"{n} DOFs of the DOF map")
            scale = abs(A).max() if A.nnz else 0.0
            if scale and abs(A - A.T).max() > SYMMETRY_TOL * scale:
                raise ValueError(f"{self.source}: {label} is not symmetric (largest |A - A^T| "
                                 f"{abs(A - A.T).max():.3g} against largest entry {scale:.3g}); a symmetric matrix "
                                 "is expected")
        if len(set(self.dofs)) != n:
            twice = next(d for d, count in Counter(self.dofs).items() if count > 1)
            raise ValueError(f"{self.source}: DOF {twice!r} appears twice in the DOF map")


#: An off-diagonal term larger than this fraction of a matrix's largest entry, in a row whose
#: diagonal term is zero or missing, marks an incomplete file (`symmetric_from_entries`).
MISSING_DIAGONAL_TOL = 1e-12


def symmetric_from_entries(rows, cols, values, n: int, source: str, what: str, names=None,
                           lines=None) -> sp.csr_matrix:
    """Symmetric matrix from entries of one triangle or of both, shape (n, n).

    An entry given in both triangles must agree to `SYMMETRY_TOL`; one given in one triangle is
    mirrored. Repeated entries at one position are refused (FE codes write each term once).

    A row with a zero or missing diagonal term and an off-diagonal term above
    `MISSING_DIAGONAL_TOL` times the largest entry, which a positive semidefinite matrix cannot
    have (``A_ij^2 <= A_ii A_jj``), marks lines missing from the file (docs/fe/nastran.md):
    refused, naming the DOF (``names``, per index) and the line of its first term (``lines``,
    per entry) when given.
    """
    rows, cols = np.asarray(rows, dtype=np.int64), np.asarray(cols, dtype=np.int64)
    values = np.asarray(values, dtype=float)
    if not np.all(np.isfinite(values)):
        raise ValueError(f"{source}: {what} holds a value that is not a finite number")
    A = sp.coo_matrix((values, (rows, cols)), shape=(n, n)).tocsr()
    if A.nnz and np.unique(rows * n + cols).size != rows.size:
        raise ValueError(f"{source}: {what} gives some entry twice; each term is expected once")
    lower, upper = sp.tril(A, -1).tocsr(), sp.triu(A, 1).tocsr()
    both = lower.T.astype(bool).multiply(upper.astype(bool)).tocsr()
    if both.nnz:
        gap = abs((lower.T - upper).multiply(both)).max()
        scale = abs(A).max()
        if gap > SYMMETRY_TOL * scale:
            raise ValueError(f"{source}: {what} is not symmetric: its two triangles differ by up to {gap:.3g} "
                             f"(largest entry {scale:.3g}); a symmetric matrix is expected")
        upper = sp.csr_matrix(upper - upper.multiply(both))   # keep the lower copy of terms given twice
    out = sp.csr_matrix(lower + lower.T + upper + upper.T + sp.diags(A.diagonal()))
    _check_diagonal(out, rows, cols, source, what, names, lines)
    return out


def _check_diagonal(A: sp.csr_matrix, rows, cols, source: str, what: str, names, lines) -> None:
    """Refuse a row with off-diagonal terms and no diagonal term (`symmetric_from_entries`)."""
    if not A.nnz:
        return
    off = abs(A - sp.diags(A.diagonal())).tocsr()
    largest = np.zeros(A.shape[0])
    counts = np.diff(off.indptr)
    if off.nnz:
        largest[counts > 0] = np.maximum.reduceat(off.data, off.indptr[:-1][counts > 0])
    bad = np.flatnonzero((A.diagonal() == 0) & (largest > MISSING_DIAGONAL_TOL * abs(A).max()))
    if not bad.size:
        return
    i = int(bad[0])
    dof = f"DOF {names[i]!r}" if names is not None else f"row {i + 1}"
    where = ""
    if lines is not None:
        mine = np.flatnonzero((np.asarray(rows) == i) | (np.asarray(cols) == i))
        where = f" (its first term at line {int(np.min(np.asarray(lines)[mine]))})"
    raise ValueError(f"{source}: {what} has off-diagonal terms at {dof}{where} but no diagonal term there, which a "
                     f"stiffness or mass matrix cannot have ({bad.size} such DOF(s)): lines are missing from the "
                     "file; is it cut short?")


def without_dofs(export: FEExport, fixed: Sequence[str]) -> FEExport:
    """The export with the DOFs ``fixed`` (names) removed: constraints the code did not apply."""
    fixed = list(fixed)
    where = {d: k for k, d in enumerate(export.dofs)}
    missing = [d for d in fixed if d not in where]
    if missing:
        raise ValueError(f"{export.source}: fixed DOF {missing[0]!r} is not in the export's DOF map")
    drop = {where[d] for d in fixed}
    keep = np.array([k for k in range(len(export.dofs)) if k not in drop], dtype=int)
    return FEExport(sp.csr_matrix(export.K[keep][:, keep]), sp.csr_matrix(export.M[keep][:, keep]),
                    tuple(export.dofs[k] for k in keep), export.source, export.nodes, export.precision, export.notes)
