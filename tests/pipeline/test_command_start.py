"""What ``vibupdate example cantilever`` pays for outside its solve: the package imports its
public names on first use, the command imports only what its run uses, and the run's steps
repeat no work of the solve's. Its wall time is measured in benchmarks/start_time.py."""

import json
import subprocess
import sys

import numpy as np
import pytest

import vibupdate

#: Modules the example run on a core install does not need (they serve other commands,
#: failed runs, or optional extras).
NOT_ON_THE_EXAMPLE_PATH = ("vibupdate.inverse.diagnosis", "vibupdate.ranges.candidates", "vibupdate.report.plots",
                           "vibupdate.study", "tomllib", "matplotlib", "dask", "distributed")


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


def test_the_core_example_run_imports_only_what_it_uses(tmp_path):
    """The README's first command on a core install (matplotlib hidden), as the console script
    runs it: ``main()`` with the command in ``sys.argv``."""
    script = ("import atexit, contextlib, io, json, sys\n"
              "sys.modules['matplotlib'] = None\n"
              "sys.argv = ['vibupdate', 'example', 'cantilever']\n"
              "from vibupdate.cli import main\n"
              "atexit.register(lambda: print(json.dumps({\n"
              "    'modules': sorted(m for m, v in sys.modules.items() if v is not None)}), file=sys.__stdout__))\n"
              "with contextlib.redirect_stdout(io.StringIO()):\n    main()\n")
    found = _child(script, tmp_path)
    loaded = [m for m in found["modules"] if m.startswith(NOT_ON_THE_EXAMPLE_PATH)]
    assert not loaded, loaded
    assert (tmp_path / "cantilever-results" / "results.json").exists()


def test_the_program_ends_with_its_exit_code_its_output_and_its_exit_handlers(tmp_path):
    """Every line is out, the exit handlers ran and the exit code is the command's."""
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
    from vibupdate import extras

    monkeypatch.setattr(extras, "installed", lambda extra: extra != "plots")
    written, real = [], pipeline.write_results

    def counting(path, run):
        written.append(run.warnings)
        return real(path, run)

    monkeypatch.setattr(pipeline, "write_results", counting)
    from vibupdate.cli import main

    assert main(["example", "cantilever", "--out", str(tmp_path / "out")]) == 0
    note = extras.skipped("plots", "plots")
    assert len(written) == 1 and written[0][-1] == note
    doc = json.loads((tmp_path / "out" / "results.json").read_text())
    assert doc["warnings"].count(note) == 1
    assert capsys.readouterr().out.count(f"warning: {note}") == 1


@pytest.mark.parametrize("n, symmetric", [(12, True), (12, False), (120, True)])
def test_matrix_files_are_those_scipy_writes_by_default(tmp_path, n, symmetric):
    """The run names the symmetry of a small symmetric matrix (`pipeline.mm_symmetry`) so that
    scipy does not look for it entry by entry; the file is the one scipy's default writes."""
    import scipy.io
    import scipy.sparse as sp

    from vibupdate.pipeline import mm_symmetry

    rng = np.random.default_rng(n)
    A = sp.random(n, n, density=0.3, random_state=rng, format="csr") + sp.identity(n, format="csr")
    A = A + A.T if symmetric else A
    scipy.io.mmwrite(str(tmp_path / "named.mtx"), sp.coo_matrix(A), **mm_symmetry(A), comment="c")
    scipy.io.mmwrite(str(tmp_path / "found.mtx"), sp.coo_matrix(A), comment="c")
    assert (tmp_path / "named.mtx").read_bytes() == (tmp_path / "found.mtx").read_bytes()
    assert bool(mm_symmetry(A)) == (symmetric and n < 100)
