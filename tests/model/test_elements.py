"""Element and assembly tests: closed-form frequencies, convergence, frames."""

import numpy as np
import pytest
from scipy.optimize import brentq

from helpers import uniform_cantilever
from vibupdate import Assembly, modes
from vibupdate.model.elements import beam_matrices, frame_matrices

# Clamped-free Euler-Bernoulli beam: roots of cos(bL) cosh(bL) = -1 (e.g. Blevins, Formulas for
# Natural Frequency and Mode Shape, Table 8-1), printed to 5 decimals.
BETA_L = np.array([1.87510, 4.69409, 7.85476])


def closed_form_cantilever(length=1.0, EI=1.0, rho_a=1.0):
    return BETA_L**2 / length**2 * np.sqrt(EI / rho_a)


def exact_beta_l():
    """Roots of cos(x) cosh(x) + 1 = 0 to machine precision."""
    brackets = [(1.0, 2.5), (4.0, 5.0), (7.5, 8.0)]
    return np.array([brentq(lambda x: np.cos(x) * np.cosh(x) + 1, a, b) for a, b in brackets])


def test_cantilever_converges_to_closed_form():
    roots = exact_beta_l()
    np.testing.assert_allclose(roots, BETA_L, atol=5e-6)  # agrees with the printed table
    exact = roots**2
    errors = []
    for n in (2, 4, 8, 16):
        s = uniform_cantilever(n)
        omega, _ = modes(s.M, s.K, 3)
        errors.append(omega / exact - 1)
    errors = np.array(errors)
    # Consistent mass converges from above, every refinement lowers every error.
    assert np.all(errors > 0)
    assert np.all(np.diff(errors, axis=0) < 0)
    # Literature values: 16 elements reproduce the printed-table frequencies within 5e-5.
    np.testing.assert_allclose(exact * (1 + errors[-1]), BETA_L**2, rtol=5e-5)
    # Asymptotic rate h^4: halving h divides the error by about 16.
    ratios = errors[-2] / errors[-1]
    assert np.all((ratios > 14) & (ratios < 18))


def test_element_matrices_symmetric_and_rigid_body():
    K, M = (a[0] for a in beam_matrices(2.0, 3.0, 0.7))
    np.testing.assert_allclose(K, K.T)
    np.testing.assert_allclose(M, M.T)
    assert np.all(np.linalg.eigvalsh(M) > 0)
    # Rigid translation and rotation have zero strain energy.
    L = 0.7
    for rigid in (np.array([1.0, 0, 1.0, 0]), np.array([0.0, 1.0, L, 1.0])):
        np.testing.assert_allclose(K @ rigid, 0, atol=1e-12)
    # Consistent mass of a translation is the element's mass.
    assert np.ones(2) @ M[np.ix_([0, 2], [0, 2])] @ np.ones(2) == pytest.approx(3.0 * 0.7)


def test_frame_element_rigid_body_in_any_direction():
    dx, dy = 0.3, 0.4
    K, M = (a[0] for a in frame_matrices(5.0, 2.0, 1.5, dx, dy))
    for rigid in (np.array([1, 0, 0, 1, 0, 0.0]), np.array([0, 1, 0, 0, 1, 0.0]),
                  np.array([0, 0, 1, -dy, dx, 1.0])):
        np.testing.assert_allclose(K @ rigid, 0, atol=1e-12)
    total = np.array([1, 0, 0, 1, 0, 0.0])
    assert total @ M @ total == pytest.approx(1.5 * 0.5)


@pytest.mark.parametrize("angle_deg", [0.0, 30.0, 90.0])
def test_inclined_frame_cantilever_matches_bending_and_axial_closed_form(angle_deg):
    """A straight cantilever of frame elements along any direction: bending frequencies as the
    beam formula, axial frequency of a clamped-free bar (2k-1) pi / (2L) sqrt(EA / rho A)."""
    L, EA, EI, rho_a, n = 1.0, 1.0e4, 1.0, 1.0, 24
    c, s = np.cos(np.radians(angle_deg)), np.sin(np.radians(angle_deg))
    asm = Assembly("frame")
    for i in range(n + 1):
        asm.node(i, c * i * L / n, s * i * L / n)
    for i in range(n):
        asm.frame(i, i + 1, EA=EA, EI=EI, mass_per_length=rho_a)
    asm.clamp(0)
    sysm = asm.system()
    omega, _ = modes(sysm.M, sysm.K, 6)
    bending = closed_form_cantilever(L, EI, rho_a)
    axial = np.pi / (2 * L) * np.sqrt(EA / rho_a)
    np.testing.assert_allclose(omega[:3], bending, rtol=5e-5)
    assert np.min(np.abs(omega / axial - 1)) < 1e-3


def test_assembly_named_dofs_supports_and_lumped():
    asm = Assembly("beam")
    for i in (1, 2, 3):
        asm.node(i, float(i))
    asm.beam(1, 2, EI=1.0, mass_per_length=1.0)
    asm.beam(2, 3, EI=1.0, mass_per_length=1.0)
    asm.pin(1)
    asm.mass("y3", 0.5)
    asm.mass("phi3", 0.1)
    asm.spring("y3", 7.0)
    asm.spring("y2", 3.0, "y3")
    s = asm.system()
    assert s.dofs == ("phi1", "y2", "phi2", "y3", "phi3")
    i, j = s.dof("y2"), s.dof("y3")
    K_bare, M_bare = (a[0] for a in beam_matrices(1.0, 1.0, 1.0))
    assert s.M[s.dof("y3"), s.dof("y3")] == pytest.approx(M_bare[2, 2] + 0.5)
    assert s.M[s.dof("phi3"), s.dof("phi3")] == pytest.approx(M_bare[3, 3] + 0.1)
    assert s.K[j, j] == pytest.approx(K_bare[2, 2] + 7.0 + 3.0)
    assert s.K[i, j] == pytest.approx(K_bare[0, 2] - 3.0)
    with pytest.raises(ValueError, match="DOF 'y9' does not exist"):
        s.dof("y9")
    with pytest.raises(ValueError, match="DOF 'x1' does not exist"):
        asm.mass("x1", 1.0)
    with pytest.raises(ValueError, match="node 7 does not exist"):
        asm.clamp(7)
