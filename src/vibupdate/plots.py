"""PNG plots of a run: FRFs nominal vs updated (as Fig. 11), homotopy objective, MAC matrix.

matplotlib is imported inside the functions, with the non-interactive Agg backend.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from vibupdate.analysis import receptance
from vibupdate.measured import TWO_PI

__all__ = ["plot_frf", "plot_homotopy", "plot_mac"]


def _pyplot():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def _finish(plt, fig, ax, path, xlabel: str, ylabel: str, title: str) -> Path:
    """Labels, legend and grid, then save as PNG and close."""
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    ax.set_title(title)
    ax.legend(fontsize=8)
    ax.grid(True, which="both", alpha=0.3)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return Path(path)


def plot_frf(path, cfg, nominal, updated, r: int, c: int, label: str) -> Path:
    """|h_rc| of the nominal and updated models of one configuration, measured frequencies
    marked (natural: solid, antiresonance: dashed).

    Parameters
    ----------
    nominal, updated : tuple (M, K, C)
        Matrices of the two models, ``C`` possibly None (undamped, and labelled so). Each
        curve uses its own model's damping: never the updated ``C`` on the nominal curve.
    r, c : int
        Response and excitation DOF indices.
    label : str
        ``h_{r,c}`` for the title.
    """
    plt = _pyplot()
    measured = [f.omega for f in cfg.natural] + [a.omega for a in cfg.antiresonances]
    top = 1.25 * max(measured) if measured else 1.0
    omega = np.linspace(top / 2000, top, 2000)
    fig, ax = plt.subplots(figsize=(7.5, 4.2))
    for (M, K, C), name, style in ((nominal, "nominal", "--"), (updated, "updated", "-")):
        h = receptance(M, K, r, c, omega, C)
        ax.semilogy(omega / TWO_PI, np.abs(h), style, label=f"{name} model" + (" (undamped)" if C is None else ""))
    for i, f in enumerate(cfg.natural):
        ax.axvline(f.omega / TWO_PI, color="0.3", lw=0.8, label="measured natural" if i == 0 else None)
    for i, a in enumerate(cfg.antiresonances):
        ax.axvline(a.omega / TWO_PI, color="tab:red", lw=0.8, ls=":", label="measured antiresonance" if i == 0 else None)
    return _finish(plt, fig, ax, path, "frequency [Hz]", f"|{label}| [m/N]",
                   f"configuration {cfg.name}: receptance {label}")


def plot_homotopy(path, steps) -> Path:
    """Objective of every solve against lambda (log scale)."""
    plt = _pyplot()
    fig, ax = plt.subplots(figsize=(6, 3.8))
    lam = [s["lambda"] for s in steps]
    obj = [max(s["objective"], 1e-300) for s in steps]
    ok = [s["status"] in ("success", "acceptable") for s in steps]
    ax.semilogy(lam, obj, "-", color="0.6")
    lam, obj, ok = np.array(lam), np.array(obj), np.array(ok, dtype=bool)
    ax.semilogy(lam[ok], obj[ok], "o", label="converged")
    if not ok.all():
        ax.semilogy(lam[~ok], obj[~ok], "x", color="tab:red", label="failed")
    return _finish(plt, fig, ax, path, "lambda", "objective", "homotopy path")


def plot_mac(path, matrix: np.ndarray, title: str) -> Path:
    """MAC matrix, measured modes (rows) against updated model modes (columns)."""
    plt = _pyplot()
    fig, ax = plt.subplots(figsize=(4.6, 4))
    im = ax.imshow(matrix, vmin=0, vmax=1, cmap="viridis")
    n, m = matrix.shape
    for i in range(n):
        for j in range(m):
            ax.text(j, i, f"{matrix[i, j]:.2f}", ha="center", va="center",
                    color="white" if matrix[i, j] < 0.6 else "black", fontsize=7)
    ax.set_xticks(range(m), [str(j + 1) for j in range(m)])
    ax.set_yticks(range(n), [str(i + 1) for i in range(n)])
    ax.set_xlabel("updated model mode")
    ax.set_ylabel("measured mode")
    ax.set_title(title)
    fig.colorbar(im, ax=ax, fraction=0.046)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return Path(path)
