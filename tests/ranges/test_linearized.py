"""Linearized parameter ranges (`vibupdate.ranges.identifiability.parameter_ranges`)."""

import numpy as np


def test_point_data_give_finite_ranges_that_hold_the_truth():
    """Exact data as points (shape intervals of zero width) on the frame refined 8 times (305
    DOFs, 29 parameters, sensitivity condition 7.2e5): every range is finite and holds the
    truth. Before the LP's rows were scaled by their half-widths and solved for the step from
    the answer, HiGHS reported all 58 programs infeasible and every range was NaN."""
    from vibupdate.examples import frame
    from vibupdate.ranges.identifiability import parameter_ranges

    frequencies, shapes = frame.generate(frequency_error=0.0, shape_error=0.0, subdivisions=8)
    shapes = [{**s, "tolerance": 0.0} for s in shapes]
    configurations = frame.configurations(frequencies, shapes, 8)
    model = configurations[0].model
    truth = np.array([frame.truth()[p.name] for p in model.parameters])
    found = parameter_ranges(configurations, model.normalized(truth), frequency_tolerance=1e-4)
    assert np.all(np.isfinite(found.lower)) and np.all(np.isfinite(found.upper))
    span = np.abs(truth) + 1e-12
    assert np.all(found.lower <= truth + 1e-9 * span) and np.all(truth <= found.upper + 1e-9 * span)
    assert np.any(found.upper - found.lower > 1e-6 * span)   # the weak directions show
