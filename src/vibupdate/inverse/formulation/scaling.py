"""Scaling of the formulation: rotational entries by a characteristic length, residual rows by
the stiffness diagonal (docs/method.md, "Scaling of rotations and of residual rows"). The
blocks' bounds are in the scaled coordinates, and every matrix term is scaled once.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from vibupdate.inverse.formulation.options import ROTATION_PREFIXES, FormulationOptions


def length_scale(model, prefixes: Sequence[str] = ROTATION_PREFIXES) -> float:
    """Characteristic length from the stiffness diagonal: ``sqrt(3 median(K_rot) / median(K_tr))``.

    For a uniform Euler-Bernoulli mesh (``K_yy = 24 EI / l^3``, ``K_phiphi = 8 EI / l``) this
    is the element length ``l``. Returns 1 when the model has no rotational DOF.
    """
    rot = rotation_mask(model.dofs, prefixes)
    if not rot.any() or rot.all():
        return 1.0
    d = np.abs(model.K0.diagonal())
    kr, kt = np.median(d[rot]), np.median(d[~rot])
    return float(np.sqrt(3.0 * kr / kt)) if kr > 0 and kt > 0 else 1.0


def rotation_mask(dofs, prefixes) -> np.ndarray:
    """Which of ``dofs`` (names) are rotations, by their prefixes; shape (n,) of bool."""
    return np.array([d.startswith(tuple(prefixes)) for d in dofs], dtype=bool)


@dataclass(frozen=True)
class Scaling:
    """Scaling of one model's DOFs.

    Attributes
    ----------
    s : ndarray, shape (n,)
        Physical entry = ``s * scaled entry``, per DOF (``S``).
    dr : ndarray, shape (n,)
        Residual row scaling per DOF, ``diag(K0)^(-1/2)`` (``D_r``).
    """

    s: np.ndarray
    dr: np.ndarray


def scaling_of(model, options: FormulationOptions) -> Scaling:
    """The `Scaling` of ``model`` under ``options`` (its length scale, or the one from ``K0``)."""
    lc = options.length_scale or length_scale(model, options.rotation_prefixes)
    rot = rotation_mask(model.dofs, options.rotation_prefixes)
    s = np.where(rot, 1.0 / lc, 1.0)
    kd = np.abs(model.K0.diagonal())
    kd = np.where(kd > 0, kd, kd.max() if kd.max() > 0 else 1.0)   # a DOF without diagonal stiffness: no division by 0
    return Scaling(s=s, dr=1.0 / np.sqrt(kd))


@dataclass(frozen=True)
class ScaledTerms:
    """Every term of a configuration's affine form on its scaled coordinates, as one list of
    entries: term ``term`` (0 nominal, ``i + 1`` parameter ``i``) has ``D K S`` = ``k`` and
    ``D M S`` = ``m`` at ``(row, col)`` (``D`` the row scaling, ``S`` the entry scaling). The
    pattern of a term is the union of its ``K`` and ``M`` patterns."""

    n: int
    term: np.ndarray
    row: np.ndarray
    col: np.ndarray
    k: np.ndarray
    m: np.ndarray


def scaled_terms(model, scaling: Scaling) -> ScaledTerms:
    """The `ScaledTerms` of ``model``: every nominal and parameter matrix scaled once, the terms
    stacked one above the other (term ``t`` on rows ``t n`` to ``t n + n - 1``)."""
    n = model.n_dofs
    # K + iM keeps the union pattern: its real and imaginary parts cannot cancel.
    K, M = (sp.vstack([sp.csr_matrix(A, dtype=complex) for A in (A0, *parts)], format="csr")
            for A0, parts in ((model.K0, model.K_par), (model.M0, model.M_par)))
    C = sp.coo_matrix(K + 1j * M)
    term, row = np.divmod(C.row.astype(np.int64), n)
    col = C.col.astype(np.int64)
    factor = scaling.dr[row] * scaling.s[col]
    return ScaledTerms(n, term, row, col, factor * C.data.real, factor * C.data.imag)
