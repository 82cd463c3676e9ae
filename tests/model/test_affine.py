"""Affine form, complex-step Jacobians (Eqs. 12-15), matrix files and input checks."""

import numpy as np
import pytest
import scipy.io
import scipy.sparse as sp

from helpers import chain_builder
from vibupdate import Assembly, Parameter, from_builder, from_files
from vibupdate.examples import cantilever


def cantilever_model():
    return from_builder(lambda p: cantilever.build(p, "y2"), cantilever.parameters())


def test_complex_step_equals_central_differences():
    model = cantilever_model()
    nominal = {p.name: p.nominal for p in model.parameters}
    for i, p in enumerate(model.parameters):
        h = 1e-5 * p.reference
        plus = cantilever.build({**nominal, p.name: p.nominal + h}, "y2")
        minus = cantilever.build({**nominal, p.name: p.nominal - h}, "y2")
        for A_par, A_plus, A_minus in ((model.M_par[i], plus.M, minus.M), (model.K_par[i], plus.K, minus.K)):
            fd = (A_plus - A_minus) / (2 * h) * p.reference
            scale = max(abs(fd).max(), 1e-300)
            assert abs(A_par - fd).max() <= 1e-7 * scale


def test_affine_form_reproduces_builder_at_random_points():
    model = cantilever_model()
    rng = np.random.default_rng(1)
    for _ in range(3):
        values = np.array([rng.uniform(p.lower, p.upper) for p in model.parameters])
        M, K = model.matrices_at(values)
        exact = cantilever.build(dict(zip(model.parameter_names, values)), "y2")
        assert abs(M - exact.M).max() <= 1e-12 * abs(exact.M).max()
        assert abs(K - exact.K).max() <= 1e-12 * abs(exact.K).max()


def test_parameter_matrices_have_the_expected_support():
    model = cantilever_model()
    names = model.parameter_names
    assert model.K_par[names.index("klc")].nnz == 1
    assert model.M_par[names.index("klc")].nnz == 0
    assert model.M_par[names.index("macc")].nnz == 1
    patch = model.K_par[names.index("Ep")]
    rows = {model.dofs[i] for i in patch.nonzero()[0]}
    assert rows == {"y5", "phi5", "y6", "phi6"}


def _thickness_builder(p):
    asm = Assembly("beam")
    for i in range(3):
        asm.node(i, 0.5 * i)
    for i in range(2):
        asm.beam(i, i + 1, EI=70e9 * 0.04 * p["h"] ** 3 / 12, mass_per_length=2700 * 0.04 * p["h"])
    asm.clamp(0)
    return asm.system()


def test_non_affine_parameter_is_reported():
    with pytest.raises(ValueError, match="parameter 'h' enters K non-affinely"):
        from_builder(_thickness_builder, [Parameter("h", 0.004, 0.003, 0.005)])


def test_product_of_parameters_is_reported():
    def build(p):
        asm = Assembly("beam")
        asm.node(1, 0.0)
        asm.fix("phi1")
        asm.mass("y1", 1.0)
        asm.spring("y1", p["a"] * p["b"])
        return asm.system()

    params = [Parameter("a", 1.0, 0.5, 2.0), Parameter("b", 1.0, 0.5, 2.0)]
    with pytest.raises(ValueError, match="jointly non-affinely"):
        from_builder(build, params)
    # Each one alone is affine: without the joint check the model builds.
    assert from_builder(build, params, check=False).n_parameters == 2


def _brace_builder(cast):
    """Two storeys on springs; the brace stiffness ``b1`` is affine, and ``cast`` is applied to
    each spring value before it goes into the matrix."""
    def build(p):
        k = np.zeros((2, 2), dtype=np.result_type(*p.values()))
        for i, value in enumerate((p["b1"], 2.0e6)):
            value = cast(value)
            k[i, i] += value
            if i:
                k[i - 1, i - 1] += value
                k[i - 1, i] -= value
                k[i, i - 1] -= value
        return np.diag([1000.0, 800.0]), k
    return build


@pytest.mark.parametrize("cast", [lambda v: np.real(v), lambda v: v.real], ids=["np.real", ".real"])
def test_builder_dropping_the_complex_step_is_named(cast):
    params = [Parameter("b1", 1.0e6, 0.5e6, 2.0e6)]
    with pytest.raises(ValueError, match="the builder drops the complex step of parameter 'b1': a complex b1 gives "
                                         "a real K") as info:
        from_builder(_brace_builder(cast), params)
    assert "non-affinely" not in str(info.value)
    # The same builder without the cast is affine.
    assert from_builder(_brace_builder(lambda v: v), params).n_parameters == 1


def test_builder_refusing_a_complex_value_is_named():
    def build(p):
        value = float(p["b1"])      # TypeError on the complex step
        return np.eye(2), np.array([[2 * value, -value], [-value, value]])

    with pytest.raises(ValueError, match="the builder fails when parameter 'b1' is complex .*complex-safe"):
        from_builder(build, [Parameter("b1", 1.0e6, 0.5e6, 2.0e6)])


def test_non_affine_parameter_with_zero_slope_is_not_called_a_dropped_step():
    # K depends on (b1 - 1)^2: its complex step is real (zero derivative) but no cast is involved;
    # the builder keeps complex output, so the message stays the non-affine one.
    def build(p):
        k = 1.0e6 * (1.0 + (p["b1"] - 1.0) ** 2) + 0j * p["b1"]
        return np.eye(1), np.array([[k]])

    with pytest.raises(ValueError, match="enters K non-affinely"):
        from_builder(build, [Parameter("b1", 1.0, 0.5, 2.0)])


@pytest.mark.parametrize("fmt", ["mtx", "npz"])
def test_matrix_files_reproduce_builder(tmp_path, fmt):
    builder = chain_builder(4)
    params = [Parameter("k2", 1000.0, 800.0, 1200.0), Parameter("m3", 1.0, 0.5, 1.5)]
    ref = from_builder(builder, params)
    nominal = builder({"k2": 1000.0, "m3": 1.0})

    def save(name, A):
        path = tmp_path / f"{name}.{fmt}"
        if fmt == "mtx":
            scipy.io.mmwrite(str(path), sp.coo_matrix(A))
        else:
            sp.save_npz(path, sp.csr_matrix(A))
        return path

    model = from_files(
        save("M0", nominal.M), save("K0", nominal.K), params,
        dK={"k2": save("dK_k2", ref.K_par[0] / 1000.0)},
        dM={"m3": save("dM_m3", ref.M_par[1] / 1.0)},
        dofs=nominal.dofs,
    )
    x = np.array([0.1, -0.2])
    for A, B in zip(model.matrices(x), ref.matrices(x)):
        assert abs(A - B).max() < 1e-12
    assert model.dof("y3") == ref.dof("y3")


def test_dense_npz_is_accepted(tmp_path):
    np.savez(tmp_path / "M0.npz", np.eye(2))
    np.savez(tmp_path / "K0.npz", np.array([[2.0, -1.0], [-1.0, 2.0]]))
    np.savez(tmp_path / "dK.npz", np.array([[1.0, 0.0], [0.0, 0.0]]))
    model = from_files(tmp_path / "M0.npz", tmp_path / "K0.npz", [Parameter("k", 1.0, 0.5, 2.0)],
                       dK={"k": tmp_path / "dK.npz"})
    assert model.K_par[0][0, 0] == 1.0


def test_bad_matrices_are_named(tmp_path):
    p = [Parameter("k", 1.0, 0.5, 2.0)]
    I2 = sp.identity(2, format="csr")
    with pytest.raises(ValueError, match="stiffness matrix is not symmetric"):
        from_files(I2, sp.csr_matrix([[2.0, 1.0], [0.0, 2.0]]), p, dK={"k": I2})
    with pytest.raises(ValueError, match="must be square"):
        from_files(sp.csr_matrix(np.ones((2, 3))), I2, p, dK={"k": I2})
    with pytest.raises(ValueError, match="mass matrix M is not positive semidefinite: negative diagonal entry -1"):
        from_files(sp.csr_matrix([[1.0, 0.0], [0.0, -1.0]]), I2, p, dK={"k": I2})
    with pytest.raises(ValueError, match=r"dK of parameter 'k' has shape \(3, 3\), expected \(2, 2\)"):
        from_files(I2, I2, p, dK={"k": sp.identity(3)})
    with pytest.raises(ValueError, match=r"mass matrix \(2, 2\) and stiffness matrix \(3, 3\) differ"):
        from_files(I2, sp.identity(3), p, dK={"k": I2})
    with pytest.raises(ValueError, match="'nope.mtx' does not exist"):
        from_files("nope.mtx", I2, p, dK={"k": I2})
    with pytest.raises(ValueError, match="neither a dM nor a dK"):
        from_files(I2, I2, p)
    with pytest.raises(ValueError, match="unknown parameters: q"):
        from_files(I2, I2, p, dK={"k": I2, "q": I2})
    bad = tmp_path / "bad.mtx"
    bad.write_text("not a matrix market file\n")
    with pytest.raises(ValueError, match="could not be read"):
        from_files(bad, I2, p, dK={"k": I2})


def test_a_builder_may_return_a_system_of_dense_arrays():
    """A user's builder that fills `System` with numpy arrays (not sparse) builds the same model."""
    import numpy as np

    from vibupdate import Parameter, System, from_builder

    def dense(p):
        k = p["k"]
        K = np.array([[2 * k, -k], [-k, k]])
        return System(np.eye(2), K, ("x1", "x2"))

    model = from_builder(dense, [Parameter("k", 100.0, 50.0, 150.0)])
    M, K = model.matrices()
    assert K.toarray() == pytest.approx(np.array([[200.0, -100.0], [-100.0, 100.0]]))
    assert model.dofs == ("x1", "x2")


def _sparse_products(model, L, R):
    """The parameter forms and products by one sparse product per parameter matrix."""
    forms = [np.column_stack([np.einsum("ij,ij->j", L, A @ R) for A in parts]) for parts in (model.M_par, model.K_par)]
    products = [np.column_stack([A @ L[:, 0] for A in parts]) for parts in (model.M_par, model.K_par)]
    return forms, products


@pytest.mark.parametrize("cap", [None, 0])
def test_the_solver_matrices_and_parameter_products_are_the_affine_forms(cap, monkeypatch):
    from vibupdate.model import affine

    if cap is not None:   # a stack over the cap keeps the sparse path
        monkeypatch.setattr(affine, "DENSE_STACK_BYTES", cap)
    model = cantilever_model()
    assert (model.dense_stacks is None) == (cap is not None)
    x = np.linspace(-0.4, 0.3, model.n_parameters)
    M, K = model.solver_matrices(x)
    assert sp.issparse(M) == (cap is not None)
    for A, exact in zip((M, K), model.matrices(x)):
        A = A.toarray() if sp.issparse(A) else A
        np.testing.assert_allclose(A, exact.toarray(), rtol=0, atol=1e-14 * abs(exact).max())
    rng = np.random.default_rng(3)
    L, R = rng.standard_normal((2, model.n_dofs, 4))
    (forms_M, forms_K), (products_M, products_K) = _sparse_products(model, L, R)
    for got, exact in zip((*model.parameter_forms(L, R), *model.parameter_products(L[:, 0])),
                          (forms_M, forms_K, products_M, products_K)):
        assert got.shape == exact.shape
        np.testing.assert_allclose(got, exact, rtol=1e-12, atol=1e-14 * np.abs(exact).max())


def test_the_dense_solver_matrices_are_kept_for_the_last_point_and_read_only():
    model = cantilever_model()
    x = np.full(model.n_parameters, 0.2)
    M = model.solver_matrices(x)[0]
    assert model.solver_matrices(x.copy())[0] is M          # the same point: no second assembly
    with pytest.raises(ValueError, match="read-only"):
        M[0, 0] = 1.0                                        # no caller can change the kept pair
    M_other = model.solver_matrices(-x)[0]
    assert M_other is not M and not np.array_equal(M_other, M)
    np.testing.assert_array_equal(model.solver_matrices()[1], model.K0.toarray())   # None: the nominal model


def test_a_model_beyond_the_dense_limit_has_no_dense_stacks(monkeypatch):
    from vibupdate.modal import eigen

    model = cantilever_model()
    monkeypatch.setattr(eigen, "DENSE_LIMIT", model.n_dofs - 1)
    assert model.dense_stacks is None and sp.issparse(model.solver_matrices()[0])


def test_a_pickled_model_leaves_its_dense_stacks_behind():
    """A model sent to a worker (a sweep on Dask) carries its matrices, not the dense stacks
    and kept point built from them; the copy rebuilds them and gives the same matrices."""
    import pickle

    from vibupdate.examples import cantilever

    model = cantilever.configurations()[0].model
    x = np.full(model.n_parameters, 0.01)
    before = len(pickle.dumps(model))
    M, K = model.solver_matrices(x)
    assert model.dense_stacks is not None
    data = pickle.dumps(model)
    assert len(data) <= before + 1000
    copy = pickle.loads(data)
    M2, K2 = copy.solver_matrices(x)
    np.testing.assert_array_equal(M, M2)
    np.testing.assert_array_equal(K, K2)
