"""What ``vibupdate example cantilever`` pays for outside its solve: the package imports its
public names on first use, the command imports only what its run uses, with the garbage
collector paused during the imports, and the run's steps repeat no work of the solve's."""

import gc
import json
import subprocess
import sys

import numpy as np
import pytest
import scipy.io
import scipy.sparse as sp

import vibupdate

#: Modules the example run on a core install does not need (they serve other commands,
#: failed runs, or optional extras).
NOT_ON_THE_EXAMPLE_PATH = ("vibupdate.inverse.diagnosis", "vibupdate.ranges.candidates", "vibupdate.report.plots",
                           "vibupdate.study", "scipy.io", "tomllib", "matplotlib", "dask", "distributed")


def _child(script: str, cwd) -> dict:
    done = subprocess.run([sys.executable, "-c", script], cwd=cwd, capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr[-2000:]
    return json.loads(done.stdout.strip().splitlines()[-1])


def test_importing_the_package_or_asking_the_version_loads_no_numpy(tmp_path):
    found = _child("import json, sys, vibupdate, vibupdate.cli\n"
                   "print(json.dumps({'numpy': 'numpy' in sys.modules, 'scipy': 'scipy' in sys.modules}))", tmp_path)
    assert found == {"numpy": False, "scipy": False}
    done = subprocess.run([sys.executable, "-m", "vibupdate", "--version"], capture_output=True, text=True,
                          cwd=tmp_path, timeout=120)
    assert done.stdout.strip() == f"vibupdate {vibupdate.__version__}"


def test_every_public_name_resolves_from_the_package():
    import importlib

    for name in vibupdate.__all__:
        assert getattr(vibupdate, name) is getattr(importlib.import_module(vibupdate._WHERE[name]), name), name
    assert set(vibupdate.__all__) <= set(dir(vibupdate))
    namespace = {}
    exec("from vibupdate import *", namespace)
    assert set(vibupdate.__all__) <= set(namespace)
    with pytest.raises(AttributeError, match="no attribute 'not_a_name'"):
        vibupdate.not_a_name  # noqa: B018


def test_the_core_example_run_imports_only_what_it_uses_and_freezes_its_imports(tmp_path):
    """The README's first command on a core install (matplotlib hidden), as the console script
    runs it: ``main()`` with the command in ``sys.argv``."""
    script = ("import atexit, contextlib, gc, io, json, sys\n"
              "sys.modules['matplotlib'] = None\n"
              "sys.argv = ['vibupdate', 'example', 'cantilever']\n"
              "from vibupdate.cli import main\n"
              "atexit.register(lambda: print(json.dumps({\n"
              "    'modules': sorted(m for m, v in sys.modules.items() if v is not None),\n"
              "    'frozen': gc.get_freeze_count(), 'enabled': gc.isenabled()}), file=sys.__stdout__))\n"
              "with contextlib.redirect_stdout(io.StringIO()):\n    main()\n")
    found = _child(script, tmp_path)
    loaded = [m for m in found["modules"] if m.startswith(NOT_ON_THE_EXAMPLE_PATH)]
    assert not loaded, loaded
    assert found["enabled"] and found["frozen"] > 10_000    # numpy's and scipy's objects, at least
    assert (tmp_path / "cantilever-results" / "results.json").exists()


def test_the_program_ends_with_its_exit_code_its_output_and_its_exit_handlers(tmp_path):
    """`vibupdate.cli._end`: the process ends without the interpreter's teardown, yet every
    line is out, the exit handlers ran and the exit code is the command's."""
    script = ("import atexit, sys\n"
              "sys.argv = ['vibupdate'] + sys.argv[1:]\n"
              "from vibupdate.cli import main\n"
              "atexit.register(lambda: print('handler ran'))\n"
              "sys.exit(main())\n")
    for argv, code in (["example", "cantilever"], 0), (["check", "missing.toml"], 2):
        done = subprocess.run([sys.executable, "-c", script, *argv], cwd=tmp_path, capture_output=True, text=True,
                              timeout=300)
        assert done.returncode == code, done.stderr[-2000:]
        lines = done.stdout.splitlines()
        assert lines[-1] == "handler ran"
        if code == 0:
            assert any(line.startswith("wrote cantilever-results/") for line in lines)
            assert (tmp_path / "cantilever-results" / "results.json").exists()
        else:
            assert "does not exist" in done.stderr


def test_the_program_with_another_thread_alive_ends_as_usual():
    import threading

    from vibupdate.cli import _end

    release = threading.Event()
    waiting = threading.Thread(target=release.wait, daemon=False)
    waiting.start()
    try:
        assert _end(3) == 3     # returned: the interpreter's exit joins the thread
    finally:
        release.set()
        waiting.join()


@pytest.mark.parametrize("enabled", [True, False])
def test_loading_the_library_leaves_the_collector_as_it_was(enabled):
    from vibupdate.cli import _load_library

    was = gc.isenabled()
    try:
        (gc.enable if enabled else gc.disable)()
        _load_library()
        assert gc.isenabled() == enabled
    finally:
        gc.unfreeze()
        (gc.enable if was else gc.disable)()


def _small(symmetric: bool, n: int = 12, seed: int = 0) -> sp.csr_matrix:
    rng = np.random.default_rng(seed)
    A = sp.random(n, n, density=0.4, random_state=rng, format="csr") + sp.identity(n, format="csr")
    A.data *= 10.0 ** rng.integers(-12, 12, A.data.size)
    return sp.csr_matrix(A + A.T) if symmetric else A


@pytest.mark.parametrize("case", ["symmetric", "general", "skew", "nan", "explicit_zero", "dense", "large", "integer",
                                  "unicode"])
def test_matrix_files_are_byte_for_byte_those_of_scipy(tmp_path, case):
    from vibupdate.io.matrix_market import _own, write_matrix

    A = {"symmetric": lambda: _small(True), "general": lambda: _small(False),
         "large": lambda: _small(True, n=120)}.get(case, lambda: _small(True))()
    if case == "skew":
        A = sp.csr_matrix(_small(False) - _small(False).T)
    if case == "nan":
        A = A.tolil()
        A[3, 3] = np.nan
        A = A.tocsr()
    if case == "explicit_zero":   # stored zeros, one of them -0, in mirrored places
        coo = A.tocoo()
        k = int(np.flatnonzero(coo.row > coo.col)[0])
        mirror = int(np.flatnonzero((coo.row == coo.col[k]) & (coo.col == coo.row[k]))[0])
        coo.data[k], coo.data[mirror] = 0.0, -0.0
        A = coo.tocsr()
        assert A.nnz == coo.nnz
    if case == "dense":
        A = A.toarray()
    if case == "integer":
        A = sp.csr_matrix(np.array([[2, 1], [1, 3]]))
    comment = "vibupdate: M of configuration é, two\nlines" if case == "unicode" else "vibupdate: K of A"
    write_matrix(tmp_path / "mine", A, comment)     # a name without .mtx gets it, as in scipy
    scipy.io.mmwrite(str(tmp_path / "theirs"), sp.coo_matrix(A), comment=comment)
    assert (tmp_path / "mine.mtx").read_bytes() == (tmp_path / "theirs.mtx").read_bytes()
    assert _own(sp.coo_matrix(A)) == (case in ("symmetric", "explicit_zero", "dense", "unicode"))


def test_matrix_values_are_written_as_scipy_writes_them():
    """Shortest digits, ``E`` exponent left out at 0: against scipy on 400,000 doubles, random
    bit patterns among them (subnormals, extremes)."""
    import io

    from vibupdate.io.matrix_market import format_value

    rng = np.random.default_rng(7)
    bits = rng.integers(0, 2**63 - 1, 200_000, dtype=np.int64).view(np.float64)
    spread = rng.standard_normal(200_000) * 10.0 ** rng.integers(-30, 30, 200_000)
    values = np.concatenate([bits[np.isfinite(bits)], spread, [0.0, -0.0, 1.0, -2.5, 0.5, 1e5, 9.99, 5e-324,
                                                               1.7976931348623157e308, np.inf, -np.inf, np.nan]])
    n = values.size
    target = io.BytesIO()
    scipy.io.mmwrite(target, sp.coo_matrix((values, (np.arange(n), np.zeros(n, int))), shape=(n, 1)),
                     symmetry="general")
    theirs = [line.split(" ", 2)[2] for line in target.getvalue().decode().splitlines()[3:]]
    mismatches = [(v, t) for v, t in zip(values.tolist(), theirs) if format_value(v) != t]
    assert not mismatches, mismatches[:5]


def test_linearized_ranges_from_the_answers_modal_data_are_those_it_computes_itself():
    from vibupdate.examples import cantilever
    from vibupdate.inverse.correlation import model_frequencies
    from vibupdate.ranges.identifiability import parameter_ranges

    configurations = cantilever.configurations()
    xbar = np.linspace(-0.1, 0.1, configurations[0].model.n_parameters)
    own = parameter_ranges(configurations, xbar, frequency_tolerance=0.01)
    given = parameter_ranges(configurations, xbar, frequency_tolerance=0.01,
                             freqs=[model_frequencies(c, xbar, derivatives=True) for c in configurations])
    for field in ("lower", "upper", "width_pct", "singular_values"):
        assert np.array_equal(getattr(own, field), getattr(given, field), equal_nan=True), field


def test_results_json_is_written_once_when_only_the_plots_were_skipped(monkeypatch, tmp_path, capsys):
    import vibupdate.pipeline as pipeline
    from vibupdate import _extras

    monkeypatch.setattr(_extras, "installed", lambda extra: extra != "plots")
    written, real = [], pipeline.write_results

    def counting(path, run):
        written.append(run.warnings)
        return real(path, run)

    monkeypatch.setattr(pipeline, "write_results", counting)
    from vibupdate.cli import main

    assert main(["example", "cantilever", "--out", str(tmp_path / "out")]) == 0
    note = _extras.skipped("plots", "plots")
    assert len(written) == 1 and written[0][-1] == note
    doc = json.loads((tmp_path / "out" / "results.json").read_text())
    assert doc["warnings"].count(note) == 1
    assert capsys.readouterr().out.count(f"warning: {note}") == 1
