"""Repeated natural frequencies: model modes that share one eigenspace.

Every combination of the modes of a repeated frequency is a mode of it (which one an
eigen-solver returns is decided by rounding), so such a mode is checked as its eigenspace:
`cluster` groups the model's modes whose frequencies agree to `REPEATED_GAP`; `paired_vector`
is the vector a measured mode is compared with, its declared mode or the combination whose
shape ratios lie deepest in the measured intervals (`_best_combination`). The rule in full:
docs/notes/verification.md, "Repeated frequencies: the rule in full".
"""

from __future__ import annotations

import numpy as np
import scipy.linalg as sla

#: Largest relative difference of two model frequencies that are taken as one repeated frequency
#: (`cluster`): far below what a measured frequency resolves, far above the split rounding leaves
#: in an exactly repeated pair (1.7e-10 on a square frame exported to ten digits).
REPEATED_GAP = 1e-8


def cluster(omega: np.ndarray, m: int) -> np.ndarray:
    """Indices of the model modes that repeat mode ``m`` (0-based, itself included): the
    consecutive modes whose frequencies each lie within `REPEATED_GAP` of the next.

    Parameters
    ----------
    omega : ndarray, shape (n_m,)
        Model frequencies, rad/s, ascending.
    m : int
        The mode, 0-based.

    Returns
    -------
    ndarray of int, ascending
    """
    omega = np.asarray(omega, dtype=float)
    close = np.abs(np.diff(omega)) <= REPEATED_GAP * np.maximum(np.abs(omega[:-1]), np.abs(omega[1:]))
    run = np.cumsum(np.r_[True, ~close])   # each mode's run of modes close to the next
    return np.flatnonzero(run == run[m])


def paired_vector(cfg, Phi_all: np.ndarray, omega_all: np.ndarray, k: int) -> tuple[np.ndarray, np.ndarray]:
    """The model vector paired with the ``k``-th (0-based) measured natural frequency of
    ``cfg``, shape (n,), and the modes of its frequency (`cluster`): the declared mode itself,
    or for a repeated frequency with a measured shape its `_best_combination` (ratio 1 at the
    shape's reference DOF).

    Parameters
    ----------
    cfg : Configuration
    Phi_all : ndarray, shape (n, n_m)
        The model's modes.
    omega_all : ndarray, shape (n_m,)
        Their frequencies, rad/s, ascending.
    """
    nat = cfg.natural[k]
    m = nat.mode - 1
    near = cluster(omega_all, m)
    if near.size == 1 or nat.shape is None or len(nat.shape.bounds) < 2:
        return Phi_all[:, m], near
    bounds = nat.shape.ratio_bounds()
    lo, hi = np.array(list(bounds.values()), dtype=float).T
    U = Phi_all[:, near]
    c = _best_combination(cfg.model.measurement(list(bounds)) @ U,
                          (cfg.model.measurement([nat.shape.reference]) @ U)[0], lo, hi)
    return (Phi_all[:, m] if c is None else U @ c), near


def paired_modes(cfg, f) -> np.ndarray:
    """`paired_vector` of every measured natural frequency of ``cfg``, shape (n, n_p): ``f.Phi``
    (a `vibupdate.inverse.correlation.ModelFrequencies`) with each mode of a repeated frequency
    that has a measured shape replaced by its best combination."""
    if not f.Phi_all.size:
        return f.Phi
    return np.column_stack([paired_vector(cfg, f.Phi_all, f.omega_all, k)[0] for k in range(len(cfg.natural))]
                           or [np.zeros((f.Phi.shape[0], 0))])


def _best_combination(U: np.ndarray, u: np.ndarray, lower: np.ndarray, upper: np.ndarray) -> np.ndarray | None:
    """The combination ``c`` of a cluster's vectors (``U`` at the ratios' DOFs, ``u`` at the
    reference) whose ratios ``U c`` at ``u c = 1`` lie deepest in ``[lower, upper]``: the better
    of the least-squares fit to the midpoints and the linear program of the largest distance
    outside (module docstring); None when every vector is zero at the reference."""
    from scipy.optimize import linprog

    norm = float(u @ u)
    if norm == 0.0 or not np.all(np.isfinite(U)):
        return None
    c0 = u / norm                                   # u c0 = 1
    N = sla.null_space(u[None, :])                  # k x (k - 1): directions keeping u c = 1
    mid = 0.5 * (lower + upper)
    z = np.linalg.lstsq(U @ N, mid - U @ c0, rcond=None)[0] if N.shape[1] else np.zeros(0)
    c_ls = c0 + N @ z

    def miss(c: np.ndarray) -> float:
        r = U @ c
        return float(np.max(np.maximum(np.maximum(lower - r, r - upper), 0.0), initial=0.0))

    best = miss(c_ls)
    scale = float(np.max(np.abs(U @ c_ls - mid), initial=0.0) + np.max(0.5 * (upper - lower), initial=0.0))
    if best == 0.0 or N.shape[1] == 0 or scale == 0.0:
        return c_ls
    # c = c_ls + scale N y; distance t scale: lower <= U c_ls + scale U N y + t scale, and above (the
    # LP solver's absolute tolerances then act relative to the least-squares fit's own miss)
    A = U @ N
    n_e, q = A.shape
    A_ub = np.vstack([np.column_stack([A, -np.ones(n_e)]), np.column_stack([-A, -np.ones(n_e)])])
    r0 = U @ c_ls
    b_ub = np.concatenate([(upper - r0) / scale, (r0 - lower) / scale])
    cost = np.zeros(q + 1)
    cost[-1] = 1.0
    sol = linprog(cost, A_ub=A_ub, b_ub=b_ub, bounds=[(None, None)] * q + [(0.0, None)], method="highs")
    if sol.status == 0:
        c_lp = c_ls + scale * (N @ sol.x[:q])
        if miss(c_lp) < best:
            return c_lp
    return c_ls

