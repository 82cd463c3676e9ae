"""Oblique sensors on an imported FE mesh: their readings as DOFs of the model
(`vibupdate.model.fe.sensors`, `vibupdate.model.fe.oblique`, `vibupdate import`)."""

import csv
import json
import re

import numpy as np
import pytest

import fe_cases
from vibupdate.cli import main
from vibupdate.examples.frame3d import NOMINAL, frame3d
from vibupdate.io.case_keys import Where
from vibupdate.io.case_model import read_sensors
from vibupdate.model.fe.oblique import Oblique, coordinate_change, rigid_translations, translation_masses
from vibupdate.model.fe.sensors import ALIGN_TOL, place

SMALL = (2, 1, 2)
N_MODES = 8


@pytest.fixture(scope="module")
def small():
    return frame3d(*SMALL)


def _corners(frame):
    return [d.split(":")[0] for d in fe_cases.measured_dofs(frame, SMALL[2])[::2]][:4]


def _oblique_tables(frame):
    """Sensors on the four roof corners: aligned by DOF and by position, one oblique with a
    second one against it, one at 45 degrees of an aligned one on its node, two oblique at 60
    degrees on one node.
    Returns the import file's text and each sensor's (node, unit direction as given)."""
    c = _corners(frame)
    at = {k: np.asarray(frame.nodes[int(k)], dtype=float) for k in c}
    sensors = [("a", c[0], None, "x"), ("b", c[0], [1, 1, 0], None), ("b2", c[0], [0, 0, -1], None),
               ("c", c[1], [0.3, 0.2, 0.93], None), ("c-", c[1], [-0.3, -0.2, -0.93], None), ("e", c[2], [1, 1, 0], None), ("f", c[2], [0, 1, 1], None),
               ("g", c[3], None, "x"), ("h", c[3], None, "y"), ("i", c[3], [0, 0, 1], None)]
    lines, truth = ['nodes = "nodes.csv"'], {}
    for name, node, direction, axis in sensors:
        lines += ["[[sensor]]", f'name = "{name}"']
        if axis:
            lines.append(f'dof = "{node}:{axis}"')
            direction = np.eye(3)["xyz".index(axis)]
        else:
            offset = [0.01, -0.02, 0.0] if name == "c" else [0.0, 0.0, 0.0]
            lines += [f"position = {(at[node] + offset).tolist()}", f"direction = {list(map(float, direction))}"]
        truth[name] = (node, np.asarray(direction, dtype=float) / np.linalg.norm(direction))
    return "\n".join(lines) + "\n", truth


def _write_nodes(frame, folder):
    folder.mkdir(parents=True, exist_ok=True)
    rows = ["node,x,y,z"] + [f"{k}," + ",".join(repr(float(c)) for c in v) for k, v in frame.nodes.items()]
    (folder / "nodes.csv").write_text("\n".join(rows) + "\n")


def _import(frame, root, sensors, names=fe_cases.AFFINE):
    _write_nodes(frame, root / "exports")
    return fe_cases.write_export_set("nastran", root / "exports", frame, names, sensors=sensors)


def _oblique_case(model_dir, K, M, dofs, truth):
    """Case file with the exact first modes of (K, M) as the sensors of ``sensors.csv`` read
    them: each sensor's given direction dotted with its node's translation, times its sign,
    under its DOF."""
    from vibupdate.modal.analysis import modes

    omega, phi = modes(M, K, N_MODES)[:2]
    index = {d: k for k, d in enumerate(dofs)}
    values = {}
    with (model_dir / "sensors.csv").open(newline="") as handle:
        for row in csv.DictReader(handle):
            node, n = truth[row["sensor"]]
            u = phi[[index[f"{node}:{a}"] for a in "xyz"]]          # (3, modes)
            values.setdefault(row["dof"], float(row["sign"]) * (n @ u))
    rows = ["mode,dof,value,tolerance"] + [f"{k + 1},{d},{float(v[k])!r},0" for k in range(N_MODES)
                                           for d, v in values.items()]
    (model_dir / "shapes.csv").write_text("\n".join(rows) + "\n")
    hz = ", ".join(repr(float(w / (2 * np.pi))) for w in omega)
    (model_dir / "case.toml").write_text('case = "oblique"\n' + (model_dir / "model.toml").read_text()
                                         + f'\n[[configuration]]\nname = "test"\nnatural_hz = [{hz}]\n'
                                           'mode_shapes_csv = "shapes.csv"\n')
    return model_dir / "case.toml", sorted(values)


def _errors(out, truth):
    doc = json.loads((out / "results.json").read_text())
    return doc, {p["name"]: abs(p["updated"] / truth[p["name"]] - 1) for p in doc["parameters"]}


@pytest.mark.slow   # two whole runs through import, about 11 s: in CI's second step (pytest -m slow)
def test_oblique_sensors_placed_by_position_recover_the_truth_like_aligned_ones(small, tmp_path, capsys):
    text, directions = _oblique_tables(small)
    assert main(["import", str(_import(small, tmp_path / "oblique", text)), "--out", str(tmp_path / "model")]) == 0
    said = capsys.readouterr().out
    c = _corners(small)
    assert f"sensor b: {c[0]}:n1 (0 m from the position)" in said
    assert f"oblique DOF {c[0]}:n1 in place of {c[0]}:y: the node's translation along (0.7071, 0.7071, 0)" in said
    truth = {k: NOMINAL[k] * fe_cases.TRUTH[k] for k in fe_cases.AFFINE}
    K, M = small.matrices(truth)
    case, measured = _oblique_case(tmp_path / "model", K, M, small.dofs, directions)
    assert {f"{c[0]}:n1", f"{c[1]}:n1", f"{c[2]}:n1", f"{c[2]}:n2"} <= set(measured) and len(measured) == 9
    assert main(["run", str(case), "--out", str(tmp_path / "out")]) == 0, capsys.readouterr().err
    doc, err = _errors(tmp_path / "out", truth)
    # the same exports and truth, measured by aligned sensors (the route of test_fe_import)
    assert main(["import", str(fe_cases.write_export_set("nastran", tmp_path / "aligned", small)), "--out",
                 str(tmp_path / "model-aligned")]) == 0
    aligned = fe_cases.exact_case(tmp_path / "model-aligned", K, M, small.dofs,
                                  fe_cases.measured_dofs(small, SMALL[2]), N_MODES)
    assert main(["run", str(aligned), "--out", str(tmp_path / "out-aligned")]) == 0
    _, err_aligned = _errors(tmp_path / "out-aligned", truth)
    print("oblique", err, "aligned", err_aligned)
    assert doc["solver"]["status"] == "success" and max(err.values()) <= 1e-6, err
    assert max(err_aligned.values()) <= 1e-6, err_aligned
    # the map, with the directions, travels to results.json and the report
    rows = {s["sensor"]: s for s in doc["sensors"]}
    assert rows["b2"]["dof"] == f"{c[0]}:z" and rows["b2"]["sign"] == -1.0 and rows["b2"]["direction"] == [0, 0, -1]
    assert np.allclose(rows["c"]["direction"], directions["c"][1], atol=1e-15)
    assert (rows["c-"]["dof"], rows["c-"]["sign"]) == (f"{c[1]}:n1", -1.0)
    report = (tmp_path / "out" / "report.md").read_text()
    assert f"| b | {c[0]}:n1 | + | (0.7071, 0.7071, 0) | 0 |" in report
    assert f"| c | {c[1]}:n1 | + | (0.3008, 0.2005, 0.9324) | 0.0224 |" in report


def _masses_said(text):
    return re.findall(r"mass moving with a unit translation x (\S+) kg, y (\S+) kg, z (\S+) kg", text)


def test_the_oblique_model_has_the_exported_eigenvalues_and_masses(small, tmp_path, capsys):
    from vibupdate.io.fe_import import read_import, summary_lines
    from vibupdate.modal.analysis import modes

    text, _ = _oblique_tables(small)
    oblique = read_import(_import(small, tmp_path / "oblique", text))
    plain = read_import(_import(small, tmp_path / "plain", ""))
    assert len(oblique.obliques) == 4 and oblique.model.dofs != plain.model.dofs
    truth = plain.model.normalized([NOMINAL[k] * fe_cases.TRUTH[k] for k in fe_cases.AFFINE])
    worst = 0.0
    for xbar in (None, truth):          # at the nominal point and away from it: the derivatives too
        w1 = modes(*oblique.model.matrices(xbar), 30)[0]
        w0 = modes(*plain.model.matrices(xbar), 30)[0]
        worst = max(worst, float(np.max(np.abs(w1 ** 2 / w0 ** 2 - 1))))
    m1 = translation_masses(oblique.model.M0, oblique.model.dofs, oblique.directions)
    m0 = translation_masses(plain.model.M0, plain.model.dofs)
    print(f"eigenvalues: largest relative difference {worst:.2e}; masses {m1} and {m0}")
    assert worst <= 1e-12
    assert all(abs(m1[a] / m0[a] - 1) <= 1e-12 for a in "xyz"), (m1, m0)
    said = [line for line in summary_lines(oblique) if line.startswith("mass moving")]
    assert said == [line for line in summary_lines(plain) if line.startswith("mass moving")]
    # the figures a naive sum over the ':x' DOFs would give differ: the test can fail
    naive = np.array([d.endswith(":x") for d in oblique.model.dofs], dtype=float)
    assert abs(naive @ oblique.model.M0 @ naive / m0["x"] - 1) > 1e-3


def test_check_gives_the_exported_masses_from_the_directions_of_sensors_csv(small, tmp_path, capsys):
    text, directions = _oblique_tables(small)
    assert main(["import", str(_import(small, tmp_path / "e", text)), "--out", str(tmp_path / "model")]) == 0
    said = capsys.readouterr().out
    printed = [re.search(rf"unit {a} translation: (\S+) kg", said).group(1) for a in "xyz"]
    K, M = small.matrices()
    case, _ = _oblique_case(tmp_path / "model", K, M, small.dofs, directions)
    assert main(["check", str(case)]) == 0
    assert _masses_said(capsys.readouterr().out) == [tuple(printed)]
    # without the directions, the figure is not given rather than wrong
    path = tmp_path / "model" / "sensors.csv"
    rows = [line.split(",")[:4] for line in path.read_text().splitlines()]
    path.write_text("\n".join(",".join(r) for r in rows) + "\n")
    assert main(["check", str(case)]) == 2
    assert "reads the oblique DOF" in capsys.readouterr().err
    case.write_text(case.read_text().replace('sensors = "sensors.csv"\n', ""))
    assert main(["check", str(case)]) == 0
    assert "mass moving with a unit translation not computed: the directions of the oblique DOFs" in \
        capsys.readouterr().out


@pytest.mark.parametrize("spoil, expected", [
    ("zero", "sensor[1]: sensor 'z': position and direction are [x, y, z] (finite numbers) with a non-zero "
             "direction, got"),
    ("dependent", "sensor 'c' at node {c0}: direction [0.7071, 0.7071, 0.0] is within 0.57 degrees of the span of "
                  "the node's other readings (sensors 'a' (x), 'b' (y); angles 45.0, 45.0 degrees)"),
    ("fixed", "sensor[1]: sensor 'base': the nearest node to [0.0, 0.0, 0.0], 1 (0 m away), has no "
              "translational DOF in the model"),
])
def test_a_bad_sensor_exits_2_naming_it_and_writes_nothing(small, tmp_path, capsys, spoil, expected):
    c0 = _corners(small)[0]
    at = list(map(float, small.nodes[int(c0)]))
    text = {"zero": f'[[sensor]]\nname = "z"\nposition = {at}\ndirection = [0.0, 0.0, 0.0]\n',
            "dependent": f'[[sensor]]\nname = "a"\ndof = "{c0}:x"\n[[sensor]]\nname = "b"\ndof = "{c0}:y"\n'
                         f'[[sensor]]\nname = "c"\nposition = {at}\ndirection = [1.0, 1.0, 0.0]\n',
            "fixed": '[[sensor]]\nname = "base"\nposition = [0.0, 0.0, 0.0]\ndirection = [1.0, 0.0, 0.0]\n'}[spoil]
    spec = _import(small, tmp_path / "exports", 'nodes = "nodes.csv"\n' + text, names=("E_col",))
    assert main(["import", str(spec), "--out", str(tmp_path / "model")]) == 2
    err = capsys.readouterr().err
    assert expected.format(c0=c0) in err and "Traceback" not in err, err
    assert not (tmp_path / "model").exists()
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".vibupdate-import")]


def test_place_shares_parallel_directions_keeps_aligned_names_and_picks_the_largest_component(small):
    nodes = {str(k): v for k, v in small.nodes.items()}
    c0 = _corners(small)[0]
    at = small.nodes[int(c0)]
    tilt = np.array([np.cos(ALIGN_TOL / 2), np.sin(ALIGN_TOL / 2), 0.0])   # within the tolerance of x
    sensors, obliques = place([{"name": "p", "position": at, "direction": [0.2, -0.3, 0.9]},
                               {"name": "q", "position": at, "direction": [-0.2, 0.3, -0.9]},
                               {"name": "r", "position": at, "direction": tilt.tolist()}], small.dofs, nodes)
    assert [(s.dof, s.sign) for s in sensors] == [(f"{c0}:n1", 1.0), (f"{c0}:n1", -1.0), (f"{c0}:x", 1.0)]
    assert len(obliques) == 1 and obliques[0].replaces == f"{c0}:z"      # its largest component, x being read
    assert np.allclose(sensors[1].direction, -sensors[0].direction, rtol=0, atol=0)
    # an oblique sensor needs the node's three translations
    dofs = [d for d in small.dofs if d != f"{c0}:z"]
    with pytest.raises(ValueError, match=r"sensor\[1\]: sensor 'p' at node .* is oblique, which needs the node's "
                                         r"x, y and z translations; z not in the model"):
        place([{"name": "p", "position": at, "direction": [0.2, -0.3, 0.9]}], dofs, nodes)
    # of two nodes at one place, the one that moves
    base = {"ground": np.asarray(at), **nodes}
    assert place([{"name": "s", "position": at, "direction": [1, 0, 0]}], small.dofs, base)[0][0].dof == f"{c0}:x"


def test_the_new_coordinates_are_the_oblique_readings_and_the_other_translations():
    rng = np.random.default_rng(3)
    dofs = ["1:x", "1:y", "1:rx", "1:z", "2:x", "2:y", "2:z"]
    a, b = np.array([1.0, 1.0, 0.0]) / np.sqrt(2), np.array([0.0, 0.6, 0.8])
    T, names = coordinate_change(dofs, [Oblique("1:n1", "1:x", a), Oblique("1:n2", "1:z", b)])
    assert names == ("1:n1", "1:y", "1:rx", "1:n2", "2:x", "2:y", "2:z")
    q = rng.standard_normal(len(dofs))
    new = np.linalg.solve(T.toarray(), q)
    u = q[[0, 1, 3]]
    assert new[0] == pytest.approx(a @ u, abs=1e-14) and new[3] == pytest.approx(b @ u, abs=1e-14)
    assert np.allclose(np.delete(new, [0, 3]), np.delete(q, [0, 3]), rtol=0, atol=1e-14)
    E = rigid_translations(names, {"1:n1": a, "1:n2": b})
    assert np.allclose(T.toarray() @ E, rigid_translations(dofs), atol=1e-15)
    with pytest.raises(ValueError, match="the directions of the oblique DOFs 1:n2 are not known"):
        rigid_translations(names, {"1:n1": a})


def test_sensors_files_with_and_without_directions(tmp_path):
    where = Where(tmp_path / "case.toml")
    dofs = ["7:x", "7:n1", "7:rz"]
    old = tmp_path / "old.csv"
    old.write_text("sensor,dof,sign,distance_m\na,7:x,-1,0.5\nr,7:rz,1,0\n")
    assert [s["direction"] for s in read_sensors(old, dofs, where)] == [[-1.0, 0.0, 0.0], None]
    new = tmp_path / "new.csv"
    new.write_text("sensor,dof,sign,distance_m,nx,ny,nz\nb,7:n1,-1,0,0.6,0.0,-0.8\nr,7:rz,1,0,,,\n")
    assert [s["direction"] for s in read_sensors(new, dofs, where)] == [[0.6, 0.0, -0.8], None]
    for body, message in (("b,7:n1,1,0,,,", "reads the oblique DOF '7:n1': its direction nx, ny, nz is needed"),
                          ("b,7:n1,1,0,0.6,0,0.6", "nx, ny, nz must be a unit vector")):
        new.write_text("sensor,dof,sign,distance_m,nx,ny,nz\n" + body + "\n")
        with pytest.raises(ValueError, match=re.escape(message)):
            read_sensors(new, dofs, where)
