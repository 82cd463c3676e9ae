"""Exact first derivatives of modal data with respect to the normalized parameters.

With ``M(xbar) = M0 + sum_i xbar_i M_i`` and ``K(xbar) = K0 + sum_i xbar_i K_i`` (Eqs. 12-14)
every derivative below is analytic; no finite difference of an eigensolver is taken, so the
derivatives are as accurate as the eigenpairs themselves.

* **Natural frequencies.** For a simple eigenvalue ``eigval = w^2`` with mass-normalized mode
  ``phi`` (``phi^T M phi = 1``), ``d eigval / d xbar_i = phi^T (K_i - eigval M_i) phi``, and
  ``d w / d xbar_i = (d eigval / d xbar_i) / (2 w)``.
* **Mode-shape ratios.** A measured shape is known up to scale, so what is compared is the
  ratio ``phi_j / phi_p`` to a reference entry ``p``. Differentiating ``(K - eigval M) phi = 0``
  gives ``(K - eigval M) dphi = -(K_i - eigval M_i) phi + d_eigval M phi``: a singular but consistent
  system whose solutions differ by multiples of ``phi``. Any solution ``v`` gives the exact
  derivative of the ratio, ``(v_j phi_p - phi_j v_p) / phi_p^2``, because the multiple of
  ``phi`` cancels. ``v`` is found as in Nelson's method: fix the entry of largest ``|phi|``
  to zero and solve the remaining non-singular system (one factorization per mode).
* **Modal mass.** A mass-normalized measured shape also fixes the mode's scale: with the ratio
  vector ``q = phi / phi_p`` (``q_p = 1``), the modal mass at ``p`` is ``m_p = 1 / phi_p^2 =
  q^T M q``, so ``d m_p / d xbar_i = q^T M_i q + 2 (M q)^T dq_i``, ``dq_i`` the ratio derivative
  above over every entry: the same solutions ``v``, no further factorization.
* **Antiresonances.** The zeros of ``h_rc`` are eigenvalues of the adjunct pencil
  ``(K_rc, M_rc)`` (row ``c`` and column ``r`` removed, Eq. 8), which is not symmetric when
  ``r != c``. With right vector ``v`` and left vector ``y``,
  ``d eigval_z / d xbar_i = y^T (K_i,rc - eigval_z M_i,rc) v / (y^T M_rc v)``. For a symmetric model
  the transposed pencil is the adjunct of ``h_cr``, so ``y`` is an adjunct vector of
  ``h_cr``; for ``r == c``, ``y = v``.
"""

from __future__ import annotations

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp

from vibupdate.modal import eigen
from vibupdate.modal.factor import sparse_lu
from vibupdate.modal.kept import Kept
from vibupdate.modal.readings import ratio_derivatives, readings
from vibupdate.modal.rigid import embed
from vibupdate.modal.zeros import antiresonance_vectors, dense_zeros


def eigenvalue_derivatives(model, omega, Phi) -> np.ndarray:
    """``d(w^2)/d xbar`` of the given modes.

    Parameters
    ----------
    model : AffineModel
    omega : ndarray, shape (n_m,)
        Natural frequencies, rad/s, at the point where ``Phi`` was computed.
    Phi : ndarray, shape (n, n_m)
        Mass-normalized modes at that point.

    Returns
    -------
    ndarray, shape (n_m, n_x)
        In (rad/s)^2 per unit of normalized parameter.
    """
    omega = np.asarray(omega, dtype=float)
    eigval = np.sign(omega) * omega**2
    forms_M, forms_K = model.parameter_forms(Phi, Phi)
    return forms_K - eigval[:, None] * forms_M


def frequency_derivatives(model, omega, Phi) -> np.ndarray:
    """``d w / d xbar`` of the given modes, rad/s per unit of normalized parameter.

    Shapes as in `eigenvalue_derivatives`; returns shape (n_m, n_x).
    """
    omega = np.asarray(omega, dtype=float)
    return eigenvalue_derivatives(model, omega, Phi) / (2.0 * omega[:, None])


def _factor(A):
    """A solver of ``A x = b``: sparse LU above the dense limit; one LAPACK solve below (each
    caller solves once, so a kept factorization would only add the checks of two calls)."""
    if sp.issparse(A):
        return sparse_lu(A).solve
    A = np.asarray(A)
    if not np.isfinite(A).all():    # as LU's own check
        raise ValueError("array must not contain infs or NaNs")

    def solve(b):
        try:
            return np.linalg.solve(A, b)
        except np.linalg.LinAlgError:   # exactly singular: LU's answer (inf or NaN), as before
            return sla.lu_solve(sla.lu_factor(A), b)
    return solve


def shape_ratio_derivatives(model, xbar, omega: float, phi, entries, reference: int, *,
                            vectors: bool = False, basis: np.ndarray | None = None):
    """Exact derivative of the shape ratios ``phi[entries] / phi[reference]`` of one mode.

    Parameters
    ----------
    model : AffineModel
    xbar : ndarray, shape (n_x,)
        Point of the eigenpair.
    omega : float
        Natural frequency, rad/s (a simple eigenvalue).
    phi : ndarray, shape (n,)
        Mass-normalized mode at ``xbar``.
    entries : sequence of int, length n_e, or sparse matrix, shape (n_e, n)
        DOF indices of the ratios' numerators, or their measurement map (sensor weights,
        `vibupdate.model.measurement`).
    reference : int or sparse matrix, shape (1, n)
        DOF index of the denominator, or its measurement map; the reading of ``phi`` there must
        not vanish.
    vectors : bool
        Also return the solutions ``V`` of the module docstring (one per parameter): the
        derivatives of ``phi`` up to multiples of ``phi``.
    basis : ndarray, shape (n, k), optional
        For a mode of a repeated frequency (`vibupdate.inverse.repeated`): the modes of that
        frequency, ``phi`` (any scaling) a combination of them. The derivative is then that of
        the ratios of the same combination as the eigenspace moves: the right-hand sides and
        ``V`` are cleared of the eigenspace, ``k`` rows and columns removed instead of one (a
        turn within the eigenspace is left to whoever chose the combination; where it was chosen
        to fit the data best, it does not change the fit's gradient).

    Returns
    -------
    D : ndarray, shape (n_e, n_x)
        Derivatives of the dimensionless ratios per unit of normalized parameter.
    V : ndarray, shape (n, n_x)
        Only with ``vectors``.
    """
    phi = np.asarray(phi, dtype=float)
    n = phi.size
    key = V = None
    if n > eigen.DENSE_LIMIT:   # one sparse LU each: re-used by the stages that ask at the same point
        key = (model.fingerprint, np.asarray(xbar, dtype=float).tobytes(), float(omega), phi.tobytes(),
               None if basis is None else np.asarray(basis, dtype=float).tobytes())
        V = _RATIO_SOLUTIONS.get(key)
    if V is None:
        V = ratio_solution(model, xbar, omega, phi, basis)
        if key is not None:
            _RATIO_SOLUTIONS.put(key, V, V.nbytes)
    D = ratio_derivatives(V, phi, entries, reference)
    return (D, V.copy()) if vectors else D


def ratio_solutions(model, xbar, omega, Phi) -> np.ndarray | None:
    """The solutions ``V`` of the module docstring of several simple modes at once, shape
    (m, n, n_x), on a model with dense stacks (`vibupdate.model.AffineModel.dense_stacks`, at
    most `vibupdate.modal.eigen.DENSE_LIMIT` DOFs; None otherwise: `shape_ratio_derivatives`
    one mode at a time). The same systems as `ratio_solution`, in one batched solve: the row
    and column of each mode's largest ``|phi|`` replaced by those of the identity (its entry of
    ``V`` is then 0 and the other entries solve the system without them) instead of removed,
    so that the m systems have one size. Memory: m dense n x n matrices.

    Parameters
    ----------
    omega : ndarray, shape (m,)
        Natural frequencies, rad/s, each a simple eigenvalue.
    Phi : ndarray, shape (n, m)
        Their mass-normalized modes at ``xbar``.
    """
    stacks = model.dense_stacks
    if stacks is None:
        return None
    M, K = model.solver_matrices(xbar)
    Phi = np.asarray(Phi, dtype=float)
    eigval = np.asarray(omega, dtype=float) ** 2
    m = eigval.size
    products_M, products_K = (S[1:] @ Phi for S in stacks)                  # (n_x, n, m)
    F = np.transpose(products_K - eigval * products_M, (2, 1, 0))           # (m, n, n_x)
    d_eigval = np.einsum("nm,mnx->mx", Phi, F)
    rhs = -F + (M @ Phi).T[:, :, None] * d_eigval[:, None, :]
    A = K[None, :, :] - eigval[:, None, None] * M[None, :, :]
    k, p = np.arange(m), np.argmax(np.abs(Phi), axis=0)
    A[k, p, :] = 0.0
    A[k, :, p] = 0.0
    A[k, p, p] = 1.0
    rhs[k, p, :] = 0.0
    if not np.isfinite(A).all():
        raise ValueError("array must not contain infs or NaNs")
    try:
        return np.linalg.solve(A, rhs)
    except np.linalg.LinAlgError:   # one system exactly singular: each on its own (LU's inf or NaN there)
        return np.stack([ratio_solution(model, xbar, w, phi) for w, phi in zip(omega, Phi.T)])


def modal_mass_derivatives(model, M, phi, reference, V) -> tuple[float, np.ndarray]:
    """The modal mass ``q^T M q`` (kg) of the mode ``phi`` scaled to 1 at DOF ``reference``
    (``1 / phi_p^2`` of a mass-normalized mode), ``M`` the model's mass matrix at the mode's
    point, and its exact derivative, shape (n_x,), from the solutions ``V`` of
    `shape_ratio_derivatives` (``vectors=True``) of the same mode (module docstring)."""
    phi = np.asarray(phi, dtype=float)
    ref = readings(phi, reference)
    q = phi / ref
    dQ = (V * ref - np.outer(phi, readings(V, reference))) / ref**2
    Mq = M @ q
    direct = model.parameter_forms(q[:, None], q[:, None])[0][0]
    return float(q @ Mq), direct + 2.0 * (Mq @ dQ)


#: Solutions ``V`` of large models kept by (model, point, eigenpair): the polish's last
#: evaluation, the sensitivity rows and the linearized ranges ask for the same ones at the
#: answer; the most recent within 256 MB.
_RATIO_SOLUTIONS = Kept(64, 256 * 2**20)


def ratio_solution(model, xbar, omega: float, phi: np.ndarray, basis: np.ndarray | None = None) -> np.ndarray:
    """The solutions ``V`` (n, n_x) of the module docstring: one factorization of
    ``K - eigval M`` without the row and column of the largest ``|phi|``, every parameter in one
    solve. With a ``basis`` of a repeated frequency's modes (`shape_ratio_derivatives`): without
    the rows and columns where they are most independent, the eigenspace cleared."""
    M, K = model.solver_matrices(xbar)
    eigval = omega**2
    n = phi.size
    products_M, products_K = model.parameter_products(phi)
    F = products_K - eigval * products_M
    V = np.zeros((n, model.n_parameters))
    if basis is None:
        p = int(np.argmax(np.abs(phi)))
        keep = np.delete(np.arange(n), p)
        solve = _factor(_kept(K - eigval * M, keep))
        Mphi = M @ phi
        d_eigval = phi @ F
        V[keep] = solve((-F + np.outer(Mphi, d_eigval))[keep])   # every parameter in one solve
        return V
    U = np.asarray(basis, dtype=float)
    MU = M @ U
    G = U.T @ MU
    removed = sorted(sla.qr(U.T, mode="r", pivoting=True)[1][:U.shape[1]].tolist())
    keep = np.delete(np.arange(n), removed)
    solve = _factor(_kept(K - eigval * M, keep))
    V[keep] = solve((-F + MU @ np.linalg.solve(G, U.T @ F))[keep])
    return V - U @ np.linalg.solve(G, MU.T @ V)


def _kept(A, keep):
    """``A`` without the rows and columns not in ``keep``: dense on the dense path, csr above."""
    if not sp.issparse(A):
        return A[np.ix_(keep, keep)]
    kept = A.tocsr()[keep][:, keep]
    return kept if A.shape[0] > eigen.DENSE_LIMIT else kept.toarray()


def adjunct_eigenpairs(M, K, r: int, c: int, n_zeros: int | None = None, precision: float | None = None):
    """Finite, real, positive eigenvalues of the adjunct pencil of ``h_rc`` with right and left
    vectors, without the structural zeros of a model with rigid-body modes
    (`vibupdate.modal.zeros.structural`): dense up to `vibupdate.modal.eigen.DENSE_LIMIT` DOFs, shift-invert above (the
    lowest ``n_zeros``; the left vectors are the right vectors of the transposed pencil, the
    adjunct of ``h_cr``). ``precision``: the relative precision of the entries of ``K`` and
    ``M`` (`vibupdate.modal.rigid`), None for double precision.

    Returns
    -------
    eigval_z : ndarray, shape (n_z,)
        Squared antiresonance frequencies, (rad/s)^2, ascending.
    V_right, V_left : ndarray, shape (n - 1, n_z)
        Right and left eigenvectors: ``(K_rc - eigval_z M_rc) V_right = 0`` and
        ``V_left^T (K_rc - eigval_z M_rc) = 0``.
    """
    if M.shape[0] > eigen.DENSE_LIMIT:
        k = n_zeros or 20
        wz, V_right = antiresonance_vectors(M, K, r, c, n_zeros=k, precision=precision)
        if r == c:
            return wz**2, V_right, V_right
        wy, V_left = antiresonance_vectors(M, K, c, r, n_zeros=k, precision=precision)
        if wy.size != wz.size or np.any(np.abs(wy - wz) > 1e-6 * np.maximum(wz, 1e-300)):
            raise ValueError(f"the zeros of h_{r},{c} and h_{c},{r} of a symmetric model differ: the sparse "
                             "eigen-solve did not converge to the same set")
        return wz**2, V_right, V_left
    # a dense-limit model is small: one conversion costs less than sparse slicing and products
    M, K = eigen.as_dense(M), eigen.as_dense(K)
    eigval_z, V_right, V_left = dense_zeros(M, K, r, c, 1e-8, precision)
    return eigval_z[:n_zeros], V_right[:, :n_zeros], V_left[:, :n_zeros]


def antiresonance_derivatives(model, xbar, r: int, c: int, *, pairs=None, n_zeros: int | None = None):
    """Antiresonances of ``h_rc`` at ``xbar`` and their exact derivatives.

    Parameters
    ----------
    model : AffineModel
    xbar : ndarray, shape (n_x,)
    r, c : int
        Response and excitation DOF indices.
    pairs : tuple, optional
        ``adjunct_eigenpairs`` of the model at ``xbar`` when already computed.
    n_zeros : int, optional
        Only the lowest zeros (all of them on the dense path by default, 20 on the sparse).

    Returns
    -------
    omega_z : ndarray, shape (n_z,)
        Antiresonance frequencies, rad/s, ascending.
    D : ndarray, shape (n_z, n_x)
        ``d omega_z / d xbar``, rad/s per unit of normalized parameter.
    """
    M, K = model.solver_matrices(xbar)
    eigval_z, V_right, V_left = (pairs if pairs is not None else
                                 adjunct_eigenpairs(M, K, r, c, n_zeros, model.matrix_precision))
    # Embed the vectors in the full space (zero at the removed column r / row c), so that the
    # adjunct products become products with the full sparse matrices.
    right_full, left_full = embed(V_right, M.shape[0], r), embed(V_left, M.shape[0], c)
    denom = np.einsum("ij,ij->j", left_full, M @ right_full)
    forms_M, forms_K = model.parameter_forms(left_full, right_full)
    D = (forms_K - eigval_z[:, None] * forms_M) / denom[:, None]
    omega_z = np.sqrt(eigval_z)
    return omega_z, D / (2.0 * omega_z[:, None])
