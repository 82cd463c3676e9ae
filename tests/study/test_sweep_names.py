"""A sweep names each datum as a run does (`vibupdate.data.names`): the model mode, not the
position among the measured frequencies, and a zero by its receptance and index; a sweep
written with the earlier positional columns (``A:f1_hz``) resumes."""

import csv
import json
import shutil

import numpy as np
import pytest

from sweep_cases import TRUTH, chain_case_text, chain_frequencies_hz
from helpers import chain_model
from vibupdate.cli import main
from vibupdate.io.case import load_case
from vibupdate.modal.analysis import antiresonances
from vibupdate.study.sampling import SamplingOptions, data_intervals, draw_configurations, positional_labels
from vibupdate.study.sweep import RUN_COLUMNS, columns, read_rows, run_sweep

#: The chain's measured modes (its first is not measured), and its one zero of h_y1,y3.
MODES = (2, 3, 4, 5)
DAMPING = (0.010, 0.012, 0.015, 0.020)
#: The data columns of that case, in their order.
PREDICTED = ["A:mode2_hz", "A:mode3_hz", "A:mode4_hz", "A:mode5_hz", "A:zero1_h_y1/y3_hz"]
DRAWN = PREDICTED + ["A:mode2_xi", "A:mode3_xi", "A:mode4_xi", "A:mode5_xi"]
#: The same columns as earlier versions named them, by position.
POSITIONAL = ["A:f1_hz", "A:f2_hz", "A:f3_hz", "A:f4_hz", "A:z1_hz", "A:xi1", "A:xi2", "A:xi3", "A:xi4"]


def _higher_modes_case(path):
    """The sweep tests' chain measured in its modes 2-5 (with damping ratios) and the first
    zero of its transfer receptance h_y1,y3, all at the true parameters."""
    model = chain_model(5, list(TRUTH))
    M, K = model.matrices(model.normalized([TRUTH[p.name] for p in model.parameters]))
    hz = chain_frequencies_hz(TRUTH)
    zero = antiresonances(M, K, model.dof("y1"), model.dof("y3"))[0]
    text = chain_case_text().split("[[configuration]]")[0]
    text += ("[[configuration]]\nname = \"A\"\n"
             f"natural_hz = [{', '.join(repr(float(hz[m - 1])) for m in MODES)}]\n"
             f"natural_modes = {list(MODES)}\ndamping_ratios = {list(DAMPING)}\n"
             f"antiresonances = [{{ hz = {float(zero / (2 * np.pi))!r}, response = \"y1\", excitation = \"y3\", "
             "index = 1 }]\n")
    path.write_text(text, encoding="utf-8")
    return path


@pytest.fixture(scope="module")
def case_file(tmp_path_factory):
    return _higher_modes_case(tmp_path_factory.mktemp("case") / "higher.toml")


@pytest.fixture(scope="module")
def client():
    from vibupdate.study.engine import open_client

    with open_client(1) as c:   # the local cluster a sweep starts itself
        yield c


@pytest.fixture(scope="module")
def sweep(client, case_file, tmp_path_factory):
    out = tmp_path_factory.mktemp("sweep") / "s"
    run_sweep(str(case_file), out, 4, seed=3, client=client, plots=False)
    return out


def test_the_columns_name_the_model_mode_and_the_zero_s_receptance(case_file):
    case = load_case(case_file)
    header = columns(case, SamplingOptions())
    assert [c[5:] for c in header if c.startswith("pred:")] == PREDICTED
    assert [c[5:] for c in header if c.startswith("data:")] == DRAWN
    assert not [c for c in header if "," in c or " " in c]          # CSV-safe: no comma, no blank
    drawn = draw_configurations(case.configurations, case.frequency_tolerance, 3, 0)[1]
    assert list(drawn) == ["A:mode2_xi", "A:mode2_hz", "A:mode3_xi", "A:mode3_hz", "A:mode4_xi", "A:mode4_hz",
                           "A:mode5_xi", "A:mode5_hz", "A:zero1_h_y1/y3_hz"]
    named = {d.label: d.name for d in data_intervals(case.configurations, case.frequency_tolerance)}
    assert named["A:mode2_hz"] == "mode 2 (measured 1)" and named["A:zero1_h_y1/y3_hz"] == "zero 1 of h_y1,y3"
    assert positional_labels(case.configurations) == dict(zip(POSITIONAL, PREDICTED + DRAWN[5:]))


def test_a_sweep_s_files_name_the_data_as_a_run_does(case_file, sweep):
    header, rows = read_rows(sweep / "samples.csv")
    assert [c for c in header if c.startswith(("pred:", "data:"))] == \
        [f"pred:{c}" for c in PREDICTED] + [f"data:{c}" for c in DRAWN]
    case = load_case(case_file)
    measured = {d.label: d for d in data_intervals(case.configurations, case.frequency_tolerance)}
    ok = [r for r in rows if r["outcome"] == "verified"]
    assert len(ok) >= 3
    for r in ok:   # each column holds its datum: the model's mode 2 beside the drawn mode 2
        for label in PREDICTED:
            d = measured[label]
            assert d.lower <= r[f"data:{label}"] <= d.upper
            assert r[f"pred:{label}"] == pytest.approx(r[f"data:{label}"], rel=0.02)
    doc = json.loads((sweep / "sweep.json").read_text())
    assert [(p["label"], p["name"], p["kind"]) for p in doc["predictions"]] == [
        ("A:mode2_hz", "mode 2 (measured 1)", "natural"), ("A:mode3_hz", "mode 3 (measured 2)", "natural"),
        ("A:mode4_hz", "mode 4 (measured 3)", "natural"), ("A:mode5_hz", "mode 5 (measured 4)", "natural"),
        ("A:zero1_h_y1/y3_hz", "zero 1 of h_y1,y3", "antiresonance")]
    assert all(p["configuration"] == "A" and p["q50"] == pytest.approx(p["measured_hz"], rel=0.02)
               for p in doc["predictions"])


def _positional_copy(sweep, to, keep):
    """The sweep's folder as an earlier version left it, stopped after ``keep`` rows: the data
    columns named by position."""
    shutil.copytree(sweep, to)
    with open(sweep / "samples.csv", newline="", encoding="utf-8") as f:
        lines = list(csv.reader(f))
    renamed = {f"{side}:{new}": f"{side}:{old}" for old, new in zip(POSITIONAL, PREDICTED + DRAWN[5:])
               for side in ("pred", "data")}
    with open(to / "samples.csv", "w", newline="", encoding="utf-8") as f:
        csv.writer(f).writerows([[renamed.get(c, c) for c in lines[0]], *lines[1:1 + keep]])
    return lines[0]


def _data_rows(rows):
    return [{k: v for k, v in r.items() if k not in RUN_COLUMNS} for r in sorted(rows, key=lambda r: r["index"])]


def test_a_sweep_with_positional_columns_resumes_under_the_data_s_names(client, case_file, sweep, tmp_path):
    old = tmp_path / "old"
    header = _positional_copy(sweep, old, keep=2)
    assert "pred:A:f1_hz" in (old / "samples.csv").read_text().splitlines()[0]
    said = []
    run_sweep(str(case_file), old, 4, seed=3, client=client, resume=True, plots=False, progress=said.append)
    resumed_header, resumed = read_rows(old / "samples.csv")
    assert resumed_header == header
    assert _data_rows(resumed) == _data_rows(read_rows(sweep / "samples.csv")[1])
    assert any("renamed to the data's names" in s and "data:A:f1_hz -> data:A:mode2_hz" in s for s in said)
    assert "resuming: 2 of 4 samples done, 2 to go" in said


def test_a_samples_file_of_other_columns_is_refused_naming_it(case_file, sweep, tmp_path, capsys):
    other = tmp_path / "other"
    shutil.copytree(sweep, other)
    text = (other / "samples.csv").read_text(encoding="utf-8")
    (other / "samples.csv").write_text(text.replace("data:A:mode3_hz", "data:A:mode9_hz", 1), encoding="utf-8")
    code = main(["sweep", str(case_file), "--samples", "4", "--seed", "3", "--resume", "--out", str(other)])
    err = capsys.readouterr().err
    assert code == 2
    assert str(other / "samples.csv") in err and "'data:A:mode9_hz'" in err and "'data:A:mode3_hz'" in err
    assert "run the sweep again with another --out" in err and "Traceback" not in err
    assert (other / "samples.csv").read_text(encoding="utf-8") == text.replace("data:A:mode3_hz", "data:A:mode9_hz", 1)


def test_data_whose_columns_would_read_alike_are_refused_before_any_work():
    """A column joins response and excitation with '/'; DOF names that hold '/' could make two
    receptances' zeros one column, and one of them would be lost from samples.csv."""
    import scipy.sparse as sp

    from vibupdate import Configuration, NaturalFrequency, Parameter
    from vibupdate.data.measured import Antiresonance
    from vibupdate.model.build import from_files

    K = sp.csr_matrix(np.array([[2.0, -1, 0, 0], [-1, 2, -1, 0], [0, -1, 2, -1], [0, 0, -1, 1]]) * 1000)
    model = from_files(sp.identity(4, format="csr"), K, [Parameter("k", 1.0, 0.5, 1.5)], dK={"k": K},
                       dofs=["a/b", "c", "a", "b/c"])
    zeros = (Antiresonance(2 * np.pi * 3.1, "a/b", "c", index=1), Antiresonance(2 * np.pi * 3.3, "a", "b/c", index=1))
    cfg = Configuration("A", model, (NaturalFrequency(2 * np.pi * 1.4),), zeros)
    with pytest.raises(ValueError, match=r"zero 1 of h_a/b,c and zero 1 of h_a,b/c of configuration 'A' would "
                                         r"share the column 'A:zero1_h_a/b/c_hz'"):
        data_intervals((cfg,), 0.01)
