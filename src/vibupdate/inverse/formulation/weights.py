"""Weights of the blocks' residuals (Eqs. 7, 9; docs/method.md, "Default weights"; the
option ``FormulationOptions.weighting``).
"""

from __future__ import annotations

import numpy as np

from vibupdate.inverse.formulation.blocks import VectorBlock
from vibupdate.inverse.formulation.options import FormulationOptions


def block_weight(blk: VectorBlock, entries: dict, options: FormulationOptions) -> float:
    """Weight of a block's squared residual: ``alpha / (w^2 ||D M0 S v0||)^2``, so that the
    residual approximates the relative eigenvalue error, or the user's ``alpha`` alone with
    ``weighting = "unit"``.

    Parameters
    ----------
    blk : VectorBlock
        With its user weight ``alpha`` and its start ``v0``.
    entries : dict
        The block's entries of every term (`vibupdate.inverse.formulation.stacking.block_entries`).
    options : FormulationOptions
    """
    if options.weighting == "unit":
        return blk.alpha
    nominal = entries["term"] == 0
    Mv = np.bincount(entries["row"][nominal], weights=entries["m"][nominal] * blk.start[entries["col"][nominal]],
                     minlength=len(blk.rows))
    return blk.alpha / (blk.omega**2 * np.linalg.norm(Mv)) ** 2
