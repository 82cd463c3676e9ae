"""Linearized parameter ranges (`vibupdate.ranges.identifiability.parameter_ranges`)."""

import numpy as np


def test_point_data_give_finite_ranges_that_hold_the_truth():
    """Exact data as points (shape intervals of zero width) on the frame refined 8 times (305
    DOFs, 29 parameters, sensitivity condition 7.2e5): every range is finite and holds the
    truth. Before the LP's rows were scaled by their half-widths and solved for the step from
    the answer, HiGHS reported all 58 programs infeasible and every range was NaN."""
    import frame_data
    from vibupdate.examples import frame
    from vibupdate.ranges.identifiability import parameter_ranges

    frequencies, shapes = frame_data.generate(frequency_error=0.0, shape_error=0.0, subdivisions=8)
    shapes = [{**s, "tolerance": 0.0} for s in shapes]
    configurations = frame.configurations(frequencies, shapes, 8)
    model = configurations[0].model
    truth = np.array([frame.truth()[p.name] for p in model.parameters])
    found = parameter_ranges(configurations, model.normalized(truth), frequency_tolerance=1e-4)
    assert np.all(np.isfinite(found.lower)) and np.all(np.isfinite(found.upper))
    span = np.abs(truth) + 1e-12
    assert np.all(found.lower <= truth + 1e-9 * span) and np.all(truth <= found.upper + 1e-9 * span)
    assert np.any(found.upper - found.lower > 1e-6 * span)   # the weak directions show


def test_the_ranges_hold_every_point_whose_data_lie_in_the_windows_where_the_set_bends():
    """A 2-mass chain (k1, k2 within +-60 %) at its nominal point, both frequencies known to
    +-5 %: the parameters whose frequencies lie in those windows form a bent band. Scanned on a
    161 x 161 grid of the box, k1 reaches its upper bound (+0.6) and k2 goes down to -0.42; the
    tangent at the answer stopped both at +-0.224, so the ranges left out data-consistent
    models. Followed along the set by relinearized programs, the ranges hold every grid point."""
    from helpers import chain_model

    from vibupdate import Configuration, NaturalFrequency
    from vibupdate.modal.analysis import modes
    from vibupdate.ranges.identifiability import parameter_ranges

    model = chain_model(2, ["k1", "k2"], spread=0.6)
    omega, _ = modes(*model.matrices(np.zeros(2)), 2)
    cfg = Configuration("c", model, tuple(NaturalFrequency(w) for w in omega))
    found = parameter_ranges([cfg], np.zeros(2), frequency_tolerance=0.05)
    lo, hi = model.bounds()
    grid = np.linspace(lo[0], hi[0], 161)
    X = np.stack(np.meshgrid(grid, grid, indexing="ij"), axis=-1).reshape(-1, 2)
    k1, k2 = model.physical(X).T                       # unit masses: K = [[k1 + k2, -k2], [-k2, k2]]
    K = np.stack([np.stack([k1 + k2, -k2], -1), np.stack([-k2, k2], -1)], -2)
    w = np.sqrt(np.linalg.eigvalsh(K))
    np.testing.assert_allclose(w[80 * 161 + 80], omega, rtol=1e-12)   # the grid's centre is the answer
    inside = X[np.all(np.abs(w / omega - 1) <= 0.05, axis=1)]
    lower, upper = model.normalized(found.lower), model.normalized(found.upper)
    step = grid[1] - grid[0]
    assert np.all(inside.min(axis=0) >= lower - step) and np.all(inside.max(axis=0) <= upper + step)


def test_where_the_warm_simplex_fails_the_interior_point_method_gives_the_same_ranges(monkeypatch):
    """The ranges' programs go to HiGHS's simplex from a kept basis (`vibupdate.ranges.highs`);
    where it does not report an optimum, the interior-point method on the one-sided form solves
    the same program. Constructed: a 3-mass chain (k1, k2, k3 within +-30 %) with its three
    frequencies known to +-1 %: with every simplex solve made to fail, every range is the one the
    simplex gives, to the solvers' tolerances, and the fallback ran for each of the 6 programs."""
    from helpers import chain_model

    from vibupdate import Configuration, NaturalFrequency
    from vibupdate.modal.analysis import modes
    from vibupdate.ranges import identifiability

    model = chain_model(3, ["k1", "k2", "k3"])
    omega, _ = modes(*model.matrices(np.zeros(3)), 3)
    cfg = Configuration("c", model, tuple(NaturalFrequency(w) for w in omega))
    simplex = identifiability.parameter_ranges([cfg], np.zeros(3), frequency_tolerance=0.01)
    fallbacks = []
    real = identifiability.linprog
    monkeypatch.setattr(identifiability, "solve_highs", lambda h, c: False)
    monkeypatch.setattr(identifiability, "linprog", lambda *a, **k: fallbacks.append(1) or real(*a, **k))
    interior = identifiability.parameter_ranges([cfg], np.zeros(3), frequency_tolerance=0.01)
    assert len(fallbacks) >= 6
    width = simplex.upper - simplex.lower
    assert np.all(width > 0)
    assert np.allclose(interior.lower, simplex.lower, rtol=0, atol=1e-6 * width.max())
    assert np.allclose(interior.upper, simplex.upper, rtol=0, atol=1e-6 * width.max())
