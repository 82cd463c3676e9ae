"""A run through the command line with conflicting data: results.json, the report and the
matrix files carry the diagnosis and say that the model is not verified; a verified run has
neither."""

import json

import pytest

from helpers import BIASED_CHAIN_TRUTH, biased_chain
from vibupdate.cli import main
from vibupdate.io.manifests import read_manifest
from vibupdate.io.results import DiagnosisRecord, load_results, validate_document

BUILDER = '''from vibupdate import Assembly


def build(p):
    asm = Assembly("beam")
    for i in range(1, 6):
        asm.node(i, float(i))
    for i in range(1, 6):
        asm.fix(f"phi{i}")
        asm.mass(f"y{i}", 1.0)
    asm.spring("y1", p["k1"])
    for i in range(2, 6):
        asm.spring(f"y{i - 1}", p[f"k{i}"], f"y{i}")
    return asm.system()
'''


def write_case(folder, bias: float):
    """The chain of `helpers.biased_chain` as a case file: a builder, four exact frequencies,
    shapes at every DOF within +-0.005, the driving point y3 scaled by ``1 + bias``."""
    _, freqs, shapes = biased_chain("y3", bias)
    (folder / "model.py").write_text(BUILDER)
    rows = ["mode,dof,value,tolerance"] + [f"{m},{d},{v!r},0.005" for m, s in enumerate(shapes, start=1)
                                           for d, v in s.items()]
    (folder / "shapes.csv").write_text("\n".join(rows) + "\n")
    parameters = "".join(f'\n[[parameter]]\nname = "{name}"\nunit = "N/m"\nnominal = 1000.0\nlower = 700.0\n'
                         f"upper = 1300.0\n" for name in BIASED_CHAIN_TRUTH)
    case = folder / "case.toml"
    case.write_text(f'case = "chain"\n\n[model]\ntype = "builder"\nbuilder = "model.py:build"\n{parameters}\n'
                    f'[[configuration]]\nname = "A"\nnatural_hz = {freqs!r}\nmode_shapes_csv = "shapes.csv"\n')
    return case


@pytest.fixture(scope="module")
def biased_run(tmp_path_factory):
    folder = tmp_path_factory.mktemp("biased")
    out = folder / "out"
    code = main(["run", str(write_case(folder, 0.10)), "--out", str(out)])
    return code, out


def test_conflicting_data_are_diagnosed_in_results_json_and_the_report(biased_run):
    code, out = biased_run
    assert code == 1
    doc = json.loads((out / "results.json").read_text())
    validate_document(doc)
    assert doc["success"] is False and doc["diagnosis"]["trials"][0]["key"] == "A/dof/y3"
    run = load_results(out / "results.json")   # typed on reload
    assert isinstance(run.diagnosis, DiagnosisRecord) and run.diagnosis.worst.key == "A/dof/y3"
    assert run.diagnosis.best.status == "success" and run.diagnosis.best.without == "A/dof/y3"
    for name, value in run.diagnosis.best.values.items():
        assert abs(value - BIASED_CHAIN_TRUTH[name]) <= 1e-3 * BIASED_CHAIN_TRUTH[name], name
    report = (out / "report.md").read_text()
    section = report[report.index("## Which data conflict"):]
    assert "shape entry of DOF 'y3' in every mode" in section.split("\n| 2 |")[0]
    assert "Updated again in full" in section and "**success**" in section


def test_a_not_verified_model_is_written_under_names_that_say_so(biased_run):
    _, out = biased_run
    run = load_results(out / "results.json")
    expected = {"M": "not_verified_M_A.mtx", "K": "not_verified_K_A.mtx",
                "M_without_worst": "without_worst_M_A.mtx", "K_without_worst": "without_worst_K_A.mtx"}
    assert run.matrix_files == {"A": expected}
    files = set(read_manifest(out))
    assert set(expected.values()) <= files and not {"M_A.mtx", "K_A.mtx"} & files
    assert "vibupdate: K of configuration A, not_verified" in (out / "not_verified_K_A.mtx").read_text()
    report = (out / "report.md").read_text()
    assert "`not_verified_M_A.mtx`" in report and "`without_worst_K_A.mtx`" in report


def test_no_diagnose_keeps_the_not_verified_names_without_a_diagnosis(tmp_path, capsys):
    out = tmp_path / "out"
    assert main(["run", str(write_case(tmp_path, 0.10)), "--out", str(out), "--no-diagnose"]) == 1
    assert "diagnosis" not in capsys.readouterr().out
    run = load_results(out / "results.json")
    assert run.diagnosis is None and run.matrix_files == {"A": {"M": "not_verified_M_A.mtx",
                                                                "K": "not_verified_K_A.mtx"}}
    assert "Which data conflict" not in (out / "report.md").read_text()


def test_a_verified_run_has_no_diagnosis_and_the_usual_matrix_names(tmp_path, capsys):
    out = tmp_path / "out"
    assert main(["run", str(write_case(tmp_path, 0.0)), "--out", str(out)]) == 0
    assert "diagnosis" not in capsys.readouterr().out
    doc = json.loads((out / "results.json").read_text())
    validate_document(doc)
    assert doc["diagnosis"] is None and doc["matrix_files"] == {"A": {"M": "M_A.mtx", "K": "K_A.mtx"}}
    assert {"M_A.mtx", "K_A.mtx"} <= set(read_manifest(out))
    assert "Which data conflict" not in (out / "report.md").read_text()


def test_a_diagnosed_run_reloads_typed_and_writes_back_the_same_bytes(biased_run, tmp_path):
    """The diagnosis, its best update's status and checks reload as their types; the loaded
    object writes the same file."""
    from vibupdate.inverse.status import Status
    from vibupdate.inverse.verify import Check as CheckRow
    from vibupdate.io.results import write_results

    _, out = biased_run
    loaded = load_results(out / "results.json")
    assert loaded.status is Status.NOT_VERIFIED and isinstance(loaded.diagnosis, DiagnosisRecord)
    best = loaded.diagnosis.best
    assert isinstance(best.status, Status) and all(isinstance(c, CheckRow) for c in best.checks)
    assert write_results(tmp_path / "results.json", loaded).read_bytes() == (out / "results.json").read_bytes()
