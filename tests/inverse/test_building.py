"""The building example: a frame that grows by storeys and bays (benchmarks/large_structure.py)."""

import numpy as np
import pytest

import building


def test_dof_count_and_sizes():
    m = building.model(4, 1)
    assert m.n_dofs == building.n_dofs(4, 1) == 180
    assert len(m.parameters) == 3 * building.GROUPS


def test_every_group_has_storeys():
    for storeys in (4, 7, 14, 43):
        groups = building._groups(storeys)
        assert sorted(set(groups.tolist())) == list(range(building.GROUPS))
        assert np.all(np.diff(groups) >= 0)


@pytest.mark.parametrize("storeys, bays, word", [(3, 1, "storeys"), (5, 0, "bay")])
def test_rejects_too_small(storeys, bays, word):
    with pytest.raises(ValueError, match=word):
        building.build(building.truth(), storeys, bays)


def test_floor_mass_is_carried_by_its_floors_beams():
    """Known truth: at 4 storeys each group is one floor, so 1 kg/m more ``q1`` adds the mass of
    the first floor's beams (``bays * BAY`` m) to a rigid vertical translation of every node,
    and nothing to the other floors."""
    bays = 2
    m = building.model(4, bays)
    truth = building.truth()
    y = np.array([d.startswith("y") for d in m.dofs], dtype=float)

    def vertical_mass(values):
        M, _ = m.matrices_at([values[p.name] for p in m.parameters])
        return y @ (M @ y)

    added = vertical_mass(truth | {"q1": truth["q1"] + 1.0}) - vertical_mass(truth)
    assert added == pytest.approx(bays * building.BAY, rel=1e-9)


def test_exact_data_determine_every_parameter():
    """The exact sensitivity of the benchmark's smallest size (7 x 1, 315 DOFs) at the truth:
    full rank over the 12 parameters and a moderate condition (measured 1.3e3)."""
    from vibupdate.inverse.data_map import sensitivity

    configurations = building.configurations(7, 1)
    m = configurations[0].model
    truth = np.array([building.truth()[p.name] for p in m.parameters])
    found = sensitivity(configurations, m.normalized(truth))
    assert found.rank == len(truth) == 12
    assert found.condition < 1e4
    # a frequency and the ratios of all but the reference entry, per mode
    assert found.matrix.shape == (building.N_MODES * len(building.measured_dofs(7, 1)), 12)


def test_polish_by_reduced_rounds_reaches_the_truth_with_fewer_full_evaluations():
    """546 DOFs (sparse path): the reduced rounds of the polish end where the full-model polish
    ends, the truth, with fewer eigen-solves of the full model (measured, one BLAS thread: 4
    full evaluations and 46 reduced against 35 full)."""
    from vibupdate.inverse.polish import PolishOptions, polish

    configurations = building.configurations(7, 2)
    m = configurations[0].model
    assert m.n_dofs == 546
    truth = m.normalized(np.array([building.truth()[p.name] for p in m.parameters]))
    x0 = np.clip(truth + 0.05 * np.cos(np.arange(truth.size)), *m.bounds())
    rounds = polish(configurations, x0, PolishOptions())
    full = polish(configurations, x0, PolishOptions(reduced_rounds=0))
    assert rounds.rounds >= 1 and rounds.reduced_evaluations > 0 and full.rounds == 0
    assert rounds.evaluations < full.evaluations
    for result in (rounds, full):
        assert result.kept and result.cost < 1e-15 * result.cost_start
        assert np.abs(m.physical(result.xbar) / m.physical(truth) - 1).max() < 1e-8


@pytest.mark.slow
@pytest.mark.parametrize("seed", [0, 5])
def test_polish_rounds_on_noisy_data_end_no_higher_than_the_full_model_polish(seed):
    """Noisy data (frequencies 0.1 %, shape entries 2 % with +-1 % intervals: a nonzero
    optimum with active interval penalties) from a start 10 % off: the reduced rounds end at
    an objective no higher than the full-model polish's (measured on seeds 0-5: equal within
    1.2e-12, or lower where the full-model polish used its 50 evaluations, seed 5: 41.35
    against 49.71), in at most 6 full evaluations against 37-50 (5 with SuperLU's partial
    pivoting; with pivots kept near the diagonal, `vibupdate.modal.factor.sparse_lu`, seed 5
    takes a sixth round to the same objective)."""
    from dataclasses import replace

    from vibupdate.data.measured import ShapeInterval
    from vibupdate.inverse.polish import PolishOptions, polish

    cfg = building.configurations(7, 2)[0]
    m = cfg.model
    rng = np.random.default_rng(seed)
    natural = []
    for f in cfg.natural:
        omega = f.omega * (1 + 0.001 * rng.standard_normal())
        mid = {d: 0.5 * (lo + hi) * (1 + 0.02 * rng.standard_normal()) for d, (lo, hi) in f.shape.bounds.items()}
        shape = ShapeInterval({d: (v - 0.01 * abs(v) - 1e-3, v + 0.01 * abs(v) + 1e-3) for d, v in mid.items()})
        natural.append(replace(f, omega=omega, shape=shape))
    configurations = [replace(cfg, natural=tuple(natural))]
    truth = m.normalized(np.array([building.truth()[p.name] for p in m.parameters]))
    x0 = np.clip(truth + 0.1 * rng.standard_normal(truth.size), *m.bounds())
    rounds = polish(configurations, x0, PolishOptions())
    full = polish(configurations, x0, PolishOptions(reduced_rounds=0))
    assert rounds.rounds >= 1 and rounds.kept and full.kept
    assert rounds.cost <= full.cost * (1 + 1e-9)
    assert rounds.evaluations <= 6 < full.evaluations


def test_polish_falls_back_to_the_full_model_when_a_round_fails(monkeypatch):
    """A reduced round that raises (here a forced failure of the projection) costs the rounds,
    not the polish: it says so and polishes on the full model."""
    from vibupdate.inverse import reduction
    from vibupdate.inverse.polish import polish

    def broken(*args, **kwargs):
        raise np.linalg.LinAlgError("forced")

    monkeypatch.setattr(reduction, "ritz_reduction", broken)
    configurations = building.configurations(7, 2)
    m = configurations[0].model
    truth = m.normalized(np.array([building.truth()[p.name] for p in m.parameters]))
    said = []
    result = polish(configurations, np.clip(truth + 0.02, *m.bounds()), progress=said.append)
    assert result.kept and result.rounds == 0 and result.evaluations > 1
    assert any("the reduced rounds failed (forced)" in s for s in said)
    assert np.abs(m.physical(result.xbar) / m.physical(truth) - 1).max() < 1e-8
