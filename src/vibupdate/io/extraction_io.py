"""Writing an `Extraction`: ``extraction.json``, case-format data files and ``fit.png``.

Hz only here, at the edge. The files and their columns are those of ``docs/frf-extraction.md``
("Output"), in the formats the case file reads (`vibupdate.io.measured_io`); the folder is
written as a run's results folder is (`vibupdate.io.outputs`), under the manifest of
``extract``.
"""

from __future__ import annotations

import csv
import math
from pathlib import Path

import numpy as np

from vibupdate.extras import require
from vibupdate.data.extraction import Extraction
from vibupdate.data.frf import FRFSet
from vibupdate.data.measured import TWO_PI

#: The files `write_extraction` writes (``fit.png`` only with the plot).
EXTRACTION_FILES = ("extraction.json", "frequencies.csv", "shapes.csv", "damping.csv", "configuration.toml",
                    "fit.png")


def check_extraction_folder(out_dir, force: bool = False, inputs=()):
    """Check the output folder before extracting: `vibupdate.io.outputs.prepare_output` as the
    command ``extract``, which never replaces or removes the FRF files it reads (``inputs``)."""
    from vibupdate.io.outputs import prepare_output

    return prepare_output(out_dir, force=force, planned=EXTRACTION_FILES, command="extract", inputs=inputs,
                          case=_extraction_case(inputs))


def _extraction_case(inputs) -> str:
    """What the manifest records as the case of an extraction: the FRF files it read (an
    extraction of other files in the same folder needs ``--force``)."""
    names = [Path(f).name for f in inputs]
    return "extraction of " + ", ".join(names) if names else "extraction"


def _num(value) -> str:
    """The shortest text that reads back as the same double."""
    return repr(float(value))


def _hz(pair) -> list[float]:
    return [float(pair[0]) / TWO_PI, float(pair[1]) / TWO_PI]


def extraction_document(result: Extraction, first_mode: int = 1) -> dict:
    """The ``extraction.json`` content (Hz; keys as in ``docs/frf-extraction.md``)."""
    natural = [{
        "mode": first_mode + k,
        "freq_hz": m.omega / TWO_PI,
        "freq_hz_interval": _hz(m.omega_interval),
        "damping_ratio": m.damping_ratio,
        "damping_ratio_interval": list(m.damping_interval),
        "shape": dict(m.shape),
        "shape_interval": {d: list(b) for d, b in m.shape_interval.items()},
        "shape_normalization": m.normalization,
        "stable_orders": m.stable_orders,
    } for k, m in enumerate(result.modes)]
    def zero(z):
        return {"response": z.response, "excitation": z.excitation, "index": z.index,
                "freq_hz": z.omega / TWO_PI, "freq_hz_interval": _hz(z.interval), "snr": z.snr}

    zeros = [zero(z) for z in result.zeros]
    quality = [{"response": q.response, "excitation": q.excitation, "quality": q.quality,
                "relative_residual": q.relative_residual, "repeats": q.n_repeats} for q in result.quality]
    stabilization = [{"pole_pairs": int(n), "freq_hz": (w / TWO_PI).tolist(), "damping_ratio": z.tolist()}
                     for n, w, z in result.stabilization]
    fitted = [{"freq_hz": float(w) / TWO_PI, "damping_ratio": float(z),
               "reported": any(m.omega == w for m in result.modes)} for w, z in result.fitted_poles]
    return {"band_hz": _hz(result.band), "fit_band_hz": _hz(result.fit_band), "confidence": result.confidence,
            "level": result.level,
            "noise": result.noise, "window": result.window, "record_s": result.record_s,
            "window_tau_s": result.window_tau, "natural": natural,
            "antiresonances": zeros, "outer_antiresonances": [zero(z) for z in result.outer_zeros],
            "noisy_antiresonances": [zero(z) for z in result.noisy_zeros],
            "cancelled_antiresonances": [zero(z) for z in result.cancelled_zeros],
            "fitted_modes": fitted,
            "quality": quality, "stabilization": stabilization}


def configuration_block(name: str = "measured", frequencies: str = "frequencies.csv",
                        shapes: str = "shapes.csv") -> str:
    """A ``[[configuration]]`` block of a case file that reads the written CSV files; it states
    the frequencies natural (the extraction gives the poles' magnitudes), so that their damping
    ratios raise no damped-or-natural note."""
    return (f'[[configuration]]\nname = "{name}"\nfrequencies_csv = "{frequencies}"\n'
            f'mode_shapes_csv = "{shapes}"\n'
            'frequency_type = "natural"   # the poles\' magnitudes, not the damped peaks\n')


def _write_csv(path: Path, header, rows) -> None:
    with open(path, "w", newline="", encoding="utf-8") as handle:
        writer = csv.writer(handle)
        writer.writerow(header)
        writer.writerows(rows)


def write_extraction(result: Extraction, frfs: FRFSet, out_dir, first_mode: int = 1, name: str = "measured",
                     plot: bool = True, force: bool = False, inputs=()) -> dict:
    """Write every output file into the folder ``out_dir``; returns ``{kind: path}``.

    Through `vibupdate.io.outputs` (a ValueError, nothing written, when the folder cannot take
    the files: `check_extraction_folder`); a ``fit.png`` that cannot be drawn costs a warning
    (`vibupdate.io.outputs.OutputWarning`), not the extraction.
    """
    from vibupdate import __version__
    from vibupdate.io.outputs import write_published

    target = check_extraction_folder(out_dir, force, inputs)
    paths = write_published(target, lambda staged: _write_files(result, frfs, staged, first_mode, name, plot),
                            case=_extraction_case(inputs), version=__version__)
    return {kind: target.path / path.name for kind, path in paths.items()}


def _write_files(result: Extraction, frfs: FRFSet, out: Path, first_mode: int, name: str, plot: bool) -> dict:
    from vibupdate.io.records import json_text

    paths = {"json": out / "extraction.json", "frequencies": out / "frequencies.csv",
             "shapes": out / "shapes.csv", "damping": out / "damping.csv", "configuration": out / "configuration.toml"}
    paths["json"].write_text(json_text(extraction_document(result, first_mode)), encoding="utf-8")
    # the mode column declares each natural frequency's model mode as shapes.csv numbers it: with
    # --first-mode N both files start at mode N and read together
    # every interval the FRF route gives, at full precision, so the table reads back as that route
    # zeros counted from the lowest only when the band starts below the first mode, as the FRF route
    rows = [["natural", _num(m.omega / TWO_PI), 1, _num(m.damping_ratio), "", "", first_mode + k, "",
             *map(_num, _hz(m.omega_interval)), *map(_num, m.damping_interval)]
            for k, m in enumerate(result.modes)]
    rows += [["antiresonance", _num(z.omega / TWO_PI), 1, "", z.response, z.excitation, "",
              z.declared_index(first_mode) or "", *map(_num, _hz(z.interval)), "", ""]
             for z in result.zeros]
    _write_csv(paths["frequencies"], ["kind", "hz", "weight", "damping_ratio", "response", "excitation", "mode",
                                      "index", "lower_hz", "upper_hz", "damping_lower", "damping_upper"], rows)
    _write_csv(paths["shapes"], ["mode", "dof", "lower", "upper"],
               [[first_mode + k, d, _num(lo), _num(hi)]
                for k, m in enumerate(result.modes) for d, (lo, hi) in m.shape_interval.items()])
    _write_csv(paths["damping"], ["mode", "hz", "damping_ratio", "lower", "upper"],
               [[first_mode + k, f"{m.omega / TWO_PI:.8g}", f"{m.damping_ratio:.6g}",
                 f"{m.damping_interval[0]:.6g}", f"{m.damping_interval[1]:.6g}"] for k, m in enumerate(result.modes)])
    block = configuration_block(name)
    if result.mass_normalized:
        drive = next(f"h_{r},{c}" for r, c in result.pairs if r == c)
        block += (f"# the shapes are mass-normalized (driving point {drive}); when the FRFs are calibrated in SI "
                  "units (N; m, m/s or m/s^2), uncomment the next line to use their modal masses as data\n"
                  "# mass_normalized_shapes = true\n")
    if first_mode != 1:
        block += (f"# the lowest extracted mode is model mode {first_mode}: frequencies.csv declares each "
                  "natural frequency's mode (column mode)\n")
    paths["configuration"].write_text(block, encoding="utf-8")
    if plot:
        from vibupdate.io.outputs import drawn

        if drawn(out / "fit.png", lambda path: plot_extraction(result, frfs, path)):
            paths["plot"] = out / "fit.png"
    return paths


def plot_extraction(result: Extraction, frfs: FRFSet, path) -> Path:
    """``|H|`` measured (mean of repeats) vs fitted, one panel per FRF, poles and zeros marked."""
    require("plots", "drawing plots")
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    data = frfs.band(*result.band)
    fitted = result.synthesize(data.omega)
    mean = data.mean()
    n = len(data.pairs)
    cols = min(n, 3)
    rows = math.ceil(n / cols)
    # on the Agg canvas, as `vibupdate.report.plots.figure`, which io may not import (report
    # comes after io in the data flow: tests/test_layout.py)
    fig = Figure(figsize=(4.2 * cols, 3.2 * rows))
    FigureCanvasAgg(fig)
    axes = fig.subplots(rows, cols, squeeze=False)
    f = data.freq_hz
    for k, (pair, ax) in enumerate(zip(data.pairs, axes.ravel())):
        ax.semilogy(f, np.abs(mean[k]), color="0.6", lw=1.0, label="measured")
        ax.semilogy(f, np.abs(fitted[k]), color="C0", lw=1.0, label="fit")
        for m in result.modes:
            ax.axvline(m.omega / TWO_PI, color="C3", lw=0.6, ls="--")
        for z in result.zeros:
            if (z.response, z.excitation) == pair:
                ax.axvline(z.omega / TWO_PI, color="C2", lw=0.6, ls=":")
        ax.set_title(f"h {pair[0]},{pair[1]}", fontsize=9)
        ax.set_xlabel("frequency [Hz]", fontsize=8)
        ax.set_ylabel("|receptance| [m/N]", fontsize=8)
        ax.grid(True, which="both", alpha=0.3)
    for ax in axes.ravel()[n:]:
        ax.axis("off")
    axes[0, 0].plot([], [], color="C3", ls="--", label="poles")
    axes[0, 0].plot([], [], color="C2", ls=":", label="zeros")
    axes[0, 0].legend(fontsize=7)
    fig.subplots_adjust(left=0.08, right=0.98, bottom=0.1, top=0.92, wspace=0.35, hspace=0.5)
    fig.savefig(path, dpi=110)
    return Path(path)
