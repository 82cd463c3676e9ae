"""The measured-data map: exact Jacobian, one order of the data for every reader."""

import numpy as np
import pytest

from vibupdate.data.measured import Antiresonance, Configuration, NaturalFrequency, ShapeInterval
from vibupdate.examples import cantilever
from vibupdate.inverse.data_map import data_jacobian, data_map, measured_shapes, sensitivity
from vibupdate.inverse.baseline import classical_residuals
from vibupdate.modal.analysis import antiresonances, modes


@pytest.fixture(scope="module")
def mixed():
    """Cantilever A's model with shape intervals and the zeros of two receptances, declared
    interleaved (the map keeps the declared order)."""
    model = cantilever.configurations()[0].model
    x_true = np.linspace(-0.3, 0.3, model.n_parameters)
    M, K = model.matrices(x_true)
    omega, Phi = modes(M, K, 3)
    ydofs = [d for d in model.dofs if d.startswith("y")]
    idx = [model.dof(d) for d in ydofs]
    natural = tuple(NaturalFrequency(omega[k], mode=k + 1, shape=ShapeInterval.from_values(
        dict(zip(ydofs, Phi[idx, k] / np.abs(Phi[idx, k]).max())), 0.02)) for k in range(3))
    pairs = ((ydofs[0], ydofs[-1]), (ydofs[-1], ydofs[-1]))
    z = {rc: antiresonances(M, K, model.dof(rc[0]), model.dof(rc[1])) for rc in pairs}
    zeros = tuple(Antiresonance(float(z[rc][j]) * 1.001, *rc, index=j + 1) for j in range(2) for rc in pairs)
    return Configuration("mixed", model, natural, zeros), x_true


def test_the_jacobian_is_the_derivative_of_the_map(mixed):
    cfg, x = mixed
    d, G = data_jacobian([cfg], x)
    h = 1e-6
    fd = np.column_stack([(data_jacobian([cfg], x + h * e)[0] - data_jacobian([cfg], x - h * e)[0]) / (2 * h)
                          for e in np.eye(x.size)])
    scale = np.maximum(np.abs(d), 1.0)[:, None]
    np.testing.assert_allclose(G / scale, fd / scale, atol=1e-6)
    n_ratios = sum(s.entries.size for s in measured_shapes(cfg))
    assert d.size == len(cfg.natural) + len(cfg.antiresonances) + n_ratios


def test_the_polish_and_the_sensitivity_read_the_map_in_its_order(mixed):
    cfg, x = mixed
    m = data_map(cfg, x)
    measured = np.array([f.omega for f in (*cfg.natural, *cfg.antiresonances)])
    shapes = [s.midpoint for s in measured_shapes(cfg)]
    r, J = classical_residuals([cfg], x, 1.0)
    np.testing.assert_array_equal(r, np.concatenate([(m.frequency_values - measured) / measured, *
                                                     [q - mid for q, mid in zip(m.ratios, shapes)]]))
    np.testing.assert_array_equal(J, m.jacobian() / np.concatenate([measured, np.ones(r.size - measured.size)])[:, None])
    S = sensitivity([cfg], x).matrix
    np.testing.assert_array_equal(S, np.vstack([m.frequency_jacobian / m.frequency_values[:, None],
                                                *m.ratio_jacobians]))


def test_without_a_jacobian_the_values_are_the_same(mixed):
    cfg, x = mixed
    with_jacobian, without = data_map(cfg, x), data_map(cfg, x, jacobian=False)
    assert without.natural_jacobian is None and without.ratio_jacobians == ()
    np.testing.assert_allclose(without.values(), with_jacobian.values(), rtol=1e-10)


def _both_ways(cfg):
    """``cfg`` with its first zero's receptance measured both ways (``h_rc`` and ``h_cr``), and
    ``(r, c)``."""
    r, c = cfg.antiresonances[0].receptance
    mirror = Antiresonance(cfg.antiresonances[0].omega, c, r, index=1)
    return Configuration("both", cfg.model, cfg.natural, cfg.antiresonances[:1] + (mirror,)), (r, c)


def test_a_reciprocal_pair_is_solved_once_with_the_zeros_and_derivatives_of_each_alone(mixed, monkeypatch):
    """h_rc and h_cr of a symmetric model have the same zeros: `declared_zeros` solves the
    adjunct pencil once for both (left and right vectors swapped) and gives what solving each
    alone gives, to the rounding of the nonsymmetric solver."""
    from vibupdate.inverse import correlation
    from vibupdate.modal import sensitivities

    cfg, x = mixed
    both, (r, c) = _both_ways(cfg)
    calls = []
    solve = sensitivities.adjunct_eigenpairs
    monkeypatch.setattr(sensitivities, "adjunct_eigenpairs", lambda *a, **k: calls.append(a[2:4]) or solve(*a, **k))
    M, K = cfg.model.matrices(x)
    values, D, zeros_all, _ = correlation.declared_zeros(both, x, M, K)
    assert len(calls) == 1
    assert values[0] == values[1] and np.array_equal(D[0], D[1])
    for rc in ((r, c), (c, r)):
        alone = sensitivities.antiresonance_derivatives(cfg.model, x, cfg.model.dof(rc[0]), cfg.model.dof(rc[1]),
                                                        pairs=solve(M, K, cfg.model.dof(rc[0]), cfg.model.dof(rc[1])))
        np.testing.assert_allclose(zeros_all[rc], alone[0], rtol=1e-9)
        np.testing.assert_allclose(D[0], alone[1][0], rtol=1e-7, atol=1e-9 * np.abs(alone[1][0]).max())


def test_the_zeros_of_a_reciprocal_pair_without_derivatives_are_solved_once(mixed, monkeypatch):
    from vibupdate.inverse import correlation

    cfg, x = mixed
    both, (r, c) = _both_ways(cfg)
    calls = []
    solve = correlation.antiresonances
    monkeypatch.setattr(correlation, "antiresonances", lambda *a, **k: calls.append(a[2:4]) or solve(*a, **k))
    f = correlation.model_frequencies(both, x)
    assert len(calls) == 1 and np.array_equal(f.zeros_all[(r, c)], f.zeros_all[(c, r)])
    M, K = cfg.model.matrices(x)
    np.testing.assert_allclose(f.zeros_all[(c, r)], solve(M, K, cfg.model.dof(c), cfg.model.dof(r)), rtol=1e-9)


@pytest.fixture(scope="module")
def weighed():
    """Cantilever A's model with mass-normalized shapes (modal constants of calibrated FRFs):
    mode 1 at every deflection, mode 2 at the driving point only (a modal mass, no ratio)."""
    model = cantilever.configurations()[0].model
    x_true = np.linspace(-0.3, 0.3, model.n_parameters)
    M, K = model.matrices(x_true)
    omega, Phi = modes(M, K, 3)
    ydofs = [d for d in model.dofs if d.startswith("y")]
    tip = model.dof(ydofs[-1])
    first = ShapeInterval.from_values({d: Phi[model.dof(d), 0] * 1.01 for d in ydofs}, 1e-3 * abs(Phi[tip, 0]))
    second = ShapeInterval.from_values({ydofs[-1]: Phi[tip, 1]}, 1e-3 * abs(Phi[tip, 1]))
    natural = (NaturalFrequency(omega[0], mode=1, shape=ShapeInterval(first.bounds, mass_normalized=True)),
               NaturalFrequency(omega[1], mode=2, shape=ShapeInterval(second.bounds, mass_normalized=True)),
               NaturalFrequency(omega[2], mode=3))
    return Configuration("weighed", model, natural), x_true, M, Phi


def test_a_mass_normalized_shape_adds_its_modal_mass_with_its_exact_derivative(weighed):
    cfg, x, M, Phi = weighed
    m = data_map(cfg, x)
    ydofs = [d for d in cfg.model.dofs if d.startswith("y")]
    p = [cfg.model.dof(f.shape.reference) for f in cfg.natural[:2]]
    # 1 / phi_p^2 of the mass-normalized mode, phi_p its largest measured entry; q^T M q of phi / phi_p
    q = Phi[:, :2] / Phi[p, [0, 1]]
    np.testing.assert_allclose(m.masses, 1 / Phi[p, [0, 1]] ** 2, rtol=1e-12)
    np.testing.assert_allclose(m.masses, np.einsum("ik,ij,jk->k", q, M.toarray(), q), rtol=1e-10)
    d, G = data_jacobian([cfg], x)
    assert d.size == 3 + (len(ydofs) - 1) + 2 and np.array_equal(d[-2:], m.masses)
    h = 1e-6
    fd = np.column_stack([(data_jacobian([cfg], x + h * e)[0] - data_jacobian([cfg], x - h * e)[0]) / (2 * h)
                          for e in np.eye(x.size)])
    scale = np.maximum(np.abs(d), 1.0)[:, None]
    np.testing.assert_allclose(G / scale, fd / scale, atol=1e-6)
    assert np.abs(G[-2:]).max() > 1e-3   # the masses move with the parameters: not a vacuous check


def test_a_modal_mass_is_held_to_its_interval_in_relative_units(weighed):
    from vibupdate import VerifyOptions
    from vibupdate.inverse.admissible import Admissible, misses

    cfg, x, _, _ = weighed
    m = data_map(cfg, x)
    lower, upper = np.array([s.mass for s in measured_shapes(cfg)]).T
    mid = 0.5 * (lower + upper)
    r, J = classical_residuals([cfg], x, 2.0)
    np.testing.assert_allclose(r[-2:], 2.0 * (m.masses - mid) / mid, rtol=1e-12)
    found = [f for f in misses(Admissible.of([cfg], VerifyOptions(modal_mass_tolerance=0.0)), [m])
             if f.kind == "modal_mass"]
    assert found[0].miss > 0 and found[1].miss == 0   # mode 1 was scaled by 1.01: its modal mass is 2 % low, outside
    S = sensitivity([cfg], x).matrix
    np.testing.assert_allclose(S[-2:], m.mass_jacobian / m.masses[:, None], rtol=1e-12)


def test_a_mass_normalized_shape_whose_largest_entry_may_be_zero_is_refused():
    with pytest.raises(ValueError, match="holds zero: its modal mass is not measured"):
        ShapeInterval({"y1": (-0.1, 0.3), "y2": (0.0, 0.1)}, mass_normalized=True)
    with pytest.raises(ValueError, match="mass_normalized must be true or false"):
        ShapeInterval({"y1": (0.1, 0.3)}, mass_normalized="yes")
    assert ShapeInterval({"y1": (-0.5, -0.4)}, mass_normalized=True).modal_mass_bounds() == pytest.approx((1 / 0.5**2, 1 / 0.4**2), rel=1e-15)


def _on_the_sparse_path(cfg, monkeypatch):
    """``cfg`` with a copy of its model whose parameter stacks are over the cap: the sparse
    path of every product and solve."""
    import dataclasses

    from vibupdate.model import affine

    monkeypatch.setattr(affine, "DENSE_STACK_BYTES", 0)
    model = dataclasses.replace(cfg.model)
    assert model.dense_stacks is None
    return dataclasses.replace(cfg, model=model)


@pytest.mark.parametrize("which", ["mixed", "weighed"])
def test_the_dense_stacks_give_the_sparse_paths_map_to_rounding(which, request, monkeypatch):
    cfg, x = request.getfixturevalue(which)[:2]
    dense = data_map(cfg, x, vectors=True)
    sparse = data_map(_on_the_sparse_path(cfg, monkeypatch), x, vectors=True)
    for got, exact in ((dense.values(), sparse.values()), (dense.jacobian(), sparse.jacobian())):
        scale = np.maximum(np.abs(exact), 1.0)
        assert np.max(np.abs(got - exact) / scale) <= 1e-9
    assert len(dense.vectors) == len(sparse.vectors)


def test_an_evaluation_within_the_dense_limit_builds_no_sparse_matrix(mixed, weighed, monkeypatch):
    import dataclasses

    from vibupdate.model.affine import AffineModel

    def refused(*args):
        raise AssertionError("a sparse M(xbar) or K(xbar) was assembled on the dense path")

    monkeypatch.setattr(AffineModel, "_combine", staticmethod(refused))
    for cfg, x in (mixed, weighed[:2]):
        cfg = dataclasses.replace(cfg, model=dataclasses.replace(cfg.model))
        for jacobian in (True, False):
            assert np.all(np.isfinite(data_map(cfg, x, jacobian=jacobian).values()))


def _noisy_chain():
    """A 3-mass chain's three modes, frequencies 0.2 % off in turn and shapes measured at every
    DOF 0-2 % off within 1 % intervals: its model and the measured natural frequencies."""
    from helpers import chain_model

    model = chain_model(3, ["k1", "k2", "k3"])
    x = model.normalized([1000.0, 800.0, 1200.0])
    omega, Phi = modes(*model.matrices(x), 3)
    dofs = ("y1", "y2", "y3")
    idx = [model.dof(d) for d in dofs]
    return model, tuple(NaturalFrequency(omega[k] * (1 + 0.002 * (-1) ** k), shape=ShapeInterval.from_values(
        dict(zip(dofs, Phi[idx, k] * (1 + 0.01 * np.arange(3)))), 0.01)) for k in range(3))


def test_an_update_builds_each_measurement_map_once_per_configuration(monkeypatch):
    """The measured shapes' measurement maps and ratio intervals depend on the data alone: an
    update (polish, uniqueness probes, verification) builds them once per configuration, not
    at every evaluation (thousands of sparse builds before)."""
    import vibupdate.model.measurement as measurement
    from vibupdate import update

    model, natural = _noisy_chain()
    cfg = Configuration("c", model, natural)
    built, real = [], measurement.measurement_rows
    monkeypatch.setattr(measurement, "measurement_rows", lambda *a: built.append(tuple(a[2])) or real(*a))
    update([cfg])
    maps = [(f.shape.reference,) for f in natural] + [tuple(f.shape.ratio_bounds()) for f in natural]
    assert all(built.count(names) == 1 for names in maps), built
    assert len(measured_shapes(cfg)) == 3 and all(built.count(names) == 1 for names in maps)


def test_the_modes_at_a_point_are_solved_once_whatever_is_asked_of_them(mixed, monkeypatch):
    """`model_frequencies` of one configuration at one point (with or without its zeros or their
    derivatives, as the polish, the verification and the sensitivity ask) solves the modes once;
    another point solves them again; the kept arrays are read-only."""
    from vibupdate.inverse import correlation

    cfg, x = mixed
    calls = []
    solve = correlation.modes
    monkeypatch.setattr(correlation, "modes", lambda *a, **k: calls.append(1) or solve(*a, **k))
    first = correlation.model_frequencies(cfg, x, zeros=False)
    again = correlation.model_frequencies(cfg, x.copy(), derivatives=True)
    assert len(calls) == 1
    np.testing.assert_array_equal(first.natural, again.natural)
    assert not again.spectrum[1].flags.writeable
    correlation.model_frequencies(cfg, x + 1e-3)
    assert len(calls) == 2


def test_configurations_of_one_model_share_the_solve_of_its_modes(mixed, monkeypatch):
    """The spectrum is the model's: a configuration of the same model object with other data
    (as the diagnosis's data without one group, `vibupdate.inverse.diagnosis.without`) reads
    the modes solved for the first at the same point; a configuration of another model object
    solves its own."""
    from dataclasses import replace

    from vibupdate.inverse import correlation

    cfg, x = mixed
    x = x + 2e-3   # a point no other test of the module solves
    calls = []
    solve = correlation.modes
    monkeypatch.setattr(correlation, "modes", lambda *a, **k: calls.append(1) or solve(*a, **k))
    full = correlation.model_frequencies(cfg, x)
    fewer = replace(cfg, natural=cfg.natural[1:], antiresonances=())
    part = correlation.model_frequencies(fewer, x, derivatives=True)
    assert len(calls) == 1
    np.testing.assert_array_equal(part.natural, full.natural[1:])
    correlation.model_frequencies(replace(cfg, model=replace(cfg.model)), x)
    assert len(calls) == 2


def test_an_update_solves_the_modes_at_each_point_once(monkeypatch):
    """Across an update (polish, uniqueness probes, minimum change, verification, sensitivity)
    no point's modes are solved twice (the polished answer was solved again for its
    verification before)."""
    from collections import Counter

    from vibupdate import update
    from vibupdate.inverse import correlation

    model, natural = _noisy_chain()
    solved, solve = Counter(), correlation.modes
    monkeypatch.setattr(correlation, "modes",
                        lambda M, K, **k: solved.update([np.asarray(K).tobytes()]) or solve(M, K, **k))
    update([Configuration("c", model, natural)])
    assert len(solved) > 10 and max(solved.values()) == 1, sorted(solved.values())[-3:]
