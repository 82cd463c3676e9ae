"""Model vectors read at measured points: a DOF index or a sensor's weights (a row of the
measurement map, `vibupdate.model.AffineModel.measurement`), and the derivatives of a mode's
ratios of readings. A leaf of `vibupdate.modal`: the eigen-solutions' refinement and the
sensitivities both read through it, so it imports neither."""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp


def readings(X, where):
    """The readings of ``X`` (a vector, shape (n,), or vectors, shape (n, k)) at ``where``: DOF
    indices (an int or a sequence of them: ``X[where]``) or a measurement map (sparse, shape
    (n_r, n): ``where @ X``, `vibupdate.model.AffineModel.measurement`). One entry point for the
    code that reads model vectors at measured points, so a DOF index and a sensor's weights are
    read alike."""
    if isinstance(where, np.ndarray) and where.dtype.kind == "i":   # DOF indices (the common case, first)
        return X[where]
    if sp.issparse(where):
        return where @ X
    return X[where] if isinstance(where, (int, np.integer)) else X[np.asarray(where, dtype=int)]


def ratio_derivatives(V, phi, entries, reference) -> np.ndarray:
    """The derivatives ``(V_e * phi_p - phi_e V_p) / phi_p^2``, shape (n_e, n_x), of the
    ratios of the readings ``e`` of ``phi`` to its reading ``p``, from solutions ``V`` (n, n_x)
    of the module docstring (any multiple of ``phi`` in them cancels). ``entries`` and
    ``reference`` are DOF indices or measurement maps (`readings`)."""
    ref = readings(phi, reference)
    return (readings(V, entries) * ref - np.outer(readings(phi, entries), readings(V, reference))) / ref**2
