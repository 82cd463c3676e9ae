"""The leakage of a windowed spectral estimate, put into the modal model (a kernel of
`vibupdate.data.extraction`). Frequencies normalized as in `vibupdate.data.modal_fit`.

An ``H1`` estimate from random excitation with a data window ``w`` over each record of
length ``T`` is in expectation the true FRF smoothed by the window's power kernel ``|W|^2``,
which a modal fit reads as damping at narrow peaks (docs/notes/frf-leakage.md).

In the time domain the same smoothing multiplies the impulse response by the window's
normalized autocorrelation ``g(t / T)`` (``g(0) = 1``, zero beyond ``T``). A modal term
``A / (j omega - a)`` is the transform of ``A exp(a t)``, so its windowed expectation is::

    T integral_0^1 exp(z u) g(u) du,   z = (a - j omega) T

in closed form for the windows here: ``g`` is a sum of ``(c0 + c1 u) exp(2 pi j m u)``, and
``integral_0^1 u^k exp(w u) du`` has a closed form (a power series where ``|w| < 1``, whose
closed form loses digits there). The derivative with respect to ``a`` (for the fit's exact
Jacobian) is ``T^2 integral_0^1 u exp(z u) g(u) du``. The residual terms (``1/s^2``, a
constant) vary slowly over a kernel's width and are left as they are.

**Impact tests** (docs/frf-extraction.md, "Input"): an exponential window ``exp(-t / tau)`` on
the one transient record turns each modal term ``A exp(a t)`` into ``A exp((a - 1/tau) t)`` on
``[0, T]``: the form above with ``g(u) = 1`` and the pole moved left by ``1/tau``. The force
window changes nothing that the fit sees and is not modelled.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

#: Windows of the estimate: ``(m, c0, c1)`` terms of ``g(u) = sum (c0 + c1 u) exp(2 pi j m u)``.
#: ``"hann"``: ``w = sin^2(pi t / T)``, ``g(u) = (2/3) [(1 - u)(1 + cos(2 pi u) / 2)
#: + 3 sin(2 pi u) / (4 pi)]``; ``"rectangular"`` (no window): ``g(u) = 1 - u``;
#: ``"exponential"`` (impact test, one transient record): ``g(u) = 1`` with the pole moved
#: by the window's decay rate (module docstring).
WINDOWS = {
    "hann": ((0, 2 / 3, -2 / 3), (1, 1 / 6 + 1 / (4j * math.pi), -1 / 6), (-1, 1 / 6 - 1 / (4j * math.pi), -1 / 6)),
    "rectangular": ((0, 1.0, -1.0),),
    "exponential": ((0, 1.0, 0.0),),
}
#: Windows that need no model: the force window of an impact test (a rectangle over the pulse).
UNMODELLED = ("none", "force")
SERIES_BELOW = 1.0      # |w| under which the moments are summed as a power series ...
SERIES_TERMS = 24       # ... of this many terms (the 24th is under 1e-24 of the first)


#: The quantity estimated, as the power of ``s = j omega`` that turns a receptance into it.
ORDERS = {"receptance": 0, "mobility": 1, "accelerance": 2}


@dataclass(frozen=True)
class Window:
    """The data window of the FRF estimate: ``name`` (a key of `WINDOWS`); ``record``, the
    record length ``T`` in the units of ``1 / x`` (``2 pi`` over the line spacing); ``order``
    of the quantity that was estimated (`ORDERS`): the window smooths that quantity, whose
    pole term ``s^k / (s - a)`` is a polynomial in ``s`` of degree under 2 (which a symmetric
    kernel of unit mass leaves as it is) plus ``a^k / (s - a)``; ``decay``, the exponential
    window's rate ``1 / tau`` in the units of ``x`` (0 for the others)."""

    name: str
    record: float
    order: int = 0
    decay: float = 0.0


def window_for(name: str | None, x: np.ndarray, measured: str = "receptance", decay: float = 0.0) -> Window | None:
    """`Window` of the named estimate of the ``measured`` quantity (a key of `ORDERS`) on
    equally spaced lines ``x`` (normalized); None for ``None``, ``"none"`` or ``"force"`` (the
    FRFs are taken as they are). ``decay``: the exponential window's rate ``1 / tau`` in the
    units of ``x``. A ValueError names an unknown window or quantity, or unequal line
    spacing."""
    if name is None or name in UNMODELLED:
        return None
    if name not in WINDOWS:
        raise ValueError(f"window {name!r} is not known: expected one of {[*UNMODELLED, *WINDOWS]}")
    if measured not in ORDERS:
        raise ValueError(f"window {name!r}: the FRFs must all be of one kind {tuple(ORDERS)} (the window smooths "
                         f"what was estimated), got {measured!r}")
    step = np.diff(np.asarray(x, dtype=float))
    if step.size == 0 or np.ptp(step) > 1e-6 * float(np.mean(step)):
        raise ValueError(f"window {name!r} needs equally spaced frequency lines (the record length is 1 / spacing); "
                         f"the spacing here runs from {step.min():.6g} to {step.max():.6g} (normalized)")
    return Window(name, 2 * math.pi / float(np.mean(step)), ORDERS[measured], float(decay))


def moments(w: np.ndarray, kmax: int) -> np.ndarray:
    """``integral_0^1 u^k exp(w u) du`` for ``k = 0..kmax``, shape (kmax + 1, *w.shape),
    complex: the closed form where ``|w| >= SERIES_BELOW``, the power series elsewhere."""
    w = np.asarray(w, dtype=complex)
    out = np.empty((kmax + 1,) + w.shape, dtype=complex)
    small = np.abs(w) < SERIES_BELOW
    big = ~small
    wb = w[big]
    ew = np.exp(wb)
    moment = (ew - 1.0) / wb
    out[0][big] = moment
    for k in range(1, kmax + 1):
        moment = ew / wb - k * moment / wb
        out[k][big] = moment
    if np.any(small):
        ws = w[small]
        ks = np.arange(kmax + 1)[:, None]
        term, total = np.ones_like(ws), np.zeros((kmax + 1, ws.size), dtype=complex)
        for n in range(SERIES_TERMS):
            total += term[None] / (n + ks + 1)
            term = term * ws / (n + 1)
        out[:, small] = total
    return out


def windowed_poles(x, a, window: Window, derivative: bool = False) -> np.ndarray:
    """The pole term ``1 / (j x - a)`` of a receptance as the windowed estimate shows it,
    shape (n_freq, n_poles), at lines ``x`` (n_freq,) for poles ``a`` (n_poles,) complex: the
    expected windowed estimate of ``s^k / (s - a)`` (``k = window.order``) divided by ``s^k``;
    with ``derivative`` its derivative with respect to ``a``."""
    T = window.record
    a = np.asarray(a, dtype=complex)[None, :]
    s = 1j * np.asarray(x, dtype=float)[:, None]
    z = (a - window.decay - s) * T
    kmax = 1 if derivative else 0
    lagged = np.zeros((kmax + 1,) + z.shape, dtype=complex)   # integral_0^1 u^k exp(z u) g(u) du, k = 0..kmax
    for m, c0, c1 in WINDOWS[window.name]:
        mom = moments(z + 2j * math.pi * m, kmax + 1)
        lagged += c0 * mom[:-1] + c1 * mom[1:]
    p = lagged[0] * T                                       # windowed 1/(s - a)
    dp = lagged[1] * T**2 if derivative else None           # and its derivative in a
    k = window.order
    if k == 0:
        return dp if derivative else p
    if k == 1:                                              # s/(s - a) = 1 + a/(s - a)
        return (p + a * dp) / s if derivative else (1.0 + a * p) / s
    # s^2/(s - a) is the impulse response's delta' + a delta + a^2 exp(a t); a window w with
    # w(0) = 1 turns delta' into delta' - w'(0) delta: the decay rate of the exponential one
    return (1.0 + 2.0 * a * p + a**2 * dp) / s**2 if derivative else (s + a + window.decay + a**2 * p) / s**2
