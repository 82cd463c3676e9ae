"""Minimum change along undetermined directions: where the data leave parameter combinations
free, the answer is the point nearest the nominal model with exactly the same data."""

import numpy as np
import pytest

from vibupdate import Configuration, NaturalFrequency, Parameter, ShapeInterval, from_builder, modes, update
from vibupdate.inverse.correlation import model_frequencies
from vibupdate.inverse.data_map import sensitivity
from vibupdate.inverse.minimum_change import DATA_TOL, minimum_change

N_STOREYS = 8


def shear_building(p):
    """Shear building: floor masses 1e4 kg, storey stiffnesses ``k_i`` x 1e7 N/m."""
    n = N_STOREYS
    dtype = complex if any(isinstance(v, complex) for v in p.values()) else float
    K = np.zeros((n, n), dtype=dtype)
    for i in range(n):
        k = p[f"k{i + 1}"] * 1e7
        K[i, i] += k
        if i > 0:
            K[i - 1, i - 1] += k
            K[i - 1, i] -= k
            K[i, i - 1] -= k
    return np.eye(n) * 1e4, K, [f"x{i + 1}" for i in range(n)]


def building_case(n_freq: int, seed: int = 0, shapes: bool = False):
    rng = np.random.default_rng(seed)
    params = [Parameter(f"k{i + 1}", 1.0, 0.3, 2.0) for i in range(N_STOREYS)]
    model = from_builder(shear_building, params)
    x_true = model.normalized(rng.uniform(0.75, 1.25, N_STOREYS))
    omega, Phi = modes(*model.matrices(x_true), n_freq)
    natural = []
    for k in range(n_freq):
        shape = None
        if shapes:   # two measured floors, exact
            shape = ShapeInterval({d: (Phi[model.dof(d), k],) * 2 for d in ("x4", "x8")})
        natural.append(NaturalFrequency(float(omega[k]), shape=shape))
    return [Configuration("A", model, tuple(natural))], x_true


def _data(cfgs, x):
    f = model_frequencies(cfgs[0], x)
    return f.natural


def test_minimum_change_is_nearest_the_nominal_point_with_the_same_data():
    cfgs, x_true = building_case(3)
    # a fitted point far along the undetermined directions: the truth itself
    out = minimum_change(cfgs, x_true)
    assert out.applied and out.kept, out.message
    assert out.rank == 3
    assert out.norm < out.norm_start
    np.testing.assert_allclose(_data(cfgs, out.xbar), _data(cfgs, x_true), rtol=1e-10)
    assert out.data_change <= DATA_TOL
    # optimality: x is orthogonal to the null space of the data Jacobian there (first-order
    # condition of min ||x||^2 on the data manifold), and a step along that null space and
    # back onto the data does not get nearer
    null = sensitivity(cfgs, out.xbar).null_directions
    assert null.shape[0] == N_STOREYS - 3
    assert np.max(np.abs(null @ out.xbar)) < 1e-8 * max(1.0, np.linalg.norm(out.xbar))


def _back_to_data(cfgs, x, target):
    """Gauss-Newton in the range of the sensitivity only: returns to the frequencies ``target``
    (rad/s) without moving along the null directions."""
    for _ in range(30):
        S = sensitivity(cfgs, x).matrix
        x = x - np.linalg.lstsq(S, np.log(_data(cfgs, x) / target), rcond=None)[0]
    return x


def test_minimum_change_does_not_depend_on_which_fitted_point_it_starts_from():
    cfgs, x_true = building_case(3)
    target = _data(cfgs, x_true)
    null = sensitivity(cfgs, x_true).null_directions
    answers = []
    for seed in range(3):
        start = _back_to_data(cfgs, x_true + 0.1 * np.random.default_rng(seed).standard_normal(null.shape[0]) @ null,
                              target)
        np.testing.assert_allclose(_data(cfgs, start), target, rtol=1e-12)
        assert np.linalg.norm(start - x_true) > 0.05
        answers.append(minimum_change(cfgs, start).xbar)
    for a in answers[1:]:
        np.testing.assert_allclose(a, answers[0], atol=1e-8)


def test_determined_parameters_are_left_alone():
    cfgs, x_true = building_case(N_STOREYS)   # every frequency: the data determine everything
    out = minimum_change(cfgs, x_true)
    assert not out.applied and not out.kept
    np.testing.assert_array_equal(out.xbar, x_true)


def test_shapes_are_data_too():
    """Exact shape entries at two floors with three frequencies: rank 3 + 3 ratios; the
    minimum change keeps every ratio."""
    cfgs, x_true = building_case(3, shapes=True)
    out = minimum_change(cfgs, x_true)
    assert out.rank == 6
    if out.kept:
        f0, f1 = model_frequencies(cfgs[0], x_true), model_frequencies(cfgs[0], out.xbar)
        for k in range(3):
            r0 = f0.Phi[cfgs[0].model.dof("x4"), k] / f0.Phi[cfgs[0].model.dof("x8"), k]
            r1 = f1.Phi[cfgs[0].model.dof("x4"), k] / f1.Phi[cfgs[0].model.dof("x8"), k]
            assert r1 == pytest.approx(r0, rel=1e-8, abs=1e-10)


def test_update_returns_the_minimum_change_answer_and_says_so():
    cfgs, x_true = building_case(3, seed=1)
    lines = []
    result = update(cfgs, progress=lines.append)
    assert result.success, result.message
    mc = result.minimum_change
    assert mc is not None and mc.applied
    # the answer is the minimum-change point of its own data: no other fitted point is nearer
    again = minimum_change(cfgs, result.xbar)
    assert again.norm >= np.linalg.norm(result.xbar) - 1e-9
    assert any(line.startswith("minimum change:") for line in lines) or not mc.kept
    assert result.solver_record()["minimum_change"]["rank"] == 3


def _two_mass_chain(p):
    """Two unit masses between two walls: springs kL (left wall), kc (between), kR (right wall)."""
    dtype = complex if any(isinstance(v, complex) for v in p.values()) else float
    kL, kc, kR = p["kL"], p["kc"], p["kR"]
    K = np.array([[kL + kc, -kc], [-kc, kR + kc]], dtype=dtype)
    return np.eye(2), K, ["x1", "x2"]


def test_valley_points_keep_the_data_and_bend_where_the_line_does_not():
    # two frequencies fix kL + kR + 2 kc and (kL + kc)(kR + kc) - kc^2; at the symmetric answer
    # kL = kR the undetermined direction is (1, -1, 0), along which kc changes only at second
    # order: the straight line keeps kc fixed, the valley of answers does not
    from vibupdate.inverse.minimum_change import valley_points
    from vibupdate.ranges.identifiability import parameter_ranges

    params = [Parameter(n, 1000.0, 600.0, 1400.0) for n in ("kL", "kc", "kR")]
    model = from_builder(_two_mass_chain, params)
    x_sym = model.normalized([1000.0, 800.0, 1000.0])
    omega, _ = modes(*model.matrices(x_sym))
    cfg = Configuration("A", model, tuple(NaturalFrequency(float(w)) for w in omega))
    points = valley_points([cfg], x_sym)
    assert points.shape[0] >= 8
    for x in points:
        assert np.allclose(model_frequencies(cfg, x).natural, omega, rtol=1e-9, atol=0)
    kc = np.array([model.physical(x)[1] for x in points])
    assert kc.min() < 800.0 - 1.0            # the valley bends: kc falls away from the symmetric point
    # a truth on that valley with kL != kR: its kc lies inside the reported range
    truth = points[len(points) // 3]
    ranges = parameter_ranges([cfg], x_sym)
    assert ranges.lower[1] <= model.physical(truth)[1] <= ranges.upper[1]
    assert ranges.upper[1] - ranges.lower[1] > 1.0


def _spring_mass_pair(p):
    """Wall, spring ``k1``, unit mass, unit spring, mass ``m2``."""
    dtype = complex if any(isinstance(v, complex) for v in p.values()) else float
    K = np.array([[p["k1"] + 1.0, -1.0], [-1.0, 1.0]], dtype=dtype)
    return np.diag([1.0, p["m2"]]).astype(dtype), K, ["x1", "x2"]


def test_minimum_change_converges_fast_on_a_curved_set_of_answers():
    # one frequency, two parameters: the models with its eigenvalue lam are the hyperbola
    # (k1 + 1 - lam)(1 - lam m2) = 1, i.e. k1 = 1 / (1 - lam m2) - 1 + lam, which bends round the
    # nominal point (1, 1); its point nearest the nominal point is where the curve's tangent
    # (k1', 1) is orthogonal to (k1 - 1, m2 - 1), a scalar root found here to machine precision.
    # A step that ignores the curve's bend gains only a fixed fraction of the remaining distance
    # per iteration here (30 iterations, the limit, on the old code)
    from scipy.optimize import brentq

    model = from_builder(_spring_mass_pair, [Parameter("k1", 1.0, 0.2, 5.0), Parameter("m2", 1.0, 0.2, 5.0)])
    x_fit = model.normalized([2.5, 0.6])
    omega, _ = modes(*model.matrices(x_fit))
    lam = omega[0] ** 2
    cfg = Configuration("A", model, (NaturalFrequency(float(omega[0])),))

    def k1(m2):
        return 1.0 / (1.0 - lam * m2) - 1.0 + lam

    m2 = brentq(lambda m: (k1(m) - 1.0) * lam / (1.0 - lam * m) ** 2 + (m - 1.0), 0.2, 0.6, xtol=1e-15)
    out = minimum_change([cfg], x_fit)
    assert out.applied and out.kept, out.message
    assert out.iterations <= 10
    np.testing.assert_allclose(model.physical(out.xbar), [k1(m2), m2], rtol=1e-10)
    assert out.data_change <= DATA_TOL
