"""Craig-Bampton reduction of affine models (large models, docs/method.md)."""

import numpy as np

from helpers import uniform_cantilever
from vibupdate import FormulationOptions, Parameter, from_builder, modes, update
from vibupdate.examples import frame
from vibupdate.inverse.reduction import craig_bampton, reduce_configurations, wants_reduction
from vibupdate.inverse.status import Status


def _beam_model(n=30):
    def build(p):
        s = uniform_cantilever(n, EI=p["EI"], rho_a=p["m"])
        return s

    return from_builder(build, [Parameter("EI", 1.0, 0.5, 2.0), Parameter("m", 1.0, 0.5, 2.0)])


def test_reduction_is_exact_with_every_interior_mode():
    model = _beam_model(8)
    keep = ["y2", "y8"]
    reduced, T = craig_bampton(model, keep, model.n_dofs - len(keep))
    w_full, _ = modes(*model.matrices())
    w_red, _ = modes(*reduced.matrices())
    np.testing.assert_allclose(w_red, w_full, rtol=1e-9)
    assert reduced.dofs[:2] == ("y2", "y8")


def test_reduced_model_is_the_projection_and_stays_affine():
    model = _beam_model(30)
    reduced, T = craig_bampton(model, ["y10", "y20", "y30"], 12)
    x = np.array([0.3, -0.2])
    M, K = model.matrices(x)
    Mr, Kr = reduced.matrices(x)
    np.testing.assert_allclose(Mr.toarray(), T.T @ M.toarray() @ T, atol=1e-12 * abs(Mr).max())
    np.testing.assert_allclose(Kr.toarray(), T.T @ K.toarray() @ T, rtol=1e-9, atol=1e-9 * abs(Kr).max())
    # Low modes of the reduced model are close upper bounds of the full model's (Rayleigh-Ritz);
    # with 3 kept DOFs and 12 interior modes the 4th mode is 2.4e-5 high.
    w_full, _ = modes(M, K, 4)
    w_red, _ = modes(Mr, Kr, 4)
    assert np.all(w_red >= w_full * (1 - 1e-12))
    np.testing.assert_allclose(w_red, w_full, rtol=1e-4)


def test_kept_dofs_keep_their_physical_meaning():
    model = _beam_model(20)
    reduced, T = craig_bampton(model, ["y5", "y20"], 10)
    _, Phi_r = modes(*reduced.matrices(), 2)
    full = T @ Phi_r
    np.testing.assert_allclose(full[model.dof("y5")], Phi_r[0])
    np.testing.assert_allclose(full[model.dof("y20")], Phi_r[1])


def test_auto_reduction_solves_a_refined_frame():
    """305 DOFs: above the threshold, solved on the reduced model, checked on the full one."""
    frequencies, shapes = frame.generate(subdivisions=8)
    configurations = frame.configurations(frequencies, shapes, 8)
    assert wants_reduction(configurations, FormulationOptions())
    assert not wants_reduction(configurations, FormulationOptions(reduction="none"))
    result = update(configurations)
    assert result.status == Status.SUCCESS, result.message
    assert result.problem_size["reduced_dofs"] == 20 + 20
    assert result.mean_error() <= 1.5
    assert np.all(result.mac["frame"] >= 0.95)
    assert result.vectors[0].shape == (configurations[0].model.n_dofs,)
    reduced, _ = reduce_configurations(configurations, 20)
    assert reduced[0].model.n_dofs == 40
