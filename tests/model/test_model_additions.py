"""Configuration masses take one path for every model type (elements, builder returning a
System or (M, K), matrices): the affine form equals the assembled matrices away from the
nominal point, so the masses' parameter dependence is seen by the updating."""

import numpy as np
import pytest
import scipy.io
import scipy.sparse as sp

import vibupdate as vu
from vibupdate.model.affine import Lumped, with_lumped
from vibupdate.io.case import load_case
from vibupdate.io.case_model import linear_expression

PARAMS = """
[[parameter]]
name = "k"
nominal = 1000.0
lower = 500.0
upper = 2000.0
[[parameter]]
name = "m"
nominal = 2.0
lower = 1.0
upper = 3.0
[[configuration]]
name = "bare"
natural_hz = [1.0]
[[configuration]]
name = "loaded"
mass = [{ dof = "y2", value = "0.001*k + 0.5*m + 0.1" }]
natural_hz = [1.0]
"""
SECOND = {"k": 1700.0, "m": 1.3}     # a second point inside the bounds


def _assembled_chain(p, extra=0.0):
    """Three masses on springs (dofs y1..y3), the reference assembly of every model type."""
    asm = vu.Assembly("beam")
    for i in range(1, 4):
        asm.node(i, float(i))
        asm.fix(f"phi{i}")
        asm.mass(f"y{i}", p["m"])
    asm.spring("y1", p["k"])
    asm.spring("y1", p["k"], "y2")
    asm.spring("y2", p["k"], "y3")
    asm.mass("y2", extra)
    return asm.system()


BUILDER = '''
import vibupdate as vu

def build(p, as_tuple=False, as_pair=False):
    asm = vu.Assembly("beam")
    for i in range(1, 4):
        asm.node(i, float(i))
        asm.fix(f"phi{i}")
        asm.mass(f"y{i}", p["m"])
    asm.spring("y1", p["k"])
    asm.spring("y1", p["k"], "y2")
    asm.spring("y2", p["k"], "y3")
    s = asm.system()
    if as_pair:          # (M, K): DOFs named q1, q2, q3 in matrix order
        return s.M, s.K
    return (s.M, s.K, s.dofs) if as_tuple else s
'''

ELEMENTS = """
[model]
type = "elements"
kind = "beam"
nodes = [[1, 1.0], [2, 2.0], [3, 3.0]]
fix = ["phi1", "phi2", "phi3"]
mass = [{ dof = "y1", value = "m" }, { dof = "y2", value = "m" }, { dof = "y3", value = "m" }]
spring = [{ dof = "y1", value = "k" }, { dof = "y1", value = "k", other = "y2" },
          { dof = "y2", value = "k", other = "y3" }]
"""


def _matrices_case(tmp_path):
    nominal = _assembled_chain({"k": 1000.0, "m": 2.0})
    names = [d for d in nominal.dofs]
    scipy.io.mmwrite(str(tmp_path / "M0.mtx"), sp.coo_matrix(nominal.M))
    scipy.io.mmwrite(str(tmp_path / "K0.mtx"), sp.coo_matrix(nominal.K))
    scipy.io.mmwrite(str(tmp_path / "dM.mtx"), sp.coo_matrix(nominal.M / 2.0))
    scipy.io.mmwrite(str(tmp_path / "dK.mtx"), sp.coo_matrix(nominal.K / 1000.0))
    return ('[model]\ntype = "matrices"\nM0 = "M0.mtx"\nK0 = "K0.mtx"\n'
            f"dofs = {names!r}\n".replace("'", '"') + 'dM = { m = "dM.mtx" }\ndK = { k = "dK.mtx" }\n')


@pytest.mark.parametrize("model_type", ["elements", "builder-system", "builder-tuple", "builder-pair", "matrices"])
def test_affine_form_equals_the_assembled_model_with_its_configuration_mass(tmp_path, model_type):
    if model_type == "elements":
        head = ELEMENTS
    elif model_type.startswith("builder"):
        (tmp_path / "chain.py").write_text(BUILDER)
        head = '[model]\ntype = "builder"\nbuilder = "chain.py:build"\n'
    else:
        head = _matrices_case(tmp_path)
    text = head + PARAMS
    if model_type == "builder-tuple":   # a builder returning (M, K, dofs)
        text = text.replace('name = "loaded"\n', 'name = "loaded"\noptions = { as_tuple = true }\n')
    if model_type == "builder-pair":    # a builder returning (M, K), as the docs allow
        text = text.replace('name = "loaded"\n', 'name = "loaded"\noptions = { as_pair = true }\n')
        text = text.replace('name = "bare"\n', 'name = "bare"\noptions = { as_pair = true }\n')
        text = text.replace('dof = "y2"', 'dof = "q2"')
    (tmp_path / "case.toml").write_text(text)
    case = load_case(tmp_path / "case.toml")
    for cfg, extra in zip(case.configurations, (0.0, 0.001 * SECOND["k"] + 0.5 * SECOND["m"] + 0.1)):
        model = cfg.model
        M, K = model.matrices_at([SECOND["k"], SECOND["m"]])
        ref = _assembled_chain(SECOND, extra)
        names = [d.replace("q", "y") for d in model.dofs]   # q1..q3 of a bare (M, K) are y1..y3
        order = [ref.dofs.index(d) for d in names]
        np.testing.assert_allclose(M.toarray(), ref.M.toarray()[np.ix_(order, order)], rtol=1e-12, atol=1e-12)
        np.testing.assert_allclose(K.toarray(), ref.K.toarray()[np.ix_(order, order)], rtol=1e-12, atol=1e-9)
    loaded = case.configurations[1].model
    i = loaded.dof("q2" if model_type == "builder-pair" else "y2")
    # dM/dxbar_k = 0.001 * p_ref(k) = 1.0 from the configuration mass alone
    assert loaded.M_par[0][i, i] == pytest.approx(1.0, rel=1e-12)


def test_matrices_model_sees_a_mass_given_as_a_parameter_expression(tmp_path):
    """The issue's case: in a matrices model `value = "0.001*k"` must give dM/dxbar_k = 1.0."""
    K = np.array([[2.0, -1, 0], [-1, 2, -1], [0, -1, 1]]) * 1000
    scipy.io.mmwrite(str(tmp_path / "M0.mtx"), sp.coo_matrix(np.eye(3)))
    scipy.io.mmwrite(str(tmp_path / "K0.mtx"), sp.coo_matrix(K))
    scipy.io.mmwrite(str(tmp_path / "dK.mtx"), sp.coo_matrix(K / 1000))
    (tmp_path / "case.toml").write_text(
        '[model]\ntype = "matrices"\nM0 = "M0.mtx"\nK0 = "K0.mtx"\ndofs = ["a", "b", "c"]\ndK = { k = "dK.mtx" }\n'
        '[[parameter]]\nname = "k"\nnominal = 1000.0\nlower = 500.0\nupper = 2000.0\n'
        '[[configuration]]\nname = "A"\nmass = [{ dof = "c", value = "0.001*k" }]\nnatural_hz = [1.0]\n')
    model = load_case(tmp_path / "case.toml").configurations[0].model
    assert model.M_par[0][2, 2] == pytest.approx(1.0)
    assert model.M0[2, 2] == pytest.approx(2.0)
    M, _ = model.matrices_at([1500.0])
    assert M[2, 2] == pytest.approx(2.5)


def test_with_lumped_adds_springs_between_dofs_and_rejects_unknown_names():
    model = vu.from_builder(lambda p: _assembled_chain(p), [vu.Parameter("k", 1000.0, 500.0, 2000.0),
                                                           vu.Parameter("m", 2.0, 1.0, 3.0)])
    spring = Lumped("K", "y1", linear_expression("0.5*k", ["k", "m"]), other="y3")
    out = with_lumped(model, [spring])
    K = out.matrices_at([1600.0, 2.0])[1].toarray()
    K_ref = model.matrices_at([1600.0, 2.0])[1].toarray()
    i, j = model.dof("y1"), model.dof("y3")
    assert K[i, j] - K_ref[i, j] == pytest.approx(-800.0) and K[i, i] - K_ref[i, i] == pytest.approx(800.0)
    with pytest.raises(ValueError, match="DOF 'y9' does not exist"):
        with_lumped(model, [Lumped("M", "y9", linear_expression(1.0, []))])
