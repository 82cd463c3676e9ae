"""The programs of a range end followed along the valley (`_along_the_valley`): only those
whose answer can move the end are solved."""

import numpy as np
import pytest

from vibupdate.ranges import identifiability


def _follow(monkeypatch, points):
    """Follow the minimum of parameter 0 from the linear end -0.5 with the relinearized
    programs' extremes scripted as ``points`` (every point's own data in the windows); returns
    the end and the counts of data maps, own checks and extremes solved."""
    counts = {"data": 0, "check": 0, "extreme": 0}
    steps = iter(points)

    def data_jacobian(configurations, x):
        counts["data"] += 1
        return None, None

    def holds(A, offset, dx, n_x):   # a point's own check
        counts["check"] += 1
        return True

    def solve(c, A, offset):
        counts["extreme"] += 1
        return np.array([next(steps), 0.0])

    monkeypatch.setattr(identifiability, "data_jacobian", data_jacobian)
    monkeypatch.setattr(identifiability, "_holds", holds)
    xbar = np.zeros(2)
    end = identifiability._along_the_valley(None, xbar, np.array([-0.5, 0.0]), 0, 1.0,
                                            lambda at: (np.zeros((1, 2)), np.zeros(1)), solve)
    return end, counts


def test_points_inside_the_linear_end_are_not_checked_and_the_last_point_needs_no_data(monkeypatch):
    """Constructed: each relinearized extreme lies inside the linear end (the valley bends
    inward): no point could lower the minimum, so no point's own check is solved, and the last
    point, which no extreme follows and no check needs, costs no data map (every program was
    solved before: 4 data maps, 4 checks, 4 extremes)."""
    end, counts = _follow(monkeypatch, [-0.45, -0.42, -0.41])
    assert end == -0.5
    assert counts == {"data": 3, "check": 0, "extreme": 3}


def test_points_beyond_the_end_so_far_are_checked_and_move_it(monkeypatch):
    """Constructed: each relinearized extreme lies beyond the last (the valley bends outward),
    each point consistent: every point after the linear end is checked and the end is the last
    one; the last point's next extreme is not solved."""
    end, counts = _follow(monkeypatch, [-0.55, -0.58, -0.59])
    assert end == pytest.approx(-0.59)
    assert counts == {"data": 4, "check": 3, "extreme": 3}


def test_a_parameter_on_a_null_direction_gets_its_box_without_a_program(monkeypatch):
    """Constructed: a 2-mass chain (k1, k2 within +-30 %) with its first frequency alone
    measured: one datum, two parameters, a null direction in which both move. Both ranges are
    their boxes, as before, and no linear program is solved for them (before: 4 programs and
    the ends followed along the valley, then replaced by the boxes)."""
    from helpers import chain_model

    from vibupdate import Configuration, NaturalFrequency
    from vibupdate.modal.analysis import modes

    solved = []
    real = identifiability.solve_highs
    monkeypatch.setattr(identifiability, "solve_highs", lambda *a, **k: solved.append(1) or real(*a, **k))
    model = chain_model(2, ["k1", "k2"])
    omega, _ = modes(*model.matrices(np.zeros(2)), 1)
    cfg = Configuration("c", model, (NaturalFrequency(omega[0]),))
    found = identifiability.parameter_ranges([cfg], np.zeros(2), frequency_tolerance=0.01)
    lo, hi = model.bounds()
    assert np.allclose(model.normalized(found.lower), lo) and np.allclose(model.normalized(found.upper), hi)
    assert not solved


def test_a_points_own_check_is_the_linear_program_it_replaces():
    """Constructed: programs of 6 data rows, 3 parameters and 2 shapes' scales (each scale in
    its own shape's 2 rows, 2 rows without a scale), at 400 random steps: the check by interval
    intersection (`_holds`) says what a linear program with the step fixed and the scales free
    says, wherever the program's answer is not within 1e-6 of a row's edge."""
    from scipy.optimize import linprog

    rng = np.random.default_rng(3)
    agree = 0
    for _ in range(400):
        A = np.zeros((6, 5))
        A[:, :3] = rng.normal(size=(6, 3))
        A[2:4, 3] = rng.normal(size=2)
        A[4:6, 4] = rng.normal(size=2)
        A[5, 4] = 0.0 if rng.random() < 0.2 else A[5, 4]   # a shape row its scale does not enter
        offset = rng.normal(scale=0.5, size=6)
        dx = rng.normal(scale=0.3, size=3)
        lp = linprog(np.zeros(5), A_ub=np.vstack([A, -A]), b_ub=np.concatenate([1 - offset, 1 + offset]),
                     bounds=[(v, v) for v in dx] + [(None, None)] * 2, method="highs")
        margin = linprog(np.r_[np.zeros(5), -1.0], A_ub=np.hstack([np.vstack([A, -A]), np.ones((12, 1))]),
                         b_ub=np.concatenate([1 - offset, 1 + offset]),
                         bounds=[(v, v) for v in dx] + [(None, None)] * 3, method="highs")
        if abs(margin.fun) < 1e-6:
            continue
        assert identifiability._holds(A, offset, dx, 3) == (lp.status == 0)
        agree += 1
    assert agree > 300


def test_a_point_whose_model_lost_a_datum_does_not_hold():
    """Constructed: a relinearized program whose rows are not finite (a zero or a mode the model
    lacks at that point gives NaN data and slopes). Its own check says it does not hold, whatever
    the other rows say (before, with only rows without a scale, a NaN row passed every
    comparison); finite rows that hold still do."""
    A = np.array([[1.0, 0.0], [np.nan, 1.0]])
    assert not identifiability._holds(A, np.zeros(2), np.zeros(2), 2)
    assert not identifiability._holds(np.eye(2), np.array([0.0, np.nan]), np.zeros(2), 2)
    assert identifiability._holds(np.eye(2), np.zeros(2), np.zeros(2), 2)
