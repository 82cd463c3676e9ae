import numpy as np
import pytest

from vibupdate.model.parameters import Parameter, normalized_bounds, to_normalized, to_physical


def test_normalization_round_trip_eq12():
    params = [Parameter("E", 55e9, 50e9, 70e9, unit="Pa"), Parameter("J", 0.0, 0.0, 5e-4, reference=2.5e-4)]
    values = np.array([60e9, 1e-4])
    xbar = to_normalized(params, values)
    np.testing.assert_allclose(xbar, [(60e9 - 55e9) / 55e9, 1e-4 / 2.5e-4])
    np.testing.assert_allclose(to_physical(params, xbar), values)
    lo, hi = normalized_bounds(params)
    np.testing.assert_allclose(lo, [-5 / 55, 0.0])
    np.testing.assert_allclose(hi, [15 / 55, 2.0])


@pytest.mark.parametrize(
    "kwargs, message",
    [
        (dict(name="E", nominal=1.0, lower=2.0, upper=1.0), "lower bound 2 > upper bound 1"),
        (dict(name="E", nominal=3.0, lower=1.0, upper=2.0), "nominal 3 is outside its bounds"),
        (dict(name="J", nominal=0.0, lower=0.0, upper=1.0), "give a reference value"),
        (dict(name="E", nominal=float("nan"), lower=0.0, upper=1.0), "nominal must be a finite number"),
        (dict(name="E", nominal=1.0, lower=0.0, upper=2.0, reference=0.0), "reference must be"),
    ],
)
def test_bad_parameters_are_named(kwargs, message):
    with pytest.raises(ValueError, match=message):
        Parameter(**kwargs)
