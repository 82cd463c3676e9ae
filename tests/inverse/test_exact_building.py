"""Exact data through `vibupdate run`: the building frame (a structure that is large, not an
over-refined mesh) exported as Matrix Market files with its exact frequencies and point shapes
is updated to its truth within 1e-6 and verified (`success`, exit code 0)."""

import json

import pytest

from vibupdate.examples import building


def _run_building(tmp_path, storeys: int, bays: int) -> tuple[int, dict]:
    from test_exact import _write_matrices_case   # this folder is on the path (pytest's prepend import mode)

    from vibupdate.cli import main

    model = building.model(storeys, bays)
    omega, _, shapes = building.exact_data(storeys, bays)
    case = _write_matrices_case(tmp_path, model, list(building.measured_dofs(storeys, bays)), omega, shapes)
    code = main(["run", str(case), "--out", str(tmp_path / "out")])
    return code, json.loads((tmp_path / "out" / "results.json").read_text())


def _check(code: int, doc: dict) -> None:
    truth = building.truth()
    assert doc["problem_size"]["n_parameters"] == 12
    err = {p["name"]: abs(p["updated"] / truth[p["name"]] - 1) for p in doc["parameters"]}
    assert code == 0 and doc["solver"]["status"] == "success", doc["solver"]["warnings"]
    assert max(err.values()) <= 1e-6, err
    assert doc["solver"]["polish"]["stopped_on"] == "convergence"
    assert not doc["solver"]["warnings"]


def test_exact_data_of_a_315_dof_building_through_vibupdate_run(tmp_path):
    """7 storeys x 1 bay (measured: largest parameter error 3.9e-12, 21 polish evaluations, 4.8 s)."""
    code, doc = _run_building(tmp_path, 7, 1)
    _check(code, doc)


@pytest.mark.slow
def test_exact_data_of_a_2940_dof_building_through_vibupdate_run(tmp_path):
    """14 storeys x 6 bays (measured: largest parameter error 1.8e-11, 3 reduced rounds, 28 s)."""
    code, doc = _run_building(tmp_path, 14, 6)
    _check(code, doc)
