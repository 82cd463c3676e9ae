"""Physical admissibility of a model: definiteness of ``M`` and ``K``, massless DOFs and
rigid-body modes, at the nominal point and over the parameter box (the rule as a user reads it:
docs/case-file.md, "Mass and stiffness").

Eigenvalues below ``t`` are counted by Sylvester's law of inertia on ``K - t M``
(`count_below`: dense eigenvalues up to `DENSE_LIMIT` DOFs, above that the pivot signs of a
sparse symmetric ``L D L^T``). The candidates for rigid-body modes, eigenvalues below
``RIGID_TOL * lam_ref`` (``lam_ref = max_i K_ii / M_ii`` over the DOFs with mass), are counted
rigid when zero within the rounding of their own mode (`vibupdate.modal.rigid`). ``M(xbar)``,
``K(xbar)`` being affine, the box is admissible when its corners are (`box_corners`); a box
reaching beyond the admissible region gets bounds inside it (`physical_box`) and a warning.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from vibupdate.modal.analysis import DENSE_LIMIT, MASSLESS_TOL, massless_dofs, modes
from vibupdate.modal import rigid as rigid_test
from vibupdate.modal.eigen import ModalAccuracyError, repeatable


#: Relative threshold (to ``lam_ref``) of a zero eigenvalue of the pencil ``(K, M)``.
RIGID_TOL = 1e-10
#: All corners are checked up to this many parameters (2^n corners), else a sample.
EXHAUSTIVE_PARAMETERS = 6
#: Seeded random corners checked besides all-lower and all-upper for larger boxes.
RANDOM_CORNERS = 14


@dataclass(frozen=True)
class Definiteness:
    """What `definiteness` found; ``problem`` is None for an admissible model.

    Attributes
    ----------
    massless : tuple of int
        Indices of DOFs without mass.
    rigid_body_modes : int
        Number of zero eigenvalues of the pencil ``(K, M)``.
    problem : str or None
        Why the model is not admissible, in words.
    """

    massless: tuple[int, ...]
    rigid_body_modes: int
    problem: str | None


def _dense(A) -> np.ndarray:
    return A.toarray() if sp.issparse(A) else np.asarray(A, dtype=float)


def count_below(A, B, t: float) -> int:
    """Number of eigenvalues of the symmetric pencil ``(A, B)`` below ``t``.

    Parameters
    ----------
    A, B : sparse or ndarray, shape (n, n)
        Symmetric; ``B`` positive semidefinite and ``A`` positive definite on its null space
        (or ``B`` the identity).
    t : float
        Threshold, in the units of ``A / B``.

    Returns
    -------
    int
        Negative eigenvalues of ``A - t B`` (Sylvester's law of inertia).
    """
    n = A.shape[0]
    if n <= DENSE_LIMIT:
        return int(np.sum(sla.eigvalsh(_dense(A) - t * _dense(B)) < 0))
    if sp.issparse(A) and sp.issparse(B):
        a, b = A.diagonal(), B.diagonal()
        if np.count_nonzero(a) == A.count_nonzero() and np.count_nonzero(b) == B.count_nonzero():
            return int(np.sum(a - t * b < 0))           # diagonal pencil (a lumped mass): its own eigenvalues
    S = sp.csc_matrix(A) - t * sp.csc_matrix(B)
    for nudge in (0.0, 1e-13, -1e-13):
        shifted = S if nudge == 0 else S + nudge * abs(S).max() * sp.eye(n, format="csc")
        try:
            lu = spla.splu(sp.csc_matrix(shifted), permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=0.0,
                           options={"SymmetricMode": True})
        except RuntimeError:  # an exactly zero pivot: move off the singular point
            continue
        if np.array_equal(lu.perm_r, lu.perm_c):
            return int(np.sum(lu.U.diagonal() < 0))
    # SuperLU left the symmetric ordering: count with shift-invert eigenvalues near t
    k = min(n - 2, 20)
    vals = spla.eigsh(sp.csc_matrix(A), k=k, M=sp.csc_matrix(B) + 1e-12 * sp.eye(n), sigma=t, which="LM",
                      return_eigenvectors=False, **repeatable(n))
    below = int(np.sum(vals < t))
    if below == k:
        raise ValueError(f"could not count the eigenvalues below {t:g}: at least {k} (the inertia "
                         "factorization did not keep a symmetric ordering)")
    return below


def _lowest(A, B) -> float | None:
    """Lowest eigenvalue of the pencil for small models (for messages), else None."""
    if A.shape[0] > DENSE_LIMIT:
        return None
    return float(sla.eigh(_dense(A), _dense(B), eigvals_only=True, subset_by_index=[0, 0])[0])


def definiteness(M, K, precision: float | None = None) -> Definiteness:
    """Check ``M`` and ``K`` of one model (module docstring).

    Parameters
    ----------
    M, K : sparse or ndarray, shape (n, n)
        Symmetric mass and stiffness matrices (SI units).
    precision : float, optional
        Relative precision of their entries (a model's ``matrix_precision``), the rounding
        unit that tells a rigid-body mode from a negative eigenvalue; None: double precision.

    Returns
    -------
    Definiteness
    """
    small = M.shape[0] <= DENSE_LIMIT
    if small:   # dense arrays: small models are checked many times (box corners)
        M, K = _dense(M), _dense(K)
    else:
        M, K = sp.csr_matrix(M), sp.csr_matrix(K)

    def block(A, rows, cols):
        return A[np.ix_(rows, cols)] if small else A[rows][:, cols]

    def eye(n):
        return np.eye(n) if small else sp.identity(n, format="csr")

    d = M.diagonal()
    scale = float(np.max(np.abs(d))) if d.size else 0.0
    if not scale > 0:
        return Definiteness((), 0, "the mass matrix M has no positive diagonal entry (no DOF carries mass)")
    if np.any(d < -MASSLESS_TOL * scale):
        i = int(np.argmin(d))
        return Definiteness((), 0, f"the mass matrix M is not positive semidefinite: negative diagonal entry "
                                   f"{d[i]:.6g} (DOF {i + 1})")
    massless = massless_dofs(M)
    mass = np.setdiff1d(np.arange(M.shape[0]), massless)
    if massless.size:
        rows = block(M, massless, np.arange(M.shape[0]))
        coupling = float(abs(rows).max()) if rows.size else 0.0
        if coupling > MASSLESS_TOL * scale:
            return Definiteness(tuple(massless), 0, "the mass matrix M is not positive semidefinite: a DOF without "
                                                    "mass on the diagonal is coupled to others by M")
    Mm = block(M, mass, mass)
    dm = Mm.diagonal()
    if count_below(Mm / dm.max(), eye(mass.size), MASSLESS_TOL) > 0:
        low = _lowest(Mm, eye(mass.size))
        shown = f" (lowest eigenvalue {low:.6g})" if low is not None else ""
        return Definiteness(tuple(massless), 0,
                            f"the mass matrix M is not positive definite on the DOFs that carry mass{shown}")
    kd = K.diagonal()
    if massless.size:
        Ks = block(K, massless, massless)
        ks = max(float(np.max(np.abs(Ks.diagonal()))), 1e-300)
        if count_below(Ks / ks, eye(massless.size), RIGID_TOL) > 0:
            return Definiteness(tuple(massless), 0,
                                f"the stiffness matrix K is not positive definite on the {massless.size} DOF(s) "
                                "without mass, so they cannot be condensed (a massless DOF must be held by stiffness)")
    lam_ref = float(np.max(np.abs(kd[mass]) / dm))
    if not lam_ref > 0:
        return Definiteness(tuple(massless), 0, "the stiffness matrix K is zero on every DOF that carries mass")
    # the candidates' threshold grows with the entries' rounding unit, as the test below does
    tol = RIGID_TOL * rigid_test.unit(precision) / rigid_test.EPS
    below = count_below(K, M, tol * lam_ref)      # candidates: rigid-body modes and any negative ones
    negative = count_below(K, M, -tol * lam_ref) if below else 0
    rigid, rounding_note = 0, ""
    finite = M.shape[0] - massless.size
    if below >= finite > 1 and precision is not None and precision > rigid_test.EPS:
        # every mode is a candidate: the entries' rounding hides the whole spectrum
        raise ModalAccuracyError(f"all {finite} modes of the model lie within the rounding of zero at the matrices' "
                                 f"relative precision {precision:g}, which cannot tell its lowest modes from zero: "
                                 "matrices written with more digits are needed")
    if below and not negative:
        # told apart by the rounding of each mode's own Rayleigh quotient (`vibupdate.modal.rigid`):
        # the threshold above, relative to the largest K_ii / M_ii, takes flexible modes of
        # finely meshed models for rigid ones (4 on the 3,893-DOF refined frame)
        omega, Phi = modes(M, K, min(below, M.shape[0] - massless.size), precision=precision)
        rigid = int(np.count_nonzero(omega == 0))
        negative = int(np.count_nonzero(omega < 0))
        if negative:
            rounding_note = _rounding_note(M, K, omega, Phi, precision)
    if negative:
        low = _lowest(K, M) if not massless.size else None
        shown = (f"; lowest eigenvalue of (K, M) {low:.6g} (rad/s)^2" if low is not None else "")
        return Definiteness(tuple(massless), 0, f"the stiffness matrix K is not positive semidefinite: {negative} "
                                                f"negative eigenvalue(s){shown}{rounding_note}")
    return Definiteness(tuple(int(i) for i in massless), rigid, None)


#: A negative eigenvalue that entries rounded to this relative precision or finer would explain
#: is reported as possibly the rounding of an export written with fewer digits
#: (`_rounding_note`): 1e-5 is about the 5 to 6 significant digits of an 8-character field.
ROUNDING_NOTE_PRECISION = 1e-5


def _rounding_note(M, K, omega, Phi, precision) -> str:
    """What to say of the negative eigenvalues (``omega < 0``) of matrices whose precision was
    not stated (``precision`` None): the relative precision of the entries at which the
    rigid-body test (`vibupdate.modal.rigid`) would count the most negative one as zero, and
    the key that states it, when that is `ROUNDING_NOTE_PRECISION` or finer. With a stated
    precision, that they lie beyond its rounding."""
    neg = omega < 0
    if precision is not None:
        return f" (beyond the rounding of entries known to the stated relative precision {precision:.3g})"
    scale = rigid_test.rounding_scale(M, K, Phi[:, neg]) / rigid_test.EPS     # |u|^T |K| |u| / u^T M u
    with np.errstate(divide="ignore"):   # a vector K does not touch (scale 0): no rounding explains it
        needed = float(np.max(omega[neg] ** 2 / (rigid_test.RIGID_FACTOR * scale)))
    if not needed <= ROUNDING_NOTE_PRECISION:
        return ""
    return (f" ({'it is' if neg.sum() == 1 else 'they are'} as small as rounding of the entries to a relative "
            f"precision of {needed:.2g} would make {'it' if neg.sum() == 1 else 'them'}; double precision is "
            "assumed: if the matrices were written with fewer significant digits, state their precision with "
            "matrix_precision in [model], docs/case-file.md)")


def box_corners(lower, upper, *, seed: int = 0) -> list[tuple[str, np.ndarray]]:
    """Corners of the box ``[lower, upper]`` (normalized parameters) to check.

    All ``2^n`` corners up to `EXHAUSTIVE_PARAMETERS` parameters; otherwise all-lower,
    all-upper and `RANDOM_CORNERS` corners drawn with ``numpy.random.default_rng(seed)``.
    Fixed parameters (``lower == upper``) stay at their value.

    Returns
    -------
    list of (ndarray of bool, ndarray of float), each shape (n,)
        Which parameters are at their upper bound, and the corner's ``xbar``.
    """
    lower, upper = np.asarray(lower, float), np.asarray(upper, float)
    n = lower.size
    if n <= EXHAUSTIVE_PARAMETERS:
        picks = [np.array(bits, dtype=bool) for bits in itertools.product((False, True), repeat=n)]
    else:
        rng = np.random.default_rng(seed)
        picks = [np.zeros(n, bool), np.ones(n, bool)] + [rng.random(n) < 0.5 for _ in range(RANDOM_CORNERS)]
    out, seen = [], set()
    for up in picks:
        x = np.where(up, upper, lower)
        key = x.tobytes()
        if key not in seen:
            seen.add(key)
            out.append((up, x))
    return out


#: Bisection steps of `physical_box` along an axis or a common shrink factor.
BISECTION_STEPS = 12
#: How far the solver's bound stays inside the last admissible point found, as a fraction of
#: its distance from the nominal value.
BOUND_MARGIN = 0.01


@dataclass(frozen=True)
class PhysicalBox:
    """Bounds (normalized, Eq. 12) inside which a model with an admissible nominal point stays
    admissible with the nominal number of rigid-body modes, and what was found beyond.

    Attributes
    ----------
    lower, upper : ndarray, shape (n_x,)
        The bounds for the solver; the model's own where nothing was found.
    findings : tuple of str
        Per corner or bound that was not admissible: where, and what.
    """

    lower: np.ndarray
    upper: np.ndarray
    findings: tuple[str, ...]

    @property
    def changed(self) -> bool:
        return bool(self.findings)


def _admissible(model, xbar, rigid: int) -> str | None:
    """None where ``M``, ``K`` at ``xbar`` are admissible with ``rigid`` rigid-body modes, else why."""
    found = definiteness(*model.matrices(xbar), model.matrix_precision)
    if found.problem:
        return found.problem
    if found.rigid_body_modes != rigid:
        return (f"K is singular there: {found.rigid_body_modes} rigid-body mode(s) where the nominal model has "
                f"{rigid} (a stiffness reaches zero)")
    return None


def _last_admissible(model, rigid: int, start, end) -> float:
    """Largest ``t`` in [0, 1] found by bisection with ``start + t (end - start)`` admissible
    (``start`` is)."""
    good, bad = 0.0, 1.0
    for _ in range(BISECTION_STEPS):
        mid = 0.5 * (good + bad)
        if _admissible(model, start + mid * (end - start), rigid) is None:
            good = mid
        else:
            bad = mid
    return good


def physical_box(model, rigid: int, describe) -> PhysicalBox:
    """Bounds for the solver that keep an admissible nominal model admissible (module docstring).

    Each bound is tried alone (the other parameters nominal); one that is not admissible is
    moved toward the nominal value to the last admissible point found by `BISECTION_STEPS`
    bisections, less `BOUND_MARGIN` of its distance from the nominal. Then the corners of the
    resulting box (`box_corners`) are checked; if one is still not admissible the whole box is
    shrunk toward the nominal point by one common factor, found the same way. ``describe(up)``
    names a corner in words.

    Parameters
    ----------
    model : AffineModel
    rigid : int
        Rigid-body modes of the nominal model.
    describe : callable
        ``describe(up)`` for ``up`` a bool array (which parameters at their upper bound).

    Returns
    -------
    PhysicalBox
    """
    lower, upper = (np.array(b, dtype=float) for b in model.bounds())
    x0 = np.zeros(lower.size)
    findings = []
    bad_corners = [(up, why) for up, x in box_corners(lower, upper)
                   if (why := _admissible(model, x, rigid)) is not None]
    if not bad_corners:
        return PhysicalBox(lower, upper, ())
    findings.append(f"at the corner with {describe(bad_corners[0][0])}: {bad_corners[0][1]}")
    for i, p in enumerate(model.parameters):
        for side, bounds in (("lower", lower), ("upper", upper)):
            if bounds[i] == 0.0:
                continue
            end = x0.copy()
            end[i] = bounds[i]
            why = _admissible(model, end, rigid)
            if why is None:
                continue
            t = _last_admissible(model, rigid, x0, end) * (1.0 - BOUND_MARGIN)
            new = t * bounds[i]
            old_value, new_value = p.nominal + bounds[i] * p.reference, p.nominal + new * p.reference
            findings.append(f"parameter '{p.name}' at its {side} bound {old_value:.6g} {p.unit}".rstrip()
                            + f": {why}; the solver keeps {p.name} {'>=' if side == 'lower' else '<='} "
                            f"{new_value:.6g} {p.unit}".rstrip())
            bounds[i] = new
    still = [x for _, x in box_corners(lower, upper) if _admissible(model, x, rigid) is not None]
    if still:
        factor = min(_last_admissible(model, rigid, x0, x) for x in still) * (1.0 - BOUND_MARGIN)
        lower, upper = factor * lower, factor * upper
        findings.append(f"corners of the box combine to a model that is not admissible; the solver's box is shrunk "
                        f"toward the nominal point to {factor:.4g} of its size")
    return PhysicalBox(lower, upper, tuple(findings))
