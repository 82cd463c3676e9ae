"""Plots drawn by the run's second process (vibupdate.io.plot_process)."""

import os
import sys

import pytest

from vibupdate.io.outputs import OutputWarning, drawn
from vibupdate.io import plot_process as pp

pytestmark = pytest.mark.skipif(not sys.platform.startswith("linux"), reason="the child is forked on Linux only")


@pytest.fixture(autouse=True)
def fresh_process(monkeypatch):
    """As a process that has not drawn yet: the child starts only there."""
    monkeypatch.delitem(sys.modules, "matplotlib.pyplot", raising=False)


def _pid_plot(path, value):
    """A module-level plot: writes the drawing process's pid, so a test can tell who drew."""
    path.write_text(f"{os.getpid()} {value}")


def _failing_plot(path):
    path.write_text("partial")
    raise ValueError("degenerate figure")


def test_a_plot_is_drawn_by_the_child_and_keeps_the_meaning_of_drawn(tmp_path):
    with pp.plot_process() as worker:
        assert worker is not None and pp.active() is worker
        assert drawn(tmp_path / "a.png", _pid_plot, 3)
        pid, value = (tmp_path / "a.png").read_text().split()
        assert int(pid) == worker[1].pid != os.getpid() and value == "3"
        with pytest.warns(OutputWarning, match=r"b.png was not drawn: ValueError: degenerate figure"):
            assert not drawn(tmp_path / "b.png", _failing_plot)
        assert not (tmp_path / "b.png").exists()   # the partial file removed, as in the run's process

        def local(path):   # a closure does not pickle: drawn in the run's own process
            path.write_text(str(os.getpid()))

        assert drawn(tmp_path / "c.png", local) and int((tmp_path / "c.png").read_text()) == os.getpid()
    assert pp.active() is None and not worker[1].is_alive()


def test_a_dead_child_leaves_the_plots_to_the_run(tmp_path):
    with pp.plot_process() as worker:
        worker[1].kill()
        worker[1].join()
        assert drawn(tmp_path / "a.png", _pid_plot, 1)
        assert int((tmp_path / "a.png").read_text().split()[0]) == os.getpid()


def test_no_child_when_not_wanted_or_pyplot_is_loaded_already(tmp_path, monkeypatch):
    with pp.plot_process(False) as worker:
        assert worker is None and pp.active() is None
    monkeypatch.setitem(sys.modules, "matplotlib.pyplot", object())
    with pp.plot_process() as worker:
        assert worker is None


def test_a_run_with_the_child_never_imports_matplotlib_itself(tmp_path):
    """The child imports and warms matplotlib up while the run solves; the run's own process
    only asks whether it is installed (`vibupdate._extras.installed`), so it does not pay the
    import too, and the plots are still drawn."""
    import subprocess

    script = ("import contextlib, io, sys\nfrom vibupdate.cli import main\n"
              "with contextlib.redirect_stdout(io.StringIO()):\n    code = main(['example', 'cantilever'])\n"
              "print(code, 'matplotlib' in sys.modules)\n")
    out = subprocess.run([sys.executable, "-c", script], cwd=tmp_path, capture_output=True, text=True, timeout=120)
    assert out.stdout.split() == ["0", "False"], out.stderr[-2000:]
    assert (tmp_path / "cantilever-results" / "frf.png").stat().st_size > 1000
