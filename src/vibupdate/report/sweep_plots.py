"""PNG plots of a sweep: parameter histograms, pairwise scatter of the least-determined
parameters, prediction bands of the frequencies and of each configuration's FRF.

Only verified samples enter the plots (the counts of the others are in the titles). The
least-determined parameters are those whose 5-95 % sampled spread is the largest fraction of
their bounds; a symmetry or a trade-off between two of them shows as a line in their scatter.
matplotlib is imported inside the functions (Agg backend).
"""

from __future__ import annotations

import warnings
from itertools import combinations
from pathlib import Path

import numpy as np

from vibupdate.data.measured import TWO_PI
from vibupdate.extras import available, require, skipped
from vibupdate.io.outputs import OutputWarning, drawn, file_names
from vibupdate.options import finite
from vibupdate.report.plots import figure, save_png


#: Samples used for an FRF band (the first verified ones by index).
FRF_SAMPLES = 100
FRF_POINTS = 600


def _save(fig, path) -> Path:
    """Lay out and save as PNG."""
    fig.tight_layout()
    return save_png(fig, path, dpi=100)


def _verified(rows):
    return sorted((r for r in rows if r["outcome"] == "verified"), key=lambda r: r["index"])


def least_determined(document: dict, n: int = 4) -> list[str]:
    """Names of the ``n`` parameters with the largest sampled spread relative to their bounds."""
    known = [p for p in document["parameters"] if finite(p.get("spread_of_bounds"))]
    known.sort(key=lambda p: -p["spread_of_bounds"])
    return [p["name"] for p in known[:n]]


def _counts(document) -> str:
    return (f"{document['verified']} verified of {document['samples']} "
            f"({document['unverified']} unverified, {document['failed']} failed)")


def histogram_bins(values, lower: float, upper: float) -> tuple[int, tuple[float, float] | None]:
    """Bins of a histogram of ``values`` (the finite ones) chosen from their spread.

    Returns ``(bins, (low, high))``: between 5 and 30 bins over the values' range, fewer
    where a bin would be narrower than half a per cent of the bounds ``upper - lower`` (it
    would not show on the axis, which spans the bounds) or than 1e-9 of the values (equal
    bins that floating point cannot resolve); identical or nearly identical values get one
    bin of that least width centred on them. ``(0, None)`` without a finite value.
    """
    v = np.array([x for x in values if finite(x)], dtype=float)
    if v.size == 0:
        return 0, None
    low, high = float(v.min()), float(v.max())
    width = abs(upper - lower) if finite(upper) and finite(lower) else 0.0
    least = max(0.005 * width, 1e-9 * max(abs(low), abs(high)), 1e-300)
    bins = min(30, max(5, v.size // 4))
    if high - low >= bins * least:
        return bins, (low, high)
    if high - low >= least:
        return int((high - low) // least), (low, high)
    middle = 0.5 * (low + high)
    return 1, (middle - 0.5 * least, middle + 0.5 * least)


def plot_histograms(path, document: dict, rows) -> Path:
    """One histogram per parameter over the verified samples, bounds and nominal marked."""
    params = document["parameters"]
    ok = _verified(rows)
    cols = min(3, len(params))
    nrows = int(np.ceil(len(params) / cols))
    fig = figure(figsize=(3.6 * cols, 2.8 * nrows))
    axes = fig.subplots(nrows, cols, squeeze=False)
    for ax, p in zip(axes.flat, params):
        values = [r[f"p:{p['name']}"] for r in ok]
        bins, span = histogram_bins(values, p["lower"], p["upper"])
        if bins:
            ax.hist([v for v in values if finite(v)], bins=bins, range=span, color="tab:blue", alpha=0.8)
        ax.axvline(p["lower"], color="0.3", ls="--", lw=0.8)
        ax.axvline(p["upper"], color="0.3", ls="--", lw=0.8)
        ax.axvline(p["nominal"], color="tab:orange", lw=0.8)
        ax.set_xlabel(f"{p['name']} [{p['unit']}]" if p["unit"] else p["name"])
    for ax in list(axes.flat)[len(params):]:
        ax.set_visible(False)
    fig.suptitle(f"sampled parameters: {_counts(document)}; dashed: bounds, orange: nominal", fontsize=9)
    return _save(fig, path)


def plot_pairs(path, document: dict, rows, names, ends=()) -> Path:
    """Pairwise scatter of the named parameters over the verified samples; where a sample's
    answer was walked along a null direction (``ends``, rows of ``line_ends.csv``), the segment
    between the two ends of that direction is drawn as a line."""
    ok = _verified(rows)
    verified = {r["index"] for r in ok}
    segments: dict = {}
    for e in ends:
        if e["index"] in verified:
            segments.setdefault((e["index"], e["direction"]), []).append(e)
    pairs = list(combinations(names, 2))
    cols = min(3, max(1, len(pairs)))
    nrows = max(1, int(np.ceil(len(pairs) / cols)))
    fig = figure(figsize=(max(3.6 * cols, 6.0), 3.2 * nrows + 0.4))
    axes = fig.subplots(nrows, cols, squeeze=False)
    bounds = {p["name"]: (p["lower"], p["upper"]) for p in document["parameters"]}
    by_index = {r["index"]: r for r in ok}
    for ax, (a, b) in zip(axes.flat, pairs):
        for (index, _), pair in segments.items():
            # the walk is straight through the answer: its ends (one per side) and the answer
            points = sorted([by_index[index], *pair], key=lambda q: (q[f"p:{a}"], q[f"p:{b}"]))
            ax.plot([points[0][f"p:{a}"], points[-1][f"p:{a}"]], [points[0][f"p:{b}"], points[-1][f"p:{b}"]],
                    "-", color="tab:green", lw=0.6, alpha=0.5)
        ax.plot([r[f"p:{a}"] for r in ok], [r[f"p:{b}"] for r in ok], ".", ms=3)
        ax.set_xlim(*bounds[a])
        ax.set_ylim(*bounds[b])
        ax.set_xlabel(a)
        ax.set_ylabel(b)
    for ax in list(axes.flat)[len(pairs):]:
        ax.set_visible(False)
    walked = f"\ngreen: lines of equally good answers ({len(segments)} walked to their ends)" if segments else ""
    fig.suptitle(f"least-determined parameters (axes: bounds); {_counts(document)}{walked}", fontsize=9)
    return _save(fig, path)


def plot_frequency_bands(path, document: dict) -> Path:
    """Per measured frequency: the measured interval and the 5-95 % band of the prediction,
    both relative to the measured value (per cent)."""
    preds = [p for p in document["predictions"] if p["q05"] is not None]
    fig = figure(figsize=(max(5.0, 0.45 * len(preds) + 2), 3.8))
    ax = fig.subplots()
    x = np.arange(len(preds))
    for i, p in enumerate(preds):
        m = p["measured_hz"]
        lo, hi = (100 * (v - m) / m for v in p["interval_hz"])
        ax.plot([i - 0.15, i - 0.15], [lo, hi], color="0.5", lw=4, label="measured interval" if i == 0 else None)
        ax.plot([i + 0.15, i + 0.15], [100 * (p["q05"] - m) / m, 100 * (p["q95"] - m) / m], color="tab:blue",
                lw=4, label="prediction 5-95 %" if i == 0 else None)
        ax.plot(i + 0.15, 100 * (p["q50"] - m) / m, "k_", ms=10)
    ax.set_xticks(x, [f"{p['configuration']}: {p['name']}" for p in preds], rotation=60, ha="right", fontsize=7)
    ax.set_ylabel("relative to measured [%]")
    ax.set_title(f"frequency prediction bands; {_counts(document)}", fontsize=9)
    ax.grid(True, alpha=0.3)
    if preds:
        ax.legend(fontsize=8)
    return _save(fig, path)


def plot_frf_band(path, case, cfg, rows) -> Path:
    """5-50-95 % band of |h_rc| of one configuration over the verified samples (damped with
    each sample's Caughey coefficients when the case has damping data), measured marked."""
    from vibupdate.damping.models import caughey_damping
    from vibupdate.io.results import plotted_receptance
    from vibupdate.report.plots import model_receptance

    require("plots", "drawing plots")   # before the samples' receptances
    ok = _verified(rows)[:FRF_SAMPLES]
    plotted = plotted_receptance(cfg, cfg.model.M0)
    r, c = cfg.model.dof(plotted.response), cfg.model.dof(plotted.excitation)
    label = f"h_{plotted.response},{plotted.excitation}"
    measured = [f.omega for f in cfg.natural] + [a.omega for a in cfg.antiresonances]
    top = 1.25 * max(measured)
    omega = np.linspace(top / FRF_POINTS, top, FRF_POINTS)
    exponents = case.damping.exponents if case.damping else (0.0, 1.0)
    model = cfg.model
    curves = []
    for row in ok:
        xbar = model.normalized([row[f"p:{p.name}"] for p in model.parameters])
        M, K = model.matrices(xbar)
        C = None
        if row.get("beta0") is not None:
            C = caughey_damping(M, K, exponents, [row[f"beta{i}"] for i in range(len(exponents))],
                                max((f.mode for f in cfg.natural), default=1))
        curves.append(np.abs(model_receptance((M, K, C), r, c, omega)))
    fig = figure(figsize=(7.5, 4.2))
    ax = fig.subplots()
    if curves:
        q = np.quantile(np.log10(np.maximum(curves, 1e-300)), [0.05, 0.5, 0.95], axis=0)
        ax.fill_between(omega / TWO_PI, 10 ** q[0], 10 ** q[2], alpha=0.35, label="5-95 % of samples")
        ax.semilogy(omega / TWO_PI, 10 ** q[1], lw=1.0, label="median")
    for i, f in enumerate(cfg.natural):
        ax.axvline(f.omega / TWO_PI, color="0.3", lw=0.8, label="measured natural" if i == 0 else None)
    for i, a in enumerate(cfg.antiresonances):
        ax.axvline(a.omega / TWO_PI, color="tab:red", lw=0.8, ls=":",
                   label="measured antiresonance" if i == 0 else None)
    ax.set_yscale("log")
    ax.set_xlabel("frequency [Hz]")
    ax.set_ylabel(f"|{label}| [m/N]")
    ax.set_title(f"configuration {cfg.name}: {label}, {len(curves)} verified samples", fontsize=9)
    ax.legend(fontsize=8)
    ax.grid(True, which="both", alpha=0.3)
    return _save(fig, path)


def plot_names(case) -> list[str]:
    """Every file name `write_sweep_plots` may give a plot of ``case`` (before the sweep says
    which are drawn)."""
    parts = file_names([cfg.name for cfg in case.configurations])
    return (["parameters_hist.png", "parameters_pairs.png", "frequency_bands.png"]
            + [f"frf_band_{parts[cfg.name]}.png" for cfg in case.configurations])


def write_sweep_plots(out: Path, case, rows, document: dict, ends=()) -> list[Path]:
    """All plots of a sweep into ``out``; returns the paths of those drawn. A plot that fails
    is left out with an `vibupdate.io.outputs.OutputWarning` naming it and the error; without
    the optional extra ``[plots]`` none is drawn and one warning says so."""
    if not available("plots"):
        warnings.warn(OutputWarning(skipped("plots", "the sweep's plots")), stacklevel=2)
        return []
    out = Path(out)
    plots = [(out / "parameters_hist.png", plot_histograms, (document, rows))]
    names = least_determined(document)
    if len(names) >= 2:
        plots.append((out / "parameters_pairs.png", plot_pairs, (document, rows, names, ends)))
    plots.append((out / "frequency_bands.png", plot_frequency_bands, (document,)))
    parts = file_names([cfg.name for cfg in case.configurations])
    for cfg in case.configurations:
        plots.append((out / f"frf_band_{parts[cfg.name]}.png", plot_frf_band, (case, cfg, rows)))
    return [path for path, plot, args in plots if drawn(path, plot, *args)]
