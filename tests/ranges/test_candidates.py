"""Which parameters to update: candidates in a case file, the rotary-inertia term of the beam
element, and the screening, ranking and checking of sets of candidates
(`vibupdate.ranges.candidates`, ``vibupdate suggest``)."""

import json
import math

import numpy as np
import pytest

from vibupdate import modes
from vibupdate.cli import main
from vibupdate.io.case import load_case
from vibupdate.model import elements
from vibupdate.ranges.candidates import suggest_sets

#: A cantilever of 6 beam elements (clamped at node 7), E its parameter; its truth has E 4 %
#: above nominal and a 500 N/m spring at the free tip, which the nominal model lacks.
HEAD = """case = "tip-spring"
[model]
type = "elements"
kind = "beam"
line = { first = 1, last = 7, start = [0.0], end = [0.6] }
clamp = [7]
[[model.beam]]
nodes = [1, 2, 3, 4, 5, 6, 7]
EI = "1.0e-9*E"
mass_per_length = "0.24*rho"
rotary_inertia = "2.0e-8*r"
[[model.spring]]
dof = "y1"
value = "kt"
[[model.mass]]
dof = "y4"
value = "mmid"
[[parameter]]
name = "E"
nominal = 70.0e9
lower = 50.0e9
upper = 90.0e9
"""
CANDIDATES = """[[candidate]]
name = "rho"
nominal = 2700.0
lower = 2000.0
upper = 3400.0
[[candidate]]
name = "r"
nominal = 0.0
reference = 1.0
lower = 0.0
upper = 10.0
[[candidate]]
name = "kt"
unit = "N/m"
nominal = 0.0
reference = 100.0
lower = 0.0
upper = 5000.0
[[candidate]]
name = "mmid"
unit = "kg"
nominal = 0.0
reference = 0.01
lower = 0.0
upper = 0.2
"""
TRUTH = {"E": 72.8e9, "kt": 500.0}


def _plain_head() -> str:
    """`HEAD` with the candidates' nominal values written as numbers."""
    return HEAD.replace('"0.24*rho"', "648.0").replace('"2.0e-8*r"', "0.0").replace('"kt"', "0.0") \
        .replace('"mmid"', "0.0")


def _write(tmp_path, natural_hz, candidates=CANDIDATES, extra=""):
    cfg = f'[[configuration]]\nname = "A"\nnatural_hz = {list(natural_hz)!r}\n'
    text = HEAD + candidates + cfg + '[verification]\nnatural_tolerance = 0.0\n' + extra
    (tmp_path / "case.toml").write_text(text)
    return tmp_path / "case.toml"


def _truth_hz(tmp_path, n=4):
    case = load_case(_write(tmp_path, [1.0])).with_candidates(["kt"])
    M, K = case.configurations[0].model.matrices_at([TRUTH["E"], TRUTH["kt"]])
    omega, _ = modes(M, K)
    return (omega[:n] / (2 * math.pi)).tolist()


def test_rotary_inertia_term_is_the_consistent_matrix_and_affine():
    """``rho I`` adds the integral of ``rho I N_i' N_j'`` (Gauss quadrature of the Hermite
    cubics' slopes), linearly; the frame element carries it in its bending DOFs."""
    L = 0.37
    xs, ws = np.polynomial.legendre.leggauss(8)
    xi, w = (xs + 1) / 2, ws * L / 2
    slopes = np.array([(-6 * xi + 6 * xi**2) / L, 1 - 4 * xi + 3 * xi**2, (6 * xi - 6 * xi**2) / L,
                       -2 * xi + 3 * xi**2])
    exact = (slopes * w) @ slopes.T
    _, plain = elements.beam_matrices(2.0, 3.0, [L])
    _, with_rotary = elements.beam_matrices(2.0, 3.0, [L], rotary_inertia=1.5)
    np.testing.assert_allclose(with_rotary[0] - plain[0], 1.5 * exact, rtol=1e-13, atol=1e-15)
    _, frame = elements.frame_matrices(1.0, 2.0, 3.0, [L], [0.0], rotary_inertia=1.5)
    _, frame_plain = elements.frame_matrices(1.0, 2.0, 3.0, [L], [0.0])
    bending = np.array([1, 2, 4, 5])
    np.testing.assert_allclose((frame - frame_plain)[0][np.ix_(bending, bending)], 1.5 * exact, rtol=1e-13,
                               atol=1e-15)


def test_candidates_are_held_at_their_nominal_values_in_a_run(tmp_path):
    """The case with candidates builds the same matrices as without them (their nominal values
    written as numbers), the candidates' matrices are those of the assembly, and a candidate
    named twice or a case without any parameter is refused by name."""
    path = _write(tmp_path, [10.0])
    case = load_case(path)
    assert case.configurations[0].model.parameter_names == ("E",)
    assert [p.name for p in case.candidates] == ["rho", "r", "kt", "mmid"]
    (tmp_path / "plain.toml").write_text(_plain_head() + '[[configuration]]\nname = "A"\nnatural_hz = [10.0]\n')
    reference = load_case(tmp_path / "plain.toml").configurations[0].model
    model = case.configurations[0].model
    for a, b in ((model.M0, reference.M0), (model.K0, reference.K0), (model.K_par[0], reference.K_par[0])):
        assert abs(a - b).max() <= 1e-12 * abs(b).max()
    freed = case.with_candidates(["kt", "r"]).configurations[0].model
    assert freed.parameter_names == ("E", "r", "kt")
    M, K = freed.matrices_at([70e9, 2.0, 300.0])
    _, M_expected = elements.beam_matrices(0.0, 0.24 * 2700.0, [0.1], rotary_inertia=4e-8)
    assert K[0, 0] == pytest.approx(reference.K0[0, 0] + 300.0, rel=1e-12)
    assert M[1, 1] == pytest.approx(M_expected[0][1, 1], rel=1e-12)   # the free tip's rotation
    with pytest.raises(ValueError, match="not a candidate"):
        case.with_candidates(["E"])
    (tmp_path / "twice.toml").write_text(path.read_text().replace('name = "rho"', 'name = "E"', 1))
    with pytest.raises(ValueError, match="declared both as a \\[\\[parameter\\]\\] and as a \\[\\[candidate\\]\\]"):
        load_case(tmp_path / "twice.toml")
    only = (HEAD.split("[[parameter]]")[0] + '[[candidate]]\nname = "E"\nnominal = 70.0e9\nlower = 50.0e9\n'
            'upper = 90.0e9\n' + CANDIDATES + '[[configuration]]\nname = "A"\nnatural_hz = [10.0]\n')
    (tmp_path / "only.toml").write_text(only)
    assert load_case(tmp_path / "only.toml").configurations[0].model.n_parameters == 0
    assert main(["check", str(tmp_path / "only.toml")]) == 2   # run says the same: it validates as check does


def test_suggest_finds_the_missing_spring_and_the_run_names_it(tmp_path, capsys):
    """Exact frequencies of the cantilever with its tip spring: the run with E alone is not
    verified and its report names kt; `suggest` ranks kt first, its full update is `success`
    with E and kt at their truth."""
    path = _write(tmp_path, _truth_hz(tmp_path))
    code = main(["suggest", str(path), "--out", str(tmp_path / "sg")])
    out = capsys.readouterr().out
    assert code == 0, out
    record = json.loads((tmp_path / "sg" / "suggestion.json").read_text())
    assert record["best"] == ["kt"] and record["sizes"] == [1]
    top = record["trials"][0]
    assert top["candidates"] == ["kt"] and top["update"]["success"]
    assert top["update"]["values"]["E"] == pytest.approx(TRUTH["E"], rel=1e-6)
    assert top["update"]["values"]["kt"] == pytest.approx(TRUTH["kt"], rel=1e-5)
    assert "suggested: add kt" in out and "suggested: add kt" in (tmp_path / "sg" / "suggestion.md").read_text()
    # the work, not the wall time: one set per candidate of size 1 (4, measured), none left to the
    # limits, and no larger set once a single candidate fits
    assert len(record["trials"]) == 4 and record["untried"] == 0
    assert main(["run", str(path), "--out", str(tmp_path / "run"), "--no-diagnose"]) == 1
    report = (tmp_path / "run" / "report.md").read_text()
    assert "## Which parameters might be missing" in report and "Adding kt lets the data fit" in report
    results = json.loads((tmp_path / "run" / "results.json").read_text())
    assert results["suggestion"]["trials"][0]["candidates"] == ["kt"]
    # opt out: no screening
    (tmp_path / "off.toml").write_text(path.read_text() + "suggest = false\n")
    assert main(["run", str(tmp_path / "off.toml"), "--out", str(tmp_path / "off"), "--no-diagnose"]) == 1
    assert json.loads((tmp_path / "off" / "results.json").read_text())["suggestion"] is None


def test_sets_left_untried_on_the_limits_are_named(tmp_path):
    """With room for 2 sets, the other candidates of size 1 are named as untried, in the record
    and in suggestion.md's sentence, not only counted."""
    from vibupdate.io.case import load_case
    from vibupdate.ranges.candidates import suggest_sets
    from vibupdate.io.records import SuggestionRecord
    from vibupdate.report.suggestion import suggestion_markdown

    case = load_case(_write(tmp_path, _truth_hz(tmp_path)))
    names = [p.name for p in case.candidates]
    found = suggest_sets(case.with_candidates(names).configurations, list(case.configurations[0].model.parameter_names),
                         names, max_size=1, checked=0, max_sets=2)
    assert len(found.trials) == 2 and found.untried == len(names) - 2
    assert found.untried_sets == tuple((n,) for n in names[2:])
    record = found.record()
    assert record["untried_sets"] == [[n] for n in names[2:]]
    assert f"left untried on the limits ({', '.join(names[2:])})" in suggestion_markdown(
        SuggestionRecord.from_dict(record), "c")


def test_suggest_bad_input_is_named(tmp_path, capsys):
    path = _write(tmp_path, [10.0, 60.0])
    assert main(["suggest", str(path), "--max-size", "0"]) == 2
    assert "--max-size must be an integer >= 1, got 0" in capsys.readouterr().err
    (tmp_path / "none.toml").write_text(_plain_head() + '[[configuration]]\nname = "A"\nnatural_hz = [10.0]\n')
    assert main(["suggest", str(tmp_path / "none.toml")]) == 2
    assert "declares no [[candidate]]" in capsys.readouterr().err
    case = load_case(path)
    with pytest.raises(ValueError, match="largest set size must be an integer >= 1, got 0"):
        suggest_sets(case.pool, ["E"], ["kt"], max_size=0)


@pytest.mark.slow
def test_free_free_bar_known_truth_suggests_the_rotary_inertia_factor_with_E(tmp_path, capsys):
    """The known-truth bar of `vibupdate.examples.bar`: a Timoshenko truth (shear and rotary inertia)
    modelled as an Euler-Bernoulli beam, one accelerometer, nine hammer points, 1 % noise.
    `extract` gives shapes at all nine points whose 95 % intervals hold the truth at a rate of
    0.90-1.00 over 10 seeds, and so do the modal masses of the mass-normalized shapes;
    `suggest` over six candidates ranks the rotary-inertia factor r with E first: frequencies
    and shape ratios see E and rho only through their ratio, the modal masses see rho (seed 0:
    E + r objective 1.9e-6, rho + r 1.9e-5, whose rho 2.4 % high puts the modal masses outside
    their intervals, within the 5 % model-form tolerance). The update with E and r is `success`
    with every natural frequency within 0.1 % and E within 0.5 % of its truth; no single
    candidate verifies. Figures over 20 seeds: benchmarks/suggest_bar.py, benchmarks/RESULTS.md."""
    from vibupdate.examples import bar
    from frf_synthetic import bar_true_shapes, write_uff
    from vibupdate.data.extraction import extract

    shapes, hz = bar_true_shapes()
    band = tuple(2 * math.pi * np.array(bar.BAND_HZ))
    hits, masses = [], []
    for seed in range(10):
        result = extract(bar.measured(seed).reciprocal(), band=band)
        assert len(result.modes) == 4
        for m, phi, nat in zip(result.modes, shapes, result.to_measured(mass_normalized=True)[0]):
            assert set(m.shape_interval) == {f"y{k}" for k in bar.HAMMER}
            sign = 1.0 if sum(m.shape[d] * phi[d] for d in m.shape) >= 0 else -1.0
            hits += [m.shape_interval[d][0] <= sign * phi[d] <= m.shape_interval[d][1] for d in phi]
            lo, hi = nat.shape.modal_mass_bounds()
            masses.append(lo <= 1 / phi[nat.shape.reference] ** 2 <= hi)
    assert 0.90 <= np.mean(hits) <= 1.00, np.mean(hits)
    assert 0.90 <= np.mean(masses) <= 1.00, np.mean(masses)   # measured: 0.95 of 40
    write_uff(tmp_path / "hammer.uff", bar.measured(0))
    (tmp_path / "case.toml").write_text(bar.case_text())
    assert main(["suggest", str(tmp_path / "case.toml"), "--out", str(tmp_path / "sg")]) == 0
    capsys.readouterr()
    record = json.loads((tmp_path / "sg" / "suggestion.json").read_text())
    first = record["trials"][0]
    assert first["candidates"] == ["E", "r"] and record["best"] == ["E", "r"]
    assert first["update"]["success"] and first["update"]["natural_max_pct"] < 0.1
    assert abs(first["update"]["values"]["E"] / bar.E_TRUE - 1) < 0.005, first["update"]["values"]
    assert all(not t["passed"] for t in record["trials"] if len(t["candidates"]) == 1)
