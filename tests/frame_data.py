"""The generator of the frame example's bundled data (`vibupdate.examples.frame`): the true
model's modes with seeded noise, as the tests and the scaling benchmark make them again."""

from __future__ import annotations

import numpy as np

from vibupdate.damping.series import modal_damping
from vibupdate.examples import frame
from vibupdate.modal.analysis import modes


#: The Caughey law that generates the measured damping ratios: Y, beta.
DAMPING_LAW = ((0.0, 0.5, 1.0), (0.6, 2.0e-3, 2.0e-5))


def generate(frequency_error: float = frame.FREQUENCY_ERROR, shape_error: float = frame.SHAPE_ERROR,
             seed: int = frame.SEED, subdivisions: int = 1):
    """Measured data from the true model: 7 frequencies with relative noise, 7 damping ratios
    of the Caughey law `DAMPING_LAW`, and mode shapes at the translational DOFs with noise,
    given as intervals value +- 3 sigma.

    Returns
    -------
    frequencies : list of dict
        ``{"mode", "hz", "damping_ratio"}``.
    shapes : list of dict
        ``{"mode", "dof", "value", "tolerance"}`` with the shape scaled to unit largest
        measured entry.
    """
    rng = np.random.default_rng(seed)
    m = frame.model(subdivisions)
    values = frame.truth()
    M, K = m.matrices_at([values[p.name] for p in m.parameters])
    omega, Phi = modes(M, K, frame.N_MODES)
    hz = omega / (2 * np.pi) * (1 + frequency_error * rng.standard_normal(frame.N_MODES))
    ratios = modal_damping(DAMPING_LAW[0], DAMPING_LAW[1], omega)
    frequencies = [{"mode": k + 1, "hz": float(hz[k]), "damping_ratio": float(ratios[k])}
                   for k in range(frame.N_MODES)]
    idx = [m.dof(d) for d in frame.MEASURED_DOFS]
    shapes = []
    for k in range(frame.N_MODES):
        v = Phi[idx, k] / np.abs(Phi[idx, k]).max()
        sigma = shape_error
        noisy = v + sigma * rng.standard_normal(v.size)
        shapes += [{"mode": k + 1, "dof": d, "value": float(x), "tolerance": float(3 * sigma)}
                   for d, x in zip(frame.MEASURED_DOFS, noisy)]
    return frequencies, shapes
