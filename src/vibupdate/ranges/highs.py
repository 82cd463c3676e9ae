"""HiGHS (highspy) for the ranges' linear programs: one solver instance kept between solves.

The ranges solve many programs of one shape: the same rows under another objective (each
parameter's lowest and highest value) or rows relinearized at another point
(`vibupdate.ranges.identifiability`, `vibupdate.ranges.certify`). scipy's ``milp`` and
``linprog`` build and solve each program from nothing; a kept instance re-solves from the
last optimal basis, which on the 37-parameter problems of the size family takes a fifth of
the time (`benchmarks/RESULTS.md`, "The linearized ranges solved warm").
"""

from __future__ import annotations

import functools
import os

import numpy as np
import scipy.sparse as sp


@functools.cache
def _banner_written() -> bool:
    """HiGHS writes a banner to the process's standard output (file descriptor 1, below
    Python's ``sys.stdout``) when its first instance is made: that one is made here with the
    descriptor pointed at the null device, once per process."""
    import highspy

    try:
        out = os.dup(1)
    except OSError:   # no standard output (a closed descriptor 1): nothing to keep clean
        highspy.Highs()
        return True
    try:
        with open(os.devnull, "wb") as null:
            os.dup2(null.fileno(), 1)
            highspy.Highs()
    finally:
        os.dup2(out, 1)
        os.close(out)
    return True


def highs(A, row_lower, row_upper, col_lower, col_upper, h=None, basis=None):
    """A silent HiGHS instance holding the program ``row_lower <= A z <= row_upper``,
    ``col_lower <= z <= col_upper`` (infinite entries: no bound), its objective zero until
    `solve` sets one.

    Parameters
    ----------
    A : ndarray or sparse matrix, shape (m, n)
    row_lower, row_upper : ndarray, shape (m,)
    col_lower, col_upper : ndarray, shape (n,)
    h : highspy.Highs, optional
        An instance to load the program into; a new one by default.
    basis : highspy.HighsBasis, optional
        The basis the next solve starts from (another program's of the same shape, whose
        optimum is near this one's); none by default.

    Returns
    -------
    highspy.Highs
    """
    import highspy

    _banner_written()
    if h is None:
        h = highspy.Highs()
        h.setOptionValue("output_flag", False)
    C = sp.csc_matrix(A)
    inf = highspy.kHighsInf
    lp = highspy.HighsLp()
    lp.num_row_, lp.num_col_ = C.shape
    lp.col_cost_ = np.zeros(C.shape[1])
    lp.col_lower_, lp.col_upper_ = (np.where(np.isfinite(b), b, s * inf) for b, s in ((col_lower, -1), (col_upper, 1)))
    lp.row_lower_, lp.row_upper_ = (np.where(np.isfinite(b), b, s * inf) for b, s in ((row_lower, -1), (row_upper, 1)))
    lp.a_matrix_.format_ = highspy.MatrixFormat.kColwise
    lp.a_matrix_.start_, lp.a_matrix_.index_, lp.a_matrix_.value_ = C.indptr, C.indices, C.data
    h.passModel(lp)
    if basis is not None and basis.valid and (len(basis.row_status), len(basis.col_status)) == C.shape:
        h.setBasis(basis)
    return h


def solve(h, cost) -> bool:
    """Set the objective ``cost`` (shape (n,)) of the program ``h`` holds and solve it from its
    last basis; True when HiGHS found an optimum."""
    import highspy

    n = h.getNumCol()
    h.changeColsCost(n, np.arange(n, dtype=np.int32), np.asarray(cost, dtype=float))
    h.run()
    return h.getModelStatus() == highspy.HighsModelStatus.kOptimal
