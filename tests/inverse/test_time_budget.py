"""The homotopy's time budget (`SolverOptions.time_budget`) and the progress of long solves."""

import numpy as np
import pytest
from helpers import chain_model

import vibupdate as vu
from vibupdate import Configuration, NaturalFrequency, modes
from vibupdate.inverse.backends import casadi_ipopt
from vibupdate.inverse.homotopy import SolverOptions, solve_homotopy
from vibupdate.inverse.status import Status
from vibupdate.inverse.update import prepare


TRUTH = {"k1": 1100.0, "k3": 900.0, "m2": 1.15, "m5": 0.85}


def chain_configuration(truth, noise=0.0, seed=0):
    """Four frequencies of a 5-mass chain at ``truth``, with relative noise."""
    model = chain_model(5, list(TRUTH))
    omega = modes(*model.matrices_at([truth[p.name] for p in model.parameters]))[0]
    omega = omega * (1 + noise * np.random.default_rng(seed).standard_normal(omega.size))
    return Configuration("C", model, tuple(NaturalFrequency(w) for w in np.sort(omega)[:4]))


@pytest.fixture(scope="module")
def problem():
    return prepare([chain_configuration(TRUTH, noise=0.01, seed=11)])


def test_a_spent_budget_stops_the_path_at_its_last_point(problem):
    said = []
    path = solve_homotopy(problem, SolverOptions(time_budget=1e-9), progress=said.append)
    assert path.status == Status.TIME_LIMIT and path.lam == 0.0
    assert [s.lam for s in path.steps] == [0.0]       # the relaxation, then no step, no retry, no halving
    assert any("time budget of 1e-09 s spent" in line for line in said)


def test_ipopt_is_stopped_between_iterations_when_the_budget_is_spent(problem):
    path = solve_homotopy(problem, SolverOptions(time_budget=1e-9, relaxation_solver="nlp", max_iter=77))
    assert path.status == Status.TIME_LIMIT
    first = path.steps[0]
    assert first.status == Status.TIME_LIMIT and first.iterations <= 1


def test_a_long_solve_says_its_iterations_and_the_time_left(problem, monkeypatch):
    monkeypatch.setattr(casadi_ipopt, "PROGRESS_AFTER", 0.0)
    monkeypatch.setattr(casadi_ipopt, "PROGRESS_EVERY", 0.0)
    said = []
    path = solve_homotopy(problem, SolverOptions(relaxation_solver="nlp", max_iter=79), progress=said.append)
    assert path.status.ok
    lines = [line for line in said if "iteration" in line and "left of the time budget" in line]
    assert lines and lines[0].strip().startswith("lambda = 0.0000: iteration 1, objective")


def test_update_goes_on_to_the_further_starts_and_says_why(problem):
    cfg = chain_configuration(TRUTH, noise=0.0, seed=0)
    result = vu.update([cfg], solver=SolverOptions(time_budget=1e-9))
    assert "time_limit" in result.message
    assert result.success                  # the polish from the further starts still finds the answer
    np.testing.assert_allclose(result.values, list(TRUTH.values()), rtol=1e-6)


def test_the_budget_is_an_option_of_the_case_file():
    from vibupdate.options import problem as refused

    assert refused("solver", "time_budget", 0.0) == "solver.time_budget: must be finite and > 0, got 0.0"
    assert SolverOptions().time_budget == 300.0


def test_a_failed_stepped_path_counts_its_solves_once(monkeypatch):
    """The result's seconds add the path's solves (``steps``) and the starts: the stepped path's
    start leaves out the solves its steps already count, also when the path fails."""
    import time
    from dataclasses import replace

    from vibupdate.inverse import update as update_module

    def slow(problem, options, progress=None):   # every solve 0.5 s longer, and its steps say so
        path = solve_homotopy(problem, options, progress=progress)
        time.sleep(0.5)
        steps = path.steps[:-1] + (replace(path.steps[-1], seconds=path.steps[-1].seconds + 0.5),)
        return replace(path, steps=steps)

    monkeypatch.setattr(update_module, "solve_homotopy", slow)
    result = vu.update([chain_configuration(TRUTH)], solver=SolverOptions(time_budget=1e-9))
    stepped = result.restarts[0]
    assert stepped.start == "stepped homotopy path" and stepped.status == "path failed"
    assert stepped.seconds < 0.25                    # the 0.5 s are in the path's steps only
    assert sum(s.seconds for s in result.steps) >= 1.0   # the direct and the stepped path's
