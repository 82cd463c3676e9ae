"""The homotopy's step control on a scripted backend (no solver): which lambdas it tries."""

from types import SimpleNamespace

import numpy as np

from vibupdate.inverse import homotopy
from vibupdate.inverse.backends import StepOutcome
from vibupdate.inverse.status import Status


class Problem(SimpleNamespace):
    """What the homotopy reads of a problem (a class, so that the relaxation cache can refer to it)."""


class Scripted:
    """A backend whose steps no longer than ``reach`` succeed and longer ones fail (deterministic,
    as a solve from the same point to the same lambda is)."""

    def __init__(self, reach):
        self.reach, self.at, self.tried = reach, 0.0, []

    def join(self, x, u, t, r):
        return np.zeros(1)

    def split(self, z):
        return np.zeros(1), np.zeros(0), np.zeros(0), None

    def solve(self, z, lam, prox_weight=0.0, z_prev=None, warm=False, mult_x=None, mult_g=None):
        self.tried.append(lam)
        ok = lam == 0.0 or lam - self.at <= self.reach
        if ok:
            self.at = lam
        return StepOutcome(np.zeros(1), 0.0, 1, Status.SUCCESS if ok else Status.NUMERICAL_ERROR, "", 0.0,
                           np.zeros(1), np.zeros(1))


def test_a_failed_jump_to_one_is_halved_as_tried_not_repeated(monkeypatch):
    backend = Scripted(reach=0.2)
    monkeypatch.setattr(homotopy, "mccormick", lambda problem: None)
    monkeypatch.setattr(homotopy, "build", lambda problem, envelope, options: backend)
    monkeypatch.setattr(homotopy, "lifted_values", lambda problem, x, u: np.zeros(0))
    problem = Problem(n_x=1, x_lower=np.array([-1.0]), x_upper=np.array([1.0]), u_start=np.zeros(0),
                      objective=lambda x, u: 1.0, residual=lambda x, u: np.zeros(0), identity=lambda: "scripted")
    result = homotopy.solve_homotopy(problem, homotopy.SolverOptions())
    assert result.status == Status.SUCCESS and result.lam == 1.0
    # the default direct jump, grown back to 1 after each success and clipped at lambda = 1:
    # a failed attempt is never made again from the same point (the same solve, the same failure)
    attempts, at = [], 0.0
    for s in result.steps[1:]:
        attempts.append((at, s.lam, s.cold))
        if s.status.ok:
            at = s.lam
    assert len(attempts) == len(set(attempts)), attempts
