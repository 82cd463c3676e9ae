"""The command line and the README."""

import json
import re
from pathlib import Path

import pytest

from vibupdate.cli import main

ROOT = Path(__file__).resolve().parents[1]


def test_example_list(capsys):
    assert main(["example", "--list"]) == 0
    assert "cantilever" in capsys.readouterr().out


def test_unknown_example_is_a_clear_error(capsys, tmp_path):
    assert main(["example", "nothing", "--out", str(tmp_path)]) == 2
    assert "unknown example 'nothing'" in capsys.readouterr().err


def test_readme_opens_with_the_two_commands():
    text = (ROOT / "README.md").read_text()
    first_block = re.search(r"```(?:bash|sh)?\n(.*?)```", text, re.S).group(1)
    assert 'pip install . && vibupdate example cantilever' in first_block
    assert 'pip install ".[test]" && pytest' in first_block


def test_readme_python_examples_run(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    text = (ROOT / "README.md").read_text()
    blocks = re.findall(r"```python\n(.*?)```", text, re.S)
    assert blocks, "README has no python example"
    for block in blocks:
        exec(compile(block, "README.md", "exec"), {})


def test_example_cantilever_writes_results_json(tmp_path, capsys):
    out = tmp_path / "run"
    assert main(["example", "cantilever", "--out", str(out)]) == 0
    doc = json.loads((out / "results.json").read_text())
    for key in ("case", "parameters", "frequencies", "damping", "summary", "problem_size", "solver"):
        assert key in doc
    rows = doc["frequencies"]
    assert len(rows) == 16
    assert {r["configuration"] for r in rows} == {"A", "B", "C", "D"}
    assert sorted({r["index"] for r in rows if r["kind"] == "natural"}) == [1, 2, 3]
    assert [r["index"] for r in rows if r["kind"] == "antiresonance"] == [1, 1, 1, 1]
    first = rows[0]
    assert first["measured_hz"] == pytest.approx(73.4)
    assert first["error_nominal_pct"] == pytest.approx(
        100 * abs(first["nominal_hz"] - 73.4) / 73.4)
    assert [p["name"] for p in doc["parameters"]] == ["E", "rho", "macc", "mlc", "klc", "Ep", "rho_p"]
    out = capsys.readouterr().out
    assert "Frequencies [Hz]" in out and "paper upd" in out and "lambda = 1.0000" in out
    assert doc["solver"]["status"] == "success"
    assert doc["summary"]["mean_error_updated_pct"] <= 0.6
    assert len(doc["solver"]["steps"]) >= 11
    assert set(doc["solver"]["steps"][0]) >= {"lambda", "objective", "iterations", "status", "seconds"}
    assert doc["solver"]["relaxation_lower_bound"] <= doc["solver"]["objective"]
    assert doc["problem_size"]["n_lifted"] == 552
    assert all(p["lower"] <= p["updated"] <= p["upper"] for p in doc["parameters"])
