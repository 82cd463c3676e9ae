"""The second stage over several configurations: measured damping ratios paired with the
updated model's natural frequencies, the Caughey fit, the Rayleigh baseline and their sanity
checks.
"""

from __future__ import annotations

import warnings
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from vibupdate.damping.sanity import checked_frequencies, damping_sanity
from vibupdate.damping.series import DampingFit, DampingWarning, fit_caughey


@dataclass(frozen=True)
class DampingStage:
    """The second stage over several configurations: a Caughey fit and its Rayleigh baseline.

    Both fits are made on the updated model's natural frequencies.

    Attributes
    ----------
    caughey : DampingFit
        The Caughey series fitted with the exponents asked for.
    rayleigh : DampingFit
        The Rayleigh baseline (``Y = [0, 1]``) on the same data, unweighted.
    warnings : tuple of str
        What `damping_sanity` found in either fit (negative modal damping within 1.5 times
        the highest measured frequency, or a damping matrix with negative eigenvalues), in
        words; empty when nothing.
    """

    caughey: DampingFit
    rayleigh: DampingFit
    warnings: tuple[str, ...] = ()

    def rows(self) -> list[dict]:
        """The ``damping`` rows of ``results.json``, plus the Rayleigh value of each ratio.

        Returns
        -------
        list of dict
            One row per measured ratio: ``configuration``, ``mode``, ``measured`` and
            ``identified`` ratios (dimensionless), ``error_pct``, and the Rayleigh baseline's
            ``rayleigh`` and ``error_rayleigh_pct``.
        """
        return [
            {"configuration": cfg, "mode": mode, "measured": float(m), "identified": float(c),
             "error_pct": float(e), "rayleigh": float(r), "error_rayleigh_pct": float(er)}
            for (cfg, mode), m, c, e, r, er in zip(
                self.caughey.labels, self.caughey.measured, self.caughey.fitted, self.caughey.errors_pct,
                self.rayleigh.fitted, self.rayleigh.errors_pct)
        ]

    def summary(self) -> dict:
        """The mean errors of both fits, as the ``summary`` of ``results.json`` holds them.

        Returns
        -------
        dict
            ``mean_damping_error_pct`` (Caughey fit) and ``mean_damping_error_rayleigh_pct``
            (Rayleigh baseline), in percent of the measured ratios.
        """
        return {"mean_damping_error_pct": self.caughey.mean_error_pct,
                "mean_damping_error_rayleigh_pct": self.rayleigh.mean_error_pct}


def damping_data(configurations, xbar=None, freqs=None):
    """Measured ratios with the paired updated-model frequencies: (omega, ratios, labels).

    ``freqs``: the `vibupdate.inverse.correlation.ModelFrequencies` of each configuration at
    ``xbar``, in their order (``UpdateResult.correlation.updated``), when already computed;
    solved here otherwise."""
    from vibupdate.inverse.correlation import model_frequencies

    omega, ratios, labels = [], [], []
    for i, cfg in enumerate(configurations):
        paired = freqs[i] if freqs is not None else None
        for k, f in enumerate(cfg.natural):
            if f.damping_ratio is None:
                continue
            paired = paired or model_frequencies(cfg, xbar, zeros=False)
            omega.append(paired.natural[k])
            ratios.append(f.damping_ratio)
            labels.append((cfg.name, f.mode))   # the model mode (`vibupdate.data.names`)
    if not ratios:
        raise ValueError("no measured damping ratio in any configuration: nothing to identify")
    return np.array(omega), np.array(ratios), tuple(labels)


@dataclass(frozen=True)
class DampingWeights:
    """The diagonal of ``W`` in Eq. 24, one entry per measured ratio, and the rule that made it.

    Attributes
    ----------
    weights : ndarray, shape (n_ratios,)
        ``W_ii`` in the order of the ratios' labels.
    rule : str
        The rule as the report states it (``"W_ii = w_mode / h_i^2 ..."``).
    """

    weights: np.ndarray
    rule: str


def damping_weights(labels, ratios, mode_weights=(), *, relative: bool = False,
                    half_widths=None) -> DampingWeights:
    """The weights of the damping fit of a case: ``W_ii = w_mode / h_i^2`` when every ratio has
    an interval (``h_i`` its half-width), else ``w_mode / xi_i^2`` when ``relative`` (relative
    errors), else ``w_mode``.

    Parameters
    ----------
    labels : sequence of (configuration, mode) pairs, one per measured ratio (`damping_data`).
    ratios : array_like, shape (n_ratios,)
        The measured damping ratios (dimensionless).
    mode_weights : sequence of (mode, factor) pairs
        ``w_mode`` by mode number, applied in every configuration; 1 for modes not named.
    relative : bool
        Weigh relative rather than absolute errors when the ratios have no intervals.
    half_widths : array_like, shape (n_ratios,), or None
        The half-widths of the ratios' intervals, or None when some ratio has none.
    """
    factors = dict(mode_weights)
    weights = np.array([float(factors.get(mode, 1.0)) for _, mode in labels])
    if half_widths is not None:
        half = np.asarray(half_widths, dtype=float)
        weights = weights / half**2
        rule = ("W_ii = w_mode / h_i^2, h_i the half-width of the measured ratio's interval ("
                + ", ".join(f"mode {mode}: {h:.3g}" for (_, mode), h in zip(labels, half)) + ")"
                + ("; the case's relative = true is superseded by the intervals" if relative else ""))
    else:
        if relative:
            weights = weights / np.asarray(ratios, dtype=float) ** 2
        rule = "W_ii = " + ("w_mode / xi_i^2 (relative errors)" if relative else "w_mode")
    rule += f" with w_mode = {factors}" if factors else " with w_mode = 1"
    return DampingWeights(weights, rule)


def identify_damping(configurations: Sequence, xbar=None, exponents=(0.0, 1.0), weights=None, *,
                     freqs=None) -> DampingStage:
    """Second stage: fit a Caughey series to the measured damping ratios on the updated model.

    Parameters
    ----------
    configurations : sequence of Configuration
        The measured configurations; the natural frequencies that carry a ``damping_ratio``
        are the data.
    xbar : array_like, shape (n_x,), optional
        Normalized parameters of the updated model (``UpdateResult.xbar``); the nominal values
        when None.
    exponents : array_like, shape (n_h,)
        The Caughey exponents ``Y`` (Eq. 20); ``(0, 1)`` is Rayleigh damping.
    weights : None, array_like or dict, optional
        None (equal weights); one weight per measured ratio, in configuration and mode order;
        a full matrix ``W`` (Eq. 24); or a mapping ``{mode number: weight}`` applied in every
        configuration.
    freqs : sequence of ModelFrequencies, optional
        The modal data of each configuration at ``xbar`` when already computed
        (``UpdateResult.correlation.updated``; `damping_data`): then no eigen-solve is repeated
        on the dense path.

    Returns
    -------
    DampingStage
        The Caughey fit, the Rayleigh baseline on the same data and the warnings of both.

    Raises
    ------
    ValueError
        No configuration has a measured damping ratio, the exponents repeat, or the weights
        are not positive (a matrix not symmetric positive definite) or not one per ratio.
    """
    omega, ratios, labels = damping_data(configurations, xbar, freqs)
    if isinstance(weights, dict):   # per mode number: one weight per data point
        for key, value in weights.items():
            if not isinstance(key, (int, np.integer)) or key < 1:
                raise ValueError(f"damping weight keys must be mode numbers >= 1, got {key!r}")
            if not np.isfinite(value) or value <= 0:
                raise ValueError(f"damping weight of mode {key} must be positive, got {value!r}")
        weights = np.array([float(weights.get(mode, 1.0)) for _, mode in labels])
    caughey = fit_caughey(omega, ratios, exponents, weights, labels)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DampingWarning)
        rayleigh = fit_caughey(omega, ratios, [0.0, 1.0], None, labels)
    frequencies = checked_frequencies(configurations, xbar, freqs)  # one spectrum per configuration for both checks
    checks = (damping_sanity(caughey, configurations, xbar, f"Caughey fit (Y = {caughey.exponents.tolist()})",
                             frequencies=frequencies)
              + damping_sanity(rayleigh, configurations, xbar, "Rayleigh baseline", frequencies=frequencies))
    return DampingStage(caughey, rayleigh, checks)
