"""Abaqus ``*MATRIX OUTPUT`` files in the layouts ``*MATRIX INPUT`` allows, and files with lines missing.

The fixtures in ``tests/fixtures/fe`` are hand-made from the data lines of ``*MATRIX INPUT`` as
the Abaqus Keywords Reference gives them (row node, row DOF, column node, column DOF, value; a
symmetric matrix as its lower triangle, its upper triangle or the square): ``lower_STIF1.mtx``
(the lower triangle, no zeros), ``square_STIF1.mtx`` (the square matrix with the zeros of its
pattern, E exponents) and ``job_MASS1.mtx`` (the lower triangle with a zero of the pattern).
"""

import json
from pathlib import Path

import numpy as np
import pytest

import fe_cases
from vibupdate.cli import main
from vibupdate.examples.frame3d import frame3d
from vibupdate.model.fe.abaqus import read_abaqus

FIXTURES = Path(__file__).resolve().parents[1] / "fixtures" / "fe"
K_EXACT = np.array([[2000.0, -1000.0, 0.0], [-1000.0, 2000.0, -1000.0], [0.0, -1000.0, 2000.0 / 3]])
M_EXACT = np.array([[2 / 3, 1 / 6, 0.0], [1 / 6, 2 / 3, 0.0], [0.0, 0.0, 0.1]])


@pytest.mark.parametrize("stiffness", ["lower_STIF1.mtx", "square_STIF1.mtx"])
def test_the_hand_made_layouts_read_to_their_matrices(stiffness):
    export = read_abaqus(FIXTURES / stiffness, FIXTURES / "job_MASS1.mtx")
    assert export.dofs == ("1:x", "1:y", "2:rz")
    assert np.abs(export.K.toarray() - K_EXACT).max() <= 1e-12 * 2000
    assert np.abs(export.M.toarray() - M_EXACT).max() <= 1e-15


def _spoiled(tmp_path, name, edit):
    lines = (FIXTURES / name).read_text().splitlines()
    (tmp_path / name).write_text("\n".join(edit(lines)) + "\n")
    return tmp_path / name


def test_a_square_file_missing_a_line_is_refused_naming_the_unpaired_line(tmp_path):
    path = _spoiled(tmp_path, "square_STIF1.mtx", lambda t: t[:6] + t[7:])   # (1:y, 2:rz) gone
    with pytest.raises(ValueError, match=r"square_STIF1.mtx: line 8: the term \(2:rz, 1:y\) has no mirror \(1:y, "
                                         r"2:rz\), though the file gives both triangles"):
        read_abaqus(path, FIXTURES / "job_MASS1.mtx")


def test_a_triangle_missing_a_diagonal_line_is_refused_naming_the_coupling(tmp_path):
    path = _spoiled(tmp_path, "lower_STIF1.mtx", lambda t: t[:3] + t[4:])    # (1:y, 1:y) gone
    with pytest.raises(ValueError, match=r"lower_STIF1.mtx: the matrix has off-diagonal terms at DOF '1:y' \(its "
                                         r"first term at line 3\) but no diagonal term"):
        read_abaqus(path, FIXTURES / "job_MASS1.mtx")


def test_a_stiffness_file_cut_before_a_dof_with_mass_is_refused(tmp_path):
    path = _spoiled(tmp_path, "lower_STIF1.mtx", lambda t: t[:4])
    with pytest.raises(ValueError, match=r"lower_STIF1.mtx: no term of DOF '2:rz', which the mass file .*job_MASS1.mtx "
                                         r"gives \(line 5\)"):
        read_abaqus(path, FIXTURES / "job_MASS1.mtx")


@pytest.mark.parametrize("route", ["abaqus", "abaqus-square-zeros"])
@pytest.mark.parametrize("missing", [(0, 5), (200, 205), (-5, None)])
def test_an_export_missing_five_lines_exits_2_naming_it(tmp_path, capsys, route, missing):
    # before: exit 0 and a stiffness derivative 203 % off, without a word
    frame = frame3d(2, 1, 1)
    spec = fe_cases.write_export_set(route, tmp_path / "exports", frame, names=("E_col", "k_base"))
    target = next((tmp_path / "exports" / "E_col_plus").glob("*_STIF*.mtx"))
    lines = target.read_text().splitlines(keepends=True)
    a, b = missing
    target.write_text("".join(lines[:a] + (lines[b:] if b is not None else [])))
    assert main(["import", str(spec), "--out", str(tmp_path / "model")]) == 2
    err = capsys.readouterr().err
    said = err.replace(str(tmp_path), "")   # the folder's name holds "missing"
    assert str(target) in err and ("lines are missing" in said or "cut short" in said), err
    assert "Traceback" not in err
    assert not (tmp_path / "model").exists()


@pytest.mark.parametrize("route", list(fe_cases.ABAQUS_LAYOUTS))
def test_every_layout_imports_the_model_of_the_lower_triangle(tmp_path, route):
    from vibupdate.io.fe_import import read_import

    frame = frame3d(2, 1, 2)
    ref = read_import(fe_cases.write_export_set("abaqus", tmp_path / "ref", frame, names=("E_col", "m_floor")))
    other = read_import(fe_cases.write_export_set(route, tmp_path / route, frame, names=("E_col", "m_floor")))
    m, r = other.model, ref.model
    assert m.dofs == r.dofs and m.matrix_precision is None
    for a, b in zip(m.K_par + m.M_par + (m.K0, m.M0), r.K_par + r.M_par + (r.K0, r.M0)):
        assert abs(a - b).max() == 0


@pytest.mark.parametrize("line, said", [
    ("1,2, 1,x, 5.0", r"line 4: expected 'node, dof, node, dof, value', got '1,2, 1,x, 5.0' \(invalid literal for "
                      r"int\(\) with base 10: 'x'\)"),
    ("1,2, 1,2", r"line 4: expected 'node, dof, node, dof, value', got '1,2, 1,2' \(4 fields\)"),
    ("1,2, 1,2, 1.5.3", r"line 4: .* got '1,2, 1,2, 1.5.3' \(could not convert string to float: '1.5.3'\)"),
    ("-3,1, 1,1, 5.", r"line 4: internal node -3 \(a constraint's Lagrange multiplier\)"),
    ("1,7, 1,1, 5.", r"line 4: DOF component 7 of node 1; 0 to 6 is expected"),
])
def test_a_bad_line_is_refused_naming_its_number(tmp_path, line, said):
    # the whole-file parse fails; the refusal still names the line, as the line-by-line reader did
    path = _spoiled(tmp_path, "lower_STIF1.mtx", lambda t: t[:3] + [line] + t[3:])
    with pytest.raises(ValueError, match="lower_STIF1.mtx: " + said):
        read_abaqus(path, FIXTURES / "job_MASS1.mtx")


def test_comments_blank_lines_and_d_exponents_read_as_the_plain_file(tmp_path):
    def edit(lines):
        data = [t.replace("2000.", "2.000d+03").replace("-1000.", " -1.000D+03 ") for t in lines[1:]]
        return ["** a comment", "", lines[0]] + data[:2] + ["   ", "*HEADING-like line"] + data[2:]

    path = _spoiled(tmp_path, "lower_STIF1.mtx", edit)
    export = read_abaqus(path, FIXTURES / "job_MASS1.mtx")
    assert export.dofs == ("1:x", "1:y", "2:rz")
    assert np.abs(export.K.toarray() - K_EXACT).max() <= 1e-12 * 2000
    # 15 significant digits at most ("666.666666666667"); "2.000d+03" and "2000." are trailing zeros dropped
    assert export.precision == pytest.approx(5e-15)
