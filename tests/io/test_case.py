"""Case files: the documented example, every input form, and malformed files."""

import re
from pathlib import Path

import numpy as np
import pyuff
import pytest

from helpers import CASE_FILE_EXAMPLE, CHAIN_CASE, CHAIN_K, write_chain_matrices
from vibupdate.io.case import load_case
from vibupdate.io.case_model import linear_expression
from vibupdate.cli import main
from vibupdate.inverse.correlation import model_frequencies
from vibupdate.examples import cantilever

ROOT = Path(__file__).resolve().parents[2]
DOC = (ROOT / "docs" / "case-file.md").read_text()
EXAMPLE = CASE_FILE_EXAMPLE


def write(tmp_path, text, name="case.toml"):
    path = tmp_path / name
    path.write_text(text)
    return path


def test_documented_example_is_the_shipped_case_file():
    shipped = (ROOT / "examples" / "cantilever" / "case.toml").read_text()
    assert EXAMPLE in shipped


def test_documented_example_builds_the_bundled_cantilever(tmp_path):
    case = load_case(write(tmp_path, EXAMPLE))
    assert [c.name for c in case.configurations] == ["A", "B", "C", "D"]
    for mine, ref in zip(case.configurations, cantilever.configurations()):
        a, b = model_frequencies(mine), model_frequencies(ref)
        np.testing.assert_allclose(a.natural, b.natural, rtol=1e-8)
        np.testing.assert_allclose(a.antiresonances, b.antiresonances, rtol=1e-8)
        assert [f.damping_ratio for f in mine.natural] == [f.damping_ratio for f in ref.natural]
    assert case.damping.exponents == (-1.5, -0.75, 0.0)
    assert case.solver.n_lambda == 10


def test_every_documented_key_is_read_by_the_loader():
    """Keys in the tables of docs/case-file.md are the keys the loader accepts."""
    from vibupdate.io import case_keys as module

    first_cells = [line.split(" | ")[0] for line in DOC.splitlines() if line.startswith("| `")]
    names = {n for cell in first_cells for n in re.findall(r"`(\w+)`", cell)}
    accepted = (set(module.TOP_KEYS) | set(module.ELEMENTS_KEYS) | set(module.CFG_KEYS) | set(module.SOLVER_KEYS)
                | set(module.FORMULATION_KEYS) | set(module.DAMPING_KEYS) | set(module.PARAMETER_KEYS)
                | set(module.POLISH_KEYS) | set(module.VERIFICATION_KEYS)
                | set(module.MATRICES_KEYS) | set(module.ELEMENT_MATRICES_KEYS) | {"builder"})
    assert names <= accepted, names - accepted
    assert accepted - {"type"} <= names, (accepted - {"type"}) - names


def test_linear_expressions():
    f = linear_expression("2.5e-3*E + rho*2 - 1e-1 + k", ["E", "rho", "k"])
    assert f({"E": 1000.0, "rho": 3.0, "k": 0.5}) == pytest.approx(2.5 + 6.0 - 0.1 + 0.5)
    assert linear_expression(4, []) ({}) == 4.0
    with pytest.raises(ValueError, match="'q', which is not a parameter"):
        linear_expression("2*q", ["E"])
    with pytest.raises(ValueError, match="cannot read"):
        linear_expression("E*E", ["E"])


def test_csv_and_case_files_saved_with_a_byte_order_mark_read_as_without(tmp_path):
    """A spreadsheet's "CSV UTF-8" and some editors' TOML start with a byte-order mark: the
    first column is still `kind` (it read as '\\ufeffkind'), the case file still parses."""
    hz = write_chain_matrices(tmp_path)
    bom = "\ufeff"
    (tmp_path / "f.csv").write_text(bom + "kind,hz,damping_ratio\n" + "".join(f"natural,{h},0.02\n" for h in hz[:2]),
                                    encoding="utf-8")
    (tmp_path / "s.csv").write_text(bom + "mode,dof,value,tolerance\n1,a,0.5,0.1\n1,c,1.0,0.1\n", encoding="utf-8")
    path = write(tmp_path, CHAIN_CASE + 'frequencies_csv = "f.csv"\nmode_shapes_csv = "s.csv"\n')
    path.write_text(bom + path.read_text(encoding="utf-8"), encoding="utf-8")
    cfg = load_case(path).configurations[0]
    assert [f.freq_hz for f in cfg.natural] == pytest.approx(hz[:2])
    assert cfg.natural[0].shape.bounds == {"a": (0.4, 0.6), "c": (0.9, 1.1)}


def test_a_shape_at_a_dof_the_model_lacks_names_the_csv_row_and_the_closest_dofs(tmp_path, capsys):
    hz = write_chain_matrices(tmp_path)
    (tmp_path / "f.csv").write_text("kind,hz\n" + "".join(f"natural,{h}\n" for h in hz[:2]))
    (tmp_path / "s.csv").write_text("mode,dof,value,tolerance\n1,a,0.5,0.1\n1,cc,1.0,0.1\n")
    path = write(tmp_path, CHAIN_CASE + 'frequencies_csv = "f.csv"\nmode_shapes_csv = "s.csv"\n')
    assert main(["check", str(path)]) == 2
    err = capsys.readouterr().err
    assert "s.csv: row 3: DOF 'cc' is not in the model (closest: c" in err and err.count("error:") == 1


def test_matrices_csv_and_uff_inputs(tmp_path):
    hz = write_chain_matrices(tmp_path)
    (tmp_path / "f.csv").write_text("kind,hz,weight,damping_ratio,response,excitation\n"
                                    + "".join(f"natural,{h},1,0.02,,\n" for h in hz[:2]))
    (tmp_path / "s.csv").write_text("mode,dof,value,tolerance\n1,a,0.5,0.1\n1,c,1.0,0.1\n")
    case = load_case(write(tmp_path, CHAIN_CASE + 'frequencies_csv = "f.csv"\nmode_shapes_csv = "s.csv"\n'))
    cfg = case.configurations[0]
    assert [f.freq_hz for f in cfg.natural] == pytest.approx(hz[:2])
    assert cfg.natural[0].shape.bounds == {"a": (0.4, 0.6), "c": (0.9, 1.1)}
    # UFF dataset 55: frequencies, damping and shapes from the file
    uff = pyuff.UFF(str(tmp_path / "m.uff"))
    for k, h in enumerate(hz[:2]):
        uff.write_sets(pyuff.prepare_55(
            id1="test", model_type=1, analysis_type=2, data_ch=2, spec_data_type=8, data_type=2,
            n_data_per_node=3, r1=np.array([0.3, 0.6, 1.0]) * (k + 1), r2=np.zeros(3), r3=np.zeros(3),
            load_case=1, mode_n=k + 1, freq=float(h), modal_m=0.0, modal_damp_vis=0.01 * (k + 1),
            modal_damp_his=0.0, node_nums=np.array([1, 2, 3])), "add")
    text = CHAIN_CASE.replace('["a", "b", "c"]', '["x1", "x2", "x3"]') + 'mode_shapes_uff = "m.uff"\nuff_tolerance = 0.1\n'
    cfg = load_case(write(tmp_path, text)).configurations[0]
    assert [f.freq_hz for f in cfg.natural] == pytest.approx(hz[:2], rel=1e-5)
    assert [f.damping_ratio for f in cfg.natural] == pytest.approx([0.01, 0.02])
    assert cfg.natural[1].shape.bounds["x3"] == pytest.approx((1.8, 2.2))


def test_builder_from_a_python_file(tmp_path):
    (tmp_path / "model.py").write_text(
        "import vibupdate as vu\n"
        "def build(p, tip=0.0):\n"
        "    asm = vu.Assembly('beam')\n"
        "    for i in range(4):\n"
        "        asm.node(i, 0.2 * i)\n"
        "    for i in range(3):\n"
        "        asm.beam(i, i + 1, EI=p['EI'], mass_per_length=1.0)\n"
        "    asm.clamp(0)\n"
        "    asm.mass('y3', tip)\n"
        "    return asm.system()\n")
    text = ('[model]\ntype = "builder"\nbuilder = "model.py:build"\n'
            '[[parameter]]\nname = "EI"\nnominal = 10.0\nlower = 5.0\nupper = 20.0\n'
            '[[configuration]]\nname = "A"\nnatural_hz = [1.0, 5.0]\noptions = { tip = 0.2 }\n')
    case = load_case(write(tmp_path, text))
    assert case.configurations[0].model.M0[case.configurations[0].model.dof("y3"),
                                            case.configurations[0].model.dof("y3")] > 0.2


@pytest.mark.parametrize(
    "edit, message",
    [
        (lambda t: t.replace("lower = 50.3e9\n", ""), r"parameter\[1\]\.lower: is required"),
        (lambda t: t.replace('response = "y1", excitation = "y3" }]\n\n[[configuration]]\nname = "B"',
                             'response = "y9", excitation = "y3" }]\n\n[[configuration]]\nname = "B"'),
         r"configuration 'A': .*DOF 'y9' does not exist"),
        (lambda t: t.replace("damping_ratios = [0.044,", "damping_ratios = [-0.044,"),
         r"configuration 'A': damping ratio must be a finite number >= 0, got -0.044"),
        (lambda t: t.replace("[solver]\nn_lambda = 10", "[solver]\nn_lambda = 10\nspeed = 3"),
         r"solver\.speed: unknown key"),
        (lambda t: t.replace("n_lambda = 10", 'n_lambda = "ten"'), r"solver\.n_lambda: must be an integer"),
        (lambda t: re.sub(r"natural_hz = \[73\.4,[^\n]*\ndamping_ratios = [^\n]*\n", 'frequencies_csv = "missing.csv"\n', t,
                          count=1),
         r"CSV file .*missing\.csv.* could not be read"),
        (lambda t: t.replace('EI = "2.1333333333e-10*E"', 'EI = "2.1333333333e-10*Q"', 1),
         r"model\.beam\[1\]\.EI: .*'Q', which is not a parameter"),
    ],
)
def test_malformed_case_files_give_one_clear_message(tmp_path, capsys, edit, message):
    path = write(tmp_path, edit(EXAMPLE))
    with pytest.raises(ValueError, match=message):
        load_case(path)
    out = tmp_path / "out"
    assert main(["run", str(path), "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.count("vibupdate: error:") == 1 and str(path) in err
    assert not out.exists()
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".out.partial")]


def test_uff_without_dataset_55_is_named(tmp_path, capsys):
    write_chain_matrices(tmp_path)
    uff = pyuff.UFF(str(tmp_path / "no55.uff"))
    uff.write_sets(pyuff.prepare_15(node_nums=[1, 2], def_cs=[0, 0], disp_cs=[0, 0], color=[1, 1],
                                    x=[0.0, 1.0], y=[0.0, 0.0], z=[0.0, 0.0]), "add")
    path = write(tmp_path, CHAIN_CASE + 'mode_shapes_uff = "no55.uff"\n')
    assert main(["check", str(path)]) == 2
    assert "has no dataset 55" in capsys.readouterr().err


def test_uff_modes_file_cut_short_is_named(tmp_path, capsys):
    """A dataset-55 file that does not end with the ``-1`` closing its last dataset (a copy that
    stopped) is refused naming the file, as an FRF file is, not read without its last mode."""
    write_chain_matrices(tmp_path)
    uff = pyuff.UFF(str(tmp_path / "cut.uff"))
    for k in range(2):
        uff.write_sets(pyuff.prepare_55(
            id1="test", model_type=1, analysis_type=2, data_ch=2, spec_data_type=8, data_type=2,
            n_data_per_node=3, r1=np.array([0.3, 0.6, 1.0]), r2=np.zeros(3), r3=np.zeros(3),
            load_case=1, mode_n=k + 1, freq=10.0 * (k + 1), modal_m=0.0, modal_damp_vis=0.01,
            modal_damp_his=0.0, node_nums=np.array([1, 2, 3])), "add")
    lines = (tmp_path / "cut.uff").read_text().splitlines(keepends=True)
    (tmp_path / "cut.uff").write_text("".join(lines[:-2]))
    text = CHAIN_CASE.replace('["a", "b", "c"]', '["x1", "x2", "x3"]') + 'mode_shapes_uff = "cut.uff"\n'
    assert main(["check", str(write(tmp_path, text))]) == 2
    err = capsys.readouterr().err
    assert "cut.uff" in err and "-1" in err


def test_check_prints_the_problem_size(tmp_path, capsys):
    assert main(["check", str(write(tmp_path, EXAMPLE))]) == 0
    out = capsys.readouterr().out
    assert "OK" in out and "n_lifted 552" in out


def test_shipped_frame_case_file_matches_the_bundled_example(capsys):
    from vibupdate.examples import frame

    path = ROOT / "examples" / "frame" / "case.toml"
    case = load_case(path)
    bundled = frame.configurations()[0]
    cfg = case.configurations[0]
    assert case.configurations[0].model.parameter_names == bundled.model.parameter_names
    np.testing.assert_allclose([f.omega for f in cfg.natural], [f.omega for f in bundled.natural], rtol=1e-9)
    mine, ref = cfg.natural[3].shape.bounds, bundled.natural[3].shape.bounds
    assert list(mine) == list(ref)
    np.testing.assert_allclose([mine[d] for d in mine], [ref[d] for d in ref], rtol=1e-9)
    assert case.frequency_tolerance == pytest.approx(3 * frame.FREQUENCY_ERROR)
    assert main(["check", str(path)]) == 0
    assert "n_parameters 29" in capsys.readouterr().out


def test_matrices_case_runs_end_to_end(tmp_path):
    """Exported matrices, one stiffness parameter, exact frequencies: the run recovers it and
    writes a complete output directory."""
    import json

    write_chain_matrices(tmp_path)  # M0 = I, K0 = K, dK/dk = K / 1000
    hz = np.sqrt(np.linalg.eigvalsh(CHAIN_K * 1.3)) / (2 * np.pi)
    text = CHAIN_CASE + f"natural_hz = [{float(hz[0])!r}, {float(hz[1])!r}]\ndamping_ratios = [0.02, 0.015]\n"
    out = tmp_path / "out"
    assert main(["run", str(write(tmp_path, text)), "--out", str(out)]) == 0
    doc = json.loads((out / "results.json").read_text())
    assert doc["parameters"][0]["updated"] == pytest.approx(1300.0, rel=1e-6)
    assert {"M_only.mtx", "K_only.mtx", "C_only.mtx", "report.md"} <= {p.name for p in out.iterdir()}


def test_declared_modes_and_zero_indices_in_case_files(tmp_path):
    """natural_modes, antiresonance index, CSV mode/index columns, shapes keyed by the declared mode;
    [polish] and [verification] tables."""
    hz = write_chain_matrices(tmp_path)
    text = CHAIN_CASE + f"natural_modes = [2, 3]\nnatural_hz = [{hz[1]}, {hz[2]}]\n"
    text += '[[configuration.antiresonances]]\nhz = 20.0\nresponse = "a"\nexcitation = "a"\nindex = 2\n'
    (tmp_path / "s.csv").write_text("mode,dof,value,tolerance\n3,a,0.5,0.1\n3,c,1.0,0.1\n")
    text = text.replace('name = "only"\n', 'name = "only"\nmode_shapes_csv = "s.csv"\n')
    text += "[polish]\nenabled = false\nreduced_rounds = 0\n[verification]\nnatural_tolerance = 0.05\nmac_min = 0.9\n"
    case = load_case(write(tmp_path, text))
    cfg = case.configurations[0]
    assert [f.mode for f in cfg.natural] == [2, 3]
    assert cfg.natural[0].shape is None and cfg.natural[1].shape is not None
    assert [a.index for a in cfg.antiresonances] == [2]
    assert case.polish.enabled is False and case.polish.reduced_rounds == 0
    with pytest.raises(ValueError, match=r": polish\.reduced_rounds: must be an integer >= 0, got -1$"):
        load_case(write(tmp_path, text.replace("reduced_rounds = 0", "reduced_rounds = -1")))
    assert case.verification.natural_tolerance == 0.05 and case.verification.mac_min == 0.9
    (tmp_path / "f.csv").write_text("kind,hz,mode,index,response,excitation\n"
                                    f"natural,{hz[1]},2,,,\nnatural,{hz[2]},3,,,\nantiresonance,20.0,,2,a,a\n")
    case = load_case(write(tmp_path, CHAIN_CASE + 'frequencies_csv = "f.csv"\n'))
    cfg = case.configurations[0]
    assert [f.mode for f in cfg.natural] == [2, 3] and [a.index for a in cfg.antiresonances] == [2]
    (tmp_path / "f.csv").write_text("kind,hz,mode\nnatural,10.0,1.5\n")
    with pytest.raises(ValueError, match="row 2: mode must be an integer"):
        load_case(write(tmp_path, CHAIN_CASE + 'frequencies_csv = "f.csv"\n'))
    with pytest.raises(ValueError, match="natural_modes"):
        load_case(write(tmp_path, CHAIN_CASE + f"natural_modes = [2]\nnatural_hz = [{hz[1]}, {hz[2]}]\n"))


@pytest.mark.parametrize("modes, said", [("[2, 2]", "mode 2 is given twice"), ("[3, 2]", "mode 2 comes after a higher one")])
def test_natural_modes_that_do_not_rise_are_named(tmp_path, capsys, modes, said):
    hz = write_chain_matrices(tmp_path)
    path = write(tmp_path, CHAIN_CASE + f"natural_modes = {modes}\nnatural_hz = [{hz[1]}, {hz[2]}]\n")
    assert main(["check", str(path)]) == 2
    err = capsys.readouterr().err
    assert "natural_modes: " + said in err and err.count("error:") == 1


# -- models given element by element: groups and the parameters that scale them -----------------

def _spring_chain_table(folder: Path, n: int = 17) -> None:
    """``elements.csv``: ``n`` springs in a chain from ground, one Matrix Market file each (its
    DOFs in the table), unit masses on the nodes as elements of their own; groups ``brace_1``
    ... ``brace_16`` of one spring each (the 17th, the ground spring, in none)."""
    import scipy.io
    import scipy.sparse as sp

    k = np.array([[1.0, -1.0], [-1.0, 1.0]]) * 1000.0
    scipy.io.mmwrite(str(folder / "spring.mtx"), sp.coo_matrix(k))
    scipy.io.mmwrite(str(folder / "mass.mtx"), sp.coo_matrix(np.eye(1)))
    scipy.io.mmwrite(str(folder / "none.mtx"), sp.coo_matrix(np.zeros((1, 1))))
    rows = ["element,K,M,dofs,group"]
    rows += [f"s{e},spring.mtx,,q{e} q{e + 1},{f'brace_{e}' if e else ''}" for e in range(n)]
    rows += [f"m{e},none.mtx,mass.mtx,q{e}," for e in range(1, n + 1)]
    (folder / "elements.csv").write_text("\n".join(rows) + "\n")


ELEMENT_GROUP_CASE = """
[model]
type = "element_matrices"
elements = "elements.csv"
fix = ["q0"]

[[parameter]]
name = "k_{group}"
each_group = "brace_*"
nominal = 1000.0
lower = 500.0
upper = 1500.0

[[configuration]]
name = "only"
natural_hz = [1.0]
"""


def test_each_group_makes_one_parameter_per_group_in_a_few_lines(tmp_path):
    _spring_chain_table(tmp_path)
    case = load_case(write(tmp_path, ELEMENT_GROUP_CASE))
    model = case.configurations[0].model
    assert model.parameter_names == tuple(f"k_brace_{g}" for g in range(1, 17))
    # each parameter's dK/dp is its spring's matrix per N/m (normalized: times the nominal)
    k = model.K_par[model.parameter_names.index("k_brace_3")].toarray()
    i, j = model.dof("q3"), model.dof("q4")
    assert k[np.ix_([i, j], [i, j])].tolist() == [[1000.0, -1000.0], [-1000.0, 1000.0]]
    assert np.count_nonzero(k) == 4
    assert model.dofs[0] == "q1" and model.n_dofs == 17      # q0 fixed


@pytest.mark.parametrize("edit, message", [
    (('name = "k_{group}"', 'name = "k"'), r"parameter\[1\]\.name: must hold \{group\}"),
    (('each_group = "brace_*"', 'each_group = "beam_*"'), r"'beam_\*' matches no group"),
    (('each_group = "brace_*"', 'elements = ["brace_1", "s99"]'), r"'s99' is neither a group"),
    (('each_group = "brace_*"', 'each_group = "brace_*"\nscales = "C"'), r"scales: must be 'K' \(stiffness\) or 'M'"),
    (('each_group = "brace_*"', 'each_group = "brace_*"\nelements = ["s1"]'), "give either each_group"),
    (('[[configuration]]', '[[parameter]]\nname = "extra"\nelements = ["s3"]\nnominal = 1.0\nlower = 0.5\nupper = 2.0\n'
                           '[[configuration]]'), r"model: element 's3' has its K scaled by both 'k_brace_3' and 'extra'"),
    (('fix = ["q0"]', 'fix = ["q99"]'), r"model\.fix\[1\]: must be a DOF of the elements"),
    (('fix = ["q0"]', 'clamp = [3]'), r"model\.clamp\[1\]: must be a node of the elements"),
    (('elements = "elements.csv"', 'elements = "missing.mtx"'), r"model\.elements: .*missing\.mtx' does not exist"),
    (('fix = ["q0"]', 'fix = ["q0"]\ngroups = "header_only.csv"'), r"model\.groups: .*header_only\.csv: lists no element"),
])
def test_element_group_mistakes_name_the_key(tmp_path, edit, message):
    _spring_chain_table(tmp_path)
    (tmp_path / "header_only.csv").write_text("element,group\n")
    with pytest.raises(ValueError, match=message) as info:
        load_case(write(tmp_path, ELEMENT_GROUP_CASE.replace(*edit)))
    assert str(info.value).startswith(str(tmp_path / "case.toml"))


def test_element_groups_need_an_element_matrices_model(tmp_path):
    write_chain_matrices(tmp_path)
    text = CHAIN_CASE.replace('upper = 2000.0', 'upper = 2000.0\nelements = ["a"]')
    with pytest.raises(ValueError, match=r"parameter\[1\]\.elements: element groups are read by a model of type "
                                         "'element_matrices'"):
        load_case(write(tmp_path, text))


def test_element_group_candidates_are_freed_by_suggest(tmp_path):
    _spring_chain_table(tmp_path, n=5)
    text = ELEMENT_GROUP_CASE.replace("[[parameter]]", "[[candidate]]")
    case = load_case(write(tmp_path, text))
    assert [p.name for p in case.candidates] == [f"k_brace_{g}" for g in range(1, 5)]
    freed = case.with_candidates(["k_brace_2"]).configurations[0].model
    assert freed.parameter_names == ("k_brace_2",)


def test_the_documented_sixteen_brace_groups_make_sixteen_parameters():
    import tomllib

    from vibupdate.io.case_elements import ElementSource, expand_group_parameters
    from vibupdate.io.case_keys import Where

    block = next(b for b in re.findall(r"```toml\n(.*?)```", DOC, re.S) if "each_group" in b)
    spec = tomllib.loads(block)
    names = [f"brace_{storey}{side}" for storey in range(1, 5) for side in ("x", "y", "X", "Y")]
    groups = {"columns": (1,), **{g: (1001 + 2 * k, 1002 + 2 * k) for k, g in enumerate(names)}}
    items = expand_group_parameters(spec["parameter"], "parameter", ElementSource(None, groups, ()), Where(Path("x")))
    assert [item["name"] for item in items] == [f"E_{g}" for g in names]
    assert all(item["elements"] == g and item["nominal"] == 210e9 for item, g in zip(items, names))


# -- damped or natural frequencies --------------------------------------------------------------

#: Damping ratios of the chain's three modes: the first makes natural and damped differ by 0.18 %.
CHAIN_ZETA = [0.06, 0.01, 0.01]


def _damped_chain_case(tmp_path, statement="", tolerance=0.001):
    """The chain of `CHAIN_CASE` at k = 1200 with its three frequencies measured as damped
    ones, ``omega_d = omega_n sqrt(1 - zeta^2)``, within +-``tolerance``; returns the case file
    and the natural frequencies (Hz), the truth."""
    hz = write_chain_matrices(tmp_path)
    damped = [h * np.sqrt(1 - z**2) for h, z in zip(hz, CHAIN_ZETA)]
    text = (f"frequency_tolerance = {tolerance}\n" + CHAIN_CASE
            + f"natural_hz = {[float(h) for h in damped]}\ndamping_ratios = {CHAIN_ZETA}\n" + statement)
    return write(tmp_path, text), hz


def test_damped_frequencies_are_made_natural_with_their_damping_ratios(tmp_path, capsys):
    path, natural = _damped_chain_case(tmp_path, 'frequency_type = "damped"\n')
    case = load_case(path)
    got = [f.freq_hz for f in case.configurations[0].natural]
    np.testing.assert_allclose(got, natural, rtol=1e-14)
    assert [f.damping_ratio for f in case.configurations[0].natural] == CHAIN_ZETA
    # the conversion moved mode 1 beyond its interval (0.18 % > 0.1 %), and the run says so
    assert main(["run", str(path), "--out", str(tmp_path / "out")]) == 0
    out = capsys.readouterr().out
    assert "warning: configuration 'only': the damped frequencies were made natural" in out
    assert "frequency 1" in out and "0.18 % > 0.1 %" in out and "frequency 2" not in out
    doc = __import__("json").loads((tmp_path / "out" / "results.json").read_text())
    assert abs(doc["parameters"][0]["updated"] / 1200.0 - 1) <= 1e-6


def test_damped_frequencies_not_declared_are_taken_as_natural_with_a_note(tmp_path):
    from vibupdate.io.validation import validate_case

    path, natural = _damped_chain_case(tmp_path)
    case = load_case(path)
    assert case.configurations[0].natural[0].freq_hz < natural[0] * (1 - 1e-3)     # taken as given
    said = [w for w in validate_case(case).warnings if "damping ratios make natural frequencies higher" in w]
    assert len(said) == 1 and said[0].startswith("configuration 'only': ")
    assert "frequency 1 at " in said[0] and "frequency_type = \"damped\"" in said[0]
    # stated natural: the user has said, no note; a wider interval than the shift: no note
    for statement, tolerance in (('frequency_type = "natural"\n', 0.001), ("", 0.01)):
        path, _ = _damped_chain_case(tmp_path, statement, tolerance)
        assert not [w for w in validate_case(load_case(path)).warnings if "damped" in w]


@pytest.mark.parametrize("edit, message", [
    (("damping_ratios = [0.06, 0.01, 0.01]\n", ""), r"configuration 'only'\.frequency_type: 'damped' converts each "
                                                   r"frequency with its damping ratio; frequency 1 .* has none"),
    (('frequency_type = "damped"', 'frequency_type = "undamped"'), r"frequency_type: must be 'natural' or 'damped'"),
])
def test_damped_frequency_mistakes_name_the_key(tmp_path, edit, message):
    path, _ = _damped_chain_case(tmp_path, 'frequency_type = "damped"\n')
    path.write_text(path.read_text().replace(*edit))
    with pytest.raises(ValueError, match=message):
        load_case(path)


def test_a_damped_interval_becomes_the_natural_one_with_the_ratios_that_move_it_farthest():
    from vibupdate.data.measured import NaturalFrequency, damped_shift, natural_from_damped

    f = NaturalFrequency(100.0, damping_ratio=0.05, interval=(99.0, 101.0), damping_interval=(0.02, 0.08))
    n = natural_from_damped(f)
    assert n.omega == pytest.approx(100.0 / np.sqrt(1 - 0.05**2), rel=1e-15)
    assert n.interval == pytest.approx((99.0 / np.sqrt(1 - 0.02**2), 101.0 / np.sqrt(1 - 0.08**2)), rel=1e-15)
    assert damped_shift(0.06) == pytest.approx(0.0018, rel=0.01)
    with pytest.raises(ValueError, match="has no damping ratio"):
        natural_from_damped(NaturalFrequency(100.0))


def test_the_case_types_are_named_without_the_file_reader():
    """`Case` and `DampingOptions` live in their own module: the examples and the pipeline name
    them without loading the TOML reader, which still gives them (and so does the package)."""
    import subprocess
    import sys

    import vibupdate
    import vibupdate.io.case as reader
    from vibupdate.io import case_types

    assert reader.Case is case_types.Case is vibupdate.Case
    assert reader.DampingOptions is case_types.DampingOptions is vibupdate.DampingOptions
    probe = ("import sys\nimport vibupdate.io.case_types, vibupdate.examples.cantilever, vibupdate.pipeline\n"
             "print('vibupdate.io.case' in sys.modules)")
    done = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr[-2000:]
    assert done.stdout.strip() == "False"
