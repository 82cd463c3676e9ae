"""Kernels at scale: massless DOFs, receptances without n_f x n^2 arrays, sparse antiresonances,
the residual check of shift-invert modes and the batched assembly."""

import numpy as np
import pytest
import scipy.linalg as sla
import scipy.sparse as sp

from helpers import uniform_cantilever
from vibupdate import Assembly, antiresonances, modes, receptance
from vibupdate.modal import eigen
from vibupdate.modal import receptance as receptance_module
from vibupdate.modal.analysis import DENSE_LIMIT, ModalAccuracyError, adjunct, antiresonance_vectors, mode_residuals


def lumped_portal(storeys=3, per_column=3):
    """A portal frame whose members carry no distributed mass: masses are lumped on the
    translations only, so every rotation is a massless DOF."""
    asm = Assembly("frame")
    height, width = 3.0, 4.0
    n_levels = storeys * per_column
    for level in range(n_levels + 1):
        for side, x in (("L", 0.0), ("R", width)):
            asm.node(f"{side}{level}", x, level * height / per_column)
    for level in range(n_levels):
        for side in "LR":
            asm.frame(f"{side}{level}", f"{side}{level + 1}", EA=4e8, EI=2e6 * (1 + 0.1 * level), mass_per_length=0.0)
    for level in range(1, n_levels + 1):
        mass = 800.0 if level % per_column == 0 else 40.0
        if level % per_column == 0:
            asm.frame(f"L{level}", f"R{level}", EA=4e8, EI=5e6, mass_per_length=0.0)
        for side in "LR":
            asm.mass(f"x{side}{level}", mass)
            asm.mass(f"y{side}{level}", mass)
    asm.clamp("L0")
    asm.clamp("R0")
    return asm.system()


def condensed(M, K, s):
    """Reference: massless DOFs ``s`` condensed out by an explicit Schur complement."""
    M, K = M.toarray(), K.toarray()
    m = np.setdiff1d(np.arange(M.shape[0]), s)
    Kc = K[np.ix_(m, m)] - K[np.ix_(m, s)] @ np.linalg.solve(K[np.ix_(s, s)], K[np.ix_(s, m)])
    return M[np.ix_(m, m)], Kc, m


def test_massless_dofs_give_the_condensed_model_frequencies():
    sysm = lumped_portal()
    s = np.array([i for i, d in enumerate(sysm.dofs) if d.startswith("phi")])
    assert np.all(sysm.M.diagonal()[s] == 0) and s.size == sysm.M.shape[0] // 3
    Mc, Kc, m = condensed(sysm.M, sysm.K, s)
    lam_ref = sla.eigh(Kc, Mc, eigvals_only=True)
    omega, Phi = modes(sysm.M, sysm.K)
    assert omega.size == m.size  # one finite mode per DOF carrying mass
    np.testing.assert_allclose(omega[:10] ** 2, lam_ref[:10], rtol=1e-10)
    # Full-length vectors: they solve the full pencil, massless rows included, and are
    # mass-normalized.
    assert Phi.shape == (sysm.M.shape[0], m.size)
    assert mode_residuals(sysm.M, sysm.K, omega[:10], Phi[:, :10]).max() < 1e-13
    np.testing.assert_allclose(Phi.T @ (sysm.M @ Phi), np.eye(m.size), atol=1e-9)
    # Shift-invert needs no condensation (only K - sigma M is factorized).
    w_sparse, P_sparse = modes(sysm.M, sysm.K, 6, dense=False)
    np.testing.assert_allclose(w_sparse, omega[:6], rtol=1e-11)
    np.testing.assert_allclose(np.abs(np.sum(P_sparse * (sysm.M @ Phi[:, :6]), axis=0)), 1.0, atol=1e-9)
    with pytest.raises(ValueError, match=f"n_modes must be between 1 and {m.size}, got {m.size + 1}"):
        modes(sysm.M, sysm.K, m.size + 1)


def test_one_definition_of_massless_for_the_eigen_solver_and_the_admissibility_check():
    """A rotation carrying a rounding-level mass (1e-16 of the largest, as exported files
    print it) is massless for both `modes` and `definiteness`: the same DOFs, the same
    finite modes as with exact zeros, no spurious mode far above the physical ones."""
    from vibupdate.model.physical import definiteness

    sysm = lumped_portal()
    s = np.array([i for i, d in enumerate(sysm.dofs) if d.startswith("phi")])
    M = sysm.M.tolil()
    top = sysm.M.diagonal().max()
    for i in s:
        M[i, i] = 1e-16 * top
    M = sp.csr_matrix(M)
    np.testing.assert_array_equal(eigen.massless_dofs(M), s)
    assert definiteness(M, sysm.K).massless == tuple(s)
    omega_exact, _ = modes(sysm.M, sysm.K)
    omega, _ = modes(M, sysm.K)
    assert omega.size == omega_exact.size == sysm.M.shape[0] - s.size
    np.testing.assert_allclose(omega, omega_exact, rtol=1e-9)


def test_massless_dof_without_stiffness_is_named():
    sysm = lumped_portal()
    K = sysm.K.tolil()
    j = sysm.dofs.index("phiL1")
    K[j, :] = 0
    K[:, j] = 0
    with pytest.raises(ValueError, match="not positive definite on the .* massless DOFs"):
        modes(sysm.M, sp.csr_matrix(K))


@pytest.mark.parametrize("pair", [("xL3", "yR6"), ("phiL2", "xR9"), ("phiL2", "phiR5"), ("phiL4", "phiL4")])
def test_receptance_with_massless_dofs_equals_the_direct_solve(pair):
    sysm = lumped_portal()
    r, c = (sysm.dofs.index(d) for d in pair)
    omega, _ = modes(sysm.M, sysm.K, 6)
    w = np.concatenate([[0.0], 0.5 * (omega[:-1] + omega[1:]), [1.3 * omega[-1]]])
    h = receptance(sysm.M, sysm.K, r, c, w)
    M, K = sysm.M.toarray(), sysm.K.toarray()
    direct = np.array([np.linalg.solve(K - x**2 * M, np.eye(M.shape[0])[:, c])[r] for x in w])
    np.testing.assert_allclose(h.real, direct, rtol=1e-8, atol=1e-12 * np.abs(direct).max())


def test_damped_receptance_in_chunks_equals_one_solve_per_frequency(monkeypatch):
    s = uniform_cantilever(20)
    C = 1e-4 * s.K + 0.2 * s.M
    w = np.linspace(0.5, 300.0, 11)
    n = s.M.shape[0]
    # Chunks of 3 frequencies: the stack never holds more than 3 x n x n numbers.
    monkeypatch.setattr(receptance_module, "_CHUNK_BYTES", 3 * 16 * n * n)
    h = receptance(s.M, s.K, 3, 17, w, C)
    M, K, Cd = s.M.toarray(), s.K.toarray(), C.toarray()
    direct = np.array([np.linalg.solve(K + 1j * x * Cd - x**2 * M, np.eye(n)[:, 17])[3] for x in w])
    np.testing.assert_allclose(h, direct, rtol=1e-10)


def refined_frame():
    """The frame example refined to 422 DOFs (over `DENSE_LIMIT`), lam_max / lam_1 ~ 7e8."""
    from vibupdate.examples import frame

    sysm = frame.build(frame.truth(), 11)
    assert sysm.M.shape[0] > DENSE_LIMIT
    return sysm


def test_large_model_receptance_equals_the_modal_sum_of_all_modes():
    sysm = refined_frame()
    omega, Phi = modes(sysm.M, sysm.K)
    w = np.concatenate([0.5 * (omega[:5] + omega[1:6]), [0.0]])
    r, c = sysm.dof("x6"), sysm.dof("y10")
    h = receptance(sysm.M, sysm.K, r, c, w)  # one sparse LU per frequency
    modal = (Phi[r] * Phi[c]) @ (1.0 / (omega[:, None] ** 2 - w[None] ** 2))
    np.testing.assert_allclose(h.real, modal, rtol=1e-9)  # measured 7e-11
    assert np.all(h.imag == 0)


@pytest.mark.parametrize("pair, rtol", [(("x6", "x6"), 1e-10), (("x6", "y10"), 1e-8), (("y4", "x12"), 1e-8)])
def test_sparse_adjunct_antiresonances_equal_the_dense_ones(pair, rtol):
    """Shift-invert on the sparse adjunct pencil against dense LAPACK (symmetric for r = c,
    measured 3e-12 apart; QZ otherwise, whose error grows like eps lam_max / lam: measured
    5e-10 and 1.3e-9 apart)."""
    sysm = refined_frame()
    M, K = sysm.M, sysm.K
    r, c = sysm.dof(pair[0]), sysm.dof(pair[1])
    z_dense = antiresonances(M, K, r, c, dense=True)
    z, V = antiresonance_vectors(M, K, r, c, n_zeros=6)
    assert z.size == 6
    np.testing.assert_allclose(z, z_dense[:6], rtol=rtol)
    Mr, Kr = adjunct(M, r, c), adjunct(K, r, c)
    # Right vectors of the (r, c) pencil; those of the (c, r) pencil are its left vectors.
    _, U = antiresonance_vectors(M, K, c, r, n_zeros=6)
    for k in range(6):
        A = Kr - z[k] ** 2 * Mr
        scale = abs(Kr).sum(axis=0).max() + z[k] ** 2 * abs(Mr).sum(axis=0).max()
        assert np.linalg.norm(A @ V[:, k]) < 1e-12 * scale * np.linalg.norm(V[:, k])
        assert np.linalg.norm(A.T @ U[:, k]) < 1e-12 * scale * np.linalg.norm(U[:, k])
        assert np.max(np.abs(V[:, k])) == pytest.approx(1.0)


def test_antiresonances_n_zeros_is_checked_and_honoured():
    s = uniform_cantilever(6)
    every = antiresonances(s.M, s.K, 0, 0)
    np.testing.assert_array_equal(antiresonances(s.M, s.K, 0, 0, n_zeros=2), every[:2])
    with pytest.raises(ValueError, match="n_zeros must be between 1 and 11, got 0"):
        antiresonances(s.M, s.K, 0, 0, n_zeros=0)


def test_dense_and_shift_invert_modes_agree_on_a_stiff_model():
    """At lam_max / lam_1 = 1.5e11 the dense reciprocal pencil and shift-invert agree to 1.5e-9
    (measured); the direct pencil ``eigh(K, M)`` is 6.3e-7 away, as its error bound
    ``eps lam_max / lam_1`` allows."""
    s = uniform_cantilever(150)
    w_all, _ = modes(s.M, s.K)
    assert w_all[-1] ** 2 / w_all[0] ** 2 > 1e11
    w_sparse, _ = modes(s.M, s.K, 8, dense=False)
    np.testing.assert_allclose(w_all[:8], w_sparse, rtol=1e-8)


def test_shift_invert_flags_a_residual_above_its_tolerance():
    s = uniform_cantilever(30)
    with pytest.raises(ModalAccuracyError, match="mode 1 .* residual .* cannot be trusted"):
        modes(s.M, s.K, 3, dense=False, rtol=1e-30)


def test_batched_frames_equal_element_by_element_assembly_with_complex_values():
    rng = np.random.default_rng(7)
    xy = rng.uniform(0, 2, (6, 2))
    pairs = [(0, 1), (1, 2), (2, 3), (3, 4), (4, 5), (0, 5), (1, 4)]
    EA = rng.uniform(1, 2, len(pairs)) + 1j * 1e-20
    EI = rng.uniform(0.1, 0.2, len(pairs))
    mpl = rng.uniform(1, 3, len(pairs)) - 2j * 1e-20

    def assemble(batched):
        asm = Assembly("frame")
        asm.nodes(range(6), xy[:, 0], xy[:, 1])
        if batched:
            asm.frames([a for a, _ in pairs], [b for _, b in pairs], EA=EA, EI=EI, mass_per_length=mpl)
        else:
            for k, (a, b) in enumerate(pairs):
                asm.frame(a, b, EA=EA[k], EI=EI[k], mass_per_length=mpl[k])
        asm.clamp(0)
        return asm.system()

    from vibupdate.model.elements import frame_matrices

    one, many = assemble(False), assemble(True)
    np.testing.assert_array_equal(one.K.toarray(), many.K.toarray())
    np.testing.assert_array_equal(one.M.toarray(), many.M.toarray())
    assert np.iscomplexobj(many.K.data) and np.abs(many.M.imag).max() > 0
    # ... and both equal a hand assembly of the single-element matrices.
    K = np.zeros((18, 18), dtype=complex)
    for k, (a, b) in enumerate(pairs):
        idx = [3 * a, 3 * a + 1, 3 * a + 2, 3 * b, 3 * b + 1, 3 * b + 2]
        K[np.ix_(idx, idx)] += frame_matrices(EA[k], EI[k], 0.0, *(xy[b] - xy[a]))[0][0]
        e = np.array([1.0, 0, 0, 1, 0, 0])
        assert e @ frame_matrices(0.0, 0.0, mpl[k], *(xy[b] - xy[a]))[1][0].imag @ e == pytest.approx(-2e-20 * np.hypot(*(xy[b] - xy[a])))
    np.testing.assert_allclose(many.K.toarray(), K[3:, 3:], rtol=1e-13, atol=1e-13 * np.abs(K).max())


def test_exported_matrices_with_massless_dofs_pass_from_files():
    from vibupdate import Parameter, from_files

    sysm = lumped_portal()
    p = [Parameter("s", 1.0, 0.5, 1.5)]
    model = from_files(sysm.M, sysm.K, p, dK={"s": sysm.K}, dofs=sysm.dofs)
    assert model.n_dofs == sysm.M.shape[0]
    K = sysm.K.tolil()
    j = sysm.dofs.index("phiR4")
    K[j, :] = 0
    K[:, j] = 0
    with pytest.raises(ValueError, match="not positive definite on the 18 DOF.s. without mass"):
        from_files(sysm.M, sp.csr_matrix(K), p, dK={"s": sysm.K}, dofs=sysm.dofs)


def test_a_declared_mode_beyond_the_finite_modes_is_named():
    """18 of the portal's 54 DOFs carry no mass: 36 finite modes. Declaring mode 36 works,
    mode 40 is a clear error naming the configuration, not an index error."""
    from vibupdate import Parameter, from_files
    from vibupdate.data.measured import Configuration, NaturalFrequency
    from vibupdate.inverse.correlation import model_frequencies

    sysm = lumped_portal()
    model = from_files(sysm.M, sysm.K, [Parameter("s", 1.0, 0.5, 1.5)], dK={"s": sysm.K}, dofs=sysm.dofs)
    n_finite = model.n_dofs - eigen.massless_dofs(sysm.M).size
    last = model_frequencies(Configuration("A", model, (NaturalFrequency(10.0, mode=n_finite),), ()))
    assert last.natural.size == 1 and last.spectrum[0].size == n_finite
    with pytest.raises(ValueError, match=f"configuration 'A': mode 40 is declared, but the model has {n_finite} "
                                         "finite modes"):
        model_frequencies(Configuration("A", model, (NaturalFrequency(10.0, mode=40),), ()))


def test_large_model_with_massless_dofs_by_shift_invert():
    """Over `DENSE_LIMIT` DOFs, a third of them massless: shift-invert modes and driving-point
    antiresonances (singular M and M_rr) equal the dense condensed results. The tolerance is
    the model's own conditioning (stiff axial members, soft sway): shift-invert, the condensed
    dense pencil and the uncondensed reciprocal pencil ``eigh(M, K)`` differ pairwise by
    1.4e-9 to 3.6e-9 (measured)."""
    sysm = lumped_portal(storeys=3, per_column=50)
    assert sysm.M.shape[0] > DENSE_LIMIT
    omega, Phi = modes(sysm.M, sysm.K, 6)  # sparse by default
    w_dense, _ = modes(sysm.M, sysm.K, 6, dense=True)
    np.testing.assert_allclose(omega, w_dense, rtol=1e-8)
    assert mode_residuals(sysm.M, sysm.K, omega, Phi).max() < 1e-13
    r = sysm.dof("xL75")
    np.testing.assert_allclose(antiresonances(sysm.M, sysm.K, r, r, n_zeros=5),
                               antiresonances(sysm.M, sysm.K, r, r, dense=True)[:5], rtol=1e-8)


def test_all_modes_of_a_huge_model_is_a_clear_error_not_a_memory_storm(monkeypatch):
    s = uniform_cantilever(40)
    monkeypatch.setattr(eigen, "DENSE_MAX", 50)
    monkeypatch.setattr(eigen, "DENSE_LIMIT", 20)
    with pytest.raises(ValueError, match="all modes of a 80-DOF model would need .* ask for the lowest n_modes"):
        modes(s.M, s.K)
    assert modes(s.M, s.K, 3)[0].size == 3  # the lowest few: shift-invert, no dense matrix


def test_damped_receptance_over_many_lines_by_the_state_space_modes(monkeypatch):
    s = uniform_cantilever(20)
    C = 1e-4 * s.K + 0.2 * s.M
    w = np.linspace(0.0, 400.0, 120)  # over 50 lines: one 2n eigen-solve of the first-order form
    used = []
    original = receptance_module._state_space_receptances
    monkeypatch.setattr(receptance_module, "_state_space_receptances", lambda *a: used.append(1) or original(*a))
    h = receptance(s.M, s.K, 3, 17, w, C)
    assert used and original(s.M, s.K, C, np.array([3]), np.array([17]), w) is not None  # the modal form was accepted
    n = s.M.shape[0]
    M, K, Cd = s.M.toarray(), s.K.toarray(), C.toarray()
    direct = np.array([np.linalg.solve(K + 1j * x * Cd - x**2 * M, np.eye(n)[:, 17])[3] for x in w])
    assert np.abs(h - direct).max() < 1e-7 * np.abs(direct).max()


def test_every_mode_of_a_stiff_model_keeps_the_better_pencil():
    """lam_max / lam_1 = 1.5e11: the low modes from the reciprocal pencil, the high ones from
    the direct pencil; every pair has a small backward error, none is lost as 'zero mass'."""
    s = uniform_cantilever(150)
    omega, Phi = modes(s.M, s.K)
    assert omega.size == s.M.shape[0] and np.all(np.diff(omega) > 0)
    assert mode_residuals(s.M, s.K, omega, Phi).max() < 1e-13
    lam_direct = sla.eigh(s.K.toarray(), s.M.toarray(), eigvals_only=True)
    np.testing.assert_allclose(omega[-50:] ** 2, lam_direct[-50:], rtol=1e-12)


def test_the_qz_of_the_adjunct_pencil_is_scipys_eig_without_its_loop():
    """Eigenvalues and the real parts of the unit left and right vectors as
    ``scipy.linalg.eig`` gives them, on a pencil with real eigenvalues and complex pairs."""
    from vibupdate.modal.zeros import qz

    rng = np.random.default_rng(4)
    D = sla.block_diag(*np.arange(1.0, 7.0), *[[[a, b], [-b, a]] for a, b in ((2.0, 1.0), (5.0, 0.5), (9.0, 3.0))])
    P, Q = rng.standard_normal((2, 12, 12))
    A, B = P @ D @ Q, P @ Q          # eigenvalues 1 to 6 and three complex pairs
    (alpha, beta), left, right = qz(A, B)
    (alpha_ref, beta_ref), left_ref, right_ref = sla.eig(A, B, left=True, right=True, homogeneous_eigvals=True)
    assert np.count_nonzero(alpha.imag) == 6 and np.count_nonzero(alpha.imag == 0) == 6
    np.testing.assert_allclose(alpha, alpha_ref, rtol=0, atol=1e-14 * np.abs(alpha_ref).max())
    np.testing.assert_allclose(beta, beta_ref, rtol=0, atol=1e-14 * np.abs(beta_ref).max())
    np.testing.assert_allclose(left, left_ref.real, rtol=0, atol=1e-14)
    np.testing.assert_allclose(right, right_ref.real, rtol=0, atol=1e-14)
    with pytest.raises(ValueError, match="infs or NaNs"):
        qz(np.full((3, 3), np.nan), B[:3, :3])


def test_the_ratio_solutions_of_several_modes_in_one_solve_equal_each_ones_own():
    """`ratio_solutions` (the simple modes of a dense model in one batched solve, each mode's
    largest entry's row and column replaced by the identity's) against the one-mode solve with
    them removed; a model above the dense limit has no dense stacks and gives None (its modes
    are solved one at a time, sparse)."""
    from helpers import chain_model
    from vibupdate.modal.sensitivities import ratio_solution, ratio_solutions

    model = chain_model(12, ["k1", "k2", "m3", "k7"])
    x = np.array([0.1, -0.2, 0.05, 0.3])
    omega, Phi = modes(*model.matrices(x), 5)
    V = ratio_solutions(model, x, omega, Phi)
    assert V.shape == (5, 12, 4)
    for k in range(5):
        own = ratio_solution(model, x, omega[k], Phi[:, k])
        np.testing.assert_allclose(V[k], own, rtol=1e-9, atol=1e-12 * np.abs(own).max())
        assert np.all(V[k][np.argmax(np.abs(Phi[:, k]))] == 0.0)
    large = chain_model(DENSE_LIMIT + 1, ["k1"])
    assert large.dense_stacks is None
    assert ratio_solutions(large, np.zeros(1), omega[:2], np.zeros((DENSE_LIMIT + 1, 2))) is None
