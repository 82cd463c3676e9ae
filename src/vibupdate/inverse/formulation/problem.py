"""The stacked bilinear least-squares problem of the first stage: its arrays, its exact residual
and objective, its sizes.

Separate from the code that builds it (`vibupdate.inverse.formulation.stacking`) because it is
what every solver reads (the relaxation, the homotopy, its backends) and they need nothing of
how it was built.
"""

from __future__ import annotations

import hashlib
from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp

from vibupdate.inverse.formulation.blocks import VectorBlock
from vibupdate.inverse.formulation.options import FormulationOptions
from vibupdate.modal.eigen import DENSE_LIMIT
from vibupdate.model.parameters import Parameter


@dataclass(frozen=True)
class BilinearProblem:
    """The stacked bilinear least-squares problem (`vibupdate.inverse.formulation`).

    Attributes
    ----------
    parameters : tuple of Parameter, length n_x
    x_lower, x_upper : ndarray, shape (n_x,)
        Box of the normalized parameters.
    blocks : tuple of VectorBlock
    u_offsets : ndarray of int, shape (n_blocks + 1,)
        Block ``b`` owns free unknowns ``u[u_offsets[b]:u_offsets[b+1]]``.
    u_lower, u_upper, u_start : ndarray, shape (n_u,)
    A_u : csr_matrix, shape (n_R, n_u)
    A_x : csr_matrix, shape (n_R, n_x)
    A_b : csr_matrix, shape (n_R, n_b)
    r0 : ndarray, shape (n_R,)
    prod_x, prod_u : ndarray of int, shape (n_b,)
        The bilinear products are ``xbar[prod_x] * u[prod_u]``.
    row_weight : ndarray, shape (n_R,)
        ``alpha`` of the block of each residual row.
    row_offsets : ndarray of int, shape (n_blocks + 1,)
    notes : tuple
        What the transformations set aside, as typed records with a ``message`` (e.g.
        `vibupdate.inverse.interlacing.SignConflict`): the run reports them and goes on.
    """

    parameters: tuple[Parameter, ...]
    x_lower: np.ndarray
    x_upper: np.ndarray
    blocks: tuple[VectorBlock, ...]
    u_offsets: np.ndarray
    u_lower: np.ndarray
    u_upper: np.ndarray
    u_start: np.ndarray
    A_u: sp.csr_matrix
    A_x: sp.csr_matrix
    A_b: sp.csr_matrix
    r0: np.ndarray
    prod_x: np.ndarray
    prod_u: np.ndarray
    row_weight: np.ndarray
    row_offsets: np.ndarray
    options: FormulationOptions = field(default_factory=FormulationOptions)
    notes: tuple = ()

    @property
    def n_x(self) -> int:
        return len(self.parameters)

    @property
    def n_u(self) -> int:
        return self.u_lower.size

    @property
    def n_b(self) -> int:
        return self.prod_x.size

    @property
    def n_r(self) -> int:
        return self.r0.size

    def residual(self, x, u) -> np.ndarray:
        """Exact residual (lambda = 1), shape (n_R,)."""
        return self.A_u @ u + self.A_x @ x + self.A_b @ (x[self.prod_x] * u[self.prod_u]) + self.r0

    def objective(self, x, u) -> float:
        """``sum_k w_k R_k^2`` at the exact products."""
        R = self.residual(x, u)
        return float(np.sum(self.row_weight * R**2))

    def unknowns_at(self, x) -> np.ndarray:
        """The free unknowns that minimize `objective` at the parameters ``x``, each measured
        entry within its measured interval.

        With ``x`` fixed the residual is linear in ``u`` and each block's rows read only its own
        unknowns, so this is one bounded linear least squares per block (`bounded_lstsq`). The
        boxes of the entries that were not measured are margins of the relaxation, not data, and
        are left out: the vector of the model at ``x`` may lie outside them. `update` returns
        these unknowns at its answer, so that the vectors and the objective it reports belong
        to the model it returns, wherever the polish moved it from the homotopy's point.
        """
        x = np.asarray(x, dtype=float)
        bilinear = sp.csr_matrix((x[self.prod_x], (np.arange(self.n_b), self.prod_u)), shape=(self.n_b, self.n_u))
        w = np.sqrt(self.row_weight)
        A = sp.csr_matrix(sp.diags(w) @ (self.A_u + self.A_b @ bilinear))
        rhs = -w * (self.A_x @ x + self.r0)
        u = np.clip(self.u_start, self.u_lower, self.u_upper)
        whole = A.toarray() if A.shape[0] * A.shape[1] <= DENSE_LIMIT**2 else None   # small: sliced dense
        for b, blk in enumerate(self.blocks):
            rows = slice(self.row_offsets[b], self.row_offsets[b + 1])
            cols = slice(self.u_offsets[b], self.u_offsets[b + 1])
            measured = np.zeros(blk.n_free, bool) if blk.measured is None else blk.measured[~blk.fixed]
            lower = np.where(measured, self.u_lower[cols], -np.inf)
            upper = np.where(measured, self.u_upper[cols], np.inf)
            free = lower < upper     # an unknown its interval pins stays there
            u[cols] = np.where(free, u[cols], lower)
            if free.any():
                block = whole[rows, cols] if whole is not None else A[rows][:, cols]
                if sp.issparse(block) and block.shape[1] <= DENSE_LIMIT:   # no n x n dense above
                    block = block.toarray()
                u[cols][free] = bounded_lstsq(block[:, free], rhs[rows] - block[:, ~free] @ lower[~free],
                                              lower[free], upper[free])
        return u

    def identity(self) -> str:
        """A digest of everything a solver reads (bounds, start, matrices, products, weights):
        two problems with the same identity are the same problem (`vibupdate.inverse.homotopy`
        solves its relaxation once)."""
        digest = hashlib.blake2b(digest_size=20)
        for a in (self.x_lower, self.x_upper, self.u_lower, self.u_upper, self.u_start, self.r0, self.row_weight):
            digest.update(np.ascontiguousarray(a, dtype=float).tobytes())
            digest.update(b"|")
        for a in (self.prod_x, self.prod_u):
            digest.update(np.ascontiguousarray(a, dtype=np.int64).tobytes())
            digest.update(b"|")
        for A in (self.A_u, self.A_x, self.A_b):
            A = sp.csr_matrix(A)
            digest.update(repr(A.shape).encode())
            for a in (A.indptr, A.indices):
                digest.update(np.ascontiguousarray(a, dtype=np.int64).tobytes())
            digest.update(np.ascontiguousarray(A.data, dtype=float).tobytes())
        return digest.hexdigest()

    def block_vector(self, b: int, u) -> np.ndarray:
        """Physical vector of block ``b`` (fixed entries included) from the free unknowns."""
        blk = self.blocks[b]
        full = blk.lower.copy()
        full[~blk.fixed] = u[self.u_offsets[b]:self.u_offsets[b + 1]]
        return blk.scale * full

    def sizes(self) -> dict:
        """Counts comparable with Table 1 of the paper."""
        nat = sum(b.n_free for b in self.blocks if b.kind == "natural")
        adj = sum(b.n_free for b in self.blocks if b.kind == "antiresonance")
        return {
            "n_parameters": self.n_x,
            "n_mode_unknowns": nat,
            "n_adjunct_unknowns": adj,
            "n_lifted": self.n_b,
            "n_residuals": self.n_r,
            "n_fixed_entries": int(sum(np.count_nonzero(b.fixed) for b in self.blocks)),
        }


def bounded_lstsq(B, r, lower, upper) -> np.ndarray:
    """``argmin |B v - r|`` over ``lower <= v <= upper`` (infinite entries: unbounded).

    A dense ``B``: scipy's ``lsq_linear`` (``bvls``, exact to rounding). A sparse one (a
    block above `vibupdate.modal.eigen.DENSE_LIMIT` unknowns, `BilinearProblem.unknowns_at`):
    for given bounded unknowns ``v_m`` (the measured entries of a mode, few) the unbounded ones
    are ``v_n = y0 - Y v_m``, the least squares of ``B_n`` by one sparse LU of the augmented
    system ``[[I, B_n], [B_n^T, 0]]``; what is left is a dense bounded least squares in ``v_m``,
    by ``bvls`` again: the same answer without an ``n x n`` dense matrix. A singular ``B_n``
    (unbounded unknowns the block does not determine) goes to ``bvls`` on the dense ``B``.

    Parameters
    ----------
    B : sparse matrix or ndarray, shape (m, n)
    r : ndarray, shape (m,)
    lower, upper : ndarray, shape (n,)

    Returns
    -------
    ndarray, shape (n,)
    """
    from scipy.optimize import lsq_linear

    from vibupdate.modal.factor import sparse_lu

    def bvls(C, d, lo, hi):
        if not (np.isfinite(lo).any() or np.isfinite(hi).any()):   # unbounded: lsq_linear's own first solve
            return np.linalg.lstsq(C, d, rcond=-1)[0]
        return lsq_linear(C, d, bounds=(lo, hi), method="bvls", tol=1e-14).x

    if not sp.issparse(B):
        return bvls(B, r, lower, upper)
    bounded = np.isfinite(lower) | np.isfinite(upper)
    B = sp.csc_matrix(B)
    Bn, Bm = B[:, ~bounded], B[:, bounded].toarray()
    m, k = B.shape[0], Bn.shape[1]
    try:
        lu = sparse_lu(sp.bmat([[sp.eye(m), Bn], [Bn.T, None]]))
    except RuntimeError:   # B_n singular
        return bvls(B.toarray(), r, lower, upper)
    Y = lu.solve(np.vstack([np.column_stack([r, Bm]), np.zeros((k, 1 + Bm.shape[1]))]))[m:]
    y0, Yb = Y[:, 0], Y[:, 1:]
    v = np.empty(B.shape[1])
    v[bounded] = bvls(Bm - Bn @ Yb, r - Bn @ y0, lower[bounded], upper[bounded]) if bounded.any() else 0.0
    v[~bounded] = y0 - Yb @ v[bounded]
    return v
