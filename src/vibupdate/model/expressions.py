"""Values affine in the physical parameters: ``constant + sum_i coefficient_i p_i``.

Element properties (``EI``, ``EA``, ``mass_per_length``) and lumped masses and springs of an
`vibupdate.model.assembly.Assembly` may be given as a `LinearExpression`. Every element matrix
is linear in its properties, so the assembled ``M``, ``K`` are then affine in the parameters by
construction and their parameter matrices (Eqs. 13-14) can be assembled directly
(`vibupdate.model.affine.affine_from_assembly`) instead of differentiated.
"""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class LinearExpression:
    """``constant + sum_i coefficient_i * p[name_i]``: a value affine in the parameters.

    Calling it with a mapping of parameter values (real or complex, for the complex step of
    Eq. 15) gives the value; `coefficients` are the exact derivatives ``d value / d p_i`` in
    physical units (value unit per parameter unit).

    Attributes
    ----------
    constant : float
        The value with every parameter at zero.
    coefficients : tuple of (str, float)
        Parameter name and ``d value / d p`` pairs, each name once.
    """

    constant: float
    coefficients: tuple[tuple[str, float], ...]

    def __call__(self, p):
        return self.constant + sum(c * p[n] for n, c in self.coefficients)

    @property
    def names(self) -> tuple[str, ...]:
        """Names of the parameters the value depends on."""
        return tuple(n for n, _ in self.coefficients)

    def coefficient(self, name: str) -> float:
        """``d value / d p[name]``: 0.0 for a parameter the value does not involve."""
        return sum(c for n, c in self.coefficients if n == name)
