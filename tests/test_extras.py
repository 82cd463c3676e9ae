"""Optional extras: the core runs alone, and a feature whose extra is missing says which extra
to install (exit code 2 on the command line, `MissingExtra` from the library), never a
traceback. A missing package is simulated by ``sys.modules[name] = None``, which makes
``import name`` raise ImportError."""

import ast
import json
import sys
import tomllib
from pathlib import Path

import pytest
from outputs_helpers import write_case

from vibupdate.extras import EXTRAS, MissingExtra, available, require
from vibupdate.cli import main

ROOT = Path(__file__).resolve().parents[1]
PACKAGE = ROOT / "src" / "vibupdate"


def _without(monkeypatch, *modules):
    for name in modules:
        monkeypatch.setitem(sys.modules, name, None)


def test_the_extras_of_pyproject_are_those_the_code_names():
    project = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
    extras = project["optional-dependencies"]
    assert set(extras) == set(EXTRAS) | {"all", "test"}
    assert extras["all"] == [f"vibupdate[{','.join(EXTRAS)}]"]
    # the tests install every extra (the ANSYS reader's sample .full file is read) and pyNastran, the
    # DMIG reader's peer, kept on numpy 2 (its releases from 1.4 need numpy 1)
    assert f"vibupdate[{','.join(EXTRAS)}]" in extras["test"]
    assert {"numpy>=2", "pyNastran>=1.3.4"} <= set(extras["test"])
    core = {d.split(">")[0].split("[")[0] for d in project["dependencies"]}
    assert core == {"numpy", "scipy", "casadi", "piqp", "highspy", "threadpoolctl"}


def test_the_readme_table_lists_every_extra_with_what_it_installs():
    import re

    project = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
    readme = (ROOT / "README.md").read_text()
    rows = dict(re.findall(r"^\| `(\w+)` \| ([^|]+) \|", readme, re.M))
    for name in EXTRAS:
        packages = {d.split(">")[0] for d in project["optional-dependencies"][name]}
        assert set(rows[name].strip().split(", ")) == packages, name
    assert {"all", "test"} <= set(rows)


def _imported_modules(node) -> set[str]:
    if isinstance(node, ast.Import):
        return {a.name.split(".")[0] for a in node.names}
    if isinstance(node, ast.ImportFrom) and node.module and not node.level:
        return {node.module.split(".")[0]}
    return set()


def test_extra_packages_are_imported_only_inside_functions_after_require():
    """No module imports an extra's package at import time, and every function that imports
    one calls ``require`` with its extra first."""
    owner = {m.split(".")[0]: name for name, extra in EXTRAS.items() for m in extra.modules}
    offenders = []
    for path in PACKAGE.rglob("*.py"):
        tree = ast.parse(path.read_text(encoding="utf-8"))
        for node in tree.body:
            if _imported_modules(node) & set(owner):
                offenders.append(f"{path.name}: module-level import of {_imported_modules(node) & set(owner)}")
        for func in [n for n in ast.walk(tree) if isinstance(n, (ast.FunctionDef, ast.AsyncFunctionDef))]:
            required = {c.args[0].value for c in ast.walk(func) if isinstance(c, ast.Call)
                        and getattr(c.func, "id", None) == "require" and c.args
                        and isinstance(c.args[0], ast.Constant)}
            for stmt in func.body:
                for module in _imported_modules(stmt) & set(owner):
                    if owner[module] not in required:
                        offenders.append(f"{path.name}:{stmt.lineno} imports {module} without require")
    assert not offenders, offenders


def test_require_names_the_extra_and_how_to_install_it(monkeypatch):
    _without(monkeypatch, "pyuff")
    assert not available("frf")
    with pytest.raises(ImportError, match=r'reading UFF files needs the optional extra \[frf\]: '
                                          r'pip install "vibupdate\[frf\]"') as info:
        require("frf", "reading UFF files")
    assert isinstance(info.value, MissingExtra) and info.value.extra == "frf"
    with pytest.raises(ValueError, match="unknown optional extra 'nope'"):
        require("nope", "x")


def test_library_calls_raise_the_import_error_naming_the_extra(monkeypatch, tmp_path):
    from vibupdate.data.frf import read_uff58
    from vibupdate.study.engine import open_client

    _without(monkeypatch, "pyuff", "distributed")
    with pytest.raises(MissingExtra, match=r"\[frf\]"):
        read_uff58(tmp_path / "x.uff")
    with pytest.raises(MissingExtra, match=r"\[study\]"):
        with open_client(1):
            pass


def test_certified_ranges_and_plots_name_their_extra_before_any_work(monkeypatch, tmp_path):
    from vibupdate.examples import cantilever
    from vibupdate.ranges.certify import certified_ranges
    from vibupdate.report.plots import plot_homotopy

    _without(monkeypatch, "clarabel", "matplotlib", "matplotlib.pyplot")
    with pytest.raises(MissingExtra, match=r"computing certified ranges needs the optional extra \[certify\]"):
        certified_ranges(cantilever.configurations(), seconds=0.0)
    with pytest.raises(MissingExtra, match=r"drawing plots needs the optional extra \[plots\]"):
        plot_homotopy(tmp_path / "h.png", [])
    assert not (tmp_path / "h.png").exists()


@pytest.fixture(scope="module")
def case_file(tmp_path_factory):
    return str(write_case(tmp_path_factory.mktemp("extras")))


@pytest.fixture(scope="module")
def uff_case_file(tmp_path_factory):
    """The tiny case with its mode shapes in a UFF file (read through pyuff)."""
    from outputs_helpers import TINY_CASE

    text = TINY_CASE.replace('name = "A"\n', 'name = "A"\nmode_shapes_uff = "shapes.uff"\n')
    return str(write_case(tmp_path_factory.mktemp("extras_uff"), text))


@pytest.mark.parametrize("argv, missing, line", [
    (["sweep", "{case}", "--samples", "2"], "distributed",
     'vibupdate sweep needs the optional extra [study]: pip install "vibupdate[study]"'),
    (["batch", "{case}"], "distributed",
     'vibupdate batch needs the optional extra [study]: pip install "vibupdate[study]"'),
    (["run", "{case}", "--samples", "2"], "distributed",
     'vibupdate run --samples needs the optional extra [study]: pip install "vibupdate[study]"'),
    (["example", "cantilever", "--samples", "2"], "distributed",
     'vibupdate example --samples needs the optional extra [study]: pip install "vibupdate[study]"'),
    (["run", "{case}", "--certify", "5"], "clarabel",
     'vibupdate run --certify needs the optional extra [certify]: pip install "vibupdate[certify]"'),
    (["example", "cantilever", "--certify", "5"], "clarabel",
     'vibupdate example --certify needs the optional extra [certify]: pip install "vibupdate[certify]"'),
    (["extract", "x.uff", "--band", "10", "100"], "pyuff",
     'vibupdate extract needs the optional extra [frf] for reading UFF files: pip install "vibupdate[frf]"'),
    (["run", "{uff_case}"], "pyuff",
     'vibupdate run needs the optional extra [frf] for reading UFF files: pip install "vibupdate[frf]"'),
])
def test_a_command_whose_extra_is_missing_exits_2_with_one_line(monkeypatch, capsys, tmp_path, case_file,
                                                                 uff_case_file, argv, missing, line):
    _without(monkeypatch, missing)
    out = tmp_path / "out"
    argv = [a.format(case=case_file, uff_case=uff_case_file) for a in argv] + ["--out", str(out)]
    assert main(argv) == 2
    captured = capsys.readouterr()
    assert captured.err.strip() == line
    assert not out.exists()


def test_check_of_a_case_with_uff_data_names_the_extra(monkeypatch, capsys, uff_case_file):
    _without(monkeypatch, "pyuff")
    assert main(["check", uff_case_file]) == 2
    assert capsys.readouterr().err.strip() == ('vibupdate check needs the optional extra [frf] for reading UFF files: '
                                               'pip install "vibupdate[frf]"')


def test_the_example_runs_without_matplotlib_and_says_the_plots_were_skipped(monkeypatch, capsys, tmp_path):
    """The README's first command on a core install: results, report and matrices are
    written, the plots are skipped with one line naming [plots], the exit code is the run's."""
    _without(monkeypatch, "matplotlib", "matplotlib.pyplot")
    out = tmp_path / "cantilever"
    assert main(["example", "cantilever", "--out", str(out)]) == 0
    printed = capsys.readouterr().out
    note = 'plots skipped: they need the optional extra [plots] (pip install "vibupdate[plots]")'
    assert [line for line in printed.splitlines() if "[plots]" in line] == [f"warning: {note}"]
    assert not list(out.glob("*.png"))
    assert {"results.json", "report.md", "M_A.mtx", "K_A.mtx"} <= {p.name for p in out.iterdir()}
    report = (out / "report.md").read_text()
    assert report.count(note) == 1 and ".png" not in report
    doc = json.loads((out / "results.json").read_text())
    assert doc["solver"]["status"] == "success" and note in doc["warnings"]


def test_extract_without_matplotlib_writes_its_files_and_names_the_extra_for_the_plot(monkeypatch, capsys, tmp_path):
    import numpy as np
    from frf_synthetic import measured

    frfs, *_ = measured(8, repeats=2)
    columns = [(r, rep) for (r, _), h in zip(frfs.pairs, frfs.H) for rep in h]   # every pair is excited at y3
    table = tmp_path / "hits.npz"
    np.savez(table, freq_hz=frfs.freq_hz, H=np.stack([rep for _, rep in columns], axis=1))
    _without(monkeypatch, "matplotlib", "matplotlib.pyplot")
    out = tmp_path / "extraction"
    assert main(["extract", str(table), "--responses", *[r for r, _ in columns], "--excitations", "y3",
                 "--band", "20", "300", "--out", str(out)]) == 0
    printed = capsys.readouterr().out
    assert "fit.png was not drawn: drawing plots needs the optional extra [plots]" in printed
    assert not (out / "fit.png").exists() and (out / "extraction.json").exists()


def test_installed_finds_a_module_without_importing_it(monkeypatch):
    from vibupdate.extras import installed

    monkeypatch.delitem(sys.modules, "pyuff", raising=False)
    found = installed("frf")
    assert "pyuff" not in sys.modules       # found, not imported
    assert found == available("frf")
    _without(monkeypatch, "pyuff")
    assert not installed("frf")
