"""Models given element by element: the Abaqus element-matrix reader, the groups' parameter
matrices against a hand assembly, and a case file of element groups run end to end."""

import json
from pathlib import Path

import numpy as np
import pytest
import scipy.linalg

from element_frames import SMALL as ef, storey_frame
from vibupdate import Parameter
from vibupdate.cli import main
from vibupdate.model.element_groups import ElementScaling, affine_from_elements, element_matrices
from vibupdate.model.fe.abaqus_elements import read_abaqus_element_sets, read_abaqus_elements

FIXTURE = Path(__file__).resolve().parents[1] / "fixtures" / "abaqus_element_matrices.mtx"
SETS = Path(__file__).resolve().parents[1] / "fixtures" / "abaqus_element_sets.inp"
#: The truth of the recovery test: the first storey's braces lost 30 % of their stiffness.
TRUTH = {"brace_1": 0.7, "brace_2": 0.95, "columns": 1.0}


def _frame_model(tmp_path, factors_of=("brace_1", "brace_2")):
    elements = read_abaqus_elements([ef.write_abaqus_elements(tmp_path / "frame.mtx")])
    params = [Parameter(g, 1.0, 0.3, 1.5) for g in factors_of]
    scaling = {g: ElementScaling(tuple(e for e, item in ef.elements.items() if item[2] == g)) for g in factors_of}
    fixed = [d for d in elements.dofs if int(d.split(":")[0]) in ef.base]
    return affine_from_elements(elements, params, scaling, fixed=fixed)


def test_the_group_matrices_equal_the_hand_assembled_ones(tmp_path):
    model = _frame_model(tmp_path)
    assert model.dofs == tuple(ef.free_dofs())
    scale = np.abs(ef.hand_assembled()).max()
    assert np.abs(model.K0.toarray() - ef.hand_assembled()).max() <= 1e-14 * scale
    assert np.abs(model.M0.toarray() - ef.hand_assembled(which="M")).max() <= 1e-14 * np.abs(model.M0).max()
    for k, group in enumerate(("brace_1", "brace_2")):
        # dK/dp of a factor with nominal 1 is the group's assembled stiffness, and dM/dp is zero
        assert np.abs(model.K_par[k].toarray() - ef.hand_assembled(groups={group})).max() <= 1e-14 * scale
        assert model.M_par[k].nnz == 0
    M, K = model.matrices_at([0.7, 0.95])
    assert np.abs(K.toarray() - ef.hand_assembled({"brace_1": 0.7, "brace_2": 0.95})).max() <= 1e-14 * scale


def test_a_density_parameter_scales_its_group_mass(tmp_path):
    elements = read_abaqus_elements([ef.write_abaqus_elements(tmp_path / "frame.mtx")])
    fixed = [d for d in elements.dofs if int(d.split(":")[0]) in ef.base]
    rho = Parameter("rho_beams", 7850.0, 7000.0, 8500.0, reference=785.0)
    model = affine_from_elements(elements, [rho], {"rho_beams": ElementScaling((5, 6), "M")}, fixed=fixed)
    beams = ef.hand_assembled(groups={"beams"}, which="M")
    # dM/dxbar = (group mass / nominal) * reference
    assert np.abs(model.M_par[0].toarray() - beams * 785.0 / 7850.0).max() <= 1e-14 * np.abs(beams).max()
    assert model.K_par[0].nnz == 0
    M, _ = model.matrices_at([8000.0])
    assert np.abs(M.toarray() - (ef.hand_assembled(which="M") + beams * (8000.0 / 7850.0 - 1))).max() \
        <= 1e-13 * np.abs(beams).max()


def test_the_reader_follows_the_layout_abaqus_writes():
    # tests/fixtures/abaqus_element_matrices.mtx, written by hand in the layout of the Abaqus
    # Keywords Reference Guide (*ELEMENT MATRIX OUTPUT, OUTPUT FILE=USER DEFINED: the *USER ELEMENT,
    # LINEAR input format): a 2-node truss (DOFs 1, 2) and a spring whose second node has DOF 2
    # only (a DOF change line), lower triangles row by row wrapped at four entries.
    elements = read_abaqus_elements([FIXTURE])
    assert elements.labels == (12, 40)
    assert elements.dofs == ("7:x", "7:y", "8:x", "8:y")
    K = elements.assemble("K").toarray()
    truss = 1.0e6 * np.array([[1, 0, -1, 0], [0, 0, 0, 0], [-1, 0, 1, 0], [0, 0, 0, 0]])
    spring = np.zeros((4, 4))
    spring[np.ix_([0, 3], [0, 3])] = 2.5e3 * np.array([[1, -1], [-1, 1]])
    assert np.array_equal(K, truss + spring)
    assert np.array_equal(elements.assemble("M").toarray(), np.diag([0.5, 0.5, 0.5, 0.5]))
    assert elements.precision == pytest.approx(5e-15)


def test_the_element_sets_of_an_abaqus_input_file_are_the_groups(tmp_path):
    sets = read_abaqus_element_sets(SETS)
    assert sets == {"columns": [1, 2, 3, 4], "beams": [5, 6], "brace_1": [7, 8], "brace_2": [9, 10],
                    "Braces": [7, 8, 9, 10]}
    assert {g: [e for e, item in ef.elements.items() if item[2] == g] for g in ("columns", "beams", "brace_1",
                                                                                "brace_2")} == {
        g: sets[g] for g in ("columns", "beams", "brace_1", "brace_2")}
    (tmp_path / "parts.inp").write_text("*Part, name=frame\n*Element, type=B21, elset=a\n1, 1, 2\n*End Part\n")
    with pytest.raises(ValueError, match="parts.inp: line 1: [*]Part: the element sets of parts and instances"):
        read_abaqus_element_sets(tmp_path / "parts.inp")


def test_an_element_matrix_with_the_wrong_count_is_named(tmp_path):
    text = FIXTURE.read_text().replace("-1.00000000000000E+06 , 0.0 , 1.00000000000000E+06\n", "")
    (tmp_path / "bad.mtx").write_text(text)
    with pytest.raises(ValueError, match=r"bad.mtx: element 12: the stiffness matrix has 7 entries; a symmetric matrix "
                                         r"of 4 DOFs has 10"):
        read_abaqus_elements([tmp_path / "bad.mtx"])


def test_an_element_of_no_nodes_is_refused_naming_it(tmp_path):
    # the first node's DOF line needs a first node: NODES=0 is refused, not an index error
    text = FIXTURE.read_text()
    (tmp_path / "none.mtx").write_text(text.replace("*USER ELEMENT, NODES= 2, LINEAR\n** ELEMENT NODES\n** 7, 8\n1\n",
                                                    "*USER ELEMENT, NODES= 0, LINEAR\n** ELEMENT NODES\n1\n", 1))
    assert (tmp_path / "none.mtx").read_text() != text
    with pytest.raises(ValueError, match=r"none.mtx: element 40 \(line 19\): \*USER ELEMENT has NODES=0; an element "
                                         r"has at least one node"):
        read_abaqus_elements([tmp_path / "none.mtx"])


def test_an_element_scaled_by_two_parameters_is_refused():
    k = np.array([[1.0, -1.0], [-1.0, 1.0]])
    elements = element_matrices([(1, ["a", "b"], k, np.eye(2)), (2, ["b", "c"], k, np.eye(2))])
    params = [Parameter("p", 1.0, 0.5, 2.0), Parameter("q", 1.0, 0.5, 2.0)]
    with pytest.raises(ValueError, match="element 2 has its K scaled by both 'p' and 'q'"):
        affine_from_elements(elements, params, {"p": ElementScaling((1, 2)), "q": ElementScaling((2,))},
                             fixed=["a"])


def test_assembly_sums_the_elements_without_a_loop_over_entries():
    # 2,000 springs in a chain: the triplets are laid out per element size, and the group's
    # matrix equals the dense sum
    n = 2000
    k = np.array([[1.0, -1.0], [-1.0, 1.0]])
    elements = element_matrices([(e, [f"q{e}", f"q{e + 1}"], k * e, np.eye(2)) for e in range(n)])
    group = elements.assemble("K", np.arange(0, n, 2)).toarray()
    dense = np.zeros((n + 1, n + 1))
    for e in range(0, n, 2):
        dense[e:e + 2, e:e + 2] += k * e
    assert np.array_equal(group, dense)


def _exact_data(model_dir: Path, n_modes=6) -> str:
    K = ef.hand_assembled(TRUTH)
    M = ef.hand_assembled(which="M")
    lam, phi = scipy.linalg.eigh(K, M)
    hz = np.sqrt(lam[:n_modes]) / (2 * np.pi)
    dofs = ef.free_dofs()
    measured = ["3:x", "4:y", "5:x", "6:y"]
    rows = ["mode,dof,value,tolerance"] + [f"{k + 1},{d},{float(phi[dofs.index(d), k])!r},0"
                                           for k in range(n_modes) for d in measured]
    (model_dir / "shapes.csv").write_text("\n".join(rows) + "\n")
    return (f'[[configuration]]\nname = "test"\nnatural_hz = [{", ".join(repr(float(h)) for h in hz)}]\n'
            'mode_shapes_csv = "shapes.csv"\n')


GROUP_CASE = """
case = "braced-frame"
[model]
type = "element_matrices"
elements = "{elements}"
clamp = [1, 2]
{groups}
[[parameter]]                  # one stiffness factor per brace group: brace_1, brace_2
name = "{{group}}"
each_group = "brace_*"
nominal = 1.0
lower = 0.3
upper = 1.5

[[parameter]]
name = "columns"
elements = "columns"
nominal = 1.0
lower = 0.5
upper = 1.5
"""


@pytest.mark.parametrize("route", ["abaqus", "npz-table"])
def test_a_case_of_element_groups_recovers_the_damaged_braces_through_run(tmp_path, route, capsys):
    if route == "abaqus":      # the groups are the element sets of the input file
        ef.write_abaqus_elements(tmp_path / "frame.mtx")
        (tmp_path / "frame.inp").write_text(SETS.read_text())
        text = GROUP_CASE.format(elements="frame.mtx", groups='groups = "frame.inp"')
    else:
        ef.write_element_table(tmp_path / "elements")
        text = GROUP_CASE.format(elements="elements/elements.csv", groups="")
    (tmp_path / "case.toml").write_text(text + _exact_data(tmp_path))
    code = main(["run", str(tmp_path / "case.toml"), "--out", str(tmp_path / "out")])
    assert code == 0, capsys.readouterr().err
    doc = json.loads((tmp_path / "out" / "results.json").read_text())
    updated = {p["name"]: p["updated"] for p in doc["parameters"]}
    assert set(updated) == {"brace_1", "brace_2", "columns"}
    assert max(abs(updated[g] - TRUTH[g]) for g in updated) <= 1e-6, updated


def test_suggest_names_the_damaged_group_among_element_group_candidates(tmp_path, capsys, monkeypatch):
    monkeypatch.setitem(TRUTH, "brace_2", 1.0)          # only the first storey's braces damaged
    ef.write_abaqus_elements(tmp_path / "frame.mtx")
    groups = "[model.groups]\n" + "\n".join(
        f"{g} = {[e for e, item in ef.elements.items() if item[2] == g]}" for g in ("brace_1", "brace_2", "columns"))
    text = (GROUP_CASE.format(elements="frame.mtx", groups=groups).replace("[[parameter]]", "[[candidate]]")
            .replace('each_group = "brace_*"', 'each_group = ["brace_*", "columns"]'))
    text = text[:text.index('[[candidate]]\nname = "columns"')]
    (tmp_path / "case.toml").write_text(text + _exact_data(tmp_path))
    assert main(["suggest", str(tmp_path / "case.toml"), "--out", str(tmp_path / "out")]) == 0, \
        capsys.readouterr().err
    assert "suggested: add brace_1 (verified" in capsys.readouterr().out


def test_an_element_written_twice_is_refused_naming_it():
    with pytest.raises(ValueError, match="element 12 is written twice .*one step and increment"):
        read_abaqus_elements([FIXTURE, FIXTURE])


def test_sixteen_brace_groups_of_a_four_storey_frame_in_a_few_lines_recover_the_damage(tmp_path, capsys):
    frame = storey_frame()              # 4 storeys x 2 bays, an X of braces per bay: 16 brace groups
    truth = {g: 1.0 for g in frame.groups} | {"brace_11a": 0.6, "brace_32b": 0.8}
    frame.write_abaqus_elements(tmp_path / "frame.mtx")
    frame.write_groups_csv(tmp_path / "groups.csv")
    K, M = frame.hand_assembled(truth), frame.hand_assembled(which="M")
    lam, phi = scipy.linalg.eigh(K, M)
    dofs = frame.free_dofs()
    measured = [d for d in dofs if not d.endswith(":rz")]
    rows = ["mode,dof,value,tolerance"] + [f"{k + 1},{d},{float(phi[dofs.index(d), k])!r},0"
                                           for k in range(8) for d in measured]
    (tmp_path / "shapes.csv").write_text("\n".join(rows) + "\n")
    hz = ", ".join(repr(float(w)) for w in np.sqrt(lam[:8]) / (2 * np.pi))
    (tmp_path / "case.toml").write_text(f"""
[model]
type = "element_matrices"
elements = "frame.mtx"
groups = "groups.csv"
clamp = [0, 1, 2]

[[parameter]]
name = "{{group}}"
each_group = "brace_*"
nominal = 1.0
lower = 0.3
upper = 1.5

[[configuration]]
name = "test"
natural_hz = [{hz}]
mode_shapes_csv = "shapes.csv"
""")
    assert main(["run", str(tmp_path / "case.toml"), "--out", str(tmp_path / "out")]) == 0, capsys.readouterr().err
    updated = {p["name"]: p["updated"] for p in json.loads((tmp_path / "out" / "results.json").read_text())["parameters"]}
    assert len(updated) == 16 and all(name.startswith("brace_") for name in updated)
    assert max(abs(updated[g] - truth[g]) for g in updated) <= 1e-6, updated
