"""Which model mode, and which zero of a receptance, each measured value is: data, never
inferred from nearness at the updated point (docs/method.md, "Declared correspondence").

A natural frequency's omitted ``mode`` is the mode after the previous one (`declared_modes`).
An antiresonance's omitted ``index`` is assigned once, from the nominal model (`zero_indices`):
above the measured pole of mode ``m``, the ``j``-th measured zero of ``h_rc`` is zero
``n_0 + j``, ``n_0`` the nominal zeros below mode ``m``; at a driving point ``n_0`` comes from
interlacing. A cross receptance's nominal zero on a pole (within `ON_POLE`) stays hidden on it
unless the gap holds more measured zeros than nominal ones, and in a gap with skipped modes the
nominal zero nearest each skipped pole is hidden (why: docs/notes/data-and-formulation.md,
"Zeros on poles of cross receptances" and "Zeros beside a mode the test did not see"). Zeros
that leave or join the real axis shift the count in a way no default sees: the case then states
``index``.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import replace
from itertools import combinations
from typing import TYPE_CHECKING

import numpy as np

from vibupdate.data.names import zero_name

if TYPE_CHECKING:   # for the annotations only: vibupdate.data.measured imports this module
    from vibupdate.data.measured import NaturalFrequency


#: A nominal zero within this relative distance of the first mode lies on it (a node of that
#: mode at a driving point), not below it. A chosen figure: far above the rounding of the
#: eigen-solves (1e-12 to 1e-10 relative), far below any gap between a zero and a pole that a
#: measurement resolves.
ON_POLE = 1e-6


def zero_indices(poles, modes, zeros, nominal_omega, nominal_zeros, driving: bool = False) -> list[int]:
    """Default zero indices of one receptance's measured antiresonances (module docstring).

    Parameters
    ----------
    poles : sequence of float, length n_p
        Measured natural frequencies of the configuration, rad/s, ascending.
    modes : sequence of int, length n_p
        Their declared model modes (1-based).
    zeros : sequence of float, length n_z
        Measured antiresonances of the receptance, rad/s, ascending.
    nominal_omega : ndarray
        Nominal model natural frequencies, rad/s, ascending (at least up to the highest mode).
    nominal_zeros : ndarray
        Nominal model zeros of the receptance, rad/s, ascending.
    driving : bool
        A driving-point receptance (response = excitation): zeros below a mode counted by
        interlacing (module docstring).

    Returns
    -------
    list of int, length n_z
    """
    poles = np.asarray(poles, dtype=float)
    zeros = np.asarray(zeros, dtype=float)
    nominal_zeros = np.asarray(nominal_zeros, dtype=float)
    if poles.size == 0:
        return list(range(1, zeros.size + 1))

    def on(w: float) -> int:   # the nominal zeros on the pole at w
        return int(np.count_nonzero(np.abs(nominal_zeros - w) <= ON_POLE * w))

    below_first = int(np.count_nonzero(nominal_zeros < nominal_omega[0] * (1 - ON_POLE)))   # a driving point's
    out = []
    gap = np.searchsorted(poles, zeros, side="right")   # g: above the measured pole g - 1, below pole g
    for g in np.unique(gap):
        mine = zeros[gap == g]
        c = mine.size
        if g == 0:   # below the lowest measured pole: counted down from it
            w0 = nominal_omega[modes[0] - 1]
            if driving:
                top = below_first + modes[0] - 1
            else:
                strict = int(np.count_nonzero(nominal_zeros < w0 * (1 - ON_POLE)))
                top = strict + min(max(c - strict, 0), on(w0))
            out += [max(top - c + 1 + i, 1 + i) for i in range(c)]
            continue
        a = modes[g - 1]
        wa = nominal_omega[a - 1]
        wb, pb = (nominal_omega[modes[g] - 1], poles[g]) if g < poles.size else (np.inf, np.inf)
        skipped = nominal_omega[a:modes[g] - 1] if g < poles.size else nominal_omega[:0]
        # the nominal zeros of the gap: by interlacing at a driving point, else those strictly inside
        inside = (np.arange(below_first + a, below_first + modes[g]) if driving and skipped.size else
                  1 + np.flatnonzero((nominal_zeros > wa * (1 + ON_POLE)) & (nominal_zeros < wb * (1 - ON_POLE))))
        if skipped.size and c < inside.size:   # modes the test did not see lie in this gap
            out += _unhidden(inside, nominal_zeros, skipped, inside.size - c)[:c]
            continue
        if driving:
            first = below_first + a
        else:
            excess = max(c - inside.size, 0)
            f_a = on(wa)
            f_b = 0 if wb <= wa * (1 + ON_POLE) or not np.isfinite(wb) else on(wb)   # pole b's own zeros
            # the excess zeros came off the poles' zeros, each off the nearer pole (relative distance)
            nearer_a = int(np.count_nonzero(mine / poles[g - 1] - 1 <= 1 - mine / pb))
            up = min(nearer_a, f_a, excess)
            down = min(c - nearer_a, f_b, excess - up)
            up = min(f_a, excess - down)     # and the rest off pole a's, as far as it has them
            first = int(np.count_nonzero(nominal_zeros <= wa * (1 + ON_POLE))) - up + 1
        out += [first + i for i in range(c)]
    # keep them strictly rising (a sparse nominal spectrum can repeat a count)
    for i in range(1, len(out)):
        out[i] = max(out[i], out[i - 1] + 1)
    return out


def _unhidden(inside: np.ndarray, nominal_zeros: np.ndarray, skipped: np.ndarray, missing: int) -> list[int]:
    """The zero indices ``inside`` a gap (1-based, rising) without those hidden by the modes the
    test skipped there (module docstring): up to ``missing`` zeros, each the nominal zero nearest
    (relative distance) to a skipped pole ``skipped`` (rad/s) not yet paired, nearest pairs first."""
    w = np.array([nominal_zeros[k - 1] if k <= nominal_zeros.size else np.inf for k in inside])
    distance = np.abs(w[:, None] / skipped[None, :] - 1)
    hidden = set()
    for _ in range(min(missing, skipped.size)):
        i, j = np.unravel_index(np.argmin(distance), distance.shape)
        hidden.add(int(i))
        distance[i, :] = distance[:, j] = np.inf
    return [int(k) for i, k in enumerate(inside) if i not in hidden]


#: The MAC a measured shape needs with one nominal mode, and with no other, for `modes_by_shape`
#: to name that mode: the usual threshold below which two shapes are not taken as the same mode.
MAC_MIN = 0.8


def shape_macs(shapes: Sequence[dict], model, n_modes: int) -> np.ndarray:
    """The MAC of each measured shape with the nominal model's lowest ``n_modes`` flexible modes.

    Parameters
    ----------
    shapes : sequence of dict
        Per measured mode, ``{dof: (lower, upper)}`` (DOFs or sensors of ``model``); the
        midpoints are the shape.
    model : AffineModel
    n_modes : int

    Returns
    -------
    ndarray, shape (n_shapes, n_modes)
    """
    from vibupdate.modal.analysis import flexible_modes, mac

    Phi = flexible_modes(*model.matrices(), min(model.n_dofs, n_modes), precision=model.matrix_precision)[1]
    return np.array([mac(np.array([0.5 * (lo + hi) for lo, hi in s.values()]), model.measurement(list(s)) @ Phi)[0]
                     for s in shapes]).reshape(len(shapes), -1)


def modes_by_shape(shapes: Sequence[dict], model) -> list[int] | None:
    """The model mode of each measured mode by the MAC of its shape with the nominal model's
    lowest modes, two more than the shapes (at most two modes skipped; `shape_macs`), where that
    is unambiguous: every shape at 3 DOFs or more, and exactly one rising choice of modes gives
    every shape a mode at `MAC_MIN` or above; None otherwise. A shape may match a second mode
    (with few sensors a higher mode can look like a lower one) as long as the order of the
    others rules it out. The default numbers of modes extracted from FRFs without
    ``first_mode`` (docs/frf-extraction.md)."""
    if not shapes or any(len(s) < 3 for s in shapes):
        return None
    macs = shape_macs(shapes, model, len(shapes) + 2)
    rows = np.arange(len(shapes))
    fits = [c for c in combinations(range(macs.shape[1]), len(shapes)) if np.all(macs[rows, list(c)] >= MAC_MIN)]
    return [k + 1 for k in fits[0]] if len(fits) == 1 else None


def declared_modes(natural: Sequence[NaturalFrequency]) -> list[int]:
    """Model mode of each measured natural frequency (1-based): its ``mode``, or the mode
    after the previous one (1 for the first)."""
    out, prev = [], 0
    for f in natural:
        prev = f.mode if f.mode is not None else prev + 1
        out.append(prev)
    return out


def declare(cfg):
    """Natural frequencies and antiresonances of ``cfg`` with every mode and index explicit.

    Returns
    -------
    natural : tuple of NaturalFrequency
    antiresonances : tuple of Antiresonance
    """
    from vibupdate.modal.analysis import antiresonances, flexible_modes

    where = f"configuration {cfg.name!r}"
    mode_list = declared_modes(cfg.natural)
    natural = tuple(f if f.mode == m else replace(f, mode=m) for f, m in zip(cfg.natural, mode_list))
    zeros = list(cfg.antiresonances)
    poles = [f.omega for f in natural]
    todo = [rc for rc in cfg.receptances() if any(a.index is None for a in zeros if a.receptance == rc)]
    if todo:
        M0, K0 = cfg.model.matrices()
        n_modes = min(cfg.model.n_dofs, max(mode_list, default=0) + 1)
        precision = cfg.model.matrix_precision
        nominal_omega = flexible_modes(M0, K0, n_modes, precision=precision)[0] if mode_list else np.array([])
        for rc in todo:
            mine = [i for i, a in enumerate(zeros) if a.receptance == rc]
            nominal_z = antiresonances(M0, K0, cfg.model.dof(rc[0]), cfg.model.dof(rc[1]), precision=precision)
            found = zero_indices(poles, mode_list, [zeros[i].omega for i in mine], nominal_omega, nominal_z,
                                 driving=rc[0] == rc[1])
            for i, idx in zip(mine, found):
                if zeros[i].index is None:
                    zeros[i] = replace(zeros[i], index=idx)
    for rc in cfg.receptances():
        idx = [a.index for a in zeros if a.receptance == rc]
        if any(b <= a for a, b in zip(idx, idx[1:])):
            shown = ", ".join(f"{a.freq_hz:.6g} Hz -> {a.index}" for a in zeros if a.receptance == rc)
            raise ValueError(f"{where}: antiresonance indices of h_{rc[0]},{rc[1]} must rise with frequency, "
                             f"got {shown}")
        if idx and idx[-1] > cfg.model.n_dofs - 1:
            raise ValueError(f"{where}: {zero_name(rc[0], rc[1], idx[-1])} is declared, but the "
                             f"adjunct system has only {cfg.model.n_dofs - 1} DOFs")
    return natural, tuple(zeros)
