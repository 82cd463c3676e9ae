"""The further families of known-truth problems (`acceptance.families`): each draws what it
says, and, over a few seeds (slow), meets the criteria of `acceptance.criteria`."""

from __future__ import annotations

import numpy as np
import pytest

from acceptance import criteria as C
from acceptance import families as F
from acceptance import runner as R
from acceptance import structures as S
from acceptance import truth as T
from vibupdate.io.case import load_case

SEEDS = range(4)


def _truth(problem):
    return np.array([problem.truth[p.name] for p in problem.parameters])


@pytest.mark.parametrize("family", ["close_modes", "cross_receptance", "symmetric_ring", "hidden_mode",
                                    "mass_normalized",
                                    "many_dofs", "many_parameters"])
@pytest.mark.parametrize("seed", SEEDS)
def test_in_family_data_admit_the_truth(family, seed):
    problem = F.MAKERS[family](seed)
    assert problem.in_family
    assert not R.misses(problem, _truth(problem))[0]


@pytest.mark.parametrize("family", ["biased_channel", "frequency_shift", "misnumbered_zero"])
@pytest.mark.parametrize("seed", SEEDS)
def test_measurement_errors_exclude_the_truth(family, seed):
    problem = F.MAKERS[family](seed)
    assert not problem.in_family
    assert R.misses(problem, _truth(problem))[0], "the error left the truth admissible"


@pytest.mark.parametrize("family", ["coarse_mesh", "root_spring", "sensor_masses", "shear_building"])
@pytest.mark.parametrize("seed", SEEDS)
def test_model_form_data_come_from_another_model(family, seed):
    """The data are not the updated model's at the truth: some natural frequency differs by more
    than rounding."""
    problem = F.MAKERS[family](seed)
    assert not problem.in_family
    M, K, _ = S.matrices_at(problem.structure, problem.truth)
    w = T.modes(M, K)[0] / (2 * np.pi)
    measured = [(n.hz, w[n.mode - 1]) for n in problem.data[0].natural]
    if problem.noise == 0:
        assert max(abs(a - b) / a for a, b in measured) > 1e-6
    assert any(abs(a - b) / a > 1e-6 for a, b in measured)


def test_close_modes_reach_a_tenth_of_a_percent():
    spacings = []
    for seed in range(12):
        problem = F.close_modes(seed)
        hz = np.array([n.hz for n in problem.data[0].natural])
        spacings.append(np.min(np.diff(hz) / hz[1:]))
    assert min(spacings) < 0.001 and max(spacings) < 0.05


def test_cross_receptances_are_cross():
    for seed in SEEDS:
        zeros = F.cross_receptance(seed).data[0].zeros
        assert zeros and all(z.response != z.excitation for z in zeros)


def test_symmetric_rings_leave_zero_indices_to_the_default_with_zeros_on_nominal_poles():
    """The ring's data state no zero index, and over a few seeds the nominal model has a zero of
    the cross receptance on a pole (what the family is for): the default must count it."""
    on_pole = 0
    for seed in range(6):
        problem = F.symmetric_ring(seed)
        data = problem.data[0]
        assert any(z.response != z.excitation for z in data.zeros)
        if data.declare:   # zeros left or joined the real axis: stated
            continue
        M, K, dofs = S.matrices_at(problem.structure, {p.name: p.nominal for p in problem.parameters})
        w = T.modes(M, K)[0]
        c = next(z.excitation for z in data.zeros if z.response != z.excitation)
        z = T.zeros(M, K, dofs.index("y1"), dofs.index(c))[0]
        on_pole += int(any(np.min(np.abs(w - x)) <= 1e-6 * x for x in z))
    assert on_pole >= 3, on_pole


def test_hidden_modes_are_hidden_at_the_exciter_and_leave_zero_indices_to_the_default():
    """The measured modes skip one (declared), whose modal constant at the exciter is under 1 %
    of the largest there among the measured modes; zero indices are stated only where the note
    says why (in at most 2 of the first 6 seeds), and no measured zero of either FRF lies within
    0.5 % of the hidden pole."""
    stated = 0
    for seed in range(6):
        problem = F.hidden_mode(seed)
        data = problem.data[0]
        declared = [n.mode for n in data.natural]
        assert data.declare in ("modes", True) and np.any(np.diff(declared) == 2), declared
        hidden = next(m for m, n in zip(declared, declared[1:]) if n == m + 2) + 1
        M, K, dofs = S.matrices_at(problem.structure, problem.truth)
        w, Phi = T.modes(M, K)
        exciter = data.zeros[0].excitation
        constants = Phi[dofs.index(exciter), np.array(declared + [hidden]) - 1] ** 2
        assert constants[-1] <= 0.01 * constants.max()
        assert all(abs(2 * np.pi * z.hz / w[hidden - 1] - 1) > 0.005 for z in data.zeros)
        assert (data.declare is True) == ("indices stated" in problem.note)
        stated += data.declare is True
    assert stated <= 2


def test_the_size_families_span_what_they_say():
    """50-5,000 DOFs (both ends reached over 40 seeds; sizes from the maker's own first draw),
    springs in contiguous zones from the ground, and 20-40 parameters; above
    `structures.DENSE_MAX` DOFs the judge's matrices are sparse."""
    import scipy.sparse as sp

    sizes = [F._chain_size(F._rng("many_dofs", seed)) for seed in range(40)]
    assert 50 <= min(sizes) < 80 and 3000 < max(sizes) <= 5000
    for seed in (0, 8):
        problem = F.many_dofs(seed)
        assert len(problem.structure.measurable) == sizes[seed]
        zones = [v.names[0] for f, _, v, _ in problem.structure.lumped if f == "spring"]
        assert zones == sorted(zones, key=lambda z: int(z[1:])), "zones not contiguous from the ground"
        assert {p.name for p in problem.parameters} == set(zones) | {"m1"}
    spec, params = F._zoned_chain(np.random.default_rng(0), max(sizes), 3)
    assert sp.issparse(S.matrices_at(spec, {p.name: p.nominal for p in params})[0])
    counts = [len(F.many_parameters(seed).parameters) for seed in range(12)]
    assert min(counts) >= 20 and max(counts) <= 40 and len(set(counts)) > 3


def test_the_biased_sensor_is_a_diagnosis_group_of_the_data():
    problem = F.biased_channel(0)
    cfg, kind, dof = problem.expected_first.split("/")
    assert kind == "dof" and cfg == problem.data[0].name
    assert all(dof in n.shape for n in problem.data[0].natural if n.shape)


def test_a_mass_normalized_shape_is_judged_without_a_free_scaling():
    """Its entries scaled by 2 are the same shape to a ratio check, not to a mass-normalized one."""
    problem = F.mass_normalized(1)
    assert problem.mass_normalized and not R.misses(problem, _truth(problem))[0]
    from dataclasses import replace

    doubled = replace(problem, data=tuple(replace(c, natural=tuple(
        replace(n, shape={d: (2 * lo, 2 * hi) for d, (lo, hi) in n.shape.items()}) for n in c.natural))
        for c in problem.data))
    assert R.misses(doubled, _truth(doubled))[0]
    assert not R.misses(replace(doubled, mass_normalized=False), _truth(doubled))[0]


def test_a_family_measures_no_more_modes_than_its_model_has():
    """Seed 48 of `mass_normalized` draws a 3-mass chain and 4 modes to measure: it measures
    the chain's 3 (it failed to draw, an IndexError, before); `measure` refuses a mode the
    model lacks by name."""
    from acceptance.measure import measure

    problem = F.mass_normalized(48)
    assert len(problem.structure.measurable) == 3
    assert [n.mode for n in problem.data[0].natural] == [1, 2, 3]
    assert not R.misses(problem, _truth(problem))[0]
    with pytest.raises(ValueError, match="model mode 4 asked for, but the model has 3 modes"):
        measure(problem.structure, problem.parameters, problem.truth, kind="P2", rng=np.random.default_rng(0),
                n_modes=4)


@pytest.mark.parametrize("family", [f for f in (*C.NEW_FAMILIES, "shear_building") if f != "frf_test"])
def test_case_file_and_python_objects_are_the_same_problem(tmp_path, family):
    problem = F.MAKERS[family](1)
    case = load_case(problem.write_case(tmp_path))
    python = problem.configurations()
    x = problem.xbar_true
    for a, b in zip(case.configurations, python):
        for A, B in zip(a.model.matrices(x), b.model.matrices(x)):
            assert abs(A - B).max() <= 1e-9 * abs(B).max()
        assert [n.omega for n in a.natural] == pytest.approx([n.omega for n in b.natural], rel=1e-14)
        assert [z.index for z in a.antiresonances] == [z.index for z in b.antiresonances]
        assert [n.shape for n in a.natural] == [n.shape for n in b.natural]
        assert [n.damping_ratio for n in a.natural] == [n.damping_ratio for n in b.natural]


def test_the_frf_familys_files_hold_its_true_modes(tmp_path):
    """`frf_test` gives FRF files instead of data (its Python objects are the judge's true modes):
    the case file's extraction finds each true mode of a well-resolved problem within 0.1 %."""
    problem = F.frf_test(0)
    case = load_case(problem.write_case(tmp_path))
    found = [n.freq_hz for n in case.configurations[0].natural]
    true = [n.hz for n in problem.data[0].natural]
    assert len(found) == len(true)
    assert found == pytest.approx(true, rel=1e-3)
    assert case.configurations[0].antiresonances   # the FRFs' zeros too


@pytest.mark.parametrize("csv", [False, True])
def test_damping_ratios_and_exponents_reach_the_case_file_either_way(tmp_path, csv):
    """The damping family writes its ratios typed in the case file or in its frequency table,
    and the true series' exponents as the ``[damping]`` table."""
    problem = next(p for p in map(F.caughey_damping, range(50)) if p.csv == csv)
    case = load_case(problem.write_case(tmp_path))
    ratios = [n.damping for c in problem.data for n in c.natural]
    assert [n.damping_ratio for c in case.configurations for n in c.natural] == ratios
    assert all(r is not None for r in ratios)
    assert tuple(case.damping.exponents) == problem.damping[0]


def test_every_family_states_what_a_right_answer_is():
    for family in C.FAMILIES.values():
        assert "right answer" in family.meaning, family.name


# -- each family over a few seeds, judged by its criteria (slow) -----------------------------------

#: Seeds of each family in the slow step (`SLOW_SEEDS_OF` where a family differs). Seeds 0-5
#: of `many_dofs` hold 52, 90, 105, 891, 1,640 and 2,129 DOFs (the sparse path and the reduced
#: rounds twice above 1,000 DOFs); one `shear_building` problem, its runs the longest. Of
#: `many_parameters`, six of its ``dev`` seeds 0-14 drawing each class (chain or zoned beam,
#: exact or noisy data): 0 a beam with noisy data (23 parameters), 1, 4 and 10 chains with exact
#: data (23, 35, 21), 8 a chain with noisy data (24), 14 a beam with exact data (20; seeds 0-5
#: drew none). Measured on 2026-12-06 (both routes and the judge, CPU seconds, each verified on
#: both routes): 128 s for these six against 260 s for seeds 0-5 (2 and 5 were 48 and 43 s, 3
#: 86 s); the step's longest test before (benchmarks/RESULTS.md, "The slow step and the
#: held-out size families").
SLOW_SEEDS = range(6)
SLOW_SEEDS_OF = {"shear_building": range(1), "many_parameters": (0, 1, 4, 8, 10, 14)}
#: The families of the slow step.
SLOW_FAMILIES = (*C.NEW_FAMILIES, "shear_building")
#: Criteria today's code fails, with the measured reason: (family, "defects" or "budgets") -> reason.
#: Family defects known and measured, each a strict xfail: none since the admissible-data contract
#: (the two listed before, mass-normalized entries outside their intervals and an unmodelled
#: sensor mass answered worse than nominal, pass on every slow seed: benchmarks/RESULTS.md, "One
#: admissible-data contract on main").
KNOWN_FAILURES: dict = {}
_RUNS: dict = {}


def test_the_slow_seeds_of_many_parameters_draw_every_class_of_its_dev_seeds():
    """The slow step's `many_parameters` seeds (chosen for their cost) draw every (structure,
    exact or noisy data) class that its ``dev`` seeds draw."""
    def classes(seeds):
        return {(c["structure"], c["data"]) for c in (F.many_parameters(s).classes() for s in seeds)}

    assert classes(C.PROFILES["dev"]["many_parameters"]) <= classes(SLOW_SEEDS_OF["many_parameters"])


def _runs(family, folder):
    if family not in _RUNS:
        _RUNS[family] = [v for s in SLOW_SEEDS_OF.get(family, SLOW_SEEDS)
                         for v in R.run_problem(C.FAMILIES[family].make(s), workdir=folder)]
    return _RUNS[family]


def _cases(which):
    return [pytest.param(f, marks=pytest.mark.xfail(strict=True, reason=KNOWN_FAILURES[(f, which)]))
            if (f, which) in KNOWN_FAILURES else f for f in SLOW_FAMILIES]


def _failed(family, folder, defects: bool):
    verdicts = _runs(family, folder)
    findings = [f for f in C.check(verdicts, C.FAMILIES) if f.criterion.startswith("defect") == defects]
    print("\n" + C.summary(verdicts) + "\n" + "\n".join(f.line() for f in findings))
    return [f.line() for f in findings if not f.ok]


@pytest.mark.slow
@pytest.mark.parametrize("family", _cases("defects"))
def test_each_family_has_no_defect(family, tmp_path_factory):
    bad = _failed(family, tmp_path_factory.mktemp(family), defects=True)
    assert not bad, "\n".join(bad)


@pytest.mark.slow
@pytest.mark.parametrize("family", _cases("budgets"))
def test_each_family_keeps_its_budgets(family, tmp_path_factory):
    bad = _failed(family, tmp_path_factory.mktemp(family), defects=False)
    assert not bad, "\n".join(bad)
