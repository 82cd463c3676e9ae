"""Sign bounds from the pole/zero pattern of a receptance (paper Eq. 11, Section 3.6).

Between two consecutive natural frequencies ``w_k < w_k+1`` the undamped receptance
``h_rc = sum_k u_k(r) u_k(c) / (w_k^2 - w^2)`` runs from ``-sign(A_k) inf`` to
``+sign(A_k+1) inf`` with ``A_k = u_k(r) u_k(c)`` the modal constant. So an odd number of
antiresonances between them means ``A_k`` and ``A_k+1`` have the same sign, an even number
(none) means opposite signs. From the measured sequence and the sign of the first modal
constant (nominal model, or the user) every modal constant's sign follows; it becomes the
bounds ``[delta, B]`` or ``[-B, -delta]`` on ``u(r)`` and ``u(c)`` (Fig. 10), which the
McCormick envelopes then use. This is a transformation of the blocks' bounds only.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from vibupdate.data.measured import TWO_PI, Configuration

__all__ = ["modal_constant_signs", "sign_bounds"]


def modal_constant_signs(poles: Sequence[float], zeros: Sequence[float], first: int,
                         modes: Sequence[int] | None = None) -> list[int | None]:
    """Signs of the modal constants ``u_k(r) u_k(c)`` of the measured modes.

    Parameters
    ----------
    poles : sequence of float, length n_p
        Measured natural frequencies, ascending (any unit, same as ``zeros``).
    zeros : sequence of float
        All measured antiresonances of ``h_rc`` in the band of the poles, ascending.
    first : {+1, -1}
        Sign of the first modal constant.
    modes : sequence of int, length n_p, optional
        Declared model modes of the poles; consecutive when omitted. Only poles of
        consecutive modes are linked by the pattern.

    Returns
    -------
    list, length n_p
        +1 / -1 where the pattern determines the sign relative to ``first``; None from the
        first pole after a gap in the modes, or after a repeated pole, on (not determined by
        the data: the modes of a repeated frequency are any combination of each other, and so
        are their modal constants).
    """
    poles, zeros = np.asarray(poles, float), np.asarray(zeros, float)
    modes = list(range(1, poles.size + 1)) if modes is None else list(modes)
    signs: list[int | None] = [int(first)]
    for k in range(poles.size - 1):
        if signs[-1] is None or modes[k + 1] != modes[k] + 1 or poles[k + 1] == poles[k]:
            signs.append(None)   # a gap in the modes, or a repeated frequency: its modes' constants are any split
            continue
        between = int(np.count_nonzero((zeros > poles[k]) & (zeros < poles[k + 1])))
        signs.append(signs[-1] if between % 2 == 1 else -signs[-1])
    return signs


def _nominal_first_sign(blk_r, blk_c) -> int:
    product = blk_r * blk_c
    return 1 if product >= 0 else -1


def _bound_sign(lower, upper, j, sign, delta, where):
    lo, hi = lower[j], upper[j]
    if sign > 0:
        lo = max(lo, delta)
    else:
        hi = min(hi, -delta)
    if lo > hi:
        raise ValueError(
            f"{where}: the interlacing sign pattern asks for a {'positive' if sign > 0 else 'negative'} "
            f"entry, but its bounds are [{lower[j]:.4g}, {upper[j]:.4g}] (infeasible sign pattern)"
        )
    lower[j], upper[j] = lo, hi


def sign_bounds(blocks, configurations: Sequence[Configuration], options):
    """Transform: tighten the natural blocks' bounds at ``r`` and ``c`` of each receptance with
    measured antiresonances (``r != c``), for configurations with ``interlacing`` on."""
    if not options.interlacing:
        return blocks
    blocks = list(blocks)
    for cfg in configurations:
        if not cfg.interlacing or len(cfg.natural) < 1:
            continue
        mine = [i for i, b in enumerate(blocks) if b.configuration == cfg.name and b.kind == "natural"]
        for rc in cfg.receptances():
            if rc[0] == rc[1]:
                continue  # driving point: every modal constant is u(r)^2 > 0
            r, c = cfg.model.dof(rc[0]), cfg.model.dof(rc[1])
            zeros = [a.omega for a in cfg.antiresonances if a.receptance == rc]
            poles = [f.omega for f in cfg.natural]
            first_blk = blocks[mine[0]]
            first = cfg.first_sign.get(rc) or _nominal_first_sign(first_blk.start[r], first_blk.start[c])
            signs = modal_constant_signs(poles, zeros, first, [f.mode for f in cfg.natural])
            for k, i in enumerate(mine):
                if signs[k] is None:
                    continue
                blk = blocks[i]
                lower, upper = blk.lower.copy(), blk.upper.copy()
                where = (f"configuration {cfg.name!r}, mode {k + 1} ({poles[k] / TWO_PI:.4g} Hz), "
                         f"receptance h_{rc[0]},{rc[1]}")
                sign_r = _entry_sign(lower[r], upper[r], blk.start[r])
                _bound_sign(lower, upper, r, sign_r, options.sign_delta, where + f", entry {rc[0]}")
                _bound_sign(lower, upper, c, signs[k] * sign_r, options.sign_delta, where + f", entry {rc[1]}")
                blocks[i] = blk.with_bounds(lower, upper)
    return blocks


def _entry_sign(lower: float, upper: float, start: float) -> int:
    """Sign an entry must keep: forced by its bounds when they exclude zero, else the start's."""
    if lower > 0:
        return 1
    if upper < 0:
        return -1
    return 1 if start >= 0 else -1
