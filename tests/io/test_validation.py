"""One validation path: what `run` rejects, `check` rejects, with the file and the key named;
physical checks of M and K; measured-data checks; CSV rows."""

import re

import numpy as np
import pytest
import scipy.io
import scipy.linalg as sla
import scipy.sparse as sp

from helpers import CHAIN_CASE, CHAIN_K, write_chain_matrices
from vibupdate.cli import main
from vibupdate.model.physical import box_corners, count_below, definiteness

K3 = CHAIN_K
HZ = np.sqrt(np.linalg.eigvalsh(K3 * 1.2)) / (2 * np.pi)

BASE = CHAIN_CASE.replace('case = "chain"\n', 'case = "chain"\nfrequency_tolerance = 0.01\n') + f"""natural_hz = [{float(HZ[0])!r}, {float(HZ[1])!r}]
damping_ratios = [0.02, 0.015]
antiresonances = [{{ hz = 5.0, response = "a", excitation = "a" }}]
[solver]
n_lambda = 2
[formulation]
weighting = "relative"
[damping]
exponents = [0.0, 1.0]
"""


@pytest.fixture
def folder(tmp_path):
    write_chain_matrices(tmp_path)
    return tmp_path


def _write(folder, text):
    path = folder / "case.toml"
    path.write_text(text)
    return path


def _add(section, line):
    return lambda t: t.replace(f"[{section}]\n", f"[{section}]\n{line}\n", 1)


# Each of these passed `check` and then failed in `run` (or ran on meaningless numbers) when
# these cases were first collected. The options are now rejected while loading (their
# declarations, `vibupdate.options`), the others by `vibupdate.io.validation.validate_case`,
# which `check` and `run` share.
CHECK_WAS_LOOSER = [
    (_add("solver", "max_iter = 0"), r"solver\.max_iter: must be an integer"),
    (_add("solver", "max_iter = -5"), r"solver\.?:? ?max_iter"),
    (lambda t: t.replace("n_lambda = 2", "n_lambda = 100000000"), r"solver\.n_lambda: must be an integer from 1 to"),
    (_add("solver", "max_cpu_time = 0.0"), r"solver\.max_cpu_time: must be finite and > 0, got 0\.0"),
    (_add("solver", "max_cpu_time = nan"), r"solver\.?:? ?max_cpu_time"),
    (_add("solver", "tol = 0.0"), r"solver\.tol: must be finite and in \(0, 1\), got 0\.0"),
    (_add("solver", "tol = -1.0"), r"solver\.?:? ?tol"),
    (_add("solver", "tol = nan"), r"solver\.?:? ?tol"),
    (_add("solver", "tol = 2.0"), r"solver\.tol: must be finite and in \(0, 1\)"),
    (_add("solver", "max_iter = 2000000"), r"solver\.max_iter: must be an integer from 1 to 1000000"),
    (_add("solver", "proximal = inf"), r"solver\.proximal"),
    (_add("solver", "step_growth = 0.5"), r"solver\.step_growth: must be"),
    (_add("solver", "step_growth = 1e9"), r"solver\.step_growth: must be finite and in \[1, 100\]"),
    (_add("solver", 'relaxation_solver = "osqp"'), r"solver\.relaxation_solver: must be .piqp. or .nlp., got .osqp."),
    (_add("formulation", "shape_margin = inf"), r"formulation\.shape_margin: must be finite and in \[1, 10000\], got inf"),
    (_add("formulation", "adjunct_margin = 1e300"), r"formulation\.adjunct_margin: must be finite and in \[1, 10000\], got 1e\+300"),
    (_add("formulation", "length_scale = inf"), r"formulation\.length_scale"),
    (_add("formulation", "reduction_threshold = -1"), r"formulation\.reduction_threshold"),
    (lambda t: t.replace("exponents = [0.0, 1.0]", "exponents = []"), r"damping\.exponents: needs at least one"),
    (lambda t: t.replace("exponents = [0.0, 1.0]", "exponents = [1.0, 1.0]"), r"damping\.exponents: must be distinct"),
    (lambda t: t.replace("exponents = [0.0, 1.0]", "exponents = [1e300]"), r"damping\.exponents: must lie within"),
    (_add("damping", 'mode_weights = { "1" = inf }'), r"damping\.mode_weights\.1"),
    (lambda t: t.replace("frequency_tolerance = 0.01", "frequency_tolerance = nan"), r"frequency_tolerance: must be"),
    (lambda t: t.replace("frequency_tolerance = 0.01", "frequency_tolerance = -0.1"), r"frequency_tolerance"),
    (lambda t: t.replace("damping_ratios = [0.02", "damping_ratios = [0.0"),
     r"configuration 'only'\.damping_ratios: mode 1: a damping ratio must be in \(0, 1\)"),
    (lambda t: t.replace("damping_ratios = [0.02", "damping_ratios = [2.0"), r"damping ratio must be in \(0, 1\).*2\.0"),
    (lambda t: t.replace("upper = 2000.0", "upper = 1e300"), r"parameter 'k': the bounds .* span more than"),
    (lambda t: t.replace("damping_ratios", "natural_weights = [1e300, 1.0]\ndamping_ratios"),
     r"configuration 'only'\.natural_weights: mode 1: weight"),
    (lambda t: t.replace("[solver]", '[[configuration.first_sign]]\nresponse = "zz"\nexcitation = "a"\nsign = 1\n'
                                     "[solver]"), r"configuration 'only'\.first_sign: DOF 'zz' does not exist"),
    (lambda t: t.replace("[solver]", "uff_tolerance = -1.0\n[solver]"), r"configuration 'only'\.uff_tolerance"),
    (lambda t: t.replace("[solver]", "options = { a = 1 }\n[solver]"), r"configuration 'only'\.options"),
    (lambda t: t.replace('K0 = "K0.mtx"', 'K0 = "Kneg.mtx"'), r"model: .*stiffness matrix K is not positive semidef"),
]


@pytest.mark.parametrize("edit, message", CHECK_WAS_LOOSER)
def test_check_rejects_what_run_rejects(folder, capsys, edit, message):
    scipy.io.mmwrite(str(folder / "Kneg.mtx"), sp.coo_matrix(-K3))
    path = _write(folder, edit(BASE))
    assert main(["check", str(path)]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"vibupdate: error: {path}: ") and re.search(message, err), err
    out = folder / "out"
    assert main(["run", str(path), "--out", str(out)]) == 2
    assert re.search(message, capsys.readouterr().err)
    assert not out.exists()
    assert sorted(p.name for p in folder.iterdir()) == sorted(["M0.mtx", "K0.mtx", "dK.mtx", "Kneg.mtx", "case.toml"])


def test_the_base_case_passes_check_with_its_physics_reported(folder, capsys):
    assert main(["check", str(_write(folder, BASE))]) == 0
    out = capsys.readouterr().out
    assert "only: 3 DOFs, 0 rigid-body mode(s), M positive definite" in out
    assert "corners of the parameter box" in out


def test_warnings_for_high_damping_and_rad_s(folder, capsys):
    text = BASE.replace("damping_ratios = [0.02", "damping_ratios = [0.3")
    assert main(["check", str(_write(folder, text))]) == 0
    assert "damping ratio 0.3 is above 0.2" in capsys.readouterr().out
    # the same frequencies written in rad/s as if they were Hz: measured / nominal ~ 2 pi * 1.1
    text = BASE.replace(f"natural_hz = [{float(HZ[0])!r}, {float(HZ[1])!r}]",
                        f"natural_hz = [{float(HZ[0] * 2 * np.pi)!r}, {float(HZ[1] * 2 * np.pi)!r}]")
    text = text.replace("hz = 5.0", f"hz = {float(HZ[0] * 2 * np.pi * 1.5)!r}")
    assert main(["check", str(_write(folder, text))]) == 0
    out = capsys.readouterr().out
    assert re.search(r"the measured natural frequencies are 6\.\d\d times the nominal model's, close to 2 pi: "
                     r"are they in rad/s\?", out), out


def test_negative_exponents_need_a_model_without_rigid_body_modes(folder, capsys):
    K_free = np.array([[1.0, -1, 0], [-1, 2, -1], [0, -1, 1]]) * 1000   # free-free chain: one rigid mode
    scipy.io.mmwrite(str(folder / "K0.mtx"), sp.coo_matrix(K_free))
    scipy.io.mmwrite(str(folder / "dK.mtx"), sp.coo_matrix(K_free / 1000))
    hz = np.sqrt(np.abs(np.linalg.eigvalsh(K_free * 1.2)))[1:] / (2 * np.pi)
    text = BASE.replace(f"natural_hz = [{float(HZ[0])!r}, {float(HZ[1])!r}]",
                        f"natural_hz = [{float(hz[0])!r}, {float(hz[1])!r}]")
    text = text.replace('antiresonances = [{ hz = 5.0, response = "a", excitation = "a" }]\n', "")
    text = text.replace("exponents = [0.0, 1.0]", "exponents = [-0.5, 1.0]")
    path = _write(folder, text)
    assert main(["check", str(path)]) == 2
    err = capsys.readouterr().err
    assert "damping.exponents: negative exponents (-0.5) make C infinite on the model's 1 rigid-body mode(s)" in err
    assert main(["check", str(_write(folder, text.replace("[-0.5, 1.0]", "[0.0, 1.0]")))]) == 0
    assert "only: 3 DOFs, 1 rigid-body mode(s)" in capsys.readouterr().out


# -- the physical checks themselves ---------------------------------------------------------


def _chain(n, k=1000.0, m=1.0, grounded=True):
    main_diag = np.full(n, 2 * k)
    main_diag[-1] = k
    if not grounded:
        main_diag[0] = k
    K = sp.diags([main_diag, -k * np.ones(n - 1), -k * np.ones(n - 1)], [0, 1, -1], format="csr")
    return sp.identity(n, format="csr") * m, K


def test_definiteness_counts_rigid_body_modes_and_negative_stiffness():
    M, K = _chain(5)
    assert definiteness(M, K) == definiteness(M, K).__class__((), 0, None)
    M, K = _chain(5, grounded=False)
    assert definiteness(M, K).rigid_body_modes == 1
    assert "not positive semidefinite: 4 negative eigenvalue(s)" in definiteness(M, -K).problem
    M, K = _chain(5)
    assert "not positive semidefinite: 5 negative eigenvalue(s)" in definiteness(M, -K).problem


def test_massless_dofs_are_accepted_when_stiffness_holds_them():
    M, K = _chain(6)
    M = sp.diags([1.0, 0.0, 1.0, 0.0, 1.0, 1.0], format="csr")
    found = definiteness(M, K)
    assert found.problem is None and found.massless == (1, 3) and found.rigid_body_modes == 0
    K_loose = K.tolil()
    K_loose[3, :] = 0.0
    K_loose[:, 3] = 0.0
    found = definiteness(M, sp.csr_matrix(K_loose))
    assert "not positive definite on the 2 DOF(s) without mass" in found.problem


def test_large_models_use_the_sparse_inertia_and_agree_with_dense_eigenvalues():
    rng = np.random.default_rng(3)
    n = 700                                       # above DENSE_LIMIT
    A = sp.random(n, n, density=0.004, random_state=4)
    A = sp.csc_matrix(A + A.T + sp.diags(rng.uniform(-2.0, 2.0, n)))
    exact = sla.eigvalsh(A.toarray())
    for t in (-1.0, 0.0, 0.5):
        assert count_below(A, sp.identity(n), t) == int(np.sum(exact < t))
    M, K = _chain(2000)
    assert definiteness(M, K).problem is None
    M, K = _chain(2000, grounded=False)
    assert definiteness(M, K).rigid_body_modes == 1


def test_box_corners_are_all_corners_for_few_parameters_and_a_seeded_sample_otherwise():
    corners = box_corners([-1, -2], [1, 2])
    assert sorted(tuple(x) for _, x in corners) == [(-1, -2), (-1, 2), (1, -2), (1, 2)]
    many = box_corners(-np.ones(12), np.ones(12))
    xs = [x for _, x in many]
    assert np.all(xs[0] == -1) and np.all(xs[1] == 1) and len(xs) == 16
    assert [x.tolist() for _, x in box_corners(-np.ones(12), np.ones(12))] == [x.tolist() for x in xs]


# -- CSV rows --------------------------------------------------------------------------------


@pytest.mark.parametrize("rows, message", [
    ("mode,dof,value,tolerance\n1,a,0.5,0.1\n1.7,c,1.0,0.1\n", r"row 3: mode must be an integer >= 1, got '1\.7'"),
    ("mode,dof,value,tolerance\n1,a,0.5,0.1\n1,a,0.6,0.1\n", r"row 3: mode 1, dof 'a' is also given in row 2"),
    ("mode,dof,value,tolerance\n1,a,0.5,0.1,9\n", r"row 2: 5 fields for 4 columns"),
])
def test_shape_csv_rows_are_checked(folder, capsys, rows, message):
    (folder / "s.csv").write_text(rows)
    path = _write(folder, BASE.replace("[solver]", 'mode_shapes_csv = "s.csv"\n[solver]'))
    assert main(["check", str(path)]) == 2
    err = capsys.readouterr().err
    assert "s.csv" in err and re.search(message, err), err


def test_duplicate_frequency_rows_are_errors(folder, capsys):
    (folder / "f.csv").write_text("kind,hz,damping_ratio\n# a comment line\nnatural,3.1,0.02\nnatural,3.1,0.02\n")
    text = re.sub(r"natural_hz = [^\n]*\ndamping_ratios = [^\n]*\n", 'frequencies_csv = "f.csv"\n', BASE, count=1)
    path = _write(folder, text)
    assert main(["check", str(path)]) == 2
    assert re.search(r"f\.csv: row 4: duplicates row 3", capsys.readouterr().err)


def test_a_run_plots_the_nominal_frf_undamped_and_carries_its_warnings(folder, monkeypatch, capsys):
    """The nominal curve gets no damping (the case has no nominal damping model), the
    updated one the identified C; validation warnings reach the terminal and results.json."""
    import json

    from vibupdate.report import plots

    seen = []
    real = plots.plot_receptances
    monkeypatch.setattr(plots, "plot_receptances", lambda path, panels: seen.extend(p[1:3] for p in panels)
                        or real(path, panels))
    text = BASE.replace("damping_ratios = [0.02", "damping_ratios = [0.25")
    out = folder / "out"
    assert main(["run", str(_write(folder, text)), "--out", str(out)]) in (0, 1)
    (nominal, updated), = seen
    assert nominal[2] is None and updated[2] is not None
    assert "warning: configuration 'only', mode 1: damping ratio 0.25 is above 0.2" in capsys.readouterr().out
    doc = json.loads((out / "results.json").read_text())
    assert any("damping ratio 0.25" in w for w in doc["warnings"])


def _with_density(folder, m0_scale: float, unit: str = "kg/m^3"):
    """BASE with a density parameter: 1e-4 m^3 of material at 8000 kg/m^3 on each DOF (0.8 kg)
    beside 0.2 kg of other mass, with M0 written ``m0_scale`` times its value in kg."""
    scipy.io.mmwrite(str(folder / "M0.mtx"), sp.coo_matrix(np.eye(3) * m0_scale))
    scipy.io.mmwrite(str(folder / "dM.mtx"), sp.coo_matrix(np.eye(3) * 1e-4))
    text = BASE.replace("[model.dK]", '[model.dM]\nrho = "dM.mtx"\n[model.dK]', 1).replace(
        "[[configuration]]", f'[[parameter]]\nname = "rho"\nunit = "{unit}"\nnominal = 8000.0\nlower = 7000.0\n'
                             'upper = 9000.0\n[[configuration]]', 1)
    return _write(folder, text)


def test_a_mass_matrix_in_tonnes_against_a_density_in_kg_per_m3_is_refused_by_check_and_run(folder, capsys):
    """The density's material alone would carry 0.8 kg on a DOF whose whole mass M0 says is
    0.001: M0 is in tonnes. In kg it passes; the units are told by the parameter's ``unit``."""
    assert main(["check", str(_with_density(folder, 1.0))]) == 0, capsys.readouterr().err
    capsys.readouterr()
    path = _with_density(folder, 1e-3)
    assert main(["check", str(path)]) == 2
    err = capsys.readouterr().err
    assert err.strip().splitlines() == [
        f"vibupdate: error: {path}: configuration 'only': at DOF a the mass-like parameters (rho = 8000 kg/m^3) carry "
        "0.8 at the nominal point, 800 times the model's own mass there (0.001); is the mass matrix in other units "
        "than the parameters (tonnes or grams for kg)? Give M and its derivatives in SI units"]
    assert main(["run", str(path), "--out", str(folder / "out")]) == 2 and not (folder / "out").exists()
    assert "800 times the model's own mass" in capsys.readouterr().err
    # the heuristic reads the units the case states: a density without one is not judged
    assert main(["check", str(_with_density(folder, 1e-3, unit=""))]) == 0


def test_the_mass_scale_check_holds_a_model_whose_mass_is_all_its_parameters():
    """The elements route builds M from its parameters: the mass they carry equals M0 on every
    DOF (the check's equality case), so the bundled cantilever is not refused."""
    from pathlib import Path

    from vibupdate.io.case import load_case
    from vibupdate.io.validation import validate_case

    case = load_case(Path(__file__).parents[2] / "examples" / "cantilever" / "case.toml")
    model = case.configurations[0].model   # A: no proof mass
    carried = sum(p.nominal * d.diagonal() / p.reference for p, d in zip(model.parameters, model.M_par)
                  if p.unit.startswith("kg"))
    np.testing.assert_allclose(carried, model.M0.diagonal(), rtol=1e-12)   # all of M is in kg-unit parameters
    validate_case(case)   # raises ValueError naming the DOF where the check refuses
