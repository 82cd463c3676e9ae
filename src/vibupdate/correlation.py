"""Correlation of a model with measured data: paired frequencies, errors (Eq. 26), MAC.

Pairing rules. The k-th measured natural frequency of a configuration is paired with the
model's k-th mode. A measured antiresonance of ``h_rc`` that lies after the k-th measured
natural frequency (and is the j-th such zero) is paired with the model's j-th antiresonance
of ``h_rc`` after its k-th natural frequency, so that pairing follows the pole/zero pattern
(Section 2.5) rather than mere closeness; where the model has no zero in that place, the
nearest model antiresonance is taken.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from vibupdate.analysis import antiresonances, mac, modes
from vibupdate.measured import TWO_PI, Configuration

__all__ = ["ModelFrequencies", "model_frequencies", "frequency_rows", "percent_error", "shape_mac"]


@dataclass(frozen=True)
class ModelFrequencies:
    """Model frequencies paired with one configuration's measured data.

    Attributes
    ----------
    natural : ndarray, shape (n_p,)
        rad/s, paired with ``Configuration.natural``.
    antiresonances : ndarray, shape (n_z,)
        rad/s, paired with ``Configuration.antiresonances``.
    Phi : ndarray, shape (n, n_p)
        Mass-normalized model modes paired with the natural frequencies.
    """

    natural: np.ndarray
    antiresonances: np.ndarray
    Phi: np.ndarray


def percent_error(model, measured) -> np.ndarray:
    """Absolute relative error in per cent, Eqs. 26-27."""
    model, measured = np.asarray(model, dtype=float), np.asarray(measured, dtype=float)
    return 100.0 * np.abs(model - measured) / np.abs(measured)


def model_frequencies(cfg: Configuration, xbar=None) -> ModelFrequencies:
    """Frequencies of ``cfg.model`` at ``xbar`` (nominal if None), paired with the data."""
    M, K = cfg.model.matrices(xbar)
    n_modes = min(cfg.model.n_dofs, max(len(cfg.natural), 1) + 1)
    omega, Phi = modes(M, K, n_modes)
    natural = omega[: len(cfg.natural)]
    measured_poles = np.array([f.omega for f in cfg.natural])
    zeros = np.full(len(cfg.antiresonances), np.nan)
    for rc in cfg.receptances():
        r, c = cfg.model.dof(rc[0]), cfg.model.dof(rc[1])
        model_z = antiresonances(M, K, r, c)
        if model_z.size == 0:
            continue
        for i, a in enumerate(cfg.antiresonances):
            if a.receptance != rc:
                continue
            k = int(np.sum(measured_poles < a.omega))
            j = sum(1 for b in cfg.antiresonances[:i]
                    if b.receptance == rc and np.sum(measured_poles < b.omega) == k)
            lo = omega[k - 1] if k >= 1 else 0.0
            hi = omega[k] if k < omega.size else np.inf
            candidates = model_z[(model_z > lo) & (model_z < hi)]
            if j < candidates.size:
                zeros[i] = candidates[j]
            else:
                zeros[i] = model_z[np.argmin(np.abs(model_z - a.omega))]
    return ModelFrequencies(natural, zeros, Phi[:, : len(cfg.natural)])


def shape_mac(cfg: Configuration, Phi: np.ndarray) -> np.ndarray:
    """MAC of each measured mode shape (interval midpoints on measured DOFs) with its paired
    model mode; NaN where no shape was measured. Shape (n_p,)."""
    out = np.full(len(cfg.natural), np.nan)
    for k, f in enumerate(cfg.natural):
        if f.shape is None or k >= Phi.shape[1]:
            continue
        mid = f.shape.midpoint
        idx = [cfg.model.dof(d) for d in mid]
        out[k] = mac(np.array(list(mid.values())), Phi[idx, k])[0, 0]
    return out


def frequency_rows(configurations: Sequence[Configuration], nominal: Sequence[ModelFrequencies],
                   updated: Sequence[ModelFrequencies] | None = None) -> list[dict]:
    """Rows of the ``frequencies`` table of ``results.json`` (DESIGN.md), Hz at the edge."""
    rows = []
    for i, cfg in enumerate(configurations):
        groups = (("natural", [f.omega for f in cfg.natural], "natural"),
                  ("antiresonance", [a.omega for a in cfg.antiresonances], "antiresonances"))
        for kind, measured, attr in groups:
            nom = getattr(nominal[i], attr)
            upd = getattr(updated[i], attr) if updated is not None else None
            for k, w in enumerate(measured):
                row = {
                    "configuration": cfg.name,
                    "kind": kind,
                    "index": k + 1,
                    "measured_hz": w / TWO_PI,
                    "nominal_hz": float(nom[k]) / TWO_PI,
                    "updated_hz": None if upd is None else float(upd[k]) / TWO_PI,
                    "error_nominal_pct": float(percent_error(nom[k], w)),
                    "error_updated_pct": None if upd is None else float(percent_error(upd[k], w)),
                }
                rows.append(row)
    return rows


def sensitivity(configurations: Sequence[Configuration], xbar) -> dict:
    """Relative sensitivity of the measured frequencies to the normalized parameters.

    ``S[k, i] = d omega_k / d xbar_i / omega_k`` over every measured natural frequency
    (analytic eigenvalue derivative, ``d(w^2) = phi^T (K_i - w^2 M_i) phi`` with
    mass-normalized ``phi``) and antiresonance (central differences). Its singular values
    tell how many parameter combinations the data determine.

    Returns
    -------
    dict
        ``matrix`` (n_data, n_x), ``singular_values``, ``condition``, ``rank`` (singular
        values above 1e-6 of the largest) and ``column_norm`` per parameter.
    """
    xbar = np.asarray(xbar, dtype=float)
    rows = []
    for cfg in configurations:
        model = cfg.model
        freqs = model_frequencies(cfg, xbar)
        for k in range(len(cfg.natural)):
            phi, w = freqs.Phi[:, k], freqs.natural[k]
            rows.append([phi @ ((Ki - w**2 * Mi) @ phi) / (2 * w**2) for Mi, Ki in zip(model.M_par, model.K_par)])
        if cfg.antiresonances:
            h = 1e-6
            cols = []
            for i in range(model.n_parameters):
                step = np.zeros_like(xbar)
                step[i] = h
                plus = model_frequencies(cfg, xbar + step).antiresonances
                minus = model_frequencies(cfg, xbar - step).antiresonances
                cols.append((plus - minus) / (2 * h) / freqs.antiresonances)
            rows.extend(np.array(cols).T.tolist())
    S = np.array(rows, dtype=float)
    sv = np.linalg.svd(S, compute_uv=False) if S.size else np.array([])
    rank = int(np.sum(sv > 1e-6 * sv[0])) if sv.size and sv[0] > 0 else 0
    return {
        "matrix": S,
        "singular_values": sv,
        "condition": float(sv[0] / sv[-1]) if sv.size and sv[-1] > 0 else float("inf"),
        "rank": rank,
        "column_norm": np.linalg.norm(S, axis=0),
    }
