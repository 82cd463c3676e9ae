"""FE-code exports of the known-truth space frame: readers, perturbed exports, `vibupdate import`."""

import json

import numpy as np
import pytest
import scipy.sparse as sp

import fe_cases
import fe_writers
from vibupdate.cli import main
from vibupdate.examples.frame3d import NOMINAL, frame3d
from vibupdate.model.fe.abaqus import read_abaqus
from vibupdate.model.fe.ansys import read_hbmat
from vibupdate.model.fe.export import without_dofs
from vibupdate.model.fe.nastran import nastran_float, read_dmig
from vibupdate.model.fe.perturbed import Perturbation, derivatives
from vibupdate.model.fe.sensors import place
from vibupdate.model.parameters import Parameter

SMALL = (2, 1, 2)


@pytest.fixture(scope="module")
def small():
    return frame3d(*SMALL)


def test_frame3d_is_symmetric_with_massless_rotations_and_over_1000_dofs():
    frame = frame3d()
    K, M = frame.matrices()
    assert K.shape == (1020, 1020) and len(frame.massless) == 204
    assert abs(K - K.T).max() == 0 and abs(M - M.T).max() == 0
    where = [frame.dofs.index(d) for d in frame.massless]
    assert abs(M[where]).max() == 0


def test_the_beam_element_resists_no_rigid_motion_and_carries_its_mass():
    from vibupdate.examples.frame3d import rotation, element_mass, element_stiffness

    p1, p2 = np.array([0.0, 0.0, 0.0]), np.array([1.0, 2.0, 3.0])
    T = np.kron(np.eye(4), rotation(p1, p2))
    L = float(np.linalg.norm(p2 - p1))
    k = T.T @ element_stiffness(L, 1e-2, 2e-4, 1e-4, 3e-4) @ T
    m = T.T @ element_mass(L, 1e-2, 3e-4) @ T
    for c in np.eye(6):   # three translations, three rotations about the origin
        u = np.concatenate([np.r_[c[:3] + np.cross(c[3:], p), c[3:]] for p in (p1, p2)])
        assert np.abs(k @ u).max() <= 1e-12 * np.abs(k).max()
        if c[:3].any():
            assert u @ m @ u == pytest.approx(1e-2 * L, rel=1e-14)
    assert np.linalg.eigvalsh(element_stiffness(L, 1e-2, 2e-4, 1e-4, 3e-4))[6] > 0   # exactly 6 rigid modes


@pytest.mark.parametrize("field, tol", [("free", 0.0), ("large", 1e-11), ("small", 1e-3)])
def test_dmig_reads_back_to_the_precision_of_its_field(small, tmp_path, field, tol):
    K, M = small.matrices()
    export = read_dmig(fe_writers.write_dmig(tmp_path / "a.pch", K, M, small.dofs, field))
    assert export.dofs == small.dofs
    assert fe_writers.relative_difference(export.K, K) <= tol
    assert fe_writers.relative_difference(export.M, M) <= tol


def test_nastran_reals():
    assert nastran_float("1.5+3") == 1500.0 and nastran_float("-2.D-4") == -2e-4 and nastran_float("7.E5") == 7e5


@pytest.mark.parametrize("symmetric", [False, True])
def test_hbmat_and_mapping_read_back_exactly(small, tmp_path, symmetric):
    K, M = small.matrices()
    folder = fe_writers.write_hbmat(tmp_path, K, M, small.dofs, symmetric)
    export = read_hbmat(folder / "K.matrix", folder / "M.matrix", folder / "K.mapping")
    assert export.dofs == small.dofs
    assert fe_writers.relative_difference(export.K, K) == 0 and fe_writers.relative_difference(export.M, M) == 0


def test_abaqus_unconstrained_matrices_minus_the_fixed_dofs_are_the_model(small, tmp_path):
    Ka, Ma = small.matrices(constrained=True)
    fe_writers.write_abaqus(tmp_path, Ka, Ma, small.all_dofs)
    export = read_abaqus(tmp_path / "job_STIF1.mtx", tmp_path / "job_MASS1.mtx")
    export = without_dofs(export, sorted(set(small.all_dofs) - set(small.dofs)))
    K, M = small.matrices()
    assert export.dofs == small.dofs
    assert fe_writers.relative_difference(export.K, K) <= 1e-15 and fe_writers.relative_difference(export.M, M) <= 1e-15


def test_a_beam_depth_is_reported_non_affine_and_linearized_by_the_central_difference(small, tmp_path):
    def export(values):
        K, M = small.matrices(values)
        return read_dmig(fe_writers.write_dmig(tmp_path / f"{len(list(tmp_path.iterdir()))}.pch", K, M, small.dofs))

    d0, h = NOMINAL["d_beam"], 0.02
    depth = Parameter("d_beam", d0, 0.3, 0.5, "m")
    young = Parameter("E_beam", NOMINAL["E_beam"], 1e11, 3e11, "Pa")
    nominal = export({})
    ders = derivatives(nominal, [Perturbation(depth, h, export({"d_beam": d0 + h}), -h, export({"d_beam": d0 - h})),
                                 Perturbation(young, 2e10, export({"E_beam": 2.2e11}), -2e10,
                                              export({"E_beam": 1.8e11}))])
    # the section area is linear in d, Iy cubic: a departure of 0.02 with h / d = 0.05 (0.1 for Iy alone)
    assert ders[0].departure > 0.01 and not ders[0].affine
    assert ders[1].departure < 1e-12 and ders[1].affine
    # the central difference is the derivative of the cubic K(d) to O(h^2)
    Kp, _ = small.matrices({"d_beam": d0 * (1 + 1e-6)})
    Km, _ = small.matrices({"d_beam": d0 * (1 - 1e-6)})
    exact = (Kp - Km) / (2e-6 * d0)
    assert fe_writers.relative_difference(ders[0].dK, exact) < 2 * (h / d0) ** 2
    assert set(ders[0].nodes) == {str(n) for n in small.groups["E_beam"]}


def test_sensors_by_dof_and_by_coordinates(small):
    nodes = {str(k): v for k, v in small.nodes.items()}
    corner = fe_cases.measured_dofs(small, SMALL[2])[0].split(":")[0]
    (s, c), obliques = place([{"name": "a", "position": small.nodes[int(corner)] + [0.01, 0, 0],
                               "direction": [0, -1, 0]}, {"name": "c", "dof": f"{corner}:z"}], small.dofs, nodes)
    assert (s.dof, s.sign) == (f"{corner}:y", -1.0) and s.distance == pytest.approx(0.01)
    assert s.direction.tolist() == [0, -1, 0] and not obliques
    assert (c.dof, c.sign, c.direction.tolist()) == (f"{corner}:z", 1.0, [0, 0, 1])


@pytest.mark.parametrize("route", ["ansys", "abaqus", "nastran-large"])
def test_every_route_imports_the_same_model_as_the_free_field_dmig(small, tmp_path, route):
    from vibupdate.io.fe_import import read_import

    ref = read_import(fe_cases.write_export_set("nastran", tmp_path / "ref", small))
    other = read_import(fe_cases.write_export_set(route, tmp_path / route, small))
    # 10 significant digits in 16 characters, divided by the 10 % step in the derivatives
    tol = 1e-8 if route == "nastran-large" else 1e-13
    assert other.model.dofs == ref.model.dofs
    for a, b in zip(other.model.K_par + other.model.M_par + (other.model.K0, other.model.M0),
                    ref.model.K_par + ref.model.M_par + (ref.model.K0, ref.model.M0)):
        assert fe_writers.relative_difference(a, b) <= tol


@pytest.mark.slow
def test_import_then_run_recovers_the_truth_from_exact_data(small, tmp_path, capsys):
    spec = fe_cases.write_export_set("nastran", tmp_path / "exports", small,
                                     sensors='[[sensor]]\nname = "roof"\ndof = "2001:x"\n')
    assert main(["import", str(spec), "--out", str(tmp_path / "model")]) == 0
    said = capsys.readouterr().out
    assert "rigid-body modes: 0" in said and "first frequencies (Hz)" in said and "24 without mass" not in said
    truth = {k: NOMINAL[k] * fe_cases.TRUTH[k] for k in fe_cases.AFFINE}
    K, M = small.matrices(truth)
    case = fe_cases.exact_case(tmp_path / "model", K, M, small.dofs, fe_cases.measured_dofs(small, SMALL[2]), 8)
    assert main(["run", str(case), "--out", str(tmp_path / "out")]) == 0, capsys.readouterr().err
    doc = json.loads((tmp_path / "out" / "results.json").read_text())
    err = {p["name"]: abs(p["updated"] / truth[p["name"]] - 1) for p in doc["parameters"]}
    assert max(err.values()) <= 1e-6, err
    # the sensor map travels from the import to the results and the report
    assert 'sensors = "sensors.csv"' in (tmp_path / "model" / "model.toml").read_text()
    assert doc["sensors"] == [{"sensor": "roof", "dof": "2001:x", "sign": 1.0, "distance_m": 0.0,
                               "direction": [1.0, 0.0, 0.0]}]
    report = (tmp_path / "out" / "report.md").read_text()
    assert "## Measured points on the mesh" in report and "| roof | 2001:x | + | (1, 0, 0) | 0 |" in report


def test_a_sensor_map_naming_a_dof_the_model_lacks_exits_2_naming_the_row(small, tmp_path, capsys):
    spec = fe_cases.write_export_set("nastran", tmp_path / "exports", small, names=("E_col",),
                                     sensors='[[sensor]]\nname = "roof"\ndof = "2001:x"\n')
    assert main(["import", str(spec), "--out", str(tmp_path / "model")]) == 0
    (tmp_path / "model" / "sensors.csv").write_text("sensor,dof,sign,distance_m\nroof,9999:x,1,0\n")
    K, M = small.matrices()
    case = fe_cases.exact_case(tmp_path / "model", K, M, small.dofs, fe_cases.measured_dofs(small, SMALL[2]), 4)
    capsys.readouterr()
    assert main(["check", str(case)]) == 2
    err = capsys.readouterr().err
    assert "sensors.csv: row 2: sensor 'roof' measures '9999:x', which is not a DOF of the model" in err, err


def _bad(tmp_path, small, route="nastran"):
    return fe_cases.write_export_set(route, tmp_path / "exports", small, names=("E_col", "k_base"))


@pytest.mark.parametrize("spoil, expected", [
    ("missing", "does not exist"),
    ("identical", "is identical to the nominal export"),
    ("size", "DOFs, expected"),
    ("dofmap", "does not match the nominal export"),
    ("asymmetric", "not symmetric"),
])
def test_a_bad_export_exits_2_naming_the_file_and_writes_nothing(small, tmp_path, capsys, spoil, expected):
    spec = _bad(tmp_path, small)
    target = tmp_path / "exports" / "E_col_plus.pch"
    text = (tmp_path / "exports" / "nominal.pch").read_text()
    if spoil == "missing":
        target.unlink()
    elif spoil == "identical":
        target.write_text(text)
    elif spoil == "size":
        K, M = small.matrices()
        fe_writers.write_dmig(target, K[:-6, :-6], M[:-6, :-6], small.dofs[:-6])
    elif spoil == "dofmap":
        K, M = small.matrices({"E_col": 2.3e11})
        dofs = list(small.dofs)
        dofs[0] = "99999:x"
        fe_writers.write_dmig(target, K, M, dofs)
    else:
        K, M = small.matrices({"E_col": 2.3e11})
        i, j = sp.triu(K, 1).nonzero()
        K = K.tolil()
        K[i[0], j[0]] = K[i[0], j[0]] * 1.5
        fe_writers.write_hbmat(tmp_path / "hb", K.tocsr(), M, small.dofs)   # both triangles, differing
        spec = fe_cases.write_export_set("ansys", tmp_path / "ans", small, names=("E_col",))
        for name in ("K.matrix",):
            (tmp_path / "ans" / "E_col_plus" / name).write_text((tmp_path / "hb" / name).read_text())
        target = tmp_path / "ans" / "E_col_plus" / "K.matrix"
    out = tmp_path / "model"
    assert main(["import", str(spec), "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert expected in err and target.name in err, err
    assert not out.exists()
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".vibupdate-import")]


def test_opensees_route_needs_the_extra_or_reads_the_builder(tmp_path, capsys):
    (tmp_path / "model.py").write_text(
        "from opensees import openseespy as ops\n"
        "def build(p):\n"
        "    ops.model('basic', '-ndm', 3, '-ndf', 6)\n"
        "    ops.node(1, 0, 0, 0); ops.node(2, 0, 0, 3.0)\n"
        "    ops.fix(1, 1, 1, 1, 1, 1, 1)\n"
        "    ops.geomTransf('Linear', 1, 1, 0, 0)\n"
        "    ops.element('elasticBeamColumn', 1, 1, 2, 0.01, p['E'], 8e10, 2e-4, 1e-4, 1e-4, 1, '-mass', 78.5)\n"
        "    ops.mass(2, 100.0, 100.0, 100.0, 1.0, 1.0, 1.0)\n")
    (tmp_path / "import.toml").write_text(
        'format = "opensees"\nbuilder = "model.py:build"\n[[parameter]]\nname = "E"\nnominal = 2e11\n'
        "lower = 1e11\nupper = 3e11\nstep = 2e10\nstep2 = -2e10\n")
    code = main(["import", str(tmp_path / "import.toml"), "--out", str(tmp_path / "out")])
    err = capsys.readouterr()
    try:
        import opensees.openseespy  # noqa: F401
    except ImportError:
        assert code == 2 and 'vibupdate[fe]' in err.err
        return
    assert code == 0, err.err
    # E moves the axial and bending terms of node 2, not its torsion (G is fixed)
    assert "moves 5 DOFs at 1 node(s) [2]" in err.out and "affine at the nominal" in err.out, err.out


def _opensees_builder(folder, size):
    (folder / "frame_ops.py").write_text("from fe_opensees_frame import build_frame\n\n\n"
                                        f"def build(p):\n    build_frame(p, {tuple(size)!r})\n")
    return "frame_ops.py:build"


def _route_exports(route, root, frame, size, names=fe_cases.AFFINE, two_steps=()):
    """The import file of ``route``; for OpenSees, its builder and the parameters' steps."""
    if route != "opensees":
        return fe_cases.write_export_set(route, root, frame, names, two_steps)
    root.mkdir(parents=True, exist_ok=True)
    lines = ['format = "opensees"', f'builder = "{_opensees_builder(root, size)}"']
    for name in names:
        p0 = NOMINAL[name]
        lines += ["[[parameter]]", f'name = "{name}"', f"nominal = {p0!r}", f"lower = {0.5 * p0!r}",
                  f"upper = {1.5 * p0!r}", f"step = {0.1 * p0!r}"] + ([f"step2 = {-0.1 * p0!r}"] if name in two_steps
                                                                        else [])
    (root / "import.toml").write_text("\n".join(lines) + "\n")
    return root / "import.toml"


def _truth_matrices(route, frame, size, truth):
    if route != "opensees":
        K, M = frame.matrices(truth)
        return K, M, frame.dofs
    from fe_opensees_frame import build_frame
    from vibupdate.model.fe.opensees import export_from_builder

    e = export_from_builder(lambda p: build_frame(p, size), truth)
    return e.K, e.M, e.dofs


def test_opensees_frame_imports_with_affine_parameters_and_its_own_matrices(tmp_path, capsys):
    pytest.importorskip("opensees")
    from vibupdate.io.fe_import import read_import

    imported = read_import(_route_exports("opensees", tmp_path, frame3d(*SMALL), SMALL, ("E_col", "m_floor"),
                                          ("E_col",)))
    assert imported.derivatives[0].affine and imported.derivatives[1].departure is None
    K, M = frame3d(*SMALL).matrices()
    order = [imported.model.dofs.index(d) for d in frame3d(*SMALL).dofs]
    # OpenSees's elasticBeamColumn stiffness is the generator's; its (lumped) mass is not
    assert fe_writers.relative_difference(imported.model.K0[order][:, order], K) < 1e-12


def _update(route, root, frame, size, names, truth, two_steps=(), n_modes=8, ran=None):
    """Import and run; with ``ran`` (inputs by route, filled here), a route whose model folder is
    byte for byte one already run returns that run's outcome (`fe_cases.run_inputs`)."""
    spec = _route_exports(route, root / "exports", frame, size, names, two_steps)
    assert main(["import", str(spec), "--out", str(root / "model")]) == 0
    K, M, dofs = _truth_matrices(route, frame, size, truth)
    case = fe_cases.exact_case(root / "model", K, M, dofs, fe_cases.measured_dofs(frame, size[2]), n_modes)
    if ran is not None:
        inputs = fe_cases.run_inputs(root / "model")
        twin = next((other for other, (seen, _) in ran.items() if seen == inputs), None)
        if twin is not None:
            return ran[twin][1]
    code = main(["run", str(case), "--out", str(root / "out")])
    doc = json.loads((root / "out" / "results.json").read_text())
    outcome = code, doc["solver"]["status"], {p["name"]: p["updated"] for p in doc["parameters"]}
    if ran is not None:
        ran[route] = inputs, outcome
    return outcome


@pytest.mark.slow
def test_the_1020_dof_frame_updates_to_the_truth_through_every_route(tmp_path, capsys):
    size = (3, 2, 4)
    frame = frame3d(*size)
    truth = {k: NOMINAL[k] * fe_cases.TRUTH[k] for k in fe_cases.AFFINE}
    found, ran = {}, {}
    for route in ("nastran", "ansys", "abaqus", "opensees"):
        code, status, values = _update(route, tmp_path / route, frame, size, fe_cases.AFFINE, truth, ran=ran)
        err = {n: abs(values[n] / truth[n] - 1) for n in truth}
        print(f"{route}: status {status}, largest error {max(err.values()):.3g}", err)
        assert code == 0 and status == "success" and max(err.values()) <= 1e-6, (route, err)
        found[route] = values
    # the text routes import the same doubles (one run for the three); OpenSees's probes differ
    # in the last bits of the summation order
    assert sorted(ran) == ["nastran", "opensees"], sorted(ran)
    spread = max(abs(found[a][n] / found[b][n] - 1) for a in found for b in found for n in truth)
    print(f"largest relative difference between routes: {spread:.3g}")
    assert spread <= 1e-9


@pytest.mark.slow
def test_a_non_affine_beam_depth_is_recovered_within_1_percent(tmp_path, capsys):
    size = (3, 2, 4)
    frame = frame3d(*size)
    names = ("E_col", "d_beam", "rho_col", "m_floor", "k_base")
    truth = {k: NOMINAL[k] * fe_cases.TRUTH[k] for k in names}
    code, status, values = _update("nastran", tmp_path, frame, size, names, truth, two_steps=("d_beam",))
    said = capsys.readouterr().out
    departure = next(line for line in said.splitlines() if line.startswith("parameter d_beam"))
    err = {n: abs(values[n] / truth[n] - 1) for n in truth}
    print(departure, f"status {status}", err)
    assert "NOT affine" in departure
    assert abs(values["d_beam"] / truth["d_beam"] - 1) <= 0.01, err


@pytest.mark.parametrize("field", ["free", "large", "small"])
def test_the_dmig_reader_agrees_with_pynastran(small, tmp_path, field):
    bdf = pytest.importorskip("pyNastran.bdf.bdf")
    K, M = small.matrices()
    path = fe_writers.write_dmig(tmp_path / "a.pch", K, M, small.dofs, field)
    ours = read_dmig(path)
    model = bdf.BDF(debug=False)
    model.read_bdf(str(path), punch=True, xref=False)
    for name, mine in (("KAAX", ours.K), ("MAAX", ours.M)):
        A, rows, _ = model.dmig[name].get_matrix(is_sparse=False)
        names = [f"{g}:{('s', 'x', 'y', 'z', 'rx', 'ry', 'rz')[c]}" for g, c in (rows[i] for i in range(len(rows)))]
        order = [ours.dofs.index(n) for n in names]
        assert np.abs(A - mine.toarray()[np.ix_(order, order)]).max() == 0


def test_the_import_files_of_docs_fe_models_are_valid():
    import re
    import tomllib
    from pathlib import Path

    from vibupdate.io.case_keys import Where
    from vibupdate.io.fe_import import check_import

    text = (Path(__file__).resolve().parents[2] / "docs" / "fe-models.md").read_text()
    blocks = re.findall(r"```toml\n(.*?)```", text, re.S)
    assert len(blocks) == 4
    for block in blocks:
        spec = tomllib.loads(block)
        assert check_import(spec, Where(Path("docs/fe-models.md")))


def test_without_the_fe_extra_opensees_and_full_imports_exit_2_naming_it(tmp_path, monkeypatch, capsys):
    import sys

    for name in ("opensees", "opensees.openseespy", "openseespy", "openseespy.opensees", "ansys.mapdl.reader"):
        monkeypatch.setitem(sys.modules, name, None)     # an import of it raises ImportError
    (tmp_path / "model.py").write_text("def build(p):\n    pass\n")
    (tmp_path / "ops.toml").write_text('format = "opensees"\nbuilder = "model.py:build"\n[[parameter]]\nname = "E"\n'
                                       "nominal = 1.0\nlower = 0.5\nupper = 2.0\nstep = 0.1\n")
    (tmp_path / "ans.toml").write_text('format = "ansys"\nnominal = "file.full"\n[[parameter]]\nname = "E"\n'
                                       'nominal = 1.0\nlower = 0.5\nupper = 2.0\nstep = 0.1\nexport = "e.full"\n')
    for spec in ("ops.toml", "ans.toml"):
        assert main(["import", str(tmp_path / spec), "--out", str(tmp_path / "out")]) == 2
        assert 'pip install "vibupdate[fe]"' in capsys.readouterr().err
        assert not (tmp_path / "out").exists()


def test_k_and_m_of_different_sizes_in_one_export_exit_2_naming_the_file(small, tmp_path, capsys):
    spec = fe_cases.write_export_set("ansys", tmp_path / "exports", small, names=("E_col",))
    K, M = small.matrices()
    fe_writers.write_hbmat(tmp_path / "short", K, M[:-6, :-6], small.dofs[:-6])
    target = tmp_path / "exports" / "nominal" / "M.matrix"
    target.write_text((tmp_path / "short" / "M.matrix").read_text())
    assert main(["import", str(spec), "--out", str(tmp_path / "model")]) == 2
    err = capsys.readouterr().err
    assert str(target) in err and "240 equations, but the mapping" in err and "lists 246" in err, err
    assert not (tmp_path / "model").exists()


@pytest.mark.parametrize("source", ["grid", "csv"])
def test_sensors_by_position_use_the_grid_cards_or_a_node_file(small, tmp_path, capsys, source):
    K, M = small.matrices()
    nodes = {k: tuple(map(float, v)) for k, v in small.nodes.items()}
    fe_writers.write_dmig(tmp_path / "nominal.pch", K, M, small.dofs, nodes=nodes if source == "grid" else None)
    Kp, Mp = small.matrices({"k_base": 4.4e7})
    fe_writers.write_dmig(tmp_path / "plus.pch", Kp, Mp, small.dofs)
    corner = fe_cases.measured_dofs(small, SMALL[2])[0].split(":")[0]
    x, y, z = nodes[int(corner)]
    lines = ['format = "nastran"', 'nominal = "nominal.pch"']
    if source == "csv":
        (tmp_path / "nodes.csv").write_text("node,x,y,z\n" + "".join(f"{k},{a!r},{b!r},{c!r}\n"
                                                                     for k, (a, b, c) in nodes.items()))
        lines.append('nodes = "nodes.csv"')
    lines += ["[[parameter]]", 'name = "k_base"', "nominal = 4e7", "lower = 2e7", "upper = 6e7", "step = 4e6",
              'export = "plus.pch"', "[[sensor]]", 'name = "roof"', f"position = [{x + 0.02}, {y}, {z - 0.01}]",
              "direction = [0.0, 0.0, -1.0]"]
    (tmp_path / "import.toml").write_text("\n".join(lines) + "\n")
    assert main(["import", str(tmp_path / "import.toml"), "--out", str(tmp_path / "out")]) == 0
    printed = capsys.readouterr().out
    assert f"sensor roof: -{corner}:z" in printed and "warning: sensor" not in printed
    assert (tmp_path / "out" / "sensors.csv").read_text().splitlines()[1].startswith(f"roof,{corner}:z,-1,0.0223")
    # the same position in millimetres: far from every node, still placed, and said
    text = (tmp_path / "import.toml").read_text().replace(f"position = [{x + 0.02}, {y}, {z - 0.01}]",
                                                          f"position = [{1000 * x}, {1000 * y}, {1000 * z}]")
    (tmp_path / "import.toml").write_text(text)
    assert main(["import", str(tmp_path / "import.toml"), "--out", str(tmp_path / "out_mm")]) == 0
    assert "warning: sensor roof is " in capsys.readouterr().out



def test_a_sensor_name_with_a_comma_and_quotes_reads_back_from_sensors_csv(tmp_path):
    from vibupdate.io.case_keys import Where
    from vibupdate.io.case_model import read_sensors
    from vibupdate.io.fe_import import sensors_csv
    from vibupdate.model.fe.sensors import Sensor

    sensors = [Sensor('roof, "north" corner', "12:y", -1.0, 0.25, np.array([0.0, -1.0, 0.0])),
               Sensor("plain", "13:x", 1.0, 0.0, np.array([1.0, 0.0, 0.0]))]
    (tmp_path / "sensors.csv").write_text(sensors_csv(sensors))
    back = read_sensors(tmp_path / "sensors.csv", ["12:y", "13:x"], Where(tmp_path / "case.toml"))
    assert [r["sensor"] for r in back] == ['roof, "north" corner', "plain"]
    assert back[0]["dof"] == "12:y" and back[0]["sign"] == -1.0 and back[0]["direction"] == [0.0, -1.0, 0.0]


def test_the_full_file_mapdl_wrote_reads_to_a_positive_definite_model_without_its_constrained_dofs():
    """The one `.full` file MAPDL wrote that this machine has: the sample shipped with
    ansys-mapdl-reader (a solid beam, 321 nodes, 3 DOFs each, 21 nodes fixed)."""
    reader = pytest.importorskip("ansys.mapdl.reader")
    from ansys.mapdl.reader import examples

    from vibupdate.model.fe.ansys import read_full

    export = read_full(examples.fullfile)
    constrained = {f"{n}:{'xyz'[d]}" for n, d in reader.read_binary(examples.fullfile).const}
    assert len(constrained) == 63 and not constrained & set(export.dofs)
    assert len(export.dofs) == 963 - 63 and export.K.shape == export.M.shape == (900, 900)
    assert abs(export.K - export.K.T).max() == 0 and abs(export.M - export.M.T).max() == 0
    # every equation left has stiffness and mass, and the fixed beam has no rigid-body mode
    assert np.all(export.K.diagonal() > 0) and np.all(export.M.diagonal() > 0)
    assert np.linalg.eigvalsh(export.K.toarray())[0] > 0
