"""Element matrices of the built-in finite elements.

All functions are written complex-safe: the material and section properties may be complex
numbers, so that the complex-step derivative (paper Eq. 15) flows through them unchanged.

Formulas: the standard consistent-mass Euler-Bernoulli beam element (Hermite cubic shape
functions) and its planar frame extension with linear axial shape functions, as given in
any finite-element text (e.g. Petyt, *Introduction to Finite Element Vibration Analysis*,
2nd ed., Sections 3.4 and 3.6).
"""

from __future__ import annotations

import numpy as np

__all__ = ["beam_stiffness", "beam_mass", "frame_stiffness", "frame_mass"]


def _check_length(length):
    if not np.isfinite(length) or length <= 0:
        raise ValueError(f"element length must be positive and finite, got {length!r}")


def beam_stiffness(EI, length):
    """Bending stiffness of a beam element, DOFs ``[v1, theta1, v2, theta2]``.

    Parameters
    ----------
    EI : float or complex
        Bending stiffness, N m^2.
    length : float
        Element length, m.

    Returns
    -------
    ndarray, shape (4, 4)
        Stiffness matrix in N/m, N, N m (translations in m, rotations in rad).
    """
    _check_length(length)
    L = length
    k = np.array(
        [
            [12.0, 6 * L, -12.0, 6 * L],
            [6 * L, 4 * L**2, -6 * L, 2 * L**2],
            [-12.0, -6 * L, 12.0, -6 * L],
            [6 * L, 2 * L**2, -6 * L, 4 * L**2],
        ]
    )
    return (EI / L**3) * k


def beam_mass(mass_per_length, length):
    """Consistent mass of a beam element, DOFs ``[v1, theta1, v2, theta2]``.

    Parameters
    ----------
    mass_per_length : float or complex
        rho * A, kg/m.
    length : float
        Element length, m.

    Returns
    -------
    ndarray, shape (4, 4)
        Mass matrix in kg, kg m, kg m^2.
    """
    _check_length(length)
    L = length
    m = np.array(
        [
            [156.0, 22 * L, 54.0, -13 * L],
            [22 * L, 4 * L**2, 13 * L, -3 * L**2],
            [54.0, 13 * L, 156.0, -22 * L],
            [-13 * L, -3 * L**2, -22 * L, 4 * L**2],
        ]
    )
    return (mass_per_length * L / 420.0) * m


# Positions of the bending and axial DOFs inside the frame DOF order [u1, v1, th1, u2, v2, th2].
_BENDING = np.array([1, 2, 4, 5])
_AXIAL = np.array([0, 3])


def _rotation(dx, dy):
    """Local-to-global transformation T (6 x 6) for an element along (dx, dy)."""
    L = float(np.hypot(dx, dy))
    _check_length(L)
    c, s = dx / L, dy / L
    r = np.array([[c, s, 0.0], [-s, c, 0.0], [0.0, 0.0, 1.0]])
    T = np.zeros((6, 6))
    T[:3, :3] = r
    T[3:, 3:] = r
    return T, L


def _to_global(axial, bending, dx, dy):
    """Frame element matrix in global axes from its axial (2 x 2) and bending (4 x 4) parts,
    each a function of the element length."""
    T, L = _rotation(dx, dy)
    a, b = axial(L), bending(L)
    local = np.zeros((6, 6), dtype=np.result_type(a, b, float))
    local[np.ix_(_AXIAL, _AXIAL)] = a
    local[np.ix_(_BENDING, _BENDING)] = b
    return T.T @ local @ T


def frame_stiffness(EA, EI, dx, dy):
    """Stiffness of a planar frame element in global axes, DOFs ``[x1, y1, phi1, x2, y2, phi2]``.

    Parameters
    ----------
    EA : float or complex
        Axial stiffness, N.
    EI : float or complex
        Bending stiffness, N m^2.
    dx, dy : float
        Components of the vector from node 1 to node 2, m.

    Returns
    -------
    ndarray, shape (6, 6)
    """
    return _to_global(lambda L: (EA / L) * np.array([[1.0, -1.0], [-1.0, 1.0]]),
                      lambda L: beam_stiffness(EI, L), dx, dy)


def frame_mass(mass_per_length, dx, dy):
    """Consistent mass of a planar frame element in global axes, DOFs as `frame_stiffness`.

    Parameters
    ----------
    mass_per_length : float or complex
        rho * A, kg/m.
    dx, dy : float
        Components of the vector from node 1 to node 2, m.

    Returns
    -------
    ndarray, shape (6, 6)
    """
    return _to_global(lambda L: (mass_per_length * L / 6.0) * np.array([[2.0, 1.0], [1.0, 2.0]]),
                      lambda L: beam_mass(mass_per_length, L), dx, dy)
