"""PNG plots of a run: FRFs nominal vs updated (as Fig. 11), homotopy objective, MAC matrix.

matplotlib is imported inside the functions. Each plot is a bare `matplotlib.figure.Figure`
on the Agg canvas (`figure`), never pyplot: the same PNG, without pyplot's import (a fixed cost
of every ``vibupdate run``) or its register of open figures.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from vibupdate.extras import require
from vibupdate.modal.analysis import receptances
from vibupdate.data.measured import TWO_PI


def figure(**kwargs):
    """A new `matplotlib.figure.Figure` (``kwargs``: its ``figsize`` and the like) on the
    file-only Agg canvas, held by no register: it is freed with its last reference;
    `MissingExtra` without the extra [plots]."""
    require("plots", "drawing plots")
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(**kwargs)
    FigureCanvasAgg(fig)
    return fig


#: Exponent characters of a tick label written without mathtext (`_plain_log_labels`).
_SUPERSCRIPT = str.maketrans("0123456789-", "\u2070\u00b9\u00b2\u00b3\u2074\u2075\u2076\u2077\u2078\u2079\u207b")


def plain_label(text: str) -> str:
    """A mathtext tick label of matplotlib's log axes (``$\\mathdefault{2\\times10^{-5}}$``) as
    plain text with Unicode superscripts (``2\u00d710\u207b\u2075``); other text unchanged."""
    if not (text.startswith("$\\mathdefault{") and text.endswith("}$")):
        return text
    body = text[len("$\\mathdefault{"):-2].replace("\\times", "\u00d7")
    base, hat, power = body.partition("^{")
    label = base + (power.rstrip("}").translate(_SUPERSCRIPT) if hat else "")
    return "\u2212" + label[1:] if label.startswith("-") else label


def _plain_log_labels(ax) -> None:
    """The tick labels of the log-scaled y axis of ``ax`` written as plain text
    (`plain_label`): matplotlib writes them in mathtext, whose parse is half the cost of a
    log-axis plot and the first one in a process builds the parser; the labels read the same."""
    require("plots", "drawing plots")
    from matplotlib.ticker import LogFormatterSciNotation

    class Plain(LogFormatterSciNotation):
        def __call__(self, x, pos=None):
            return plain_label(super().__call__(x, pos))

    for current, setter in ((ax.yaxis.get_major_formatter(), ax.yaxis.set_major_formatter),
                            (ax.yaxis.get_minor_formatter(), ax.yaxis.set_minor_formatter)):
        if isinstance(current, LogFormatterSciNotation):
            setter(Plain(labelOnlyBase=current.labelOnlyBase, minor_thresholds=current.minor_thresholds))


#: Lines of a model receptance plot, about the pixels across its axes.
LINES = 1000


def _margins(fig, height_in: float) -> None:
    """Fixed margins in inches (``tight_layout`` measures every text and tick: 40 % of a plot's
    cost)."""
    fig.subplots_adjust(left=0.11, right=0.97, bottom=0.55 / height_in, top=1 - 0.35 / height_in, hspace=0.12)


def _finish(fig, ax, path, xlabel: str, ylabel: str, title: str) -> Path:
    """Labels, legend and grid, then save as PNG."""
    _plain_log_labels(ax)
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    ax.set_title(title, y=1.0)
    ax.legend(fontsize=8, loc="upper right")
    ax.grid(True, which="both", alpha=0.3)
    _margins(fig, fig.get_figheight())
    return save_png(fig, path)


def save_png(fig, path, dpi: int = 110) -> Path:
    """Save ``fig`` as PNG at ``path``."""
    fig.savefig(path, dpi=dpi)
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


def reading_receptances(model, pairs, reads, omega) -> np.ndarray:
    """Receptances between readings of ``model = (M, K, C)``: of a response reading ``w`` and an
    excitation ``c`` (a DOF, or a sensor's weights: a force spread as the sensor reads),
    ``w^T H(omega) c = sum_ij w_i c_j h_ij``, from the DOF pairs they need, solved together
    (`model_receptances`).

    Parameters
    ----------
    pairs : sequence of (str, str), length n_pairs
        Response and excitation names, each a key of ``reads``.
    reads : mapping of str to sequence of (int, float)
        The DOF indices (0-based) and weights each name reads: ``((i, 1.0),)`` for a DOF.
    omega : ndarray, shape (n_f,)
        rad/s.

    Returns
    -------
    ndarray of complex, shape (n_pairs, n_f)
        m/N.
    """
    import scipy.sparse as sp

    terms = [[(i, j, w * v) for i, w in reads[r] for j, v in reads[c]] for r, c in pairs]
    dof_pairs = list(dict.fromkeys((i, j) for pair in terms for i, j, _ in pair))
    at = {p: k for k, p in enumerate(dof_pairs)}
    rows = [n for n, pair in enumerate(terms) for _ in pair]
    cols = [at[i, j] for pair in terms for i, j, _ in pair]
    weights = [w for pair in terms for _, _, w in pair]
    combine = sp.csr_matrix((weights, (rows, cols)), shape=(len(pairs), len(dof_pairs)))
    return combine @ model_receptances(model, dof_pairs, omega)


def model_receptance(model, r: int, c: int, omega) -> np.ndarray:
    """Receptance of one pair of ``model = (M, K, C)`` (`model_receptances`); shape (n_f,), m/N."""
    return model_receptances(model, [(r, c)], omega)[0]


def _nominal_curve(nominal, updated):
    """The model whose receptance draws the nominal curve.

    On a large model the updated curve is the modal sum of its damping law (`CaugheyLaw`); an
    undamped nominal model is then drawn by the same sum with zero damping, over as many modes
    (`vibupdate.modal.receptance.modal_sum`, the modes left out in its Krylov vectors), so that
    the two curves differ by the models only.
    """
    from vibupdate.damping.models import CaugheyLaw

    M, K, C = nominal
    law = updated[2]
    if C is None and isinstance(law, CaugheyLaw):
        return (M, K, CaugheyLaw((), (), law.n_modes))
    return nominal


def _damping_note(C) -> str:
    if hasattr(C, "receptance"):
        return f" ({'damping law' if C.beta else 'undamped'}, {C.n_modes} modes)"
    return " (undamped)" if C is None else ""


def plot_receptances(path, panels) -> Path:
    """|h_rc| of the nominal and updated models, one panel per receptance of every
    configuration given, in one figure; measured natural frequencies (solid) and the measured
    antiresonances of that receptance (dotted) marked.

    Parameters
    ----------
    panels : sequence of (cfg, nominal, updated, pairs)
        Per configuration: the `Configuration` (its measured frequencies), the nominal and
        updated models as ``(M, K, C)`` with ``C`` possibly None (undamped, and labelled so) or
        a `vibupdate.damping.models.CaugheyLaw` (large models: modal superposition; each curve uses its
        own model's damping, never the updated ``C`` on the nominal curve), and ``pairs``: the
        response and excitation DOF indices, the label (``h_{r,c}``) and the measured
        antiresonances (rad/s) of each receptance. The pairs of one model share its eigen-solve
        (`model_receptances`).
    """
    count = sum(len(p[3]) for p in panels)
    ncols = 2 if count >= 3 else 1
    nrows = -(-count // ncols)
    height = 0.9 + 2.3 * nrows
    fig = figure(figsize=(7.5 if ncols == 1 else 11.0, height))
    axes = fig.subplots(nrows, ncols, squeeze=False)
    cells = iter(axes.ravel())
    for cfg, nominal, updated, pairs in panels:
        measured = [f.omega for f in cfg.natural] + [a.omega for a in cfg.antiresonances]
        top = 1.25 * max(measured) if measured else 1.0
        omega = np.linspace(top / LINES, top, LINES)
        at = [(r, c) for r, c, _, _ in pairs]
        curves = [(np.abs(model_receptances(model, at, omega)), f"{name} model{_damping_note(model[2])}", style)
                  for model, name, style in ((_nominal_curve(nominal, updated), "nominal", "--"),
                                             (updated, "updated", "-"))]
        for n, (_, _, label, zeros) in enumerate(pairs):
            ax = next(cells)
            for h, name, style in curves:
                ax.semilogy(omega / TWO_PI, h[n], style, lw=1.0, label=name)
            # one collection per kind of marker: a line artist per marker costs its own draw
            across = ax.get_xaxis_transform()
            if cfg.natural:
                ax.vlines([f.omega / TWO_PI for f in cfg.natural], 0, 1, transform=across, color="0.3", lw=0.8,
                          label="measured natural")
            if zeros:
                ax.vlines(np.asarray(zeros) / TWO_PI, 0, 1, transform=across, color="tab:red", lw=0.8, ls=":",
                          label="measured antiresonance")
            # a title at a set height: placed automatically, it measures every tick label of a log axis
            ax.set_title(f"configuration {cfg.name}: {label}", fontsize=9, y=1.0)
            ax.set_ylabel("|h| [m/N]")
            ax.set_xlabel("frequency [Hz]")
            ax.grid(True, which="both", alpha=0.3)
            _plain_log_labels(ax)
    for ax in cells:
        ax.set_visible(False)
    # one legend above the panels, at a set place (matplotlib's "best" place searches every
    # point of every curve)
    labels = {}
    for ax in axes.ravel():
        for handle, label in zip(*ax.get_legend_handles_labels()):
            labels.setdefault(label, handle)
    fig.legend(list(labels.values()), list(labels), loc="upper center", ncol=4, fontsize=8,
               bbox_to_anchor=(0.5, 1 - 0.05 / height))
    fig.subplots_adjust(left=0.09 if ncols == 2 else 0.11, right=0.98, bottom=0.5 / height,
                        top=1 - 0.6 / height, hspace=0.75 / 2.3 + 0.1, wspace=0.22)
    return save_png(fig, path)


def plot_measured_frf(path, frfs, model_dofs, nominal, updated, title: str, nominal_label: str,
                      updated_label: str, sensors=()) -> Path:
    """Measured FRFs overlaid on the nominal and updated model FRFs (the paper's Fig. 11).

    One panel per measured pair ``(response, excitation)`` whose names are DOFs or sensors of
    the model (a grid of responses by excitations when the pairs form one); a sensor's model
    FRF is the combination of DOF receptances its weights give (`reading_receptances`).

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
    sensors : sequence of vibupdate.model.measurement.Sensor
        The model's sensors (``docs/sensors.md``).
    """
    index = {d: i for i, d in enumerate(model_dofs)}
    reads = {d: ((i, 1.0),) for d, i in index.items()}
    reads.update({s.name: tuple((index[d], w) for d, w in s.weights) for s in sensors})
    position = {name: k for k, name in enumerate(reads)}
    pairs = [(k, p) for k, p in enumerate(frfs.pairs) if p[0] in position and p[1] in position]
    if not pairs:
        raise ValueError(f"no measured FRF pair {list(frfs.pairs)} has both its response and excitation among the "
                         "model's DOFs and sensors")
    rows = sorted({p[0] for _, p in pairs}, key=position.get)
    cols = sorted({p[1] for _, p in pairs}, key=position.get)
    grid = len(rows) * len(cols) <= 16 and len(rows) * len(cols) < 2 * len(pairs)
    if not grid:
        rows, cols = [None] * len(pairs), [None]
    fig = figure(figsize=(3.6 * len(cols) + 1.2, 2.4 * len(rows) + 0.8))
    axes = fig.subplots(len(rows), len(cols), squeeze=False, sharex=True)
    measured = frfs.mean()
    omega, f_hz = frfs.omega, frfs.freq_hz
    at = [p for _, p in pairs]
    curves = [(np.abs(reading_receptances(model, at, reads, omega)), name, style)   # one solve per model
              for model, name, style in ((_nominal_curve(nominal, updated), nominal_label, "--"),
                                         (updated, updated_label, "-"))]
    for n, (k, (r, c)) in enumerate(pairs):
        ax = axes[rows.index(r), cols.index(c)] if grid else axes[n, 0]
        ax.semilogy(f_hz, np.abs(measured[k]), color="0.2", lw=0.9, label="measured (mean of repeats)")
        for h, name, style in curves:
            ax.semilogy(f_hz, h[n], style, lw=1.0, label=name)
        ax.set_title(f"h_{r},{c}", fontsize=9)
        ax.grid(True, which="both", alpha=0.3)
        _plain_log_labels(ax)
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
    return save_png(fig, path)


def plot_homotopy(path, steps) -> Path:
    """Objective of every solve (``steps``: `vibupdate.io.results.StepRow`) against lambda (log
    scale), each path its own line: a path starts again wherever lambda does not grow (the
    stepped restart, a first stage repeated with wider boxes)."""
    fig = figure(figsize=(6, 3.8))
    ax = fig.subplots()
    lam = np.array([s.lam for s in steps], dtype=float)
    obj = np.array([max(s.objective, 1e-300) for s in steps])
    ok = np.array([s.status.ok for s in steps], dtype=bool)
    for path_steps in np.split(np.arange(lam.size), np.flatnonzero(np.diff(lam) <= 0) + 1):
        ax.semilogy(lam[path_steps], obj[path_steps], "-", color="0.6")
    ax.semilogy(lam[ok], obj[ok], "o", label="converged")
    if not ok.all():
        ax.semilogy(lam[~ok], obj[~ok], "x", color="tab:red", label="failed")
    return _finish(fig, ax, path, "lambda", "objective", "homotopy path")


def plot_mac(path, matrix: np.ndarray, title: str) -> Path:
    """MAC matrix, measured modes (rows) against updated model modes (columns), each cell's
    value written in it.

    The axes and the colour bar sit at set places (in inches from the figure's edges):
    ``tight_layout`` and a colour bar that takes its room from the axes measure every text of
    the figure before it is drawn, more than half the plot's cost."""
    width, height = 4.6, 4.0
    fig = figure(figsize=(width, height))
    left, right, bottom, top, bar, gap = 0.65, 0.75, 0.55, 0.35, 0.15, 0.15
    side = min(width - left - right - bar - gap, height - bottom - top)
    ax = fig.add_axes((left / width, bottom / height, side / width, side / height))
    cax = fig.add_axes(((left + side + gap) / width, bottom / height, bar / width, side / height))
    im = ax.imshow(matrix, vmin=0, vmax=1, cmap="viridis", aspect="auto")
    n, m = matrix.shape
    for i in range(n):
        for j in range(m):
            ax.text(j, i, f"{matrix[i, j]:.2f}", ha="center", va="center",
                    color="white" if matrix[i, j] < 0.6 else "black", fontsize=7)
    ax.set_xticks(range(m), [str(j + 1) for j in range(m)])
    ax.set_yticks(range(n), [str(i + 1) for i in range(n)])
    ax.set_xlabel("updated model mode")
    ax.set_ylabel("measured mode")
    ax.set_title(title, y=1.0)
    fig.colorbar(im, cax=cax)
    return save_png(fig, path)
