"""First stage (Problems 1-4): known-truth recovery, relaxation properties, test case 2."""

from dataclasses import replace
from types import SimpleNamespace

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from helpers import chain_model
from vibupdate.io.results import frequencies_of, macs_of
from vibupdate import (Antiresonance, Assembly, Configuration, NaturalFrequency, Parameter,
                       ShapeInterval, antiresonances, from_builder, modes)
from vibupdate.inverse.backends.casadi_ipopt import CasadiIpopt
from vibupdate.examples import cantilever
from vibupdate.inverse.homotopy import SolverOptions
from vibupdate.inverse.admissible import VerifyOptions
from vibupdate.inverse.status import Verdict
from vibupdate.inverse.polish import PolishOptions, polish
from vibupdate.inverse.relaxation import lifted_values, mccormick
from vibupdate.inverse.status import Status
from vibupdate.inverse.update import prepare, prepare_first_stage, update

TRUE_CHAIN = {"k1": 1100.0, "k3": 900.0, "m2": 1.15, "m5": 0.85}


def exact(model, truth):
    M, K = model.matrices_at([truth[p.name] for p in model.parameters])
    omega, Phi = modes(M, K)
    return M, K, omega, Phi


def assert_recovered(result, model, truth):
    assert result.status == Status.SUCCESS, result.message
    true = np.array([truth[p.name] for p in model.parameters])
    np.testing.assert_allclose(result.values, true, rtol=1e-4)
    for row in frequencies_of(result.correlation):
        assert row.updated_hz == pytest.approx(row.measured_hz, rel=1e-6)
    assert_sound(result)
    # Exact data: the returned model has every measured frequency as an eigenvalue (or zero of
    # its receptance) with the returned vector as its eigenvector (measured: at most 1.7e-7 over
    # this file's exact-data problems, the two configurations' the largest).
    residuals = eigen_residuals(result, result.xbar)
    assert residuals.max() <= 1e-6, residuals


def first_stage_unknowns(result):
    """The first stage's problem of the result's data and its free unknowns read back from the
    returned vectors (the fixed normalization entries left out)."""
    problem = prepare_first_stage(result.correlation.configurations).problem
    assert len(result.vectors) == len(problem.blocks)
    u = np.concatenate([(v / b.scale)[~b.fixed] for v, b in zip(result.vectors, problem.blocks)])
    return problem, u


def eigen_residuals(result, xbar):
    """``||(K - w^2 M) v|| / ||K v||`` of each returned vector at ``xbar`` (rows and columns of
    its block: the whole model for a mode, the adjunct system for an antiresonance)."""
    problem, _ = first_stage_unknowns(result)
    models = {c.name: c.model for c in result.correlation.configurations}
    out = []
    for v, b in zip(result.vectors, problem.blocks):
        M, K = models[b.configuration].matrices(xbar)
        K, A = K[b.rows][:, b.cols], (K - b.omega**2 * M)[b.rows][:, b.cols]
        out.append(np.linalg.norm(A @ v) / np.linalg.norm(K @ v))
    return np.array(out)


def assert_sound(result):
    """Properties every answer has, measured or exact data: the objective it reports is the
    first stage's objective of the vectors it returns at its parameters, and the relaxation's
    lower bound is below it."""
    problem, u = first_stage_unknowns(result)
    recomputed = problem.objective(result.xbar, u)
    assert recomputed == pytest.approx(result.objective, rel=1e-6, abs=1e-14), (recomputed, result.objective)
    assert result.relaxation_lower_bound is not None
    assert result.relaxation_lower_bound <= result.objective + 1e-12


def test_problem_2_natural_frequencies_only():
    model = chain_model(5, list(TRUE_CHAIN))
    _, _, omega, _ = exact(model, TRUE_CHAIN)
    cfg = Configuration("P2", model, tuple(NaturalFrequency(w) for w in omega))
    result = update([cfg])
    assert_recovered(result, model, TRUE_CHAIN)
    assert result.problem_size["n_adjunct_unknowns"] == 0


def test_problem_3_antiresonances_only():
    truth = {"k2": 1150.0, "k4": 880.0, "m3": 1.2}
    model = chain_model(5, list(truth))
    M, K, _, _ = exact(model, truth)
    zeros = []
    for dof in ("y1", "y5"):
        i = model.dof(dof)
        zeros += [Antiresonance(z, dof, dof) for z in antiresonances(M, K, i, i)]
    cfg = Configuration("P3", model, (), tuple(zeros))
    result = update([cfg])
    assert_recovered(result, model, truth)
    assert result.problem_size["n_mode_unknowns"] == 0


def test_problem_1_interval_mode_shapes():
    model = chain_model(5, list(TRUE_CHAIN))
    _, _, omega, Phi = exact(model, TRUE_CHAIN)
    natural = []
    for k in range(4):
        values = {d: Phi[model.dof(d), k] for d in ("y1", "y2", "y3", "y4", "y5")}
        tol = 0.01 * np.abs(Phi[:, k]).max()
        natural.append(NaturalFrequency(omega[k], shape=ShapeInterval.from_values(values, tol)))
    result = update([Configuration("P1", model, tuple(natural))])
    assert_recovered(result, model, TRUE_CHAIN)
    assert np.all(macs_of(result.correlation)["P1"] > 0.999)


def test_problem_4_frequencies_antiresonances_and_interlacing():
    model = chain_model(5, list(TRUE_CHAIN))
    M, K, omega, _ = exact(model, TRUE_CHAIN)
    r, c = model.dof("y1"), model.dof("y3")
    zeros = [Antiresonance(z, "y1", "y3") for z in antiresonances(M, K, r, c) if z < omega[3]]
    cfg = Configuration("P4", model, tuple(NaturalFrequency(w) for w in omega[:4]), tuple(zeros))
    result = update([cfg])
    assert_recovered(result, model, TRUE_CHAIN)
    assert result.problem_size["n_adjunct_unknowns"] > 0


def _beam_builder(p):
    """Six-element cantilever with a tip mass and a spring; density known unless given."""
    asm = Assembly("beam")
    for i in range(7):
        asm.node(i, 0.1 * i)
    for i in range(6):
        asm.beam(i, i + 1, EI=p["E"] * 2.0e-10, mass_per_length=p.get("rho", 2700.0) * 1.6e-4)
    asm.clamp(0)
    asm.mass("y6", p["m_tip"])
    asm.spring("y3", p["k"])
    return asm.system()


def test_problem_1_on_a_beam_with_unmeasured_rotations():
    """Rotations get default bounds and are scaled by the element length (docs/method.md, "Scaling of rotations and of residual rows")."""
    # Density is known: with every mass and stiffness term a parameter, scaling all of them
    # together leaves frequencies and modes unchanged and the data could not decide.
    params = [Parameter("E", 70e9, 55e9, 85e9), Parameter("m_tip", 0.05, 0.03, 0.08),
              Parameter("k", 2000.0, 1000.0, 4000.0)]
    truth = {"E": 76e9, "m_tip": 0.062, "k": 2600.0}
    model = from_builder(_beam_builder, params)
    _, _, omega, Phi = exact(model, truth)
    translations = [d for d in model.dofs if d.startswith("y")]
    natural = []
    for k in range(4):
        values = {d: Phi[model.dof(d), k] for d in translations}
        tol = 0.01 * max(abs(v) for v in values.values())
        natural.append(NaturalFrequency(omega[k], shape=ShapeInterval.from_values(values, tol)))
    result = update([Configuration("beam", model, tuple(natural))])
    assert_recovered(result, model, truth)
    assert result.sensitivity.rank == 3


def test_several_configurations_share_the_parameters():
    """Two configurations (a proof mass moved) determine what one alone cannot."""
    names = ["k1", "k3", "m2", "m5"]

    def with_extra(dof):
        from helpers import chain_builder

        base = chain_builder(5)

        def build(p):
            s = base(p)
            M = s.M.tolil()
            M[s.dof(dof), s.dof(dof)] += 0.3
            return s.M.__class__(M), s.K, s.dofs

        params = [Parameter(n, 1000.0 if n[0] == "k" else 1.0, 700.0 if n[0] == "k" else 0.7,
                            1300.0 if n[0] == "k" else 1.3) for n in names]
        return from_builder(build, params)

    configs = []
    for name, dof in (("A", "y2"), ("B", "y4")):
        model = with_extra(dof)
        _, _, omega, _ = exact(model, TRUE_CHAIN)
        configs.append(Configuration(name, model, tuple(NaturalFrequency(w) for w in omega[:2])))
    result = update(configs)
    assert_recovered(result, configs[0].model, TRUE_CHAIN)


# -- properties of the relaxation ---------------------------------------------------------

@settings(max_examples=60, deadline=None)
@given(
    bounds=st.lists(st.tuples(st.floats(-3, 3), st.floats(0, 3), st.floats(-3, 3), st.floats(0, 3)),
                    min_size=1, max_size=5),
    fractions=st.lists(st.tuples(st.floats(0, 1), st.floats(0, 1)), min_size=5, max_size=5),
)
def test_mccormick_holds_for_every_point_of_the_boxes(bounds, fractions):
    xl = np.array([b[0] for b in bounds])
    xu = xl + np.array([b[1] for b in bounds])
    ul = np.array([b[2] for b in bounds])
    uu = ul + np.array([b[3] for b in bounds])
    n = len(bounds)
    fake = SimpleNamespace(prod_x=np.arange(n), prod_u=np.arange(n), x_lower=xl, x_upper=xu,
                           u_lower=ul, u_upper=uu, n_b=n, n_x=n, n_u=n)
    env = mccormick(fake)
    x = xl + np.array([f[0] for f in fractions[:n]]) * (xu - xl)
    u = ul + np.array([f[1] for f in fractions[:n]]) * (uu - ul)
    g = env.G @ np.concatenate([x, u, x * u])
    scale = 1e-9 * (1 + np.abs(env.lower[np.isfinite(env.lower)]).max(initial=0)
                    + np.abs(env.upper[np.isfinite(env.upper)]).max(initial=0))
    assert np.all(g >= env.lower - scale)
    assert np.all(g <= env.upper + scale)
    assert np.all(env.t_lower - 1e-12 <= x * u) and np.all(x * u <= env.t_upper + 1e-12)


@pytest.fixture(scope="module")
def cantilever_problem():
    return prepare(cantilever.configurations())


@pytest.fixture(scope="module")
def cantilever_result():
    return update(cantilever.configurations())


@pytest.fixture(scope="module")
def cantilever_backend(cantilever_problem):
    return CasadiIpopt(cantilever_problem, mccormick(cantilever_problem))


@settings(max_examples=4, deadline=None)
@given(seed=st.integers(0, 2**31 - 1))
def test_lambda_zero_problem_is_convex(cantilever_problem, cantilever_backend, seed):
    """The lam = 0 optimum does not depend on the starting point."""
    P, backend = cantilever_problem, cantilever_backend
    rng = np.random.default_rng(seed)
    x = rng.uniform(P.x_lower, P.x_upper)
    u = rng.uniform(P.u_lower, P.u_upper)
    env = mccormick(P)
    t = rng.uniform(env.t_lower, env.t_upper)
    start = backend.join(x, u, t, np.zeros(P.n_r))
    nominal = backend.join(np.zeros(P.n_x), P.u_start, lifted_values(P, np.zeros(P.n_x), P.u_start),
                           P.residual(np.zeros(P.n_x), P.u_start))
    a = backend.solve(start, 0.0)
    b = backend.solve(nominal, 0.0)
    assert a.status.ok and b.status.ok
    assert abs(a.objective - b.objective) <= 1e-9 * P.objective(np.zeros(P.n_x), P.u_start)


# -- test case 2 ----------------------------------------------------------------------------

def test_cantilever_meets_the_paper_figure(cantilever_result):
    r = cantilever_result
    assert r.status == Status.SUCCESS, r.message
    # measured 0.47662 % (the paper's Table 5: 0.6 %), the same figure as the command line's run
    # (benchmarks/RESULTS.md, "Ceilings at their measured figures")
    mean = r.mean_error("updated")
    assert mean == pytest.approx(0.4766, abs=5e-4), f"mean error {mean:.4f} % (0.4766 % measured; paper: 0.6 %)"
    assert r.mean_error("nominal") > 4.0  # the nominal model is far off, as in the paper (5.6 %)
    for p, v in zip(r.parameters, r.values):
        assert p.lower - 1e-9 * abs(p.lower) <= v <= p.upper + 1e-9 * abs(p.upper), p.name
    assert_sound(r)


def test_the_soundness_checks_fail_on_a_corrupted_answer(cantilever_result):
    """The helpers above can fail: one vector scaled, the objective misreported, a lower bound
    above the objective, or exact-data parameters moved off the answer."""
    r = cantilever_result
    vectors = list(r.vectors)
    vectors[3] = vectors[3] * np.where(np.arange(vectors[3].size) % 2, 1.05, 1.0)
    for wrong in (replace(r, vectors=tuple(vectors)), replace(r, objective=0.5 * r.objective),
                  replace(r, relaxation_lower_bound=2 * r.objective)):
        with pytest.raises(AssertionError):
            assert_sound(wrong)
    model = chain_model(5, list(TRUE_CHAIN))
    _, _, omega, _ = exact(model, TRUE_CHAIN)
    exact_result = update([Configuration("P2", model, tuple(NaturalFrequency(w) for w in omega))])
    assert_recovered(exact_result, model, TRUE_CHAIN)
    moved = model.normalized(exact_result.values * np.array([1.001, 1.0, 1.0, 1.0]))   # k1 0.1 % off
    assert eigen_residuals(exact_result, moved).max() > 1e-6


def test_cantilever_problem_size_against_table_1(cantilever_result):
    """Table 1: 168 mode unknowns, 48 adjunct unknowns, 596 lifted scalars. Each of the 12
    modes here fixes its y1 entry (normalization, docs/method.md): 12 fewer unknowns and 3
    fewer products each (E, rho, macc act on y1); each adjunct vector fixes its largest
    nominal entry, y5 under the patch, so 4 products (E, rho, Ep, rho_p) vanish instead of 2."""
    size = cantilever_result.problem_size
    assert size["n_parameters"] == 7
    assert size["n_mode_unknowns"] == 168 - 12
    assert size["n_adjunct_unknowns"] == 48
    assert size["n_lifted"] == 596 - 12 * 3 - 4 * 2


def test_cantilever_interlacing_signs(cantilever_problem):
    """Eq. 29 as measured: zero between modes 1 and 2 (same sign), none between 2 and 3."""
    P = cantilever_problem
    y3 = cantilever.configurations()[0].model.dof("y3")
    for blk in P.blocks:
        if blk.kind != "natural":
            continue
        assert blk.fixed[0] and blk.lower[0] == 1.0  # u(y1) = +1
        if blk.index in (1, 2):
            assert blk.lower[y3] > 0
        else:
            assert blk.upper[y3] < 0


# -- failures and bad input -----------------------------------------------------------------

class FailingFrom:
    """The real step solver, except that every solve at ``lam >= start`` ends with ``status``
    (as a solve that runs out of iterations does), whatever it found."""

    def __init__(self, backend, start, status):
        self.backend, self.start, self.status = backend, start, status

    def __getattr__(self, name):
        return getattr(self.backend, name)

    def solve(self, z, lam, **kwargs):
        out = self.backend.solve(z, lam, **kwargs)
        return replace(out, status=self.status, raw_status="scripted") if lam >= self.start else out


def failed_update(monkeypatch, start, status):
    import vibupdate.inverse.homotopy as homotopy

    real = homotopy.build
    monkeypatch.setattr(homotopy, "build", lambda *args: FailingFrom(real(*args), start, status))
    model = chain_model(5, list(TRUE_CHAIN))
    _, _, omega, _ = exact(model, TRUE_CHAIN)
    cfg = Configuration("P2", model, tuple(NaturalFrequency(w) for w in omega))
    result = update([cfg], polish=PolishOptions(enabled=False))
    assert not result.success and not result.status.ok
    # every attempt is on record, the failed ones included, and none claims lambda = 1
    assert any(not s.status.ok for s in result.steps)
    assert not any(s.status.ok and s.lam == 1.0 for s in result.steps)
    return result


def test_a_relaxation_out_of_iterations_is_a_status_not_an_exception(monkeypatch):
    result = failed_update(monkeypatch, 0.0, Status.MAX_ITERATIONS)
    assert result.status == Status.MAX_ITERATIONS
    assert "stopped at lambda = 0.0000 (max_iterations)" in result.message, result.message
    assert result.relaxation_lower_bound is None and len(result.steps) == 1


def test_steps_that_keep_failing_end_the_path_with_step_failed(monkeypatch):
    result = failed_update(monkeypatch, 1e-9, Status.MAX_ITERATIONS)
    assert result.status == Status.STEP_FAILED
    assert "stopped at lambda = 0.0000 (step_failed)" in result.message, result.message
    assert result.relaxation_lower_bound is not None and result.steps[0].status.ok
    assert not any(s.status.ok for s in result.steps[1:]) and len(result.steps) > 2


def test_a_failed_path_is_on_record_when_a_further_start_verifies():
    model = chain_model(5, list(TRUE_CHAIN))
    _, _, omega, _ = exact(model, TRUE_CHAIN)
    x_true = model.normalized([TRUE_CHAIN[p.name] for p in model.parameters])
    cfg = Configuration("P2", model, tuple(NaturalFrequency(w) for w in omega))
    result = update([cfg], solver=SolverOptions(max_iter=1, min_step=0.25))
    assert not any(s.status.ok and s.lam == 1.0 for s in result.steps)
    assert result.restarts and result.restarts[0].start == "stepped homotopy path"
    assert result.success, result.message
    assert "homotopy stopped at lambda" in result.message and "passed every verification check" in result.message
    assert np.allclose(result.xbar, x_true, atol=1e-6)


def test_two_answers_that_fit_exactly_are_both_said():
    # two springs of a 2-mass chain from its two natural frequencies: k1 + 2 k2 and k1 k2 are
    # fixed (unit masses), so (1000, 1000) and (2000, 500) fit exactly; the first is nearer
    # the nominal (1200, 900) and is returned, the second is reported
    model = chain_model(2, ["k1", "k2"], nominal={"k1": 1200.0, "k2": 900.0}, spread=0.7)
    truth = {"k1": 1000.0, "k2": 1000.0}
    _, _, omega, _ = exact(model, truth)
    result = update([Configuration("P2", model, tuple(NaturalFrequency(w) for w in omega))])
    assert result.success, result.message
    assert np.allclose(result.values, [1000.0, 1000.0], rtol=1e-6)
    assert len(result.alternatives) == 1
    other = result.alternatives[0]["values"]
    assert np.allclose([other["k1"], other["k2"]], [2000.0, 500.0], rtol=1e-6)
    assert any(w.startswith("uniqueness: 1 other answer") for w in result.warnings)
    assert result.verdict == Verdict.NOT_UNIQUE and result.solver_record()["verdict"] == "not_unique"
    assert result.sought.uniqueness and {r.purpose for r in result.restarts} == {"uniqueness"}
    # starts that find one of the two answers again stop there instead of converging on it twice
    statuses = [r.status for r in result.restarts if r.purpose == "uniqueness"]
    assert "same answer" in statuses, statuses


def test_a_probing_polish_stops_on_a_known_answer_and_not_elsewhere():
    model = chain_model(2, ["k1", "k2"], nominal={"k1": 1200.0, "k2": 900.0}, spread=0.7)
    _, _, omega, _ = exact(model, {"k1": 1000.0, "k2": 1000.0})
    cfg = Configuration("P2", model, tuple(NaturalFrequency(w) for w in omega))
    near = model.normalized([1000.0, 1000.0])
    far = model.normalized([2000.0, 500.0])
    start = model.normalized([1100.0, 950.0])
    again = polish([cfg], start, answers=[far, near])
    assert again.stopped_on == "known answer" and "known answer 2" in again.message, again.message
    alone = polish([cfg], start, answers=[far])
    assert alone.stopped_on == "convergence" and np.allclose(alone.xbar, near, atol=1e-8)
    assert again.evaluations < alone.evaluations


def test_bad_input_is_caught_before_any_solve():
    model = chain_model(4, ["k1", "m2"])
    nat = (NaturalFrequency.from_hz(3.0), NaturalFrequency.from_hz(8.0))
    with pytest.raises(ValueError, match="DOF 'y7' does not exist"):
        update([Configuration("A", model, nat, (Antiresonance.from_hz(5.0, "y7", "y1"),))])
    with pytest.raises(ValueError, match="lower 0.5 > upper 0.1"):
        ShapeInterval({"y1": (0.5, 0.1)})
    with pytest.raises(ValueError, match="got 0.0"):
        NaturalFrequency.from_hz(0.0)
    with pytest.raises(ValueError, match="nominal 3 is outside its bounds"):
        Parameter("k", 3.0, 1.0, 2.0)
    # A driving point must alternate pole / zero: two zeros between two poles contradict it.
    zeros = (Antiresonance.from_hz(4.0, "y1", "y1"), Antiresonance.from_hz(5.0, "y1", "y1"))
    with pytest.raises(ValueError, match="has one antiresonance between consecutive modes"):
        Configuration("A", model, nat, zeros)
    with pytest.raises(ValueError, match="5 natural frequencies measured, but the model has only 4 DOFs"):
        Configuration("A", model, tuple(NaturalFrequency.from_hz(h) for h in (1.0, 2.0, 3.0, 4.0, 5.0)))
    with pytest.raises(ValueError, match="equals a natural frequency.*node at y1 or y3 does not show in h_y1,y3"):
        Configuration("A", model, nat, (Antiresonance.from_hz(8.0, "y1", "y3"),))
    # A measured shape whose entries force the opposite sign to the interlacing pattern: the
    # pattern is set aside and said (tests/inverse/test_sign_conflicts.py), not refused.
    shape = ShapeInterval({"y1": (0.9, 1.1), "y3": (-1.0, -0.5)})
    cfg = Configuration("A", model, (NaturalFrequency.from_hz(3.0, shape=shape), nat[1]),
                        (Antiresonance.from_hz(5.0, "y1", "y3"),), first_sign={("y1", "y3"): 1})
    notes = prepare([cfg]).notes
    assert len(notes) == 1 and notes[0].receptance == ("y1", "y3") and notes[0].asked == 1


def test_sensitivity_reports_parameters_the_data_cannot_separate():
    """Every mass and stiffness term a parameter: scaling all together changes no frequency,
    so the sensitivity has rank n_x - 1 (docs/method.md, "What the data determine")."""

    params = [Parameter("E", 70e9, 55e9, 85e9), Parameter("rho", 2700.0, 2200.0, 3200.0),
              Parameter("m_tip", 0.05, 0.03, 0.08), Parameter("k", 2000.0, 1000.0, 4000.0)]
    model = from_builder(_beam_builder, params)
    _, _, omega, _ = exact(model, {"E": 76e9, "rho": 2550.0, "m_tip": 0.062, "k": 2600.0})
    result = update([Configuration("beam", model, tuple(NaturalFrequency(w) for w in omega[:4]))])
    assert result.sensitivity.rank == 3
    assert result.sensitivity.condition > 1e8



def random_chain_problem(seed, noise, use_zeros):
    """Random truth inside the bounds of a 5-mass chain, its 4 lowest frequencies with relative
    noise of standard deviation ``noise`` and, with ``use_zeros``, the zeros of h_y1,y3 below the
    fourth."""
    rng = np.random.default_rng(seed)
    model = chain_model(5, ["k1", "k3", "m2", "m5"])
    truth = {p.name: rng.uniform(p.lower, p.upper) for p in model.parameters}
    M, K, omega, _ = exact(model, truth)
    omega = omega * (1 + noise * rng.standard_normal(omega.size))
    omega.sort()
    zeros = ()
    if use_zeros:
        r, c = model.dof("y1"), model.dof("y3")
        zeros = tuple(Antiresonance(z, "y1", "y3") for z in antiresonances(M, K, r, c) if z < omega[3])
    cfg = Configuration("R", model, tuple(NaturalFrequency(w) for w in omega[:4]), zeros)
    return cfg, np.array([truth[p.name] for p in model.parameters])


def relative_misses(result, cfg):
    """Each datum's relative distance from the returned model's value, recomputed by a dense
    eigen-solve of the returned matrices (mode k against the k-th eigenvalue, zero k against
    the k-th zero; a zero the model lacks misses by infinity)."""
    M, K = (A.toarray() for A in result.matrices[cfg.name])
    omega, _ = modes(M, K)
    misses = [abs(omega[k] / d.omega - 1) for k, d in enumerate(cfg.natural)]
    if cfg.antiresonances:
        z = antiresonances(M, K, cfg.model.dof("y1"), cfg.model.dof("y3"))
        misses += [abs(z[k] / d.omega - 1) if k < z.size else np.inf for k, d in enumerate(cfg.antiresonances)]
    return np.array(misses)


#: The random problems' seeds are the same every run (as the fuzz suite's CI profile): a miss is a
#: change, not a draw; the random search for misses is the acceptance engine's.
FIXED_SEEDS = dict(deadline=None, derandomize=True, database=None)


@settings(max_examples=8, **FIXED_SEEDS)
@given(seed=st.integers(0, 2**31 - 1), use_zeros=st.booleans())
def test_random_problems_with_exact_data_end_verified_with_the_truth_among_the_answers(seed, use_zeros):
    """Exact data: a verified answer (``not_unique`` included), the truth the returned answer
    or one of the other answers said, and the objective and lower bound sound (measured: 480 of
    480 seeds, the truth within 1.4e-10 of an answer; a later draw found a miss, kept below)."""
    cfg, true = random_chain_problem(seed, 0.0, use_zeros)
    result = update([cfg])
    assert result.status == Status.SUCCESS, result.message
    assert result.verdict in (Verdict.VERIFIED, Verdict.NOT_UNIQUE)
    answers = [result.values] + [[a.values[p.name] for p in result.parameters] for a in result.alternatives]
    assert min(np.max(np.abs(np.asarray(a) / true - 1)) for a in answers) <= 1e-6, (true, answers)
    assert relative_misses(result, cfg).max() <= 1e-6
    assert_sound(result)


@pytest.mark.xfail(strict=True, reason="the search's five starts miss the truth: the homotopy's exact fit (4.3 % from "
                   "the truth in m5) is returned as verified; the weakest-direction start ends at a local minimum that "
                   "verifies (objective 1.4e-5) but does not fit as well; no start reaches the truth, another exact fit")
def test_a_random_problem_whose_truth_the_search_misses():
    """Seed 29186 of `random_chain_problem` (four exact frequencies, four parameters: isolated
    exact fits), drawn by the test above when its seeds were not fixed (2026-12-07): the answer
    is an exact fit, the truth another one that no start of the uniqueness search reaches,
    whatever its evaluation budget (20-400 per unknown); the verdict says `verified`, which
    claims only that no other answer was found."""
    cfg, true = random_chain_problem(29186, 0.0, False)
    result = update([cfg])
    answers = [result.values] + [[a.values[p.name] for p in result.parameters] for a in result.alternatives]
    assert min(np.max(np.abs(np.asarray(a) / true - 1)) for a in answers) <= 1e-6


@settings(max_examples=8, **FIXED_SEEDS)
@given(seed=st.integers(0, 2**31 - 1), noise=st.floats(0.002, 0.02), use_zeros=st.booleans())
def test_random_problems_with_noisy_data_verify_only_answers_that_fit(seed, noise, use_zeros):
    """Noisy data may leave no answer within the tolerance. A verified one has every datum,
    recomputed by a dense eigen-solve, within its admissible interval (the default 2 % model-form
    tolerance around an exact datum, `vibupdate.inverse.admissible`); one that is not verified
    names its failed check, and when that is the fit, a recomputed datum does lie outside; the
    objective and lower bound are sound either way (measured: 365 of 380 noisy problems verified,
    none with a datum more than 2.0 % off; the 15 others failed the fit, 2.04 % to 2.38 % off)."""
    cfg, _ = random_chain_problem(seed, noise, use_zeros)
    result = update([cfg])
    o = VerifyOptions()
    tolerances = (o.natural_tolerance, o.antiresonance_tolerance)
    if result.status.ok:   # 2e-8: the floor and the eigen-solve's rounding
        assert relative_misses(result, cfg).max() <= max(tolerances) + o.exact_half_width + 2e-8
    else:
        failed = [c for c in result.checks if not c.passed and c.severity == "error"]
        assert failed and all(any(w.startswith(c.name) for w in result.warnings) for c in failed)
        if any(c.name == "fit" for c in failed):
            assert relative_misses(result, cfg).max() > min(tolerances) + o.exact_half_width
    if result.relaxation_lower_bound is not None:
        assert_sound(result)


def test_a_backend_exception_becomes_a_status(monkeypatch):
    """CasADi raising inside a solve (e.g. an evaluation error) is recorded, not raised."""
    import vibupdate.inverse.backends.casadi_ipopt as backend

    model = chain_model(4, ["k1", "m2"])
    _, _, omega, _ = exact(model, {"k1": 1050.0, "m2": 1.1})
    cfg = Configuration("E", model, tuple(NaturalFrequency(w) for w in omega[:2]))
    original = backend.CasadiIpopt.__init__

    def broken_init(self, *args, **kwargs):
        original(self, *args, **kwargs)

        def boom(**_):
            raise RuntimeError("Error in Function::call for 'vibupdate_cold' [IpoptInterface]")

        self._cold = boom

    monkeypatch.setattr(backend.CasadiIpopt, "__init__", broken_init)
    # the lam = 0 step by IPOPT, not by the QP solver, so that the broken call is reached
    result = update([cfg], solver=SolverOptions(relaxation_solver="nlp"), polish=PolishOptions(enabled=False))
    assert result.status == Status.NUMERICAL_ERROR
    assert not result.success and result.relaxation_lower_bound is None


def test_the_correlation_gives_the_frequency_table_s_errors_in_its_order():
    """`Correlation.errors` (the frequency errors of the diagnosis, the screening of candidates
    and `UpdateResult.mean_error`): the per-cent error of each declared frequency in the order
    of the frequency table (a configuration's modes, then its zeros), a zero the model lacks
    (NaN) left out unless asked for, of one kind or of the nominal model when asked."""
    from types import SimpleNamespace

    from vibupdate.inverse.correlation import Correlation

    def datum(w):
        return SimpleNamespace(omega=w)

    cfgs = (SimpleNamespace(natural=(datum(10.0), datum(20.0)), antiresonances=(datum(15.0),)),
            SimpleNamespace(natural=(datum(30.0),), antiresonances=(datum(40.0),)))
    updated = (SimpleNamespace(natural=np.array([11.0, 19.0]), antiresonances=np.array([np.nan])),
               SimpleNamespace(natural=np.array([33.0]), antiresonances=np.array([38.0])))
    nominal = (SimpleNamespace(natural=np.array([10.0, 22.0]), antiresonances=np.array([15.0])),
               SimpleNamespace(natural=np.array([30.0]), antiresonances=np.array([40.0])))
    c = Correlation(cfgs, np.zeros(1), nominal, updated)
    np.testing.assert_allclose(c.errors(), [10.0, 5.0, 10.0, 5.0])
    every = c.errors(finite=False)
    assert every.size == 5 and np.isnan(every[2])
    np.testing.assert_allclose(c.errors("natural"), [10.0, 5.0, 10.0])
    np.testing.assert_allclose(c.errors("antiresonance"), [5.0])
    np.testing.assert_allclose(c.errors(which="nominal"), [0.0, 10.0, 0.0, 0.0, 0.0])
    with pytest.raises(ValueError, match="'updated' or 'nominal', got 'both'"):
        c.errors(which="both")


def test_a_start_that_reaches_an_answer_tried_already_ends_there():
    """No parameter set fits data with one shape entry 10 % off in every mode: every start of
    the search polishes to the same answer, which does not verify. Each further start ends on
    reaching it again (`vibupdate.inverse.bounded_lsq.SAME_ANSWER`, as in the uniqueness
    search) instead of converging on it once more; the answer is the homotopy's."""
    from helpers import biased_chain
    from vibupdate import ShapeInterval

    model, freqs, shapes = biased_chain("y3", 0.10, 0.005)
    cfg = Configuration("A", model, tuple(NaturalFrequency.from_hz(f, shape=ShapeInterval.from_values(s, 0.005))
                                          for f, s in zip(freqs, shapes)))
    result = update([cfg])
    assert result.status == Status.NOT_VERIFIED, result.message
    assert [(s.start, s.status) for s in result.sought.starts] == [
        ("homotopy", "not_verified"), ("stepped homotopy path", "same answer"), ("nominal point", "same answer"),
        ("random start 1", "same answer"), ("random start 2", "same answer")]
    assert result.message.startswith("solved (lambda = 1) but not verified"), result.message


def test_antiresonances_alone_on_a_craig_bampton_model_are_solved():
    """No natural frequency to compare the reduced model's with: the reduction's error is 0, and
    the update of the reduced model runs to a verified answer of its exact zero."""
    from vibupdate import FormulationOptions

    model = chain_model(5, ["k1", "k3", "m2", "m5"])
    truth = {"k1": 1100.0, "k3": 900.0, "m2": 1.15, "m5": 0.85}
    M, K, _, _ = exact(model, truth)
    zeros = antiresonances(M, K, model.dof("y1"), model.dof("y3"))
    cfg = Configuration("Z", model, (), (Antiresonance(zeros[0], "y1", "y3"),))   # the nominal model has one
    result = update([cfg], formulation=FormulationOptions(reduction="craig-bampton", reduction_modes=2))
    assert result.problem_size["reduced_dofs"] < model.n_dofs
    assert result.status.ok and result.verdict.value in ("verified", "not_unique"), result.message
