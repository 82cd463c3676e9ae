"""PNG plots of a run: FRFs nominal vs updated (as Fig. 11), homotopy objective, MAC matrix.

matplotlib is imported inside the functions, with the non-interactive Agg backend.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from vibupdate._extras import require
from vibupdate.modal.analysis import receptances
from vibupdate.data.measured import TWO_PI

__all__ = ["plot_frf", "plot_measured_frf", "plot_homotopy", "plot_mac", "model_receptance", "model_receptances"]


def _pyplot():
    require("plots", "drawing plots")
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
    return _save(plt, fig, path)


def _save(plt, fig, path) -> Path:
    """Save ``fig`` as PNG at ``path`` and close it."""
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return Path(path)


def model_receptances(model, pairs, omega) -> np.ndarray:
    """Receptances of several ``(r, c)`` pairs of ``model = (M, K, C)``, from one eigen-solve
    (or one factorization per frequency) shared by the pairs.

    Parameters
    ----------
    model : tuple (M, K, C)
        ``C`` a matrix, None (undamped) or a damping law with its own ``receptances`` (large
        models: modal superposition).
    pairs : sequence of (int, int), length n_pairs
        Response and excitation DOF indices (0-based).
    omega : ndarray, shape (n_f,)
        rad/s.

    Returns
    -------
    ndarray of complex, shape (n_pairs, n_f)
        m/N.
    """
    M, K, C = model
    if hasattr(C, "receptances"):
        return C.receptances(M, K, pairs, omega)
    return receptances(M, K, pairs, omega, C)


def model_receptance(model, r: int, c: int, omega) -> np.ndarray:
    """Receptance of one pair of ``model = (M, K, C)`` (`model_receptances`); shape (n_f,), m/N."""
    return model_receptances(model, [(r, c)], omega)[0]


def _nominal_curve(nominal, updated):
    """The model whose receptance draws the nominal curve.

    On a large model the updated curve is the modal sum of its damping law (`CaugheyLaw`); an
    undamped nominal model is then drawn by the same modal sum with zero damping, over the
    same modes, instead of one sparse LU per plotted line: on a 30,315-DOF frame those 2,000
    LUs took 585 s of a 780 s `vibupdate run`. Both curves are then truncated alike, above
    1.25 times the highest measured frequency only (`caughey_damping` chooses the modes).
    """
    from vibupdate.damping import CaugheyLaw

    M, K, C = nominal
    law = updated[2]
    if C is None and isinstance(law, CaugheyLaw):
        return (M, K, CaugheyLaw((), (), law.n_modes))
    return nominal


def _damping_note(C) -> str:
    if hasattr(C, "receptance"):
        return f" ({'damping law' if C.beta else 'undamped'}, {C.n_modes} modes)"
    return " (undamped)" if C is None else ""


def plot_frf(path, cfg, nominal, updated, r: int, c: int, label: str) -> Path:
    """|h_rc| of the nominal and updated models of one configuration, measured frequencies
    marked (natural: solid, antiresonance: dashed).

    Parameters
    ----------
    nominal, updated : tuple (M, K, C)
        Matrices of the two models, ``C`` possibly None (undamped, and labelled so) or a
        `vibupdate.damping.CaugheyLaw` (large models: modal superposition). Each curve uses its
        own model's damping: never the updated ``C`` on the nominal curve.
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
    for (M, K, C), name, style in ((_nominal_curve(nominal, updated), "nominal", "--"), (updated, "updated", "-")):
        h = model_receptance((M, K, C), r, c, omega)
        ax.semilogy(omega / TWO_PI, np.abs(h), style, label=f"{name} model{_damping_note(C)}")
    for i, f in enumerate(cfg.natural):
        ax.axvline(f.omega / TWO_PI, color="0.3", lw=0.8, label="measured natural" if i == 0 else None)
    for i, a in enumerate(cfg.antiresonances):
        ax.axvline(a.omega / TWO_PI, color="tab:red", lw=0.8, ls=":", label="measured antiresonance" if i == 0 else None)
    return _finish(plt, fig, ax, path, "frequency [Hz]", f"|{label}| [m/N]",
                   f"configuration {cfg.name}: receptance {label}")


def plot_measured_frf(path, frfs, model_dofs, nominal, updated, title: str, nominal_label: str,
                      updated_label: str) -> Path:
    """Measured FRFs overlaid on the nominal and updated model FRFs (the paper's Fig. 11).

    One panel per measured pair ``(response, excitation)`` whose DOFs are in the model (a
    grid of responses by excitations when the pairs form one).

    Parameters
    ----------
    frfs : vibupdate.data.frf.FRFSet
        Measured receptances, m/N, on ``frfs.omega`` (rad/s); the mean of the repeats is drawn.
    model_dofs : sequence of str
        DOF names of the model, in matrix order.
    nominal, updated : tuple (M, K, C)
        Matrices of the two models, ``C`` possibly None (undamped: say so in the labels).
    title : str
    nominal_label, updated_label : str
        Legend entries of the two models (their damping stated).
    """
    plt = _pyplot()
    position = {d: i for i, d in enumerate(model_dofs)}
    pairs = [(k, p) for k, p in enumerate(frfs.pairs) if p[0] in position and p[1] in position]
    if not pairs:
        raise ValueError(f"no measured FRF pair {list(frfs.pairs)} has both DOFs in the model")
    rows = sorted({p[0] for _, p in pairs}, key=position.get)
    cols = sorted({p[1] for _, p in pairs}, key=position.get)
    grid = len(rows) * len(cols) <= 16 and len(rows) * len(cols) < 2 * len(pairs)
    if not grid:
        rows, cols = [None] * len(pairs), [None]
    fig, axes = plt.subplots(len(rows), len(cols), figsize=(3.6 * len(cols) + 1.2, 2.4 * len(rows) + 0.8),
                             squeeze=False, sharex=True)
    measured = frfs.mean()
    omega, f_hz = frfs.omega, frfs.freq_hz
    at = [(position[r], position[c]) for _, (r, c) in pairs]
    curves = [(np.abs(model_receptances(model, at, omega)), name, style)   # one solve per model
              for model, name, style in ((_nominal_curve(nominal, updated), nominal_label, "--"),
                                         (updated, updated_label, "-"))]
    for n, (k, (r, c)) in enumerate(pairs):
        ax = axes[rows.index(r), cols.index(c)] if grid else axes[n, 0]
        ax.semilogy(f_hz, np.abs(measured[k]), color="0.2", lw=0.9, label="measured (mean of repeats)")
        for h, name, style in curves:
            ax.semilogy(f_hz, h[n], style, lw=1.0, label=name)
        ax.set_title(f"h_{r},{c}", fontsize=9)
        ax.grid(True, which="both", alpha=0.3)
    for ax in axes.ravel():
        if not ax.lines:
            ax.set_visible(False)
    for ax in axes[-1]:
        ax.set_xlabel("frequency [Hz]")
    for ax in axes[:, 0]:
        ax.set_ylabel("|h| [m/N]")
    handles, labels = next(a for a in axes.ravel() if a.lines).get_legend_handles_labels()
    height = fig.get_figheight()
    fig.suptitle(title, fontsize=10, y=1 - 0.05 / height, va="top")
    fig.legend(handles, labels, loc="upper center", ncol=3, fontsize=8, bbox_to_anchor=(0.5, 1 - 0.3 / height))
    fig.tight_layout(rect=(0, 0, 1, 1 - 0.65 / height))
    return _save(plt, fig, path)


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
    return _save(plt, fig, path)
