"""The unknown vectors of the formulation: one block per measured natural frequency (a mode,
Eq. 7) and per measured antiresonance (an adjunct eigenvector, Eq. 9), each with its
normalization, bounds and start (docs/method.md, section 4, "Normalization against the trivial
solution" and "Boxes of unmeasured entries"). The interlacing transforms a block's bounds, the
stacking turns it into rows, and the ranges read it.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from vibupdate.data.measured import Configuration
from vibupdate.inverse.correlation import model_frequencies
from vibupdate.inverse.formulation.options import FormulationOptions
from vibupdate.inverse.formulation.scaling import Scaling, scaling_of
from vibupdate.inverse.repeated import paired_vector
from vibupdate.modal.analysis import antiresonance_vectors


@dataclass(frozen=True)
class VectorBlock:
    """One unknown vector: a mode (natural block) or an adjunct eigenvector.

    Entries are in scaled coordinates: physical value = ``scale * entry``.

    Attributes
    ----------
    configuration : str
    kind : {"natural", "antiresonance"}
    index : int
        1-based within kind and configuration.
    omega : float
        Measured frequency, rad/s.
    alpha : float
        Weight of the block's squared residual.
    rows, cols : ndarray of int
        DOF indices of the residual rows and of the vector entries.
    scale : ndarray, shape (len(cols),)
    lower, upper, start : ndarray, shape (len(cols),)
        Bounds and starting value of every entry; ``lower == upper`` for fixed entries.
    fixed : ndarray of bool, shape (len(cols),)
    receptance : tuple of str, optional
        ``(r, c)`` of an antiresonance block.
    measured : ndarray of bool, shape (len(cols),), optional
        Entries whose bounds come from a measured interval (the others from a margin).
    """

    configuration: str
    kind: str
    index: int
    omega: float
    alpha: float
    rows: np.ndarray
    cols: np.ndarray
    scale: np.ndarray
    lower: np.ndarray
    upper: np.ndarray
    start: np.ndarray
    fixed: np.ndarray
    receptance: tuple[str, str] | None = None
    measured: np.ndarray | None = None

    @property
    def n_free(self) -> int:
        return int(np.count_nonzero(~self.fixed))

    def with_bounds(self, lower, upper) -> "VectorBlock":
        lower, upper = np.asarray(lower, float), np.asarray(upper, float)
        return replace(self, lower=lower, upper=upper, start=np.clip(self.start, lower, upper))


def natural_block(cfg: Configuration, k: int, v0_phys: np.ndarray, scaling: Scaling,
                  options: FormulationOptions) -> VectorBlock:
    """Block of the k-th (0-based) natural frequency of a configuration, from the nominal mode
    ``v0_phys`` (physical units, shape (n,))."""
    model, f = cfg.model, cfg.natural[k]
    n = model.n_dofs
    cols = np.arange(n)
    v0 = v0_phys / scaling.s
    lower = np.full(n, -np.inf)
    upper = np.full(n, np.inf)
    measured = np.zeros(n, dtype=bool)
    shape = f.shape.on_dofs(model) if f.shape is not None else None   # sensors: the box they imply on DOFs
    if shape is not None:
        idx = np.array([model.dof(d) for d in shape.bounds])
        lo = np.array([b[0] for b in shape.bounds.values()]) / scaling.s[idx]
        hi = np.array([b[1] for b in shape.bounds.values()]) / scaling.s[idx]
        mid = 0.5 * (lo + hi)
        j_local = int(np.argmax(np.abs(mid)))
        ref = mid[j_local]
        if ref == 0:
            raise ValueError(f"configuration {cfg.name!r}, mode {k + 1}: the measured mode shape is zero")
        lo, hi = np.minimum(lo / ref, hi / ref), np.maximum(lo / ref, hi / ref)
        lower[idx], upper[idx] = lo, hi
        measured[idx] = True
        j = int(idx[j_local])
    else:   # the first receptance's response DOF unless near a node there, else the largest entry
        j, receptances = int(np.argmax(np.abs(v0))), cfg.receptances()
        if receptances and abs(v0[cfg.model.dof(receptances[0][0])]) >= 1e-3 * abs(v0[j]):
            j = cfg.model.dof(receptances[0][0])
    if v0[j] == 0:
        raise ValueError(f"configuration {cfg.name!r}, mode {k + 1}: the nominal mode is zero at its "
                         "normalization entry")
    v0n = v0 / v0[j]
    # Unmeasured entries within shape_margin times the nominal mode's largest entry, relative to
    # its normalization entry or, with a measured shape, its largest measured entry
    # (docs/notes/homotopy.md, "Boxes of unmeasured entries relative to the measured reference").
    ref_size = np.max(np.abs(v0[idx])) if shape is not None else abs(v0[j])
    bound = options.shape_margin * max(1.0, np.max(np.abs(v0)) / ref_size)
    lower = np.where(np.isfinite(lower), lower, -bound)
    upper = np.where(np.isfinite(upper), upper, bound)
    lower[j] = upper[j] = 1.0
    fixed = lower == upper
    return VectorBlock(cfg.name, "natural", k + 1, f.omega, f.weight, cols, cols, scaling.s.copy(),
                       lower, upper, np.clip(v0n, lower, upper), fixed, measured=measured)


def adjunct_block(cfg: Configuration, k: int, index: int, scaling: Scaling,
                  options: FormulationOptions) -> VectorBlock:
    """Block of the k-th (0-based) antiresonance of a configuration, started from the nominal
    model's adjunct eigenvector of the declared zero."""
    model, a = cfg.model, cfg.antiresonances[k]
    r, c = model.dof(a.response), model.dof(a.excitation)
    n = model.n_dofs
    rows, cols = np.delete(np.arange(n), c), np.delete(np.arange(n), r)
    zs, V = antiresonance_vectors(model.M0, model.K0, r, c, precision=model.matrix_precision)
    if zs.size == 0:
        raise ValueError(
            f"configuration {cfg.name!r}: the nominal model has no antiresonance of "
            f"h_{a.response},{a.excitation}, so no start vector for the measured {a.freq_hz:.4g} Hz"
        )
    if a.index > zs.size:
        raise ValueError(
            f"configuration {cfg.name!r}: the measured {a.freq_hz:.4g} Hz is declared antiresonance {a.index} of "
            f"h_{a.response},{a.excitation}, but the nominal model has only {zs.size} such zeros")
    m = a.index - 1
    v0 = V[:, m] / scaling.s[cols]
    j = int(np.argmax(np.abs(v0)))
    v0n = v0 / v0[j]
    bound = options.adjunct_margin * max(1.0, np.max(np.abs(v0n)))
    lower, upper = np.full(n - 1, -bound), np.full(n - 1, bound)
    lower[j] = upper[j] = 1.0
    return VectorBlock(cfg.name, "antiresonance", index, a.omega, a.weight, rows, cols,
                       scaling.s[cols].copy(), lower, upper, np.clip(v0n, lower, upper),
                       lower == upper, (a.response, a.excitation))


def build_blocks(configurations, options: FormulationOptions, nominal=None):
    """The blocks of every configuration, the index of the configuration of each block, and
    the scaling of each configuration.

    ``nominal``: the nominal models' `vibupdate.inverse.correlation.ModelFrequencies`, one per
    configuration, when the caller has them (else solved here).
    """
    blocks, owners, scalings = [], [], []
    for i, cfg in enumerate(configurations):
        scaling = scaling_of(cfg.model, options)
        scalings.append(scaling)
        modes = nominal[i] if nominal is not None else model_frequencies(cfg, zeros=False)
        for k in range(len(cfg.natural)):   # a repeated frequency's mode: the combination nearest its shape
            v0 = paired_vector(cfg, modes.Phi_all, modes.omega_all, k)[0] if modes.Phi_all.size else modes.Phi[:, k]
            blocks.append(natural_block(cfg, k, v0, scaling, options))
        for k in range(len(cfg.antiresonances)):
            blocks.append(adjunct_block(cfg, k, k + 1, scaling, options))
        owners.extend([i] * (len(cfg.natural) + len(cfg.antiresonances)))
    return blocks, owners, scalings
