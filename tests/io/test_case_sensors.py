"""Sensors declared in a case file: the braced frame of the benchmark class with four
accelerometers per rigid floor (16 sensors, the fourth of each floor a combination of the other
three) and its braces as 16 element groups, updated and diagnosed through the CLI from a case
written without any transformation of the model; and the errors of a sensor declaration."""

import json

import numpy as np
import pytest
import scipy.linalg

import braced_floors as bf
from vibupdate.cli import main
from vibupdate.io.case import load_case

#: Three damaged brace groups: storey 1 south, storey 2 east, storey 4 north.
TRUTH = {"brace_1s": 0.6, "brace_2e": 0.75, "brace_4n": 0.85}
N_MODES = 8

CASE = """case = "braced-floors"
{top}
[model]
type = "element_matrices"
elements = "elements/elements.csv"

[[{table}]]
name = "{{group}}"
each_group = "brace_*"
nominal = 1.0
lower = 0.3
upper = 1.5

{sensors}
[[configuration]]
name = "test"
natural_hz = [{hz}]
mode_shapes_csv = "shapes.csv"
"""


def write_case(folder, table="parameter", sensors=None, values=TRUTH, top="", full=False) -> str:
    """The case of the frame at the brace factors ``values``: element files, the sensors as
    ``[[sensor]]`` tables (rigid body, offset, direction), exact frequencies and shapes at the
    16 sensors (each reading computed from the DOF weights of `braced_floors.sensor_weights`).
    ``full``: the 120-DOF model (each floor node's z, rx, ry beside the floor DOFs)."""
    K, M = bf.matrices(values, full)
    lam, phi = scipy.linalg.eigh(K, M)
    names = bf.floor_dofs(full)
    rows = ["mode,dof,value,tolerance"]
    for k in range(N_MODES):
        for s, w in bf.sensor_weights().items():
            rows.append(f"{k + 1},{s},{float(sum(c * phi[names.index(d), k] for d, c in w.items()))!r},0")
    (folder / "shapes.csv").write_text("\n".join(rows) + "\n")
    bf.write_elements(folder / "elements", full)
    hz = ", ".join(repr(float(x)) for x in np.sqrt(lam[:N_MODES]) / (2 * np.pi))
    path = folder / "case.toml"
    path.write_text(CASE.format(table=table, sensors=bf.sensor_tables() if sensors is None else sensors, hz=hz,
                                top=top))
    return str(path)


@pytest.mark.parametrize("full", [False, pytest.param(True, marks=pytest.mark.slow)])   # 12 DOFs: 5 s; 120: 10 s
def test_sixteen_floor_sensors_and_sixteen_brace_groups_recover_the_damage_through_run(tmp_path, capsys, full):
    code = main(["run", write_case(tmp_path, full=full), "--out", str(tmp_path / "out")])
    assert code == 0, capsys.readouterr().err
    doc = json.loads((tmp_path / "out" / "results.json").read_text())
    updated = {p["name"]: p["updated"] for p in doc["parameters"]}
    assert len(updated) == 16
    assert max(abs(updated[g] - TRUTH.get(g, 1.0)) for g in updated) <= 1e-6, updated
    # every sensor is data: the MAC table's rows are the 16 sensors, the floor's fourth among them
    assert doc["mac_matrix"]["test"]["dofs"] == list(bf.sensor_weights())
    assert min(doc["mac"]["test"]) >= 1 - 1e-12


@pytest.mark.slow   # 16 candidates, 1-2 min on 2 cores
def test_suggest_names_the_damaged_brace_groups_of_the_sixteen_sensor_frame(tmp_path, capsys):
    path = write_case(tmp_path, table="candidate")
    assert main(["suggest", path, "--out", str(tmp_path / "out")]) == 0, capsys.readouterr().err
    assert "suggested: add brace_1s + brace_2e + brace_4n (verified" in capsys.readouterr().out


def _layout_sheet() -> str:
    """The sensors as a layout sheet lists them: one row per sensor, floor DOFs, offset, direction."""
    rows = ["sensor,x,y,rz,offset_x,offset_y,direction"]
    for f in range(1, 5):
        rows += [f"f{f}{name},f{f}:x,f{f}:y,f{f}:rz,{dx!r},{dy!r},{axis}" for name, (dx, dy), axis in bf.LAYOUT]
    return "\n".join(rows) + "\n"


@pytest.mark.parametrize("layout", ["weights", "rigid"])
def test_a_sensors_csv_declares_the_same_sensors_as_the_rigid_body_tables(tmp_path, layout):
    if layout == "weights":
        rows = ["sensor,dof,weight"] + [f"{s},{d},{w!r}" for s, ws in bf.sensor_weights().items()
                                        for d, w in ws.items()]
        (tmp_path / "sensors.csv").write_text("\n".join(rows) + "\n")
    else:
        (tmp_path / "sensors.csv").write_text(_layout_sheet())
    by_tables = load_case(write_case(tmp_path)).configurations[0].model
    by_csv = load_case(write_case(tmp_path, sensors="", top='sensors = "sensors.csv"')).configurations[0].model
    names = list(bf.sensor_weights())
    assert [s.name for s in by_csv.sensors] == names
    assert abs(by_tables.measurement(names) - by_csv.measurement(names)).max() <= 1e-15


@pytest.mark.parametrize("text, message", [
    ("sensor,dof,weight\na,f1:x,1\nb,f1:y,1\na,f1:rz,2\n", "sensor 'a' is declared twice (its rows are not together)"),
    ("sensor,dof,wieght\na,f1:x,1\n", "unknown column 'wieght' (did you mean 'weight'?)"),
    ("sensor,x,y,rz,offset_x,offset_y\na,f1:x,f1:y,f1:rz,0,1\n", "sensor 'a' needs its direction"),
    ("sensor,x,rz,offset_x,offset_y,direction\na,f1:x,f1:rz,1,0,y\n", "reads the body's 'y'"),
])
def test_a_bad_sensors_csv_exits_2_naming_the_row(tmp_path, capsys, text, message):
    (tmp_path / "sensors.csv").write_text(text)
    assert main(["check", write_case(tmp_path, sensors="", top='sensors = "sensors.csv"')]) == 2
    err = capsys.readouterr().err
    assert message in err and "sensors.csv" in err and "Traceback" not in err


@pytest.mark.parametrize("sensors, message", [
    ('[[sensor]]\nname = "a"\ndofs = {"f1:x" = 1.0, "f7:rz" = 2.5}\n',
     "sensor 'a' reads DOF 'f7:rz', which does not exist; the model's DOFs are f1:x"),
    ('[[sensor]]\nname = "a"\ndofs = {}\n', "sensor 'a' has no DOF weights"),
    ('[[sensor]]\nname = "a"\ndofs = {"f1:x" = 1.0}\n[[sensor]]\nname = "a"\ndofs = {"f1:y" = 1.0}\n',
     "sensor 'a' is declared twice"),
    ('[[sensor]]\nname = "f1:x"\ndofs = {"f1:x" = 1.0}\n', "sensor 'f1:x' has the name of a DOF"),
    ('[[sensor]]\nname = "a"\nrigid = { x = "f1:x" }\noffset = [0.0, 1.0]\ndirection = "x"\n',
     "reads the body's 'rz'"),
    ('[[sensor]]\nname = "a"\nrigid = { x = "f1:x", rz = "f1:rz" }\noffset = [0.0, 1.0]\n', "missing direction"),
    ('[[sensor]]\nname = "a"\ndofs = {"f1:x" = 1.0}\ndirection = "x"\n', "direction belong to a rigid-body sensor"),
])
def test_a_bad_sensor_declaration_exits_2_naming_it(tmp_path, capsys, sensors, message):
    assert main(["check", write_case(tmp_path, sensors=sensors)]) == 2
    err = capsys.readouterr().err
    assert message in err and "Traceback" not in err


def test_check_counts_the_sensors(tmp_path, capsys):
    assert main(["check", write_case(tmp_path)]) == 0
    assert "model test: 12 DOFs and 16 sensor(s) reading combinations of them, 0 rigid-body mode(s)" \
        in capsys.readouterr().out


def test_a_shape_at_a_name_that_is_neither_a_dof_nor_a_sensor_is_refused(tmp_path, capsys):
    sensors = "\n".join(t for t in bf.sensor_tables().split("\n\n") if 'name = "f1xs"' not in t)
    assert main(["check", write_case(tmp_path, sensors=sensors)]) == 2
    assert "DOF 'f1xs' is not in the model" in capsys.readouterr().err


def test_an_antiresonance_at_a_sensor_is_refused_saying_receptances_are_between_dofs(tmp_path, capsys):
    path = write_case(tmp_path)
    with open(path, "a") as f:
        f.write('[[configuration.antiresonances]]\nhz = 20.0\nresponse = "f1xs"\nexcitation = "f1:x"\n')
    assert main(["check", path]) == 2
    assert "'f1xs' is a sensor (a combination of DOFs); antiresonances are measured between DOFs" \
        in capsys.readouterr().err


def test_a_sensor_on_a_model_of_matrix_files_is_read_as_on_an_element_model(tmp_path, capsys):
    # the chain of matrix files (the route `vibupdate import` writes), a sensor reading the
    # relative motion a - b: exact data at it and at c recover the stiffness through run
    from helpers import CHAIN_CASE, CHAIN_K, write_chain_matrices

    hz = write_chain_matrices(tmp_path)
    lam, phi = scipy.linalg.eigh(CHAIN_K * 1.2)
    rows = ["mode,dof,value,tolerance"] + [f"{k + 1},{d},{float(v)!r},0" for k in range(3)
                                           for d, v in (("ab", phi[0, k] - phi[1, k]), ("c", phi[2, k]))]
    (tmp_path / "s.csv").write_text("\n".join(rows) + "\n")
    text = (CHAIN_CASE + f"natural_hz = [{', '.join(repr(float(h)) for h in hz)}]\nmode_shapes_csv = \"s.csv\"\n"
            + '[[sensor]]\nname = "ab"\ndofs = {a = 1.0, b = -1.0}\n')
    (tmp_path / "case.toml").write_text(text)
    assert main(["run", str(tmp_path / "case.toml"), "--out", str(tmp_path / "out")]) == 0, capsys.readouterr().err
    doc = json.loads((tmp_path / "out" / "results.json").read_text())
    assert doc["parameters"][0]["updated"] == pytest.approx(1200.0, rel=1e-9)
    assert doc["mac_matrix"]["only"]["dofs"] == ["c", "ab"]
