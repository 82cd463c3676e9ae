"""Stacking of the blocks into the bilinear problem: each block's rows of ``D (K - w^2 M) S``
split into the linear part in ``u``, the linear part in ``xbar`` (fixed entries), the bilinear
products and the constant (docs/method.md, "Blocks and the stacked problem"), in one vectorized
pass per block.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import scipy.sparse as sp

from vibupdate.inverse.formulation.blocks import VectorBlock
from vibupdate.inverse.formulation.problem import BilinearProblem
from vibupdate.inverse.formulation.scaling import ScaledTerms
from vibupdate.inverse.formulation.weights import block_weight


def block_entries(blk: VectorBlock, terms: ScaledTerms) -> dict:
    """The block's entries of every term, in block-local indices: rows, columns, value of
    ``D (K - w^2 M) S`` and term, for the entries on the block's rows and columns."""
    row_of = np.full(terms.n, -1)
    row_of[blk.rows] = np.arange(len(blk.rows))
    col_of = np.full(terms.n, -1)
    col_of[blk.cols] = np.arange(len(blk.cols))
    lr, lc = row_of[terms.row], col_of[terms.col]
    keep = (lr >= 0) & (lc >= 0)
    value = terms.k[keep] - blk.omega**2 * terms.m[keep]
    return {"row": lr[keep], "col": lc[keep], "value": value, "term": terms.term[keep],
            "m": terms.m[keep]}


def stack(parameters, x_bounds, blocks, terms, options) -> BilinearProblem:
    """Stack the blocks, each with the `ScaledTerms` of its configuration, into one
    `BilinearProblem`; each block's ``alpha`` becomes its weight (`block_weight`)."""
    n_x = len(parameters)
    Au, Ax, Ab, r0, px, pu, wrow, weighted = [], [], [], [], [], [], [], []
    u_off, r_off, n_prod = [0], [0], 0
    for blk, term in zip(blocks, terms):
        e = block_entries(blk, term)
        blk = replace(blk, alpha=block_weight(blk, e, options))
        weighted.append(blk)
        n_rows, fixed = len(blk.rows), blk.fixed[e["col"]]
        free_of = np.cumsum(~blk.fixed) - 1              # local column -> free position
        n_free = int(np.count_nonzero(~blk.fixed))
        row_glob = r_off[-1] + e["row"]
        nominal = e["term"] == 0
        # Nominal term: free columns into A_u, fixed columns (their fixed value) into r0.
        sel = nominal & ~fixed
        Au.append((row_glob[sel], u_off[-1] + free_of[e["col"][sel]], e["value"][sel]))
        sel = nominal & fixed
        r0.append(np.bincount(e["row"][sel], weights=e["value"][sel] * blk.lower[e["col"][sel]],
                              minlength=n_rows))
        # Parameter terms: fixed columns into A_x; free columns are the bilinear products.
        sel = ~nominal & fixed
        Ax.append((row_glob[sel], e["term"][sel] - 1, e["value"][sel] * blk.lower[e["col"][sel]]))
        sel = ~nominal & ~fixed
        key = (e["term"][sel] - 1) * max(n_free, 1) + free_of[e["col"][sel]]
        products, local = np.unique(key, return_inverse=True)
        Ab.append((row_glob[sel], n_prod + local, e["value"][sel]))
        px.append(products // max(n_free, 1))
        pu.append(u_off[-1] + products % max(n_free, 1))
        n_prod += products.size
        wrow.append(np.full(n_rows, blk.alpha))
        u_off.append(u_off[-1] + n_free)
        r_off.append(r_off[-1] + n_rows)
    blocks = weighted
    n_r, n_u = r_off[-1], u_off[-1]

    def assemble(parts, n_cols):
        rows, cols, vals = (np.concatenate(a) if a else np.zeros(0) for a in zip(*parts))
        return sp.csr_matrix((vals, (rows.astype(np.int64), cols.astype(np.int64))), shape=(n_r, n_cols))

    u_lower = np.concatenate([b.lower[~b.fixed] for b in blocks])
    u_upper = np.concatenate([b.upper[~b.fixed] for b in blocks])
    u_start = np.concatenate([b.start[~b.fixed] for b in blocks])
    return BilinearProblem(
        parameters=tuple(parameters),
        x_lower=x_bounds[0], x_upper=x_bounds[1],
        blocks=tuple(blocks),
        u_offsets=np.array(u_off), u_lower=u_lower, u_upper=u_upper, u_start=u_start,
        A_u=assemble(Au, n_u),
        A_x=assemble(Ax, n_x),
        A_b=assemble(Ab, n_prod),
        r0=np.concatenate(r0),
        prod_x=np.concatenate(px).astype(int), prod_u=np.concatenate(pu).astype(int),
        row_weight=np.concatenate(wrow), row_offsets=np.array(r_off),
        options=options,
    )
