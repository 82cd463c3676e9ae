"""Measuring a true model: the exact or noisy data of a known-truth problem.

Frequencies, shapes and antiresonances come from the independent dense analysis of
`acceptance.truth`. Noisy data have a relative standard deviation ``noise`` on every
frequency and an absolute one on the shape ratios; every interval is 3 sigma and is redrawn
until it contains the true value, frequencies keep their order and the pole/zero pattern, and
each measured value stays nearest to its own model mode or zero.
"""

from __future__ import annotations

import numpy as np

from acceptance import structures as S
from acceptance import truth as T
from acceptance.problem import ConfigData, Natural, Zero

__all__ = ["measure", "draw_truth"]

TWO_PI = 2.0 * np.pi


def _noisy(rng, values: np.ndarray, sigma: float, valid) -> np.ndarray:
    """``values (1 + sigma e)`` redrawn until every interval of 3 sigma contains its true value
    and ``valid(measured)`` holds."""
    if sigma == 0:
        return values.copy()
    for _ in range(200):
        m = values * (1 + sigma * rng.standard_normal(values.size))
        if np.all(np.abs(m - values) <= 3 * sigma * m) and valid(m):
            return m
    raise RuntimeError("no noisy draw kept the order of the data; lower the noise")


def _nearest_ok(measured: np.ndarray, positions: np.ndarray, every: np.ndarray) -> bool:
    """Each measured value is nearest (relatively) to its own model value ``every[positions]``."""
    for v, j in zip(measured, positions):
        if int(np.argmin(np.abs(every - v) / v)) != j:
            return False
    return True


def _shape(rng, Phi: np.ndarray, k: int, sensors: list[int], names: list[str], sigma: float, all_modes,
           noisy_reference: bool = False) -> dict | None:
    """Shape intervals of mode ``k`` at ``sensors`` normalized at its largest entry, or None when
    the sensors cannot tell the mode from another (MAC). The reference entry is 1 exactly, or,
    with ``noisy_reference``, as noisy as the others (the true shape normalized at it still
    lies in every interval)."""
    v = Phi[sensors, k]
    ref = int(np.argmax(np.abs(v)))
    ratios = v / v[ref]
    keep = [j for j in range(len(sensors)) if j == ref or abs(ratios[j]) < 0.95]
    if len(keep) < 2:
        return None
    ratios, idx = ratios[keep], [sensors[j] for j in keep]
    ref = keep.index(ref)
    e = rng.standard_normal(len(keep)).clip(-3, 3)
    if not noisy_reference:
        e[ref] = 0.0
    m = ratios + sigma * e
    macs = [T.mac(m, Phi[idx, j]) for j in all_modes]
    own = macs[list(all_modes).index(k)]
    if own < 0.8 or any(x > own - 0.02 for j, x in zip(all_modes, macs) if j != k):
        return None
    return {names[i]: (float(x - 3 * sigma), float(x + 3 * sigma)) for i, x in zip(idx, m)}


def measure(structure, parameters, truth: dict, *, kind: str, rng, noise: float = 0.0, shape_noise: float = 0.0,
            modes: list[int] | None = None, sensors: list[str] | None = None,
            receptances: list[tuple[str, str]] | None = None, zero_indices: list[int] | None = None,
            n_modes: int | None = None, name: str = "A", extra_mass=None, declare: bool = True,
            avoid_poles: bool = False, noisy_reference: bool = False) -> ConfigData:
    """The data of one configuration measured on the true model.

    ``modes`` (1-based model modes) or ``n_modes`` consecutive elastic modes; ``sensors`` the
    DOFs of the shapes; ``receptances`` ``(response, excitation)`` pairs; ``zero_indices``
    which zeros (1-based) of each receptance for Problem 3 (Problem 4 takes every zero between
    the measured poles); ``avoid_poles`` drops zeros within 1 % of a pole of the model (no FRF
    shows a zero that cancels a pole); ``noisy_reference``: noise on the reference entry of each
    shape too (`_shape`).
    """
    spec = structure.with_mass(*extra_mass) if extra_mass else structure
    M, K, dofs = S.matrices_at(spec, truth)
    w, Phi = T.modes(M, K)
    rigid = int(np.count_nonzero(w == 0))
    if modes is None and kind != "P3":
        modes = list(range(rigid + 1, rigid + 1 + (n_modes or 3)))
    natural = []
    if kind != "P3":
        if max(modes) > w.size:
            raise ValueError(f"measure: model mode {max(modes)} asked for, but the model has {w.size} modes "
                             f"({rigid} rigid-body)")
        pos = np.array(modes) - 1
        hz = _noisy(rng, w[pos] / TWO_PI, noise, lambda m: bool(np.all(np.diff(m) > 0))
                    and _nearest_ok(m, pos, w / TWO_PI))
        shapes = {}
        if kind in ("P1", "mix"):
            idx = [dofs.index(d) for d in sensors]
            with_shape = modes if kind == "P1" else modes[: max(1, len(modes) // 2)]
            every = list(range(len(w)))   # rigid-body modes too: the verification compares with all
            for mode in with_shape:
                shapes[mode] = _shape(rng, Phi, mode - 1, idx, list(dofs), shape_noise, every, noisy_reference)
        natural = [Natural(float(h), int(m), shapes.get(m)) for h, m in zip(hz, modes)]
    zeros, interlacing = [], True
    for r, c in receptances or []:
        z, _ = T.zeros(M, K, dofs.index(r), dofs.index(c))
        if kind == "P3":
            chosen = [i for i in (zero_indices or [1, 2]) if i <= z.size]
        else:
            lo, hi = w[modes[0] - 1], w[modes[-1] - 1]
            chosen = [i + 1 for i in range(z.size) if lo < z[i] < hi]
        if avoid_poles:   # a zero on a pole cancels it: no FRF shows it
            kept = [i for i in chosen if np.min(np.abs(w - z[i - 1])) > 0.01 * z[i - 1]]
            interlacing = interlacing and (kind == "P3" or kept == chosen)   # not every zero listed
            chosen = kept
        if not chosen:
            continue
        if kind == "P3" and chosen != list(range(1, len(chosen) + 1)):
            declare = True   # without poles the default is zeros 1, 2, ...: a subset must say which
        pos = np.array(chosen) - 1
        poles = np.array([n.hz for n in natural])
        pattern = np.searchsorted(poles, z[pos] / TWO_PI)

        def keeps(m, pos=pos, z=z, pattern=pattern):
            return bool(np.all(np.diff(m) > 0) and _nearest_ok(m, pos, z / TWO_PI)
                        and np.array_equal(np.searchsorted(poles, m), pattern))

        hz = _noisy(rng, z[pos] / TWO_PI, noise, keeps)
        zeros += [Zero(float(h), r, c, int(i)) for h, i in zip(hz, chosen)]
    return ConfigData(name, tuple(natural), tuple(zeros), extra_mass, declare, interlacing)


def draw_truth(rng, parameters) -> dict:
    """Each parameter between 15 % and 85 % of the way from its nominal to a bound."""
    out = {}
    for p in parameters:
        bound = p.upper if rng.random() < 0.5 else p.lower
        out[p.name] = p.nominal + rng.uniform(0.15, 0.85) * (bound - p.nominal)
    return out
