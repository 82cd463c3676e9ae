"""Nastran DMIG punch files as Nastran writes them, and punch files cut short.

The fixtures in ``tests/fixtures/fe`` are hand-made from the DMIG bulk-data entry as the
Nastran Quick Reference Guide defines it (header ``DMIG, NAME, 0, IFO, TIN, TOUT, POLAR, ,
NCOL``, then one card per column ``DMIG, NAME, GJ, CJ, , G1, C1, A1, B1, ...``): ``small_field.pch``
(8-character fields, ``+`` continuation lines, ``$`` comment lines, NCOL in the header and a
third matrix ``BAAX``) and ``large_field.pch`` (``DMIG*`` cards, 16-character fields, ``*``
continuation lines, D exponents).
"""

import json
from pathlib import Path

import numpy as np
import pytest
import scipy.sparse as sp

import fe_cases
import fe_writers
from vibupdate.cli import main
from vibupdate.examples.frame3d import frame3d
from vibupdate.model.fe.export import FEExport
from vibupdate.model.fe.nastran import read_dmig
from vibupdate.model.fe.perturbed import Perturbation, derivatives
from vibupdate.model.parameters import Parameter

FIXTURES = Path(__file__).resolve().parents[1] / "fixtures" / "fe"
K_EXACT = np.array([[2000.0, -1000.0, 0.0], [-1000.0, 2000.0, -1000.0], [0.0, -1000.0, 2000.0 / 3]])
M_EXACT = np.array([[2 / 3, 1 / 6, 0.0], [1 / 6, 2 / 3, 0.0], [0.0, 0.0, 0.1]])


@pytest.mark.parametrize("name, precision", [("small_field.pch", 5e-7), ("large_field.pch", 5e-10)])
def test_the_hand_made_punch_files_read_to_their_matrices(name, precision):
    export = read_dmig(FIXTURES / name)
    assert export.dofs == ("1:x", "1:y", "2:rz") and export.precision == pytest.approx(precision)
    assert np.abs(export.K.toarray() - K_EXACT).max() <= precision * 2000
    assert np.abs(export.M.toarray() - M_EXACT).max() <= precision * 1
    # the third matrix is left out, and said
    assert export.notes == ((f"{FIXTURES / name}: DMIG matrices not read: BAAX (only KAAX and MAAX are)",)
                            if name.startswith("small") else ())


def _spoiled(tmp_path, edit, name="small_field.pch"):
    lines = (FIXTURES / name).read_text().splitlines()
    (tmp_path / name).write_text("\n".join(edit(lines)) + "\n")
    return tmp_path / name


@pytest.mark.parametrize("edit, expected", [
    (lambda t: [t[2][:-1] + "4"] + t[3:], "declares NCOL = 4 columns, but KAAX and MAAX name 3 DOFs"),
    (lambda t: [t[2][:-1] + "2"] + t[3:], "line 1: the header of DMIG KAAX declares NCOL = 2 columns, but its cards "
                                          "name 3 DOFs"),
    (lambda t: t[:-1] + [t[-1][:56]], "line 16: DMIG BAAX term at grid 1 component 1 has no value"),
])
def test_an_inconsistent_punch_is_refused_naming_the_line(tmp_path, edit, expected):
    path = _spoiled(tmp_path, edit)
    with pytest.raises(ValueError) as err:
        read_dmig(path)
    assert str(path) in str(err.value) and expected in str(err.value), str(err.value)


def test_a_large_field_card_cut_after_its_first_line_is_refused(tmp_path):
    path = _spoiled(tmp_path, lambda t: t[:-1], "large_field.pch")
    with pytest.raises(ValueError, match=r"line 19: the column card of DMIG MAAX at grid 2 component 6 holds no term"):
        read_dmig(path)


def test_a_cut_stiffness_loses_diagonal_terms_and_is_refused_naming_a_line(tmp_path):
    # KAAX without its last column card: DOF 2:rz keeps its coupling (line 7) but not its diagonal
    path = _spoiled(tmp_path, lambda t: t[:7] + t[8:])
    with pytest.raises(ValueError, match=r"DMIG KAAX has off-diagonal terms at DOF '2:rz' \(its first term at line "
                                         r"7\) but no diagonal term"):
        read_dmig(path)


@pytest.mark.parametrize("field", ["small", "large", "free"])
@pytest.mark.parametrize("cut", [1, 2, 3, 7, 40])
def test_a_punch_cut_at_a_line_boundary_exits_2_naming_it(tmp_path, capsys, field, cut):
    # before: exit 0 and an invented mass derivative dM_E_beam
    frame = frame3d(2, 1, 1)
    spec = fe_cases.write_export_set(f"nastran-{field}", tmp_path / "exports", frame, names=("E_beam", "m_floor"))
    target = tmp_path / "exports" / "E_beam_plus.pch"
    lines = target.read_text().splitlines(keepends=True)
    target.write_text("".join(lines[:-cut]))
    assert main(["import", str(spec), "--out", str(tmp_path / "model")]) == 2
    err = capsys.readouterr().err
    assert str(target) in err and "cut short" in err.replace(str(tmp_path), "") and "Traceback" not in err, err
    assert not (tmp_path / "model").exists()


@pytest.mark.parametrize("cut", [1, 5])
def test_a_punch_cut_in_its_grid_cards_is_refused_naming_the_grids_without_one(tmp_path, cut):
    # before: read with the last nodes missing, so a sensor placed by position went to another node
    frame = frame3d(2, 1, 1)
    nodes = {label: tuple(map(float, xyz)) for label, xyz in frame.nodes.items()}
    K, M = frame.matrices({})
    path = tmp_path / "nominal.pch"
    fe_writers.write_dmig(path, K, M, frame.dofs, "large", nodes)
    whole = read_dmig(path)
    assert set(whole.nodes) == {d.split(":")[0] for d in whole.dofs}
    lines = path.read_text().splitlines(keepends=True)
    assert all(line.startswith("GRID,") for line in lines[-cut:])
    path.write_text("".join(lines[:-cut]))
    last = sorted(whole.nodes, key=int)[-cut:]
    with pytest.raises(ValueError, match=rf"nominal\.pch: its GRID cards give the coordinates of {len(nodes) - cut} "
                                         rf"of the {len(nodes)} grid points of its matrices, not of {', '.join(last)}; "
                                         rf"the file ends at line {len(lines) - cut}: is it cut short\?"):
        read_dmig(path)


def test_a_term_missing_from_one_export_of_the_set_is_refused_unless_the_parameter_is_zero_there():
    """The assumption of the cross-check, on a constructed 2-DOF pair: a step does not make a
    term vanish unless the parameter is zero in one of the two exports."""
    K0 = sp.csr_matrix(np.array([[3.0, -1.0], [-1.0, 2.0]]))
    M = sp.identity(2, format="csr")
    nominal = FEExport(K0, M, ("1:x", "2:x"), "nominal")
    cut = FEExport(sp.csr_matrix(np.array([[3.3, 0.0], [0.0, 2.2]])), M, ("1:x", "2:x"), "cut")
    with pytest.raises(ValueError, match=r"cut: K has no term at \(1:x, 2:x\), which nominal gives \(-1\)"):
        derivatives(nominal, [Perturbation(Parameter("k", 1.0, 0.5, 2.0), 0.1, cut)])
    # a coupling spring stepped to zero removes its terms: accepted
    spring = FEExport(sp.csr_matrix(np.array([[2.0, 0.0], [0.0, 1.0]])), M, ("1:x", "2:x"), "spring")
    d = derivatives(nominal, [Perturbation(Parameter("k", 1.0, 0.0, 2.0), -1.0, spring)])[0]
    assert np.allclose(d.dK.toarray(), [[1.0, -1.0], [-1.0, 1.0]])


def test_an_extra_matrix_is_named_in_the_import_summary(tmp_path, capsys):
    frame = frame3d(2, 1, 1)
    spec = fe_cases.write_export_set("nastran-large", tmp_path / "exports", frame, names=("E_col",))
    nominal = tmp_path / "exports" / "nominal.pch"
    K, _ = frame.matrices()
    nominal.write_text(nominal.read_text() + fe_writers.dmig_text("K4AX", 0.01 * K, frame.dofs, "large"))
    assert main(["import", str(spec), "--out", str(tmp_path / "model")]) == 0
    out = capsys.readouterr().out
    assert f"note: {nominal}: DMIG matrices not read: K4AX (only KAAX and MAAX are)" in out, out


def test_a_dof_without_mass_passes_and_a_coupling_without_its_diagonal_does_not():
    """The completeness rule of every reader on constructed entries: a positive semidefinite
    matrix has no term in a row whose diagonal is zero."""
    from vibupdate.model.fe.export import symmetric_from_entries

    names = ("1:x", "1:rz", "2:x")
    # 1:rz carries no mass at all: accepted
    M = symmetric_from_entries([0, 2, 2], [0, 0, 2], [2.0, 0.5, 2.0], 3, "m.pch", "DMIG MAAX", names, [4, 5, 6])
    assert M[1].nnz == 0 and M[0, 2] == 0.5
    # 2:x coupled to 1:x (line 5) without its own diagonal term: refused naming the DOF and the line
    with pytest.raises(ValueError, match=r"m.pch: DMIG MAAX has off-diagonal terms at DOF '2:x' \(its first term at "
                                         r"line 5\) but no diagonal term there"):
        symmetric_from_entries([0, 2], [0, 0], [2.0, 0.5], 3, "m.pch", "DMIG MAAX", names, [4, 5])
