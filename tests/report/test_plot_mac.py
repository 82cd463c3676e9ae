"""The MAC plot: every cell's value written, the axes at set places."""

import numpy as np
import pytest

matplotlib = pytest.importorskip("matplotlib")


def test_the_mac_plot_writes_every_value_without_measuring_its_layout(tmp_path, monkeypatch):
    """Constructed 3 x 4 MAC matrix: one text per cell, a colour bar, a PNG; the figure is
    never laid out by measuring its texts (``tight_layout``, which cost more than half of the
    plot)."""
    from matplotlib.figure import Figure

    from vibupdate.report import plots

    measured = []
    monkeypatch.setattr(Figure, "tight_layout", lambda self, *a, **k: measured.append(self))
    figures = []
    save = plots.save_png
    monkeypatch.setattr(plots, "save_png", lambda fig, path, dpi=110: (figures.append(fig), save(fig, path))[1])
    matrix = np.linspace(0.0, 1.0, 12).reshape(3, 4)
    path = plots.plot_mac(tmp_path / "mac.png", matrix, "MAC")
    assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert not measured
    ax, bar = figures[0].axes
    assert sorted(t.get_text() for t in ax.texts) == sorted(f"{v:.2f}" for v in matrix.ravel())
    assert bar.get_ylim() == (0.0, 1.0)
