"""Sign bounds from the pole/zero pattern of a receptance (paper Eq. 11, Section 3.6).

The count of measured antiresonances between two consecutive modes' poles fixes whether their
modal constants ``u_k(r) u_k(c)`` share a sign; from the first one's sign, the bounds
``[delta, B]`` or ``[-B, -delta]`` on ``u(r)`` and ``u(c)`` follow. A transformation of the
blocks' bounds only. A receptance whose pattern contradicts what is already known of its
entries is left out and reported as a `SignConflict` (docs/method.md, "Interlacing signs").
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from vibupdate.data.measured import TWO_PI, Configuration


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


#: An entry of a nominal mode below this fraction of the mode's largest entry (scaled
#: coordinates) is "near a node", where the pole and a zero cancel in the FRF. Used only to
#: name the likely cause of a sign conflict, never to decide.
NODE_FRACTION = 0.05


@dataclass(frozen=True)
class SignConflict:
    """Sign relations of one FRF dropped because they contradict what is already known of
    the entries (the model's boxes, measured shape intervals, the signs asked by an FRF
    applied before): evidence set aside, stated, never a refusal.

    Attributes
    ----------
    configuration : str
    receptance : tuple of str
        ``(r, c)`` of the FRF ``h_rc`` whose relations were all dropped.
    mode : int
        Declared model mode of the first pole whose sign cannot be met.
    freq_hz : float
        Its measured natural frequency, Hz.
    previous_mode : int or None
        The pole before it in the pattern (None when the conflict is at the first pole).
    zeros_between : int or None
        Measured antiresonances of ``h_rc`` between the two poles.
    entry : str
        The DOF whose sign the pattern asked for.
    asked : int
        +1 or -1, the sign asked for.
    bounds : tuple of float
        The entry's bounds when it was asked (scaled coordinates of the block).
    cause : str
        The likely cause, in words (`likely_cause`).
    """

    configuration: str
    receptance: tuple[str, str]
    mode: int
    freq_hz: float
    previous_mode: int | None
    zeros_between: int | None
    entry: str
    asked: int
    bounds: tuple[float, float]
    cause: str

    @property
    def message(self) -> str:
        r, c = self.receptance
        between = ("" if self.previous_mode is None else
                   f" ({self.zeros_between} measured zero(s) between modes {self.previous_mode} and {self.mode})")
        sign = "positive" if self.asked > 0 else "negative"
        return (f"interlacing signs of h_{r},{c} in configuration {self.configuration!r} dropped: mode "
                f"{self.mode} ({self.freq_hz:.4g} Hz){between} asks for a {sign} entry {self.entry}, whose bounds "
                f"are [{self.bounds[0]:.4g}, {self.bounds[1]:.4g}]; likely cause: {self.cause}. "
                "The run goes on without the sign relations of this FRF")


def likely_cause(blocks, modes, r: int, c: int, rc, k: int, zeros_between) -> str:
    """Name the likely cause of a conflict at pole ``k`` (index among the configuration's
    natural blocks ``blocks``): a point near a node of pole ``k`` or ``k - 1`` (`NODE_FRACTION`
    of the nominal mode), else a zero lost in noise or damping (no zero measured where the
    pattern then asks for a sign change), else a zero that noise or the residual of
    out-of-band modes moved across a pole."""
    for j in (k, k - 1):
        if j < 0:
            continue
        start = np.abs(blocks[j].start)
        peak = float(np.max(start)) if start.size else 0.0
        for dof, name in ((r, rc[0]), (c, rc[1])):
            if peak > 0 and start[dof] < NODE_FRACTION * peak:
                return (f"{name} is near a node of mode {modes[j]} (nominal entry {start[dof] / peak:.2g} of the "
                        "mode's largest), where the pole and a zero cancel in the FRF")
    if zeros_between == 0:
        return "a zero between these poles lost in noise or damping"
    return "a zero moved across a pole by noise, or a residual of out-of-band modes"


def _nearest_node(blocks, mine, r: int, c: int) -> float:
    """Smallest relative size, over the natural blocks ``mine`` of ``blocks`` (nominal
    starts), of the entries at ``r`` and ``c``: how near a node of a measured mode the
    receptance's points are (0: on a node)."""
    sizes = [min(abs(blocks[i].start[r]), abs(blocks[i].start[c])) / max(float(np.max(np.abs(blocks[i].start))), 1e-300)
             for i in mine]
    return min(sizes, default=1.0)


def _feasible(lo: float, hi: float, sign: int, delta: float) -> tuple[float, float] | None:
    """The bounds of an entry that must have ``sign`` (at least ``delta`` from zero), None
    when its bounds leave no such value."""
    lo, hi = (max(lo, delta), hi) if sign > 0 else (lo, min(hi, -delta))
    return (lo, hi) if lo <= hi else None


def sign_bounds(blocks, configurations: Sequence[Configuration], options):
    """Transform: tighten the natural blocks' bounds at ``r`` and ``c`` of each receptance with
    measured antiresonances (``r != c``), for configurations with ``interlacing`` on.

    The receptances are taken from the one farthest from every node of the measured modes to
    the nearest, each checked against the bounds as they are then; one whose pattern cannot be
    met is left out whole and reported as a `SignConflict` (docs/method.md, "Interlacing
    signs").

    Returns
    -------
    (blocks, notes) : list of VectorBlock, tuple of SignConflict
    """
    if not options.interlacing:
        return blocks, ()
    blocks, notes = list(blocks), []
    nominal = list(blocks)   # starts before any sign bound clipped them: the causes read these
    for cfg in configurations:
        if not cfg.interlacing or len(cfg.natural) < 1:
            continue
        mine = [i for i, b in enumerate(blocks) if b.configuration == cfg.name and b.kind == "natural"]
        # the weakest evidence last: a receptance whose point is nearest a node of a measured mode
        receptances = sorted((rc for rc in cfg.receptances() if rc[0] != rc[1]),   # driving point: u(r)^2 > 0
                             key=lambda rc: -_nearest_node(nominal, mine, cfg.model.dof(rc[0]), cfg.model.dof(rc[1])))
        for rc in receptances:
            tightened, conflict = _receptance_bounds([blocks[i] for i in mine], [nominal[i] for i in mine], cfg, rc,
                                                     options.sign_delta)
            if conflict is not None:
                notes.append(conflict)
                continue
            for i, blk in zip(mine, tightened):
                blocks[i] = blk
    return blocks, tuple(notes)


def _receptance_bounds(natural, nominal, cfg: Configuration, rc, delta: float):
    """The natural blocks with the sign bounds of receptance ``rc``, or the `SignConflict`
    at its first pole whose signs the bounds cannot take (``nominal``: the same blocks before
    any sign bound, to name the cause)."""
    r, c = cfg.model.dof(rc[0]), cfg.model.dof(rc[1])
    zeros = np.array([a.omega for a in cfg.antiresonances if a.receptance == rc])
    poles = [f.omega for f in cfg.natural]
    modes = [f.mode or k + 1 for k, f in enumerate(cfg.natural)]
    first = cfg.first_sign.get(rc) or (1 if natural[0].start[r] * natural[0].start[c] >= 0 else -1)
    signs = modal_constant_signs(poles, zeros, first, [f.mode for f in cfg.natural])
    out = list(natural)
    for k, blk in enumerate(natural):
        if signs[k] is None:
            continue
        lower, upper = blk.lower.copy(), blk.upper.copy()
        sign_r = _entry_sign(lower[r], upper[r], blk.start[r])
        for dof, name, sign in ((r, rc[0], sign_r), (c, rc[1], signs[k] * sign_r)):
            bounds = _feasible(lower[dof], upper[dof], sign, delta)
            if bounds is None:
                between = (None if k == 0 else
                           int(np.count_nonzero((zeros > poles[k - 1]) & (zeros < poles[k]))))
                return natural, SignConflict(
                    cfg.name, tuple(rc), modes[k], poles[k] / TWO_PI, None if k == 0 else modes[k - 1], between, name,
                    sign, (float(lower[dof]), float(upper[dof])), likely_cause(nominal, modes, r, c, rc, k, between))
            lower[dof], upper[dof] = bounds
        out[k] = blk.with_bounds(lower, upper)
    return out, None


def _entry_sign(lower: float, upper: float, start: float) -> int:
    """Sign an entry must keep: forced by its bounds when they exclude zero, else the start's."""
    if lower > 0:
        return 1
    if upper < 0:
        return -1
    return 1 if start >= 0 else -1
