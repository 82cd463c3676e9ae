"""The backend protocol, the CasADi backend's status table, and its cache of compiled solvers
(the homotopy names no solver library; a solver is built once per
structure and process, not once per sample)."""

import ast
import sys
import types
from pathlib import Path

import numpy as np
import pytest

from helpers import chain_model
from sweep_cases import write_chain_case
from vibupdate import Configuration, NaturalFrequency, modes
from vibupdate.inverse import backends
from vibupdate.inverse.backends import casadi_ipopt
from vibupdate.inverse.backends.casadi_ipopt import CACHE, IPOPT_STATUS, CasadiIpopt, from_ipopt
from vibupdate.inverse.homotopy import SolverOptions, solve_homotopy
from vibupdate.inverse.relaxation import lifted_values, mccormick
from vibupdate.inverse.status import Status
from vibupdate.inverse.update import prepare, update

SRC = Path(__file__).resolve().parents[2] / "src" / "vibupdate"
TRUTH = {"k1": 1100.0, "k3": 900.0, "m2": 1.15, "m5": 0.85}


def chain_configuration(truth, noise=0.0, seed=0):
    model = chain_model(5, list(TRUTH))
    M, K = model.matrices_at([truth[p.name] for p in model.parameters])
    omega, _ = modes(M, K)
    omega = omega * (1 + noise * np.random.default_rng(seed).standard_normal(omega.size))
    return Configuration("C", model, tuple(NaturalFrequency(w) for w in np.sort(omega)[:4]))


def test_the_homotopy_names_no_solver_library():
    tree = ast.parse((SRC / "inverse" / "homotopy.py").read_text(encoding="utf-8"))
    imported = {node.module for node in ast.walk(tree) if isinstance(node, ast.ImportFrom)}
    imported |= {a.name for node in ast.walk(tree) if isinstance(node, ast.Import) for a in node.names}
    assert "vibupdate.inverse.backends" in imported
    assert not any("casadi" in name for name in imported), imported


def test_ipopt_codes_map_to_the_one_status_enum():
    assert all(isinstance(s, Status) for s in IPOPT_STATUS.values())
    assert from_ipopt("Solve_Succeeded") == Status.SUCCESS
    assert from_ipopt("Maximum_Iterations_Exceeded") == Status.MAX_ITERATIONS
    assert from_ipopt("a code IPOPT may add later") == Status.NUMERICAL_ERROR


def test_an_unknown_backend_is_named_in_the_error():
    with pytest.raises(ValueError, match="solver.backend: must be one of .*'casadi-ipopt'.*got 'gurobi'"):
        SolverOptions(backend="gurobi")


class _Wrapping:
    """A step solver that delegates to the CasADi one; tests override ``solve``."""

    def __init__(self, inner):
        self.inner = inner

    def join(self, *parts):
        return self.inner.join(*parts)

    def split(self, z):
        return self.inner.split(z)


def test_the_homotopy_uses_the_backend_chosen_by_name(monkeypatch):
    """A backend registered under another name is the one the path calls, through the protocol
    alone; here it wraps the CasADi one and counts the solves, so the answer is the same."""
    calls = []

    class Counting(_Wrapping):

        def solve(self, z0, lam, **kwargs):
            calls.append((lam, kwargs.get("warm", False)))
            return self.inner.solve(z0, lam, **kwargs)

    module = types.ModuleType("counting_backend")
    module.build = lambda problem, envelope, options: Counting(casadi_ipopt.build(problem, envelope, options))
    monkeypatch.setitem(sys.modules, "counting_backend", module)
    monkeypatch.setitem(backends.BACKENDS, "counting", "counting_backend")
    problem = prepare([chain_configuration(TRUTH)])
    counted = solve_homotopy(problem, SolverOptions(backend="counting"))
    plain = solve_homotopy(problem, SolverOptions())
    assert len(calls) == len(counted.steps) >= 2
    assert calls[0] == (0.0, False) and calls[-1][0] == 1.0 and calls[-1][1]
    np.testing.assert_allclose(counted.x, plain.x, atol=1e-10)


def test_a_second_problem_of_the_same_structure_reuses_the_compiled_solver():
    """Two data sets of one model (two sweep samples): one build, and the second answer equals
    that of a solver compiled for it alone (the data really are parameters of the NLP)."""
    first = chain_configuration(TRUTH)
    second = chain_configuration(TRUTH, noise=0.01, seed=3)
    builds = CACHE.builds
    update([first])
    after_first = CACHE.builds
    assert after_first - builds <= 1  # 0 when an earlier test compiled this structure already
    hits = CACHE.hits
    result = update([second])
    assert CACHE.builds == after_first
    assert CACHE.hits > hits

    problem = prepare([second])
    shared = CasadiIpopt(problem, mccormick(problem))
    private = CasadiIpopt(problem, mccormick(problem), cache=None)
    assert shared._compiled is not private._compiled
    x0 = np.zeros(problem.n_x)
    z0 = shared.join(x0, problem.u_start, lifted_values(problem, x0, problem.u_start),
                     problem.residual(x0, problem.u_start))
    a, b = shared.solve(z0, 1.0), private.solve(z0, 1.0)
    assert a.status.ok and b.status.ok
    np.testing.assert_allclose(a.z, b.z, rtol=0, atol=1e-12)
    assert result.success


def test_sx_and_mx_builds_solve_alike():
    """The default MX build and the SX build with expansion are the same NLP (the lam = 0
    step by IPOPT too, not by the QP solver)."""
    problem = prepare([chain_configuration(TRUTH, noise=0.01, seed=5)])
    mx = CasadiIpopt(problem, mccormick(problem), cache=None, relaxation_solver="nlp")
    sx = CasadiIpopt(problem, mccormick(problem), expand=True, cache=None, relaxation_solver="nlp")
    x0 = np.zeros(problem.n_x)
    z0 = mx.join(x0, problem.u_start, lifted_values(problem, x0, problem.u_start),
                 problem.residual(x0, problem.u_start))
    for lam in (0.0, 1.0):
        a, b = mx.solve(z0, lam), sx.solve(z0, lam)
        assert a.status.ok and b.status.ok
        assert a.objective == pytest.approx(b.objective, rel=1e-8, abs=1e-14)
        np.testing.assert_allclose(a.z, b.z, atol=1e-8)


def test_a_lambda_one_outcome_has_the_lifted_layout():
    """At lambda = 1 the backend solves the NLP without t; the outcome still has t = xbar u and
    zero multipliers for t and the McCormick rows, and a warm restart from it works."""
    problem = prepare([chain_configuration(TRUTH, noise=0.01, seed=5)])
    backend = CasadiIpopt(problem, mccormick(problem))
    x0 = np.zeros(problem.n_x)
    z0 = backend.join(x0, problem.u_start, lifted_values(problem, x0, problem.u_start),
                      problem.residual(x0, problem.u_start))
    out = backend.solve(z0, 1.0)
    x, u, t, R = backend.split(out.z)
    assert out.status.ok and out.z.size == z0.size
    np.testing.assert_allclose(t, lifted_values(problem, x, u), rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(R, problem.residual(x, u), atol=1e-9)
    n_x, n_u, n_b, n_r = backend.sizes
    assert not np.any(out.mult_x[n_x + n_u:n_x + n_u + n_b]) and not np.any(out.mult_g[n_r:])
    again = backend.solve(out.z, 1.0, warm=True, mult_x=out.mult_x, mult_g=out.mult_g)
    assert again.status.ok and again.objective <= out.objective * (1 + 1e-8) + 1e-15


def test_another_structure_gets_its_own_solver():
    model = chain_model(5, list(TRUTH))
    M, K = model.matrices_at([TRUTH[p.name] for p in model.parameters])
    omega, _ = modes(M, K)
    three = Configuration("C", model, tuple(NaturalFrequency(w) for w in omega[:3]))
    prepare_four = prepare([chain_configuration(TRUTH)])
    prepare_three = prepare([three])
    a = CasadiIpopt(prepare_four, mccormick(prepare_four))
    builds = CACHE.builds
    b = CasadiIpopt(prepare_three, mccormick(prepare_three))
    assert b._compiled is not a._compiled
    assert CACHE.builds in (builds, builds + 1)
    assert CasadiIpopt(prepare_three, mccormick(prepare_three))._compiled is b._compiled


def test_sweep_samples_of_one_case_build_the_solver_once(tmp_path):
    """The compiled solver is built once per worker process, not once per task."""
    from vibupdate.io.case import load_case
    from vibupdate.study.sampling import SamplingOptions
    from vibupdate.study.sweep import run_sample

    case = load_case(write_chain_case(tmp_path / "case.toml"))
    sampling = SamplingOptions()
    run_sample(case, 0, 7, sampling)
    builds = CACHE.builds
    rows = [run_sample(case, i, 7, sampling) for i in (1, 2)]
    assert CACHE.builds == builds, "a later sample of the same case compiled a solver again"
    assert all(r["outcome"] != "failed" for r in rows)


def test_run_builds_the_problem_once(tmp_path, monkeypatch):
    """`vibupdate run` validates the case by building its problem; the update uses that one."""
    import vibupdate.inverse.update as update_module
    from vibupdate.io.case import load_case
    from vibupdate.pipeline import run_case

    original = update_module.formulate
    calls = []

    def counting(*args, **kwargs):
        calls.append(1)
        return original(*args, **kwargs)

    monkeypatch.setattr(update_module, "formulate", counting)
    case = load_case(write_chain_case(tmp_path / "case.toml"))
    run_case(case, tmp_path / "out")
    assert len(calls) == 1


def _kkt_violation(problem, envelope, backend, out):
    """Largest violation of the lam = 0 QP's optimality conditions at ``out``, with the
    multipliers in the NLP backends' convention: grad f + J_g' mult_g + mult_x = 0 for
    ``g = [R - A_x xbar - A_u u - A_b t - r0; G [xbar; u; t]]``, feasibility, and each
    multiplier's sign and complementarity with its bound."""
    import scipy.sparse as sp

    n_x, n_u, n_b, n_r = backend.sizes
    x, u, t, R = backend.split(out.z)
    J = sp.vstack([sp.hstack([-problem.A_x, -problem.A_u, -problem.A_b, sp.eye(n_r)]),
                   sp.hstack([envelope.G, sp.csr_matrix((4 * n_b, n_r))])]).tocsr()
    grad = np.concatenate([np.zeros(n_x + n_u + n_b), 2 * problem.row_weight * R])
    stationarity = np.abs(grad + J.T @ out.mult_g + out.mult_x).max()
    rows = envelope.G @ np.concatenate([x, u, t])
    residual = np.abs(R - (problem.A_x @ x + problem.A_u @ u + problem.A_b @ t + problem.r0)).max()
    rows_out = max(np.max(envelope.lower - rows, initial=0), np.max(rows - envelope.upper, initial=0))
    m_rows = out.mult_g[n_r:]
    # a positive multiplier pushes against an upper limit, a negative one against a lower one
    slack_rows = np.where(m_rows > 0, envelope.upper - rows, rows - envelope.lower)
    slack_box = np.where(out.mult_x > 0, backend._ubx - out.z, out.z - backend._lbx)
    complementarity = max(np.max(np.abs(m_rows) * np.minimum(slack_rows, 1.0), initial=0),
                          np.max(np.abs(out.mult_x) * np.minimum(slack_box, 1.0), initial=0))
    return max(stationarity, residual, rows_out, complementarity)


@pytest.mark.parametrize("boxes", ["formulation", "tight"])
def test_the_relaxation_qp_meets_the_optimality_conditions_and_matches_ipopt(boxes):
    """The lam = 0 step by the QP solver: its point and multipliers satisfy the QP's KKT
    conditions in the NLP convention (so IPOPT can start warm from them), and its optimum is
    IPOPT's on the same QP. "tight": parameter boxes that exclude the truth, so that the
    relaxation's optimum is positive and the comparison is not one of two zeros."""
    from dataclasses import replace

    problem = prepare([chain_configuration(TRUTH, noise=0.01, seed=5)])
    if boxes == "tight":
        problem = replace(problem, x_lower=np.full(problem.n_x, 0.3), x_upper=np.full(problem.n_x, 0.4))
    envelope = mccormick(problem)
    qp = CasadiIpopt(problem, envelope, cache=None)
    nlp = CasadiIpopt(problem, envelope, cache=None, relaxation_solver="nlp")
    x0 = np.clip(np.zeros(problem.n_x), problem.x_lower, problem.x_upper)
    z0 = qp.join(x0, problem.u_start, lifted_values(problem, x0, problem.u_start), problem.residual(x0, problem.u_start))
    a, b = qp.solve(z0, 0.0), nlp.solve(z0, 0.0)
    assert a.status == Status.SUCCESS and a.raw_status == "PIQP_SOLVED"
    assert b.status.ok and not b.raw_status.startswith("PIQP")
    scale = max(1.0, np.abs(a.mult_g).max(), np.abs(a.mult_x).max())
    assert _kkt_violation(problem, envelope, qp, a) <= 1e-7 * scale
    if boxes == "tight":
        assert b.objective > 1e-6
    assert a.objective == pytest.approx(b.objective, rel=1e-6, abs=1e-14)
    warm = qp.solve(a.z, 1.0, warm=True, mult_x=a.mult_x, mult_g=a.mult_g)
    cold = qp.solve(a.z, 1.0)
    assert warm.status.ok and warm.objective == pytest.approx(cold.objective, rel=1e-6, abs=1e-14)


def test_a_failed_relaxation_qp_falls_back_to_ipopt(monkeypatch):
    """When PIQP does not report success the lam = 0 step is solved by IPOPT; the record names both."""
    from vibupdate.inverse.backends import piqp_relaxation

    problem = prepare([chain_configuration(TRUTH, noise=0.01, seed=5)])
    backend = CasadiIpopt(problem, mccormick(problem), cache=None, max_iter=50)
    backend._qp.max_iter = 1
    x0 = np.zeros(problem.n_x)
    z0 = backend.join(x0, problem.u_start, lifted_values(problem, x0, problem.u_start),
                      problem.residual(x0, problem.u_start))
    out = backend.solve(z0, 0.0)
    assert out.status.ok
    assert out.raw_status == "Solve_Succeeded (after PIQP: PIQP_MAX_ITER_REACHED)"
    assert piqp_relaxation.PIQP_STATUS["PIQP_MAX_ITER_REACHED"] == Status.MAX_ITERATIONS
    assert all(isinstance(s, Status) for s in piqp_relaxation.PIQP_STATUS.values())


def test_an_unknown_relaxation_solver_is_named_in_the_error():
    with pytest.raises(ValueError, match="solver.relaxation_solver: must be 'piqp' or 'nlp', got 'osqp'"):
        SolverOptions(relaxation_solver="osqp")


def test_a_failed_direct_jump_falls_back_to_halved_steps(monkeypatch):
    """The default path jumps from the relaxation to lam = 1; when that solve fails (warm, and
    again cold) the step is halved and the path goes on through the lifted problem, reaching
    the stepped path's answer."""
    from dataclasses import replace

    problem = prepare([chain_configuration(TRUTH, noise=0.01, seed=5)])
    failures = []

    class FirstJumpFails(_Wrapping):

        def solve(self, z0, lam, **kwargs):
            out = self.inner.solve(z0, lam, **kwargs)
            if lam == 1.0 and len(failures) < 2:
                failures.append(kwargs.get("warm", False))
                return replace(out, status=Status.NUMERICAL_ERROR, raw_status="Restoration_Failed")
            return out

    module = types.ModuleType("first_jump_fails")
    module.build = lambda problem, envelope, options: FirstJumpFails(casadi_ipopt.build(problem, envelope, options))
    monkeypatch.setitem(sys.modules, "first_jump_fails", module)
    monkeypatch.setitem(backends.BACKENDS, "first-jump-fails", "first_jump_fails")
    path = solve_homotopy(problem, SolverOptions(backend="first-jump-fails"))
    assert failures == [True, False]  # warm, then the cold retry
    assert [(s.lam, s.status.ok) for s in path.steps] == [(0.0, True), (1.0, False), (1.0, False), (0.5, True),
                                                          (1.0, True)]
    # a step's outcome is its status, said once (no flag beside it that repeats status.ok)
    keys = {"lambda", "objective", "iterations", "status", "seconds", "cold", "reused"}
    assert set(path.steps[0].as_dict()) == keys
    assert path.status == Status.SUCCESS
    stepped = solve_homotopy(problem, SolverOptions(n_lambda=10))
    assert [s.lam for s in stepped.steps] == pytest.approx([0.0, 0.1, 0.3, 0.7, 1.0])
    assert path.objective == pytest.approx(stepped.objective, rel=1e-6, abs=1e-14)


def test_a_piqp_exception_is_a_status_and_ipopt_takes_over(monkeypatch):
    import piqp

    class Broken:
        def __init__(self):
            self.settings = types.SimpleNamespace()

        def setup(self, *args):
            raise ValueError("P must be square")

    monkeypatch.setattr(piqp, "SparseSolver", Broken)
    problem = prepare([chain_configuration(TRUTH, noise=0.01, seed=5)])
    backend = CasadiIpopt(problem, mccormick(problem), cache=None)
    x0 = np.zeros(problem.n_x)
    z0 = backend.join(x0, problem.u_start, lifted_values(problem, x0, problem.u_start),
                      problem.residual(x0, problem.u_start))
    relaxed = backend._qp.solve()
    assert relaxed.status == Status.NUMERICAL_ERROR and relaxed.raw_status == "PIQP error: P must be square"
    out = backend.solve(z0, 0.0)
    assert out.status.ok and out.raw_status.endswith("(after PIQP: PIQP error: P must be square)")


def test_the_identical_relaxation_is_solved_once(monkeypatch):
    """The stepped path's restart walks from the same lambda = 0 problem as the direct jump:
    its relaxation is re-used, not solved again (counted at the QP solver)."""
    from vibupdate.inverse.backends.piqp_relaxation import RelaxationQP

    solves = []
    original = RelaxationQP.solve

    def counted(self):
        solves.append(self)
        return original(self)

    monkeypatch.setattr(RelaxationQP, "solve", counted)
    problem = prepare([chain_configuration(TRUTH, noise=0.01, seed=3)])
    direct = solve_homotopy(problem, SolverOptions())
    stepped = solve_homotopy(problem, SolverOptions(n_lambda=10))   # what the restart does
    assert len(solves) == 1
    assert [s.reused for s in direct.steps[:1] + stepped.steps[:1]] == [False, True]
    assert stepped.lower_bound == direct.lower_bound and stepped.steps[0].seconds == 0.0
    other = prepare([chain_configuration(TRUTH, noise=0.01, seed=4)])   # another problem: solved
    solve_homotopy(other, SolverOptions())
    assert len(solves) == 2
