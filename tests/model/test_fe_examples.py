"""The worked examples of the FE-code route (`vibupdate.examples.fe`) end to end through the
command line, and their pages in docs/fe/ against what they run."""

from __future__ import annotations

import json
import re
import sys
import tomllib
from pathlib import Path

import pytest

from vibupdate.cli import main
from vibupdate.examples import fe

ROOT = Path(__file__).resolve().parents[2]
#: Largest relative parameter error allowed: the data are rounded to about 1e-5 (frequencies)
#: and 5e-5 (shapes), stated as such, and rho_col is the weakest-determined parameter
#: (benchmarks/RESULTS.md, "The FE worked examples' data stated as rounded").
TOLERANCE = 1e-3


def _needs(name):
    if name == "fe-opensees":
        pytest.importorskip("opensees")


@pytest.mark.slow
@pytest.mark.parametrize("name", sorted(fe.CODES))
def test_the_worked_example_updates_to_the_truth_through_import_and_run(name, run_once):
    """The command is also the first of the example's page in docs/fe/: one run for the two
    (`conftest.run_once`)."""
    _needs(name)
    code, said, stderr, folder = run_once(f"vibupdate example {name} --out {name}")
    assert code == 0, stderr
    out = folder / name
    imp, run = fe.commands(name)
    # the two commands are printed, in order, and are what ran
    assert said.index("$ vibupdate " + " ".join(imp)) < said.index("$ vibupdate " + " ".join(run))
    assert (out / "model" / "model.toml").is_file() and (out / "model" / "case.toml").is_file()
    doc = json.loads((out / "results" / "results.json").read_text())
    assert doc["solver"]["status"] == "success"
    truth = fe.truth()
    err = {p["name"]: abs(p["updated"] / truth[p["name"]] - 1) for p in doc["parameters"]}
    assert set(err) == set(fe.PARAMETERS) and max(err.values()) <= TOLERANCE, err
    ranges = doc["identifiability"]["ranges"]
    outside = [n for n, v in truth.items() if not ranges[n]["lower"] <= v <= ranges[n]["upper"]]
    assert not outside, (outside, ranges)
    assert "relative error" in said and all(name_ in said for name_ in fe.PARAMETERS)


def test_the_opensees_example_without_the_fe_extra_exits_2_naming_it_and_writes_nothing(tmp_path, monkeypatch,
                                                                                          capsys):
    for module in ("opensees", "opensees.openseespy", "openseespy", "openseespy.opensees"):
        monkeypatch.setitem(sys.modules, module, None)     # an import of it raises ImportError
    assert main(["example", "fe-opensees", "--out", str(tmp_path / "x")]) == 2
    assert 'pip install "vibupdate[fe]"' in capsys.readouterr().err
    assert not (tmp_path / "x").exists()


def test_an_fe_example_refuses_a_folder_in_use_and_force(tmp_path, capsys):
    (tmp_path / "used").mkdir()
    (tmp_path / "used" / "keep.txt").write_text("mine")
    assert main(["example", "fe-nastran", "--out", str(tmp_path / "used")]) == 2
    assert "exists and is not empty" in capsys.readouterr().err
    assert main(["example", "fe-nastran", "--out", str(tmp_path / "new"), "--force"]) == 2
    assert "--force does not apply" in capsys.readouterr().err
    assert not (tmp_path / "new").exists() and (tmp_path / "used" / "keep.txt").read_text() == "mine"


def test_the_data_are_stated_with_tolerances_that_match_their_rounding(tmp_path):
    # before: frequencies rounded to 6 digits and shapes to 4 decimals, both stated as +-1e-3, so
    # the shapes' rounding weighed ten times more than the frequencies' in the answer
    fe.write_inputs("fe-nastran", tmp_path / "x")
    measured = tmp_path / "x" / "measured"
    # frequencies: written to FREQUENCY_DIGITS significant digits (trailing zeros dropped), whose
    # rounding is at most half a unit of the last digit, 5e-6 relative at a mantissa of 1
    largest = 0.5 * 10.0 ** (1 - fe.FREQUENCY_DIGITS)
    assert largest <= fe.FREQUENCY_TOLERANCE <= 2 * largest
    for line in (measured / "frequencies.csv").read_text().splitlines()[1:]:
        value = float(line.split(",")[1])
        assert float(f"{value:.{fe.FREQUENCY_DIGITS}g}") == value, line
    for line in (measured / "shapes.csv").read_text().splitlines()[1:]:
        value, tolerance = line.split(",")[2:4]
        rounding = 0.5 * 10.0 ** -len(value.split(".")[1])
        assert rounding <= float(tolerance) <= 2 * rounding, line
    # the data come from the model family itself: no model-form allowance
    (tmp_path / "x" / "model").mkdir()
    (tmp_path / "x" / "model" / "model.toml").write_text('[model]\nM0 = "M0.npz"\n')
    written = tomllib.loads(fe.write_case("fe-nastran", tmp_path / "x").read_text())
    assert written["frequency_tolerance"] == fe.FREQUENCY_TOLERANCE
    assert written["verification"] == {"natural_tolerance": 0.0, "shape_tolerance": 0.0}


def test_the_fe_examples_are_listed(capsys):
    assert main(["example", "--list"]) == 0
    assert set(fe.CODES) <= set(capsys.readouterr().out.split())


def _page(name):
    return (ROOT / "docs" / "fe" / f"{fe.CODES[name]}.md").read_text(encoding="utf-8")


@pytest.mark.parametrize("name", sorted(fe.CODES))
def test_the_docs_page_shows_the_commands_and_the_import_file_the_example_uses(name, tmp_path):
    _needs(name)
    text = _page(name)
    bash = "\n".join(re.findall(r"```bash\n(.*?)```", text, re.S))
    assert f"vibupdate example {name} --out {name}" in bash.splitlines()
    for command in fe.commands(name):     # the page's transcript ran in the folder the page names
        assert "$ vibupdate " + " ".join(command) in text, command
    # the import file shown is the one the example writes (with its comments left out)
    blocks = [tomllib.loads(b) for b in re.findall(r"```toml\n(.*?)```", text, re.S)]
    shown = [b for b in blocks if "format" in b]
    assert len(shown) == 1
    written = tomllib.loads(fe.write_inputs(name, tmp_path / name).read_text())
    assert shown[0] == written


def test_docs_fe_models_links_every_code_page():
    text = (ROOT / "docs" / "fe-models.md").read_text(encoding="utf-8")
    for code in fe.CODES.values():
        assert f"](fe/{code}.md)" in text, code
