"""The sparse factorization every solve of this package uses on ``K - sigma M`` and its blocks.

It lives apart from the eigen-solvers so that the modules they call (`vibupdate.modal.refinement`)
can factor without importing them."""

from __future__ import annotations

import scipy.sparse as sp
import scipy.sparse.linalg as spla


def sparse_lu(A):
    """Sparse LU (SuperLU) of a structurally symmetric matrix with a symmetric fill-reducing
    ordering (minimum degree on ``A^T + A``) and threshold pivoting that keeps a diagonal pivot
    within a factor 10 of the column's largest entry.

    SuperLU's defaults (COLAMD ordering, partial pivoting) factor the matrices of this package
    (``K - sigma M``, symmetric, often indefinite) with many times the fill: on the 30,315-DOF
    building frame, ``K`` 2.2e6 entries in L and U against 4.8e5 (0.64 s against 0.21 s), and
    ``K - w_8^2 M`` 9.0e6 against 4.8e5 (1.31 s against 0.07 s), the same backward error
    (3e-16); at 300,105 DOFs one factorization had not finished after 9 minutes, against 2.1 s
    (`benchmarks/RESULTS.md`)."""
    return spla.splu(sp.csc_matrix(A), permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=0.1)
