"""A parameter box that reaches models that are not physical while the nominal model is: a
warning naming the bound and the solver's narrower bound, not an error, and the solve kept
inside; a nominal model that is not physical stays an error. Rigid-body modes counted by the
rounding of each mode's own Rayleigh quotient, right on finely meshed models."""

import json

import numpy as np
import pytest

import vibupdate as vu
from helpers import write_chain_matrices
from test_validation import BASE, _write
from vibupdate.cli import main
from vibupdate.model.physical import definiteness


@pytest.fixture
def folder(tmp_path):
    write_chain_matrices(tmp_path)
    return tmp_path


@pytest.mark.parametrize("lower, kept", [("0.0", r"k >= 10\.\d+"), ("-1500.0", r"k >= 10\.\d+")])
def test_a_bound_where_k_turns_singular_is_a_warning_and_the_solve_stays_inside(folder, capsys, lower, kept):
    """k scales the whole chain stiffness: at k = 0 K is zero (3 rigid-body modes), below it
    negative. The check used to reject the case (exit 2); the solver's bound is now the last
    admissible k found by bisection less 1 % of its distance from the nominal 1000 N/m."""
    import re

    text = BASE.replace('antiresonances = [{ hz = 5.0, response = "a", excitation = "a" }]\n', "")
    path = _write(folder, text.replace("lower = 500.0", f"lower = {lower}"))
    assert main(["check", str(path)]) == 0
    out = capsys.readouterr().out
    assert re.search(rf"warning: model: the parameter bounds reach models that are not physical; at the corner "
                     rf"with every parameter at its lower bound: .*parameter 'k' at its lower bound {float(lower):g}: "
                     rf".*; the solver keeps {kept}", out), out
    assert main(["run", str(path), "--out", str(folder / "out")]) == 0
    results = json.loads((folder / "out" / "results.json").read_text())
    (k,) = results["parameters"]
    assert k["lower"] > 9.0 and k["updated"] == pytest.approx(1200.0, rel=1e-3)


def test_a_nominal_model_that_is_not_physical_is_still_an_error(folder, capsys):
    import scipy.io
    import scipy.sparse as sp

    scipy.io.mmwrite(str(folder / "Kneg.mtx"), sp.coo_matrix(-np.eye(3) * 1000))
    path = _write(folder, BASE.replace('K0 = "K0.mtx"', 'K0 = "Kneg.mtx"').replace("lower = 500.0", "lower = 0.0"))
    assert main(["check", str(path)]) == 2
    assert "stiffness matrix K is not positive semidefinite: 3 negative eigenvalue(s)" in capsys.readouterr().err


def _beam(n, free=True):
    asm = vu.Assembly("beam")
    for i in range(n + 1):
        asm.node(i, i / n)
    for i in range(n):
        asm.beam(i, i + 1, EI=70e9 * 8.33e-10, mass_per_length=0.27)
    if not free:
        asm.clamp(0)
    return asm.system()


def _portal(per_member, free=True):
    asm = vu.Assembly("frame")
    corners = {"a": (0.0, 0.0), "b": (0.0, 1.0), "c": (1.0, 1.0), "d": (1.0, 0.0)}
    for label, (x, y) in corners.items():
        asm.node(label, x, y)
    count = 0
    for start, end in (("a", "b"), ("b", "c"), ("c", "d")):
        (x0, y0), (x1, y1) = corners[start], corners[end]
        chain = [start]
        for k in range(1, per_member):
            count += 1
            asm.node(f"i{count}", x0 + (x1 - x0) * k / per_member, y0 + (y1 - y0) * k / per_member)
            chain.append(f"i{count}")
        chain.append(end)
        for first, second in zip(chain[:-1], chain[1:]):
            asm.frame(first, second, EA=210e9 * 1e-3, EI=210e9 * 1e-7, mass_per_length=7.85)
    if not free:
        asm.clamp("a")
        asm.clamp("d")
    return asm.system()


def test_rigid_body_modes_counted_on_coarse_and_fine_models():
    """The refined frame of the scaling benchmark fixed at its base (2,333 DOFs) was counted
    with 2 rigid-body modes and at 3,893 DOFs with 4 (a threshold of 1e-10 of the largest
    K_ii / M_ii: 6.5e3 and 5e4 (rad/s)^2 against a first mode of 686)."""
    from vibupdate.examples import frame

    for subdivisions in (60, 100):
        M, K = frame.model(subdivisions).matrices()
        assert definiteness(M, K).rigid_body_modes == 0
    for n in (20, 150, 300):                      # 42, 302 (dense) and 602 DOFs (sparse)
        assert definiteness(_beam(n).M, _beam(n).K).rigid_body_modes == 2
        assert definiteness(_beam(n, free=False).M, _beam(n, free=False).K).rigid_body_modes == 0
    for per_member in (4, 80):                    # 39 and 717 DOFs
        free, fixed = _portal(per_member), _portal(per_member, free=False)
        assert definiteness(free.M, free.K).rigid_body_modes == 3
        assert definiteness(fixed.M, fixed.K).rigid_body_modes == 0
