"""Updating parameters and their normalization, paper Section 3.2, Eq. 12 (docs/method.md, section
2): ``xbar = (p - p0) / p_ref``, ``p0`` the nominal value and ``p_ref`` the nominal, or a value the
user chooses inside the bounds when the nominal is zero; ``xbar = 0`` is the nominal model.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Parameter:
    """One updating parameter.

    Attributes
    ----------
    name : str
        Identifier used in data, reports and result files.
    nominal : float
        Value in the nominal model, in ``unit``.
    lower, upper : float
        Bounds of the updated value, ``lower <= nominal <= upper``.
    unit : str
        SI unit of the value, for reports (``"Pa"``, ``"kg/m^3"``).
    reference : float, optional
        Normalization value ``p_ref`` of Eq. 12, in ``unit``. Defaults to the nominal; required
        when the nominal is 0.

    Raises
    ------
    ValueError
        A bound or the nominal is not finite, the nominal lies outside the bounds, or the
        nominal is 0 and no non-zero reference is given.
    """

    name: str
    nominal: float
    lower: float
    upper: float
    unit: str = ""
    reference: float | None = None

    def __post_init__(self):
        if not isinstance(self.name, str) or not self.name:
            raise ValueError(f"parameter name must be a non-empty string, got {self.name!r}")
        for field in ("nominal", "lower", "upper"):
            value = getattr(self, field)
            if not isinstance(value, (int, float, np.floating, np.integer)) or not math.isfinite(value):
                raise ValueError(f"parameter '{self.name}': {field} must be a finite number, got {value!r}")
            object.__setattr__(self, field, float(value))
        if self.lower > self.upper:
            raise ValueError(
                f"parameter '{self.name}': lower bound {self.lower:g} > upper bound {self.upper:g}"
            )
        if not self.lower <= self.nominal <= self.upper:
            raise ValueError(
                f"parameter '{self.name}': nominal {self.nominal:g} is outside its bounds "
                f"[{self.lower:g}, {self.upper:g}]"
            )
        if self.reference is None:
            if self.nominal == 0.0:
                raise ValueError(
                    f"parameter '{self.name}' has nominal 0: give a reference value for the "
                    f"normalization (Section 3.2), e.g. a value inside [{self.lower:g}, {self.upper:g}]"
                )
            object.__setattr__(self, "reference", self.nominal)
        else:
            ref = self.reference
            if not isinstance(ref, (int, float, np.floating, np.integer)) or not math.isfinite(ref) or ref == 0:
                raise ValueError(
                    f"parameter '{self.name}': reference must be a finite non-zero number, got {ref!r}"
                )
            object.__setattr__(self, "reference", float(ref))


def _arrays(parameters: Sequence[Parameter]):
    nominal = np.array([p.nominal for p in parameters])
    reference = np.array([p.reference for p in parameters])
    return nominal, reference


def to_normalized(parameters: Sequence[Parameter], values) -> np.ndarray:
    """Physical values, shape (n_x,), to normalized modifications ``xbar`` (Eq. 12)."""
    nominal, reference = _arrays(parameters)
    return (np.asarray(values, dtype=float) - nominal) / reference


def to_physical(parameters: Sequence[Parameter], xbar) -> np.ndarray:
    """Normalized modifications ``xbar``, shape (n_x,), to physical values."""
    nominal, reference = _arrays(parameters)
    return nominal + np.asarray(xbar, dtype=float) * reference


def normalized_bounds(parameters: Sequence[Parameter]) -> tuple[np.ndarray, np.ndarray]:
    """Box of ``xbar``: (lower, upper), each shape (n_x,). A negative reference swaps them."""
    lo = to_normalized(parameters, [p.lower for p in parameters])
    hi = to_normalized(parameters, [p.upper for p in parameters])
    return np.minimum(lo, hi), np.maximum(lo, hi)
