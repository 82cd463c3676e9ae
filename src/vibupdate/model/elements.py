"""Element matrices of the built-in finite elements.

All functions are written complex-safe: the material and section properties may be complex
numbers, so that the complex-step derivative (paper Eq. 15) flows through them unchanged.

Formulas: the standard consistent-mass Euler-Bernoulli beam element (Hermite cubic shape
functions) and its planar frame extension with linear axial shape functions, as given in
any finite-element text (e.g. Petyt, *Introduction to Finite Element Vibration Analysis*,
2nd ed., Sections 3.4 and 3.6). The optional rotary inertia of the section (``rho I`` per
length) adds the consistent rotary-inertia mass of the same Hermite shape functions (the
kinetic energy ``rho I (w')^2 / 2``, a Rayleigh beam), linear in it: ``M = M_translational +
rotary_inertia * M_rotary``, so a factor on it keeps the model affine in the parameters.
"""

from __future__ import annotations

import numpy as np


# Beam element matrices as polynomials in the length L: k = EI / L^3 (K0 + L K1 + L^2 K2) and
# m = rho A L / 420 (M0 + L M1 + L^2 M2), DOFs [v1, theta1, v2, theta2].
_K0 = np.array([[12.0, 0, -12, 0], [0, 0, 0, 0], [-12, 0, 12, 0], [0, 0, 0, 0]])
_K1 = 6.0 * np.array([[0.0, 1, 0, 1], [1, 0, -1, 0], [0, -1, 0, -1], [1, 0, -1, 0]])
_K2 = np.array([[0.0, 0, 0, 0], [0, 4, 0, 2], [0, 0, 0, 0], [0, 2, 0, 4]])
_M0 = np.array([[156.0, 0, 54, 0], [0, 0, 0, 0], [54, 0, 156, 0], [0, 0, 0, 0]])
_M1 = np.array([[0.0, 22, 0, -13], [22, 0, 13, 0], [0, 13, 0, -22], [-13, 0, -22, 0]])
_M2 = np.array([[0.0, 0, 0, 0], [0, 4, 0, -3], [0, 0, 0, 0], [0, -3, 0, 4]])
# Rotary inertia of the section: m_rot = rho I / (30 L) (R0 + L R1 + L^2 R2), the integral of
# rho I N_i' N_j' over the element for the Hermite cubics N.
_R0 = np.array([[36.0, 0, -36, 0], [0, 0, 0, 0], [-36, 0, 36, 0], [0, 0, 0, 0]])
_R1 = 3.0 * np.array([[0.0, 1, 0, 1], [1, 0, -1, 0], [0, -1, 0, -1], [1, 0, -1, 0]])
_R2 = np.array([[0.0, 0, 0, 0], [0, 4, 0, -1], [0, 0, 0, 0], [0, -1, 0, 4]])
_AXIAL_K = np.array([[1.0, -1.0], [-1.0, 1.0]])
_AXIAL_M = np.array([[2.0, 1.0], [1.0, 2.0]]) / 6.0


def _check_length(length):
    bad = ~(np.isfinite(length) & (np.asarray(length) > 0))
    if np.any(bad):
        first = np.asarray(length).ravel()[np.flatnonzero(np.ravel(bad))[0]]
        raise ValueError(f"element length must be positive and finite, got {float(first)!r} m")


def _column(values, n: int) -> np.ndarray:
    """Values as an array of shape (n, 1, 1), complex kept, for broadcasting over elements."""
    a = np.asarray(values)
    return np.broadcast_to(a.astype(np.result_type(a, float)), (n,))[:, None, None]


def beam_matrices(EI, mass_per_length, length, rotary_inertia=0.0):
    """Stiffness and consistent mass of many beam elements at once, DOFs ``[v1, theta1, v2, theta2]``.

    Parameters
    ----------
    EI : array_like of float or complex, shape (n_e,) or scalar
        Bending stiffness, N m^2.
    mass_per_length : array_like of float or complex, shape (n_e,) or scalar
        rho * A, kg/m.
    length : array_like of float, shape (n_e,)
        Element lengths, m.
    rotary_inertia : array_like of float or complex, shape (n_e,) or scalar
        rho * I of the section, kg m (mass moment of inertia per length); 0, the default, is
        the Euler-Bernoulli element without it.

    Returns
    -------
    k, m : ndarray, shape (n_e, 4, 4)
        Stiffness (N/m, N, N m) and mass (kg, kg m, kg m^2) matrices.
    """
    L = np.atleast_1d(np.asarray(length, dtype=float))
    _check_length(L)
    n = L.size
    Lc = L[:, None, None]
    k = _column(EI, n) / Lc**3 * (_K0 + Lc * _K1 + Lc**2 * _K2)
    m = _column(mass_per_length, n) * Lc / 420.0 * (_M0 + Lc * _M1 + Lc**2 * _M2)
    if np.any(np.asarray(rotary_inertia) != 0):
        m = m + _column(rotary_inertia, n) / (30.0 * Lc) * (_R0 + Lc * _R1 + Lc**2 * _R2)
    return k, m


# Positions of the bending and axial DOFs inside the frame DOF order [u1, v1, th1, u2, v2, th2].
_BENDING = np.array([1, 2, 4, 5])
_AXIAL = np.array([0, 3])


def frame_matrices(EA, EI, mass_per_length, dx, dy, rotary_inertia=0.0):
    """Stiffness and consistent mass of many planar frame elements in global axes.

    DOFs ``[x1, y1, phi1, x2, y2, phi2]``: linear axial and Hermite cubic bending shape
    functions in local axes, rotated by ``T = diag(R, R)``, ``R = [[c, s, 0], [-s, c, 0],
    [0, 0, 1]]``.

    Parameters
    ----------
    EA : array_like of float or complex, shape (n_e,) or scalar
        Axial stiffness, N.
    EI : array_like of float or complex, shape (n_e,) or scalar
        Bending stiffness, N m^2.
    mass_per_length : array_like of float or complex, shape (n_e,) or scalar
        rho * A, kg/m.
    dx, dy : array_like of float, shape (n_e,)
        Components of the vectors from node 1 to node 2, m.
    rotary_inertia : array_like of float or complex, shape (n_e,) or scalar
        rho * I of the section, kg m, as in `beam_matrices` (default 0).

    Returns
    -------
    k, m : ndarray, shape (n_e, 6, 6)
    """
    dx = np.atleast_1d(np.asarray(dx, dtype=float))
    dy = np.atleast_1d(np.asarray(dy, dtype=float))
    L = np.hypot(dx, dy)
    _check_length(L)
    n = L.size
    kb, mb = beam_matrices(EI, mass_per_length, L, rotary_inertia)
    Lc = L[:, None, None]
    ka = _column(EA, n) / Lc * _AXIAL_K
    ma = _column(mass_per_length, n) * Lc * _AXIAL_M
    c, s = dx / L, dy / L
    T = np.zeros((n, 6, 6))
    for off in (0, 3):
        T[:, off, off] = T[:, off + 1, off + 1] = c
        T[:, off, off + 1] = s
        T[:, off + 1, off] = -s
        T[:, off + 2, off + 2] = 1.0
    out = []
    for axial, bending in ((ka, kb), (ma, mb)):
        local = np.zeros((n, 6, 6), dtype=np.result_type(axial, bending))
        local[:, _AXIAL[:, None], _AXIAL] = axial
        local[:, _BENDING[:, None], _BENDING] = bending
        out.append(np.swapaxes(T, 1, 2) @ local @ T)
    return out[0], out[1]
