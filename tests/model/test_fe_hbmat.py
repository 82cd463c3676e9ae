"""ANSYS HBMAT files in the layout MAPDL writes, read by the project's own Harwell-Boeing reader.

The fixtures in ``tests/fixtures/fe`` are hand-made from the layout the Harwell-Boeing User's
Guide (Duff, Grimes and Lewis, 1992) defines and the ANSYS command reference's ``HBMAT`` page
describes (``HBMAT, Fname, Ext, --, Form, Matrx, Rhs, Mapping``: the right-hand side and the
``Fname.mapping`` file of equation, node and DOF label): ``mapdl_K.matrix`` (``RSA``, ``(I14)``
without a repeat count, ``(d25.15)`` with D exponents, one number a line), ``mapdl_M_rhs.matrix``
(the same with ``Rhs = YES``: a fourth format, a fifth header line and the right-hand side
lines), ``repeat_K.matrix`` (repeat counts ``(8I10)``, ``(1P,3E25.15)``, E exponents, the upper
triangle) and ``mapdl.mapping``. `scipy.io.hb_read`, which the route used before, refuses each of
the three matrices ("Only unsymmetric matrices supported", "Only files without right hand side").
"""

from pathlib import Path

import numpy as np
import pytest

import fe_cases
import fe_writers
from vibupdate.cli import main
from vibupdate.examples.frame3d import frame3d
from vibupdate.model.fe.ansys import read_hbmat

FIXTURES = Path(__file__).resolve().parents[1] / "fixtures" / "fe"
K_EXACT = np.array([[2000.0, -1000.0, 0.0], [-1000.0, 2000.0, -1000.0], [0.0, -1000.0, 666.666666666667]])
M_EXACT = np.array([[0.666666666666667, 0.166666666666667, 0.0], [0.166666666666667, 0.666666666666667, 0.0],
                    [0.0, 0.0, 0.1]])


@pytest.mark.parametrize("stiffness", ["mapdl_K.matrix", "repeat_K.matrix"])
def test_the_hand_made_mapdl_layouts_read_to_their_matrices(stiffness):
    export = read_hbmat(FIXTURES / stiffness, FIXTURES / "mapdl_M_rhs.matrix", FIXTURES / "mapdl.mapping")
    assert export.dofs == ("1:x", "1:y", "2:rz")
    assert np.abs(export.K.toarray() - K_EXACT).max() <= 1e-12 * 2000
    assert np.abs(export.M.toarray() - M_EXACT).max() == 0
    # 15 significant digits written (repeat_K.matrix: 16): half a unit in the 15th
    assert export.precision == pytest.approx(5e-15)


def _copy(tmp_path, lines=None, name="mapdl_K.matrix"):
    text = (FIXTURES / name).read_text().splitlines()
    if lines is not None:
        text = lines(text)
    for f in ("mapdl_M_rhs.matrix", "mapdl.mapping"):
        (tmp_path / f).write_text((FIXTURES / f).read_text())
    (tmp_path / "K.matrix").write_text("\n".join(text) + "\n")
    return tmp_path / "K.matrix"


@pytest.mark.parametrize("spoil, expected", [
    (lambda t: t[:-1], "the file ends at line 17; its header (line 2) declares 4 header lines and 14 data lines"),
    (lambda t: t[:9] + t[10:] + ["    0.100000000000000D+01"], "line 13: row index '0.20000000' is not an integer"),
    (lambda t: t[:16] + [t[16] + t[17], t[17]], "line 17: 2 numbers; the format of the values allows 1 a line"),
    (lambda t: t[:17] + [t[17][:-1]], "line 18: value '0.666666666666667D+0' has 15 decimal(s) and 1 exponent"),
    (lambda t: t[:17] + [t[17][:12]], "line 18: value '0.666666' has 6 decimal(s) and no exponent digit(s)"),
    (lambda t: t[:1] + [t[1].replace("14", "15", 1)] + t[2:], "line 2: TOTCRD = 15 but"),
    (lambda t: t[:2] + [t[2].replace("5", "6")] + t[3:], "hold 5 row indices, the header (lines 2-3) declares 6"),
    (lambda t: t + ["    0.1D+01"], "line 19: more data than the 14 lines its header (line 2) declares"),
    (lambda t: t[:5] + ["             0"] + t[6:], "line 6: column pointer 2 is 0; the pointers must rise"),
    (lambda t: t[:10] + ["             7"] + t[11:], "line 11: row index 7 outside 1 to 3"),
    (lambda t: t[:16] + ["   -0.1000000000000x0D+04"] + t[17:], "line 17: '-0.1000000000000x0D+04' is not a Fortran real"),
    (lambda t: t[:3] + ["(I14)           (I14)           (A25)"] + t[4:], "line 4: the format of the values is"),
])
def test_a_truncated_or_inconsistent_hbmat_is_refused_naming_the_file_and_line(tmp_path, spoil, expected):
    path = _copy(tmp_path, spoil)
    with pytest.raises(ValueError) as err:
        read_hbmat(path, tmp_path / "mapdl_M_rhs.matrix", tmp_path / "mapdl.mapping")
    assert str(path) in str(err.value) and expected in str(err.value), str(err.value)


def test_a_truncated_hbmat_exits_2_through_import_naming_the_line(tmp_path, capsys):
    frame = frame3d(2, 1, 1)
    spec = fe_cases.write_export_set("ansys-mapdl", tmp_path / "exports", frame, names=("E_col",))
    target = tmp_path / "exports" / "E_col_plus" / "M.matrix"
    lines = target.read_text().splitlines(keepends=True)
    target.write_text("".join(lines[:-40]))      # cut at a line boundary
    assert main(["import", str(spec), "--out", str(tmp_path / "model")]) == 2
    err = capsys.readouterr().err
    assert f"{target}: the file ends at line {len(lines) - 40}" in err and "truncated" in err, err
    assert "Traceback" not in err and not (tmp_path / "model").exists()


def test_both_triangles_rua_must_agree(tmp_path):
    K = np.array([[2.0, -1.0], [-1.0, 2.0]])
    fe_writers.write_hbmat(tmp_path, K, np.eye(2), ("1:x", "1:y"))
    assert np.array_equal(read_hbmat(tmp_path / "K.matrix", tmp_path / "M.matrix", tmp_path / "K.mapping").K.toarray(),
                          K)
    fe_writers.write_hbmat(tmp_path, np.array([[2.0, -1.0], [-1.5, 2.0]]), np.eye(2), ("1:x", "1:y"))
    with pytest.raises(ValueError, match="not symmetric"):
        read_hbmat(tmp_path / "K.matrix", tmp_path / "M.matrix", tmp_path / "K.mapping")


@pytest.mark.parametrize("route", list(fe_cases.MAPDL_LAYOUTS))
def test_every_mapdl_layout_imports_the_model_of_the_exact_export(tmp_path, route):
    from vibupdate.io.fe_import import read_import

    frame = frame3d(2, 1, 2)
    ref = read_import(fe_cases.write_export_set("ansys", tmp_path / "ref", frame, names=("E_col", "m_floor")))
    other = read_import(fe_cases.write_export_set(route, tmp_path / route, frame, names=("E_col", "m_floor")))
    assert other.model.dofs == ref.model.dofs and other.model.matrix_precision == pytest.approx(5e-15)
    # 15 digits: each entry within 5e-15 of the exact export's, so each derivative within
    # 2 x 5e-15 x (entries of the exports, about max |A0|) / step (the model's derivatives are per
    # unit of the parameter relative to its nominal value, the step 0.1)
    m = other.model
    for a, b in ((m.K0, ref.model.K0), (m.M0, ref.model.M0)):
        assert fe_writers.relative_difference(a, b) <= 5e-15
    for k in range(2):
        for a, b, a0 in ((m.K_par[k], ref.model.K_par[k], ref.model.K0), (m.M_par[k], ref.model.M_par[k], ref.model.M0)):
            assert abs(a - b).max() <= 2.2 * 5e-15 * abs(a0).max() / 0.1
