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

    SuperLU's defaults (COLAMD ordering, partial pivoting) factor ``K - sigma M`` (symmetric,
    often indefinite) with many times the fill (`benchmarks/RESULTS.md`, "Shrinking data,
    modal, damping, model and examples")."""
    return spla.splu(sp.csc_matrix(A), permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=0.1)
