"""An `Assembly` with properties that are linear expressions of the parameters: evaluated at
parameter values (`Assembly.system`) and assembled directly into the affine form
(`affine_from_assembly`)."""

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from vibupdate import Assembly, Parameter, from_builder
from vibupdate.model.affine import affine_from_assembly
from vibupdate.model.expressions import LinearExpression

PARAMETERS = [Parameter("a", 2.0, 1.0, 3.0), Parameter("b", 5.0, 4.0, 8.0), Parameter("c", 0.5, 0.1, 1.0)]


def _assembly(coefs):
    """A three-element beam, clamped and pinned, with a tip mass and a spring; ``coefs`` (6, 3)
    are the parameter coefficients of the six values, each with a positive constant."""
    e = [LinearExpression(10.0 + i, tuple(zip("abc", row))) for i, row in enumerate(coefs)]
    asm = Assembly("beam")
    asm.nodes([1, 2, 3, 4], [0.0, 0.3, 0.7, 1.0])
    asm.beams([1, 2], [2, 3], EI=e[0], mass_per_length=e[1])
    asm.beam(3, 4, EI=e[2], mass_per_length=0.8)
    asm.mass("y4", e[3])
    asm.spring("y2", e[4])
    asm.spring("phi3", e[5], "phi4")
    asm.clamp(1)
    asm.fix("y3")
    return asm


@settings(max_examples=15, deadline=None)
@given(st.lists(st.lists(st.floats(0.0, 3.0), min_size=3, max_size=3), min_size=6, max_size=6),
       st.lists(st.floats(0.0, 1.0), min_size=3, max_size=3))
def test_affine_form_reproduces_the_assembly_everywhere(coefs, where):
    asm = _assembly(coefs)
    model = affine_from_assembly(asm, PARAMETERS)
    values = [p.lower + t * (p.upper - p.lower) for p, t in zip(PARAMETERS, where)]
    exact = asm.system(dict(zip("abc", values)))
    assert exact.dofs == model.dofs
    for A, B in zip(model.matrices_at(values), (exact.M, exact.K)):
        assert abs(A - B).max() <= 1e-13 * abs(B).max()


def test_direct_form_equals_complex_step_of_the_same_assembly():
    asm = _assembly([[1.0, 0.0, 0.5], [0.0, 2.0, 0.0], [0.0, 0.0, 3.0],
                     [0.0, 0.0, 1.0], [4.0, 0.0, 0.0], [0.0, 1.0, 1.0]])
    direct = affine_from_assembly(asm, PARAMETERS)
    stepped = from_builder(asm.system, PARAMETERS)
    for A, B in zip((*direct.M_par, *direct.K_par), (*stepped.M_par, *stepped.K_par)):
        assert abs(A - B).max() <= 1e-14 * max(abs(B).max(), 1.0)
        assert A.nnz == B.nnz


def test_system_needs_the_values_of_the_parameters_it_depends_on():
    asm = _assembly(np.ones((6, 3)))
    assert asm.parameter_names == ("a", "b", "c")
    with pytest.raises(ValueError, match="depends on parameters without a value: a, b, c"):
        asm.system()
    with pytest.raises(ValueError, match="without a value: c"):
        asm.system({"a": 1.0, "b": 1.0})
    with pytest.raises(ValueError, match=r"depends on 'c', which is not a parameter"):
        affine_from_assembly(asm, PARAMETERS[:2])


def test_a_property_is_a_number_an_array_or_one_expression():
    asm = Assembly("beam")
    asm.nodes([1, 2], [0.0, 1.0])
    e = LinearExpression(0.0, (("a", 1.0),))
    with pytest.raises(ValueError, match="EI must be a number, an array of numbers or a LinearExpression"):
        asm.beam(1, 2, EI=[e, e], mass_per_length=1.0)
    with pytest.raises(ValueError, match="mass must be a number or a LinearExpression, got 'heavy'"):
        asm.mass("y2", "heavy")


def test_safety_check_catches_a_wrong_parameter_matrix(monkeypatch):
    """The single check compares the assembly at a moved point with the affine prediction."""
    asm = _assembly(np.ones((6, 3)))
    right = Assembly.affine_parts

    def wrong(self, parameters):
        nominal, M_par, K_par = right(self, parameters)
        K_par[1] = K_par[1] * (1 + 1e-5)
        return nominal, M_par, K_par

    monkeypatch.setattr(Assembly, "affine_parts", wrong)
    with pytest.raises(ValueError, match="direct affine assembly misses the assembled K"):
        affine_from_assembly(asm, PARAMETERS)
    assert affine_from_assembly(asm, PARAMETERS, check=False).n_parameters == 3
