"""Certified outer ranges: the relaxation holds every point of the
consistent set, the safe dual bound holds for any multipliers, and the ranges contain the
truth, the answer and every point of S that random sampling and local NLP solves find."""

import numpy as np
import pytest
from helpers import chain_model
from hypothesis import HealthCheck, assume, example, given, settings
from hypothesis import strategies as st

from vibupdate import Antiresonance, Configuration, NaturalFrequency, ShapeInterval, antiresonances, modes
from vibupdate.ranges.certify import certified_ranges, enclosure
from vibupdate.ranges.consistent import consistent_set, inner_ranges, is_consistent, witness
from vibupdate.ranges.identifiability import parameter_ranges
from vibupdate.ranges.lp_relaxation import (clarabel_model, highs_model, lift, lifted_point, relax, safe_bound,
                                             solve, solve_clarabel)
from vibupdate.ranges.tightening import BEFORE, lifts, root_box, tighten

NAMES = ("k1", "k2", "k3", "m1", "m2", "m3")


def chain_data(names, fractions, shape_tolerance=None):
    """Three-mass chain, truth at ``fractions`` of each parameter's box; exact frequencies and,
    optionally, the true mode shapes within +- shape_tolerance."""
    model = chain_model(3, names)
    lo, hi = model.bounds()
    truth = lo + np.asarray(fractions) * (hi - lo)
    w, Phi = modes(*model.matrices(truth))
    natural = []
    for k in range(3):
        shape = None
        if shape_tolerance is not None:
            values = {d: float(Phi[model.dof(d), k]) for d in ("y1", "y2", "y3")}
            shape = ShapeInterval.from_values(values, shape_tolerance * np.max(np.abs(Phi[:, k])))
        natural.append(NaturalFrequency(float(w[k]), shape=shape))
    return model, truth, Configuration("A", model, tuple(natural))


def points_near(cs, centre, rng, n=40, scale=0.05):
    """Random points of S around ``centre`` (kept only if `is_consistent` confirms them)."""
    width = cs.x_upper - cs.x_lower
    cands = centre + scale * width * rng.standard_normal((n, cs.n_x))
    return [x for x in np.clip(cands, cs.x_lower, cs.x_upper) if is_consistent(cs, x)]


def inside(r, model, x):
    lo, hi = model.normalized(r.lower), model.normalized(r.upper)
    lo, hi = np.minimum(lo, hi), np.maximum(lo, hi)
    return bool(np.all(lo <= x) and np.all(x <= hi))


cases = st.tuples(
    st.lists(st.sampled_from(NAMES), min_size=2, max_size=4, unique=True),
    st.lists(st.floats(0.15, 0.85), min_size=4, max_size=4),
    st.sampled_from([0.0, 0.005, 0.02]),
    st.sampled_from([None, 0.1]),
    st.integers(0, 2**31 - 1),
)


def _drawn(case):
    """The chain, its truth, its consistent set S and a generator of a drawn case; cases whose
    truth is not in S (its eigenvectors outside the boxes) are discarded."""
    names, fractions, tol, shape_tol, seed = case
    model, truth, cfg = chain_data(sorted(names), fractions[: len(names)], shape_tol)
    cs = consistent_set([cfg], frequency_tolerance=tol)
    assume(is_consistent(cs, truth))
    return model, truth, cs, np.random.default_rng(seed)


@settings(max_examples=6, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(cases)
def test_certified_range_contains_the_truth_and_every_point_of_s_found(case):
    model, truth, cs, rng = _drawn(case)
    points = [truth] + points_near(cs, truth, rng)
    for splits in (0, 6):   # bound tightening alone, then with branching
        r = enclosure(cs, seconds=np.inf, max_passes=3, max_splits=splits, known=[truth])
        assert not r.empty and r.splits <= splits
        for x in points:
            assert inside(r, model, x)


@settings(max_examples=6, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(cases)
def test_bound_tightening_never_cuts_off_a_point_of_s_found_by_sampling(case):
    """Every point of S found by sampling, its eigenvectors included, stays inside the box
    after each pass of OBBT (parameters and vector entries), with and without a focus."""
    model, truth, cs, rng = _drawn(case)
    members = [truth] + points_near(cs, truth, rng, scale=0.1)
    R = lifts(cs)
    L = R.full
    Z = [lifted_point(L, cs, x, witness(cs, x))[:L.n_x + L.n_u] for x in members]
    box = root_box(cs, R)
    for focus in (None, int(rng.integers(cs.n_x)), None):
        tighten(R, box, np.inf, max_passes=1, focus=focus)
        assert not box.empty
        for z in Z:
            assert np.all(box.lo <= z) and np.all(z <= box.hi)


@settings(max_examples=8, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(cases)
def test_relaxation_holds_the_lifted_points_and_the_safe_bound_holds_for_any_multipliers(case):
    model, truth, cs, rng = _drawn(case)
    L = lift(cs)
    lp = relax(L, cs.x_lower, cs.x_upper, L.u_lower, L.u_upper)
    members = [truth] + points_near(cs, truth, rng, n=20)
    Z = np.array([lifted_point(L, cs, x, witness(cs, x)) for x in members])
    for z in Z:  # exactly feasible: no tolerance
        assert np.all(lp.zl <= z) and np.all(z <= lp.zu)
        a = lp.A @ z
        assert np.all(lp.lo <= a) and np.all(a <= lp.hi)
    # Convex combinations of lifted points are feasible too (the relaxation is convex).
    W = rng.dirichlet(np.ones(len(Z)), size=10)
    Z = np.vstack([Z, W @ Z])
    for _ in range(3):
        c = rng.standard_normal(L.n_z)
        status, opt, bound = solve(lp, c)
        assert status == "optimal"
        assert bound <= opt + 1e-9 * (1 + abs(opt))
        assert np.all(Z @ c >= bound)
        y = rng.standard_normal(lp.A.shape[0]) * rng.uniform(0, 10)   # any multipliers at all
        assert np.all(Z @ c >= safe_bound(c, lp, y))


@settings(max_examples=6, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(cases)
@example((["m1", "k1"], [0.5, 0.375, 0.5, 0.5], 0.0, 0.1, 9979759))   # HiGHS's default tolerances fail it
def test_clarabel_s_safe_bound_never_exceeds_the_optimum_found_by_highs(case):
    """The shortcut that keeps Clarabel's bound without a HiGHS re-solve: on random
    objectives, with one Clarabel instance re-solved for each (objective and column bounds
    updated in place), its safe bound never exceeds the LP's optimum computed by HiGHS, nor
    the objective at lifted points of S in the narrowed box."""
    model, truth, cs, rng = _drawn(case)
    L = lift(cs)
    lp = relax(L, cs.x_lower, cs.x_upper, L.u_lower, L.u_upper)
    members = [truth] + points_near(cs, truth, rng, n=20)
    Z = np.array([lifted_point(L, cs, x, witness(cs, x)) for x in members])
    cla = clarabel_model(lp)
    for k in range(6):
        if k == 3:   # narrow the parameters' columns to the hull of the points, in place
            zl, zu = lp.zl.copy(), lp.zu.copy()
            n = L.n_x
            zl[:n], zu[:n] = Z[:, :n].min(axis=0), Z[:, :n].max(axis=0)
            cla.change_bounds(np.arange(n), zl[:n], zu[:n])
            lp = type(lp)(lp.A, lp.lo, lp.hi, zl, zu, lp.n_eig)
        c = rng.standard_normal(L.n_z) * (rng.random(L.n_z) < 0.3)
        c[rng.integers(L.n_x)] += rng.choice([-1.0, 1.0])
        status, opt, bound = solve_clarabel(lp, c, cla)
        # the reference to 1e-10: at HiGHS's default feasibility tolerances (1e-7) its optimum
        # lay 5.1e-9 below the LP's on one drawn case, under the rigorous bound it is held to
        reference = highs_model(lp)
        for option in ("primal_feasibility_tolerance", "dual_feasibility_tolerance"):
            reference.setOptionValue(option, 1e-10)
        h_status, h_opt, h_bound = solve(lp, c, reference)
        assert status == h_status == "optimal"
        assert bound <= h_opt + 1e-9 * (1 + abs(h_opt))
        assert np.all(Z @ c >= bound)
        fresh = solve_clarabel(lp, c)
        assert abs(fresh[1] - h_opt) <= 1e-5 * (1 + abs(h_opt)) and fresh[2] <= h_opt + 1e-9 * (1 + abs(h_opt))


@settings(max_examples=4, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(cases)
def test_the_tightening_with_and_without_its_economies_keeps_every_point_of_s(case):
    """Tightening with and without the economies of `Tactics` (solver reuse, Clarabel's bound
    kept without a HiGHS re-solve, parameters first, the stall on parameter widths): both
    ranges hold every sampled point of S."""
    model, truth, cs, rng = _drawn(case)
    points = [truth] + points_near(cs, truth, rng)
    after = enclosure(cs, seconds=np.inf, max_passes=2, max_splits=0)
    before = enclosure(cs, seconds=np.inf, max_passes=2, max_splits=0, tactics=BEFORE)
    for r in (after, before):
        for x in points:
            assert inside(r, model, x)


def test_inner_estimate_lies_inside_the_certified_range():
    model, truth, cfg = chain_data(["k1", "k2", "m1", "m3"], [0.6, 0.3, 0.5, 0.4])
    cs = consistent_set([cfg], frequency_tolerance=0.01)
    r = enclosure(cs, seconds=np.inf, max_passes=10)
    inner = inner_ranges(cs, [truth])
    assert len(inner.points) > 1
    for x in inner.points:
        assert inside(r, model, x)
    assert np.all(r.certified)


def test_the_answer_is_inside_when_the_windows_are_widened_to_hold_it():
    model, truth, cfg = chain_data(["k1", "m2"], [0.5, 0.5])
    noisy = Configuration("A", model, tuple(NaturalFrequency(f.omega * (1 + e))
                                           for f, e in zip(cfg.natural, (0.004, -0.003, 0.002))))
    answer = truth + np.array([0.01, -0.02])
    cs = consistent_set([noisy], include=answer)
    assert is_consistent(cs, answer)
    r = certified_ranges([noisy], answer, seconds=10.0)
    assert inside(r, model, answer)


def _chain_with_intervals(tol):
    """Three-mass chain, every frequency and antiresonance with its own interval of relative
    half-width ``tol`` (a tuple: one per datum) or none (``tol`` None)."""
    model = chain_model(3, ["k1", "k2", "m1", "m3"])
    truth = np.array([0.1, -0.05, 0.08, -0.1])
    M, K = model.matrices(truth)
    w, _ = modes(M, K)
    z = antiresonances(M, K, 0, 0)
    tols = [None] * 5 if tol is None else list(tol)
    iv = [None if t is None else (x * (1 - t), x * (1 + t)) for x, t in zip([*w, *z], tols)]
    nat = tuple(NaturalFrequency(x, interval=i) for x, i in zip(w, iv[:3]))
    zs = tuple(Antiresonance(x, "y1", "y1", interval=i) for x, i in zip(z, iv[3:]))
    return model, truth, Configuration("A", model, nat, zs)


def test_each_datum_s_interval_is_its_window_of_the_consistent_set():
    model, truth, plain = _chain_with_intervals(None)
    _, _, own = _chain_with_intervals([0.01] * 5)
    by_tolerance = consistent_set([plain], frequency_tolerance=0.01)
    by_intervals = consistent_set([own], frequency_tolerance=0.3)   # unused: every datum has an interval
    np.testing.assert_allclose(by_intervals.omega_lower, by_tolerance.omega_lower, rtol=1e-12)
    np.testing.assert_allclose(by_intervals.omega_upper, by_tolerance.omega_upper, rtol=1e-12)
    assert "own measured interval (5 of 5 frequencies)" in by_intervals.definition()
    a = enclosure(by_tolerance, seconds=np.inf, max_passes=2)
    b = enclosure(by_intervals, seconds=np.inf, max_passes=2)
    np.testing.assert_allclose(a.lower, b.lower, rtol=1e-9)
    np.testing.assert_allclose(a.upper, b.upper, rtol=1e-9)
    # Mixed: a narrow interval on the first frequency, the tolerance for the others.
    _, _, mixed = _chain_with_intervals([0.001, None, None, None, None])
    cs = consistent_set([mixed], frequency_tolerance=0.01)
    w1 = mixed.natural[0].omega
    assert cs.omega_lower[0] == pytest.approx(0.999 * w1) and cs.omega_upper[0] == pytest.approx(1.001 * w1)
    assert "(1 of 5 frequencies), +-1 % of the measured frequency for the others" in cs.definition()
    narrow = enclosure(cs, seconds=np.inf, max_passes=2)
    assert inside(narrow, model, truth)
    assert np.all(narrow.upper - narrow.lower <= a.upper - a.lower + 1e-12)


def test_a_measured_shape_counts_up_to_scale_with_its_reference_entry_s_own_interval():
    """The truth's shape lies in the intervals as measured (reference entry at the low end of
    its interval), but its ratios do not lie in the intervals divided by the reference midpoint:
    S, which frees the reference entry to its interval, holds it; certified ranges too."""
    model = chain_model(3, ["k1", "k2", "m2"])
    truth = np.array([0.1, -0.1, 0.05])
    w, Phi = modes(*model.matrices(truth))
    natural = []
    for k in range(3):
        phi = Phi[:, k] / Phi[np.argmax(np.abs(Phi[:, k])), k]
        r = int(np.argmax(np.abs(phi)))
        bounds = {f"y{j + 1}": (phi[j] - 0.01, phi[j] + 0.01) for j in range(3)}
        bounds[f"y{r + 1}"] = (1.0, 1.2)   # the truth at the low end of the reference interval
        natural.append(NaturalFrequency(float(w[k]), shape=ShapeInterval(bounds)))
    cfg = Configuration("A", model, tuple(natural))
    cs = consistent_set([cfg], frequency_tolerance=0.001)
    assert all(not b.fixed.any() for b in cs.blocks)
    ratios = ShapeInterval(natural[0].shape.bounds).ratio_bounds()
    j = next(d for d in ratios if abs(Phi[model.dof(d), 0]) > 0.05 * np.max(np.abs(Phi[:, 0])))
    phi0 = Phi[:, 0] / Phi[np.argmax(np.abs(Phi[:, 0])), 0]
    assert not ratios[j][0] <= phi0[model.dof(j)] <= ratios[j][1]   # outside the midpoint ratios
    assert is_consistent(cs, truth)
    assert "3 of 3 vectors carry a measured shape" in cs.definition()
    r = enclosure(cs, seconds=np.inf, max_passes=3, max_splits=4, known=[truth])
    assert inside(r, model, truth)
    for x in points_near(cs, truth, np.random.default_rng(3), scale=0.02):
        assert inside(r, model, x)


def test_inconsistent_data_give_a_certified_empty_set():
    model = chain_model(3, ["k1", "k2", "m1"])
    w, _ = modes(*model.matrices())
    cfg = Configuration("A", model, tuple(NaturalFrequency(x) for x in w * np.array([1.0, 1.6, 1.8])))
    r = enclosure(consistent_set([cfg]), seconds=np.inf, max_passes=5)
    assert r.empty and np.all(np.isnan(r.lower))
    assert "empty" in r.message


def test_parameter_ranges_has_one_return_type_and_bad_budget_is_a_clear_error():
    model, truth, cfg = chain_data(["k1", "m2"], [0.5, 0.5])
    with pytest.raises(TypeError, match="unexpected keyword argument 'method'"):
        parameter_ranges([cfg], truth, method="certified")     # the certified ranges: certified_ranges
    with pytest.raises(ValueError, match="time budget must be >= 0 seconds, got -1"):
        enclosure(consistent_set([cfg]), seconds=-1)
    with pytest.raises(ValueError, match="frequency_tolerance must be in"):
        consistent_set([cfg], frequency_tolerance=-0.1)


def test_cli_run_with_certify_reports_the_ranges_beside_the_linearized_ones(tmp_path, capsys):
    import json

    from vibupdate.cli import main

    (tmp_path / "model.py").write_text(
        "import vibupdate as vu\n"
        "def build(p):\n"
        "    asm = vu.Assembly('beam')\n"
        "    for i in range(4):\n"
        "        asm.node(i, 0.2 * i)\n"
        "    for i in range(3):\n"
        "        asm.beam(i, i + 1, EI=p['EI'], mass_per_length=p['m'])\n"
        "    asm.clamp(0)\n"
        "    return asm.system()\n")
    head = ('[model]\ntype = "builder"\nbuilder = "model.py:build"\n'
            '[[parameter]]\nname = "EI"\nnominal = 10.0\nlower = 5.0\nupper = 20.0\n'
            '[[parameter]]\nname = "m"\nnominal = 1.0\nlower = 0.8\nupper = 1.2\n')
    from vibupdate.io.case import load_case

    (tmp_path / "probe.toml").write_text(head + '[[configuration]]\nname = "A"\nnatural_hz = [1.0, 5.0]\n')
    model = load_case(tmp_path / "probe.toml").configurations[0].model
    w, _ = modes(*model.matrices_at([12.0, 1.0]))
    hz = ", ".join(f"{x / (2 * np.pi):.9g}" for x in w[:2])
    case = tmp_path / "case.toml"
    case.write_text("frequency_tolerance = 0.01\n" + head + f'[[configuration]]\nname = "A"\nnatural_hz = [{hz}]\n')
    out = tmp_path / "out"
    assert main(["run", str(case), "--out", str(out), "--certify", "1"]) == 0
    printed = capsys.readouterr().out
    assert "Certified outer ranges" in printed
    assert "certifies nothing unless positive" in printed
    doc = json.loads((out / "results.json").read_text())
    cert = doc["identifiability"]["certified"]
    assert "Consistent set S" in cert["definition"]
    # EI and m scale together (only their ratio moves the frequencies): the ranges stay wide.
    assert cert["ranges"]["EI"]["lower"] <= 12.0 <= cert["ranges"]["EI"]["upper"]
    updated = {p["name"]: p["updated"] for p in doc["parameters"]}
    for name, rg in cert["ranges"].items():
        assert rg["lower"] <= updated[name] <= rg["upper"]
    report = (out / "report.md").read_text()
    assert "Certified outer range" in report and "certified outer range" in report
    assert main(["run", str(case), "--out", str(out), "--certify", "-1"]) == 2
    assert "budget must be >= 0 seconds, got -1" in capsys.readouterr().err


@pytest.fixture(scope="module")
def cantilever_answer():
    from vibupdate.examples import cantilever
    from vibupdate.inverse.update import update

    case = cantilever.case()
    return case, update(case.configurations, formulation=case.formulation, solver=case.solver)


def _example_check(case, result, passes, inner, tolerance, splits=0):
    """The answer and points of S near it (random, and the inner estimate's) lie inside;
    ``tolerance`` (at least the case's) leaves room in the windows for such points."""
    model = case.configurations[0].model
    last = result.attempts[-1] if result.attempts else None
    from dataclasses import replace

    boxes = replace(case.formulation, **{k: getattr(last, k) for k in ("shape_margin", "adjunct_margin") if last is not None})
    cs = consistent_set(case.configurations, frequency_tolerance=max(tolerance, case.frequency_tolerance),
                        include=result.xbar, options=boxes)
    # The answer sits on active bounds of S (vector boxes, parameter bounds) up to the solver's
    # tolerance: on the frame its mode 7 leaves its box by 8e-9. It is in S to within 1e-6.
    assert is_consistent(cs, result.xbar, margin=-1e-6)
    r = enclosure(cs, seconds=np.inf, max_passes=passes, max_splits=splits, known=[result.xbar])
    assert (r.passes == passes if not splits else r.passes <= passes) and r.splits <= splits and not r.empty
    assert inside(r, model, result.xbar)
    points = points_near(cs, result.xbar, np.random.default_rng(1), n=30, scale=0.002)
    points += list(inner_ranges(cs, [result.xbar]).points) if inner else []
    assert len(points) > 1
    for x in points:
        assert inside(r, model, x)
    return r


@pytest.mark.slow
def test_cantilever_certified_range_contains_the_answer_and_nearby_points_of_s(cantilever_answer):
    case, result = cantilever_answer
    r = _example_check(case, result, passes=1, inner=False, tolerance=0.02)
    assert np.all(r.upper - r.lower <= r.root_upper - r.root_lower)


@pytest.mark.slow
def test_cantilever_refined_range_contains_the_inner_estimate(cantilever_answer):
    case, result = cantilever_answer
    _example_check(case, result, passes=6, inner=True, tolerance=0.02, splits=6)


@pytest.mark.slow
def test_frame_certified_range_contains_the_answer_and_the_inner_estimate():
    from vibupdate.examples import frame
    from vibupdate.inverse.update import update

    case = frame.case()
    result = update(case.configurations, formulation=case.formulation, solver=case.solver)
    _example_check(case, result, passes=2, inner=True, tolerance=0.0)
