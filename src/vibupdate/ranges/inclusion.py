"""Widening the consistent set S so that it holds every answer a run reports (the rule and why:
docs/notes/ranges.md, "Certified ranges: why S holds every answer" and "the enclosure in full").

`widen` takes the included points (normalized parameters, the answer first) and widens each
frequency window to reach `WINDOW_MARGIN` past every point's paired model frequency, each vector
box `BOX_MARGIN` past its exact paired eigenvector (adjunct vector), scaled and normalized as the
first stage normalizes it, and the parameter box by rounding only (`BOUND_ROUNDING`). A point
outside its bounds, without the paired zero, with a vector below `NODE_FRACTION` of its largest
entry at its normalization entry or needing a box `GROWTH_LIMIT` times the first stage's is
listed in `Inclusion.uncovered`, and `vibupdate.ranges.certify` then flags no range certified.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace

import numpy as np

from vibupdate.data.measured import Configuration
from vibupdate.inverse.correlation import model_frequencies, zeros_wanted
from vibupdate.inverse.formulation.blocks import VectorBlock
from vibupdate.inverse.update import MAX_WIDENINGS


#: Relative margin by which a widened window reaches past an included point's frequency.
WINDOW_MARGIN = 1e-6
#: Margin by which a widened box reaches past an included vector's entry: ``BOX_MARGIN (1 + |v|)``
#: in scaled coordinates (ten times the margin of `vibupdate.ranges.consistent.witness`).
BOX_MARGIN = 1e-6
#: A vector box grows at most this factor (its largest bound against the block's largest
#: bound before): the first stage itself widens its margins at most ``10 ** MAX_WIDENINGS``-fold.
GROWTH_LIMIT = float(10 ** MAX_WIDENINGS)
#: A vector whose normalization entry is below this fraction of its largest entry cannot be
#: normalized there (its box would need at least ``1 / NODE_FRACTION``).
NODE_FRACTION = 1e-4
#: A parameter may exceed its normalized bounds by this much (rounding of the solvers); the
#: parameter box is widened to hold it.
BOUND_ROUNDING = 1e-9


def _listed(items: Sequence[str], limit: int = 6) -> str:
    more = len(items) - limit
    return ", ".join(items[:limit]) + (f" and {more} more" if more > 0 else "")


@dataclass(frozen=True)
class Inclusion:
    """How S was widened to hold the included points.

    Attributes
    ----------
    labels : tuple of str
        One per included point (e.g. ``"the answer"``, ``"sample 3"``).
    windows : tuple of (str, float)
        Each frequency window widened beyond the data's: the datum, and how far the farthest
        included frequency lies beyond the data's window (per cent of the measured frequency).
    vectors : tuple of (str, int, float)
        Each vector box widened: the vector, its entries widened, and its largest bound after
        against before.
    widened_by : tuple of str
        Labels of the points that needed any widening.
    bounds : int
        Parameters whose bounds were widened by rounding.
    uncovered : tuple of str
        One sentence per point S could not be widened to hold, with the figure.
    """

    labels: tuple[str, ...]
    windows: tuple = ()
    vectors: tuple = ()
    widened_by: tuple[str, ...] = ()
    bounds: int = 0
    uncovered: tuple[str, ...] = ()

    def text(self) -> str:
        """What the widening did, in words, for the definition of S."""
        n = len(self.labels)
        if self.labels and self.labels[0] == "the answer":
            who = "the answer" + (f" and {n - 1} verified answer(s) of sampled data sets, line ends included"
                                  if n > 1 else "")
        else:
            who = f"{n} point(s)"
        windows = [f"{where} ({r:.3g} % beyond its window)" for where, r in self.windows]
        vectors = [f"{where} ({k} entries, its largest bound {g:.3g}x)" for where, k, g in self.vectors]
        text = (f"S is widened to hold every answer the run reports ({who}). Frequency windows widened to reach "
                f"each one's paired model frequency, plus {WINDOW_MARGIN:g} relative: "
                f"{_listed(windows) if windows else 'none'}. Vector boxes widened to hold each one's exact paired "
                f"eigenvector or adjunct vector (scaled and normalized as in the first stage), plus "
                f"{BOX_MARGIN:g} (1 + |v|): {_listed(vectors) if vectors else 'none'}."
                + (f" Widened for: {_listed(list(self.widened_by))}." if self.widened_by else "")
                + (f" {self.bounds} parameter bound(s) widened by rounding." if self.bounds else ""))
        if self.uncovered:
            text += (f" {len(self.uncovered)} could not be held, so no range is flagged certified: "
                     + "; ".join(self.uncovered) + ".")
        return text

    def record(self) -> dict:
        """The ``included`` part of ``identifiability.certified`` in ``results.json``."""
        return {"points": len(self.labels), "widened_by": list(self.widened_by),
                "windows": [{"datum": where, "beyond_pct": r} for where, r in self.windows],
                "vector_boxes": [{"vector": where, "entries": k, "bound_ratio": g} for where, k, g in self.vectors],
                "bounds_widened": self.bounds}


def paired_vectors(cfg: Configuration, blocks: Sequence[VectorBlock], xbar) -> list[tuple[float, np.ndarray]]:
    """Paired model frequency (rad/s) and exact physical vector of each of ``blocks`` of
    ``cfg`` at ``xbar``: the declared mode's eigenvector, or the declared zero's right adjunct
    eigenvector (shape ``(len(cols),)``; NaN frequency where the model lacks the zero). One
    eigen-solve of the model and one adjunct solve per receptance with blocks."""
    from vibupdate.modal.zeros import antiresonance_vectors

    freqs = model_frequencies(cfg, xbar, zeros=False)
    adjunct = {}
    rcs = {blk.receptance for blk in blocks if blk.kind == "antiresonance"}
    if rcs:
        M, K = cfg.model.matrices(xbar)
        for rc in rcs:
            adjunct[rc] = antiresonance_vectors(M, K, cfg.model.dof(rc[0]), cfg.model.dof(rc[1]),
                                                n_zeros=zeros_wanted(cfg, rc), precision=cfg.model.matrix_precision)
    out = []
    for blk in blocks:
        if blk.kind == "natural":
            out.append((float(freqs.natural[blk.index - 1]), freqs.Phi[:, blk.index - 1]))
            continue
        k = cfg.antiresonances[blk.index - 1].index - 1
        z, V = adjunct[blk.receptance]
        out.append((float(z[k]), V[:, k]) if k < z.size else (np.nan, np.full(blk.cols.size, np.nan)))
    return out


def anchor(blk: VectorBlock) -> int:
    """The entry a vector is normalized at: the fixed entry, else (a measured shape with its
    reference freed) the entry whose box keeps farthest from zero."""
    if blk.fixed.any():
        return int(np.flatnonzero(blk.fixed)[0])
    away = np.where(blk.lower * blk.upper > 0, np.minimum(np.abs(blk.lower), np.abs(blk.upper)), 0.0)
    return int(np.argmax(away))


def into_box(blk: VectorBlock, v, margin: float):
    """``c v`` for a scale ``c`` that puts the free entries inside the block's box shrunk by
    ``margin`` and the fixed entries on their values, or None when no scale does."""
    free = ~blk.fixed
    if blk.fixed.any():
        j = int(np.flatnonzero(blk.fixed)[0])
        if abs(v[j]) < 1e-12 * np.max(np.abs(v)):
            return None
        v = v / v[j] * blk.lower[j]
        if np.all(v[free] >= blk.lower[free] + margin) and np.all(v[free] <= blk.upper[free] - margin):
            v[blk.fixed] = blk.lower[blk.fixed]
            return v
        return None
    lo, hi, x = blk.lower + margin, blk.upper - margin, v
    nz = x != 0
    if np.any(~nz & ((lo > 0) | (hi < 0))):
        return None
    a, b = lo[nz] / x[nz], hi[nz] / x[nz]
    c_lo, c_hi = np.max(np.minimum(a, b)), np.min(np.maximum(a, b))
    if not c_lo <= c_hi:
        return None
    return 0.5 * (c_lo + c_hi) * v


def widen_box(blk: VectorBlock, v, base: float, label: str, where: str):
    """``(block, None)``: the block with its box widened to hold the scaled vector ``v``; or
    ``(blk, reason)`` when it cannot be held (``base``: the largest bound before widening)."""
    j = anchor(blk)
    big = float(np.max(np.abs(v)))
    if not abs(v[j]) > NODE_FRACTION * big:
        return blk, (f"{label}: its {where} vector is {abs(v[j]) / big:.2g} of its largest entry at the "
                             f"normalization entry (below {NODE_FRACTION:g})")
    if not blk.fixed.any() and into_box(blk, v, BOX_MARGIN) is not None:
        return blk, None
    v = v / v[j] * (blk.lower[j] if blk.fixed.any() else 1.0)
    pad = BOX_MARGIN * (1.0 + np.abs(v))
    free = ~blk.fixed
    lower = np.where(free, np.minimum(blk.lower, v - pad), blk.lower)
    upper = np.where(free, np.maximum(blk.upper, v + pad), blk.upper)
    grown = (lower < blk.lower) | (upper > blk.upper)
    if not grown.any():
        return blk, None
    growth = float(np.max(np.maximum(np.abs(lower), np.abs(upper)))) / base
    if growth > GROWTH_LIMIT:
        return blk, (f"{label}: its {where} vector would need a box {growth:.3g} times the largest "
                             f"bound of the first stage's (limit {GROWTH_LIMIT:g})")
    return replace(blk, lower=lower, upper=upper), None


def widen(configurations: Sequence[Configuration], blocks: Sequence[VectorBlock], omega_lower, omega_upper,
          x_lower, x_upper, points, labels: Sequence[str]):
    """Widen windows, vector boxes and (by rounding) parameter bounds to hold ``points``.

    Parameters
    ----------
    configurations : sequence of Configuration
    blocks : sequence of VectorBlock
        The blocks of S, boxes in scaled coordinates.
    omega_lower, omega_upper : ndarray, shape (n_blocks,)
        The data's windows, rad/s.
    x_lower, x_upper : ndarray, shape (n_x,)
        Normalized parameter bounds.
    points : ndarray, shape (n_points, n_x)
        Normalized parameters to hold.
    labels : sequence of str
        One per point, for the messages.

    Returns
    -------
    blocks, omega_lower, omega_upper, x_lower, x_upper, Inclusion
        The widened S's pieces (new arrays) and what was done.
    """
    blocks = list(blocks)
    lo, hi = np.array(omega_lower, dtype=float), np.array(omega_upper, dtype=float)
    xl, xu = np.array(x_lower, dtype=float), np.array(x_upper, dtype=float)
    before = list(blocks)
    base = [max(float(np.max(np.abs(np.r_[b.lower, b.upper]))), 1.0) for b in blocks]
    by_name = {c.name: c for c in configurations}
    names = configurations[0].model.parameter_names
    reach = np.full(len(blocks), -1.0)          # per cent beyond the data's window; < 0: not widened
    where = [_where(by_name[b.configuration], b) for b in blocks]
    bounds, uncovered, widened_by = set(), [], []
    for p, label in zip(np.atleast_2d(np.asarray(points, dtype=float)), labels):
        out_low, out_high = xl - p, p - xu
        if np.any(np.maximum(out_low, out_high) > BOUND_ROUNDING):
            i = int(np.argmax(np.maximum(out_low, out_high)))
            value = configurations[0].model.physical(p)[i]
            uncovered.append(f"{label}: parameter {names[i]} = {value:.6g} lies outside its bounds")
            continue
        bounds.update(np.flatnonzero((out_low > 0) | (out_high > 0)).tolist())
        # just past the point: its physical value may round either way
        xl = np.minimum(xl, np.where(out_low > 0, p - 1e-3 * BOUND_ROUNDING, xl))
        xu = np.maximum(xu, np.where(out_high > 0, p + 1e-3 * BOUND_ROUNDING, xu))
        state = (lo.copy(), hi.copy(), list(blocks))
        for name, cfg in by_name.items():
            ids = [b for b, blk in enumerate(blocks) if blk.configuration == name]
            for b, (w, v) in zip(ids, paired_vectors(cfg, [blocks[b] for b in ids], p)):
                if not np.isfinite(w):
                    uncovered.append(f"{label}: the model lacks {where[b]}")
                    continue
                a, c = w * (1 - WINDOW_MARGIN), w * (1 + WINDOW_MARGIN)
                if a < lo[b] or c > hi[b]:
                    beyond = max(omega_lower[b] - w, w - omega_upper[b], 0.0)
                    reach[b] = max(reach[b], 100.0 * beyond / blocks[b].omega)
                    lo[b], hi[b] = min(lo[b], a), max(hi[b], c)
                blocks[b], why = widen_box(blocks[b], v / blocks[b].scale, base[b], label, where[b])
                if why:
                    uncovered.append(why)
        if np.any(lo != state[0]) or np.any(hi != state[1]) or any(x is not y for x, y in zip(blocks, state[2])):
            widened_by.append(label)
    vectors = []
    for b, (new, old) in enumerate(zip(blocks, before)):
        grown = (new.lower < old.lower) | (new.upper > old.upper)
        if grown.any():
            ratio = float(np.max(np.maximum(np.abs(new.lower), np.abs(new.upper)))) / base[b]
            vectors.append((where[b], int(np.count_nonzero(grown)), ratio))
    windows = tuple((where[b], float(reach[b])) for b in np.flatnonzero(reach >= 0))
    inclusion = Inclusion(tuple(labels), windows, tuple(vectors), tuple(widened_by), len(bounds), tuple(uncovered))
    return tuple(blocks), lo, hi, xl, xu, inclusion


def _where(cfg: Configuration, blk: VectorBlock) -> str:
    """The datum of a block, for messages."""
    from vibupdate.data.names import mode_name, zero_name

    if blk.kind == "natural":   # the block's index is the position among the measured frequencies
        return f"configuration {cfg.name!r} {mode_name(cfg.natural[blk.index - 1].mode, blk.index)}"
    a = cfg.antiresonances[blk.index - 1]
    return f"configuration {cfg.name!r} {zero_name(a.response, a.excitation, a.index)}"
