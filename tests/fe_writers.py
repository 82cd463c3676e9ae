"""Writers of the FE codes' export formats (`vibupdate.examples.fe_writers`, where the worked
examples use them) and the comparison of the tests of the readers."""

from __future__ import annotations

import scipy.sparse as sp

from vibupdate.examples.fe_writers import (ANSYS, COMPONENT, dmig_text, grid_text, write_abaqus,  # noqa: F401
                                           write_dmig, write_hbmat)


def relative_difference(A, B) -> float:
    A, B = sp.csr_matrix(A), sp.csr_matrix(B)
    scale = abs(B).max() if B.nnz else 0.0
    return float(abs(A - B).max() / scale) if scale else float(abs(A).max() if A.nnz else 0.0)
