"""One results object: results.json is written from it, matches the shipped schema and reads
back into the same typed object."""

import dataclasses
import json

import numpy as np
import pytest
from outputs_helpers import write_case

from vibupdate.io.results import (
    FORMAT_VERSION,
    DampingRow,
    DeclaredSensor,
    FrequencyRow,
    MeshSensor,
    ParameterRow,
    RunResult,
    Summary,
    load_results,
    schema,
    validate_document,
)


@pytest.fixture(scope="module")
def tiny_run(tmp_path_factory):
    from vibupdate.io.case import load_case
    from vibupdate.pipeline import run_case

    folder = tmp_path_factory.mktemp("tiny")
    case = load_case(write_case(folder))
    run = run_case(case, folder / "out")
    return run, folder / "out", case


def _fields(cls) -> set[str]:
    return {f.name for f in dataclasses.fields(cls)} - {"extra", "matrices"}


def test_the_written_file_matches_the_shipped_schema(tiny_run):
    _, out, _ = tiny_run
    doc = json.loads((out / "results.json").read_text())
    validate_document(doc)
    assert schema()["title"] == "vibupdate results.json"


def test_load_results_returns_the_same_typed_frozen_object(tiny_run):
    run, out, _ = tiny_run
    loaded = load_results(out / "results.json")
    assert isinstance(loaded, RunResult)
    assert loaded == run  # every field but the matrices, which live in the .mtx files
    matrices = run.matrices["A"]
    assert loaded.matrices == {} and matrices.C is not None and matrices.without_worst is None
    assert isinstance(loaded.parameters[0], ParameterRow) and isinstance(loaded.frequencies[0], FrequencyRow)
    assert isinstance(loaded.damping[0], DampingRow) and isinstance(loaded.summary, Summary)
    with pytest.raises(dataclasses.FrozenInstanceError):
        loaded.case = "other"


def test_every_key_of_the_written_file_comes_from_the_typed_result(tiny_run):
    run, out, _ = tiny_run
    doc = json.loads((out / "results.json").read_text())
    assert set(doc) == _fields(RunResult)
    assert doc == run.as_document()
    assert RunResult.from_document(doc).as_document() == doc
    for key, cls in (("parameters", ParameterRow), ("frequencies", FrequencyRow), ("damping", DampingRow)):
        for row, typed in zip(doc[key], getattr(run, key)):
            assert set(row) == _fields(cls) | {k for k, _ in typed.extra}
    assert set(doc["summary"]) == _fields(Summary)


def test_the_file_carries_version_xbar_references_dofs_mac_warnings_and_checks(tiny_run):
    from vibupdate import __version__

    run, out, case = tiny_run
    doc = json.loads((out / "results.json").read_text())
    model = case.configurations[0].model
    assert doc["version"] == __version__ and doc["format_version"] == FORMAT_VERSION
    np.testing.assert_allclose(doc["xbar"], [p["xbar"] for p in doc["parameters"]])
    # xbar = (p - p0) / p_ref (Eq. 12) with the reference values written beside them
    for p in doc["parameters"]:
        assert p["reference"] == next(q.reference for q in model.parameters if q.name == p["name"])
        assert p["xbar"] == pytest.approx((p["updated"] - p["nominal"]) / p["reference"], rel=1e-12, abs=1e-15)
    assert doc["dofs"] == {"A": list(model.dofs)}
    assert set(doc["mac"]) == {"A"} and len(doc["mac"]["A"]) == 2
    assert isinstance(doc["warnings"], list) and isinstance(doc["checks"], list)
    assert doc["frf"]["A"]["response"] in model.dofs


def test_a_file_that_breaks_the_schema_is_a_clear_error(tiny_run, tmp_path):
    _, out, _ = tiny_run
    doc = json.loads((out / "results.json").read_text())
    renamed = dict(doc)
    renamed["params"] = renamed.pop("parameters")
    for bad, where in ((renamed, "parameters"), ({**doc, "xbar": "one"}, "xbar"),
                       ({k: v for k, v in doc.items() if k != "version"}, "version")):
        path = tmp_path / "results.json"
        path.write_text(json.dumps(bad))
        with pytest.raises(ValueError, match=where) as info:
            load_results(path)
        assert str(path) in str(info.value)
    path.write_text("{not json")
    with pytest.raises(ValueError, match="could not be read"):
        load_results(path)


def test_mac_values_and_the_mac_plot_come_from_the_result_for_measured_shapes():
    """The frame example measures shapes: MAC per mode and the MAC matrix are in the object."""
    from vibupdate.examples import frame
    from vibupdate.io.results import run_result
    from vibupdate.inverse.update import update

    case = frame.case()
    result = update(case.configurations, formulation=case.formulation, solver=case.solver)
    run = run_result(case, result)
    doc = run.as_document()
    validate_document(doc)
    mac = doc["mac"]["frame"]
    assert len(mac) == len(case.configurations[0].natural) and min(mac) > 0.9
    matrix = np.array(doc["mac_matrix"]["frame"]["values"], dtype=float)
    np.testing.assert_allclose(np.diag(matrix)[:len(mac)], mac, rtol=1e-8)


def test_the_outputs_page_example_runs(tiny_run, tmp_path, monkeypatch, capsys):
    import re
    import shutil
    from pathlib import Path

    _, out, _ = tiny_run
    shutil.copytree(out, tmp_path / "case-results")
    monkeypatch.chdir(tmp_path)
    text = (Path(__file__).resolve().parents[2] / "docs" / "outputs.md").read_text()
    blocks = re.findall(r"```python\n(.*?)```", text, re.S)
    assert blocks
    for block in blocks:
        exec(compile(block, "docs/outputs.md", "exec"), {})
    assert "tiny" in capsys.readouterr().out


def _paths(value, path=()):
    """Every place in a JSON document: ``path`` tuples of keys and indices."""
    yield path
    if isinstance(value, dict):
        for key, item in value.items():
            yield from _paths(item, path + (key,))
    elif isinstance(value, list):
        for k, item in enumerate(value):
            yield from _paths(item, path + (k,))


def _replaced(doc, path, new):
    doc = json.loads(json.dumps(doc))
    *head, last = path
    target = doc
    for key in head:
        target = target[key]
    if new is _DELETE:
        del target[last]
    else:
        target[last] = new
    return doc


_DELETE = object()


@pytest.mark.slow
def test_the_schema_checker_agrees_with_jsonschema_on_valid_and_broken_documents(tiny_run):
    """`vibupdate.io.schema_check` (no schema library at run time) against the reference
    implementation: every place of a written document replaced by a string, a negative
    number, null, an empty list or deleted; both must agree on valid or not."""
    jsonschema = pytest.importorskip("jsonschema")
    from vibupdate.io.schema_check import first_error

    _, out, _ = tiny_run
    doc = json.loads((out / "results.json").read_text())
    reference = jsonschema.Draft202012Validator(schema())
    cases = [doc]
    for path in list(_paths(doc))[1:]:
        cases += [_replaced(doc, path, new) for new in ("text", -1, -0.5, None, [], _DELETE)
                  if not (new is _DELETE and isinstance(path[-1], int))]
    disagree = [k for k, case in enumerate(cases)
                if (first_error(case, schema()) is None) != reference.is_valid(case)]
    assert len(cases) > 500 and not disagree, disagree[:5]



def test_the_measured_points_of_an_imported_mesh_reload_with_their_directions(tiny_run, tmp_path):
    """`read_sensors` gives each measured point the direction it reads (null for a rotational
    DOF), the run writes it: the schema must take it so that the file reads back."""
    from vibupdate.io.results import write_results

    run, _, _ = tiny_run
    mesh = tuple(MeshSensor.from_dict(s) for s in (
        {"sensor": "acc1", "dof": "12:x", "sign": -1.0, "distance_m": 0.004, "direction": [-1.0, 0.0, 0.0]},
        {"sensor": "gyro", "dof": "12:rz", "sign": 1.0, "distance_m": 0.0, "direction": None}))
    loaded = load_results(write_results(tmp_path / "results.json", dataclasses.replace(run, sensors=mesh)))
    assert loaded.sensors == mesh


def test_declared_sensors_reload_with_their_weights(tiny_run, tmp_path):
    from vibupdate.io.results import write_results

    run, _, _ = tiny_run
    declared = (DeclaredSensor("f1_a", {"f1:x": 1.0, "f1:rz": -2.5}), DeclaredSensor("b", {"y": 2.0}))
    loaded = load_results(write_results(tmp_path / "results.json", dataclasses.replace(run, declared_sensors=declared)))
    assert loaded.declared_sensors == declared
    assert run.declared_sensors == ()   # a case without [[sensor]] lists none


def test_every_field_reloads_as_its_type_and_writes_back_the_same_bytes(tiny_run, tmp_path):
    """``load_results`` gives each section its record (no dict left at the top level), the
    statuses as `Status` and `Verdict`, and writing the loaded object gives the file back byte
    for byte."""
    from vibupdate.inverse.status import Status, Verdict
    from vibupdate.inverse.homotopy import StepRecord as StepRow
    from vibupdate.inverse.verify import Check as CheckRow
    from vibupdate.io.records import DampingModel, Identifiability, LinearRange, MacMatrix, PlottedReceptance, SolverRecord
    from vibupdate.io.results import write_results

    run, out, _ = tiny_run
    loaded = load_results(out / "results.json")
    # frequencies alone see E / rho only: the other answers along that valley make it not unique
    assert loaded.status is Status.SUCCESS and loaded.solver.verdict is Verdict.NOT_UNIQUE
    assert isinstance(loaded.solver, SolverRecord) and all(isinstance(s, StepRow) for s in loaded.solver.steps)
    assert loaded.solver.steps[-1].status is Status.SUCCESS and loaded.solver.attempts[0].status is Status.SUCCESS
    assert isinstance(loaded.identifiability, Identifiability) and isinstance(loaded.damping_model, DampingModel)
    assert all(isinstance(r, LinearRange) for r in loaded.identifiability.ranges.values())
    assert all(isinstance(c, CheckRow) for c in (*loaded.checks, *loaded.solver.checks))
    from vibupdate.inverse.search import Search, Sought
    assert isinstance(loaded.solver.sought, Sought) and isinstance(loaded.solver.sought.search, Search)
    assert isinstance(loaded.frf["A"], PlottedReceptance) and loaded.dofs["A"] == run.dofs["A"]
    mappings = {f.name for f in dataclasses.fields(RunResult) if isinstance(getattr(loaded, f.name), dict)}
    assert mappings == {"mac", "mac_matrix", "dofs", "frf", "problem_size", "matrix_files", "matrices"}   # by name
    assert loaded.frequencies[0].name == "mode 1" and loaded.frequencies[0].model_index == 1
    assert not any(row.extra for row in loaded.frequencies)
    again = write_results(tmp_path / "results.json", loaded)
    assert again.read_bytes() == (out / "results.json").read_bytes()
    assert MacMatrix.from_dict({"dofs": ["a"], "values": [[1.0]]}).as_dict() == {"dofs": ["a"], "values": [[1.0]]}
