"""Problem 1 at the scale of test case 1: the planar frame example (known truth)."""

import numpy as np
import pytest

import frame_data
from vibupdate.io.results import macs_of
from vibupdate import SolverOptions, update
from vibupdate.damping.stage import identify_damping
from vibupdate.examples import frame, read_table
from vibupdate.inverse.data_map import data_jacobian
from vibupdate.ranges.identifiability import parameter_ranges
from vibupdate.inverse.status import Status


@pytest.fixture(scope="module")
def noisy():
    configurations = frame.configurations()
    return configurations, update(configurations)


def true_values(model):
    t = frame.truth()
    return np.array([t[p.name] for p in model.parameters])


def test_shipped_data_are_what_the_generator_makes():
    frequencies, shapes = frame_data.generate()
    shipped = read_table("frame_frequencies.csv")
    np.testing.assert_allclose([float(r["hz"]) for r in shipped], [f["hz"] for f in frequencies], rtol=1e-9)
    shipped = read_table("frame_shapes.csv")
    np.testing.assert_allclose([float(r["value"]) for r in shipped], [s["value"] for s in shapes], atol=1e-9)


def test_size_matches_test_case_1():
    model = frame.model()
    assert model.n_parameters == 29                  # Table 1: 29 parameters
    assert 30 <= model.n_dofs <= 32                   # Table 1: 30 DOFs
    cfg = frame.configurations()[0]
    assert len(cfg.natural) == 7 and all(f.shape is not None for f in cfg.natural)


def test_problem_1_fits_the_frequencies_and_shapes(noisy):
    """The data carry 0.3 % frequency noise (0.387 % mean on the bundled seed) and 2 % shape
    noise: the answer is judged against the truth's noise-free modes. A model that reproduced
    the noisy frequencies would be as far from the truth's as the data are; the answer must be
    nearer (measured 0.364 %, 1 - MAC 1.5e-4; benchmarks/RESULTS.md, "The frame generator: the
    answer against the truth's noise-free modes"). Ceilings from the bundled answer's figures
    (benchmarks/RESULTS.md, "Ceilings at their measured figures"): 1 - MAC against the truth
    4.3e-4 at worst, held to 1e-3 (2.3x); MAC against the noisy shapes 0.9921 at worst, held to
    0.99 (1 - MAC 1.3x)."""
    from vibupdate.modal.analysis import modes

    configurations, r = noisy
    assert r.status == Status.SUCCESS, r.message
    assert r.mean_error("nominal") > 3.0               # the nominal model is 4.1 % off
    model = configurations[0].model
    w_true, Phi_true = modes(*model.matrices_at(true_values(model)), frame.N_MODES)
    w, Phi = modes(*model.matrices_at(r.values), frame.N_MODES)
    measured = np.array([f.omega for f in configurations[0].natural])
    data_error = np.mean(np.abs(measured / w_true - 1))
    answer_error = np.mean(np.abs(w / w_true - 1))
    assert answer_error < data_error, (answer_error, data_error)
    idx = [model.dof(d) for d in frame.MEASURED_DOFS]
    mac_true = np.array([(Phi[idx, k] @ Phi_true[idx, k]) ** 2
                         / ((Phi[idx, k] @ Phi[idx, k]) * (Phi_true[idx, k] @ Phi_true[idx, k])) for k in range(frame.N_MODES)])
    assert np.all(mac_true >= 0.999), mac_true
    assert np.all(macs_of(r.correlation)["frame"] >= 0.99)
    assert r.relaxation_lower_bound <= r.objective


def test_truth_is_recovered_within_the_measurement_error(noisy):
    """Truth and answer both lie in the set of parameters consistent with the data intervals
    (frequencies +- 3 sigma of the seeded error, shapes as given); a parameter whose whole
    consistent range is narrower than 5 % is therefore within 5 % of the truth."""
    configurations, r = noisy
    model = configurations[0].model
    true = true_values(model)
    ranges = parameter_ranges(configurations, r.xbar, frequency_tolerance=3 * frame.FREQUENCY_ERROR)
    ref = np.array([p.reference for p in model.parameters])
    slack = 0.02 * (ranges.upper - ranges.lower) + 1e-6 * ref   # linearization
    assert np.all(true >= ranges.lower - slack) and np.all(true <= ranges.upper + slack)
    assert np.all(np.abs(r.values - true) <= ranges.upper - ranges.lower + slack)
    # the parameters the data narrow below their box (+-5 %, 10 % wide): each lies within its
    # range's width of the truth (E4: 5.03 % wide at this answer, measured; 4.72 % at the answer
    # that reproduced the noisy frequencies)
    box = 100 * np.array([(p.upper - p.lower) / p.reference for p in model.parameters])
    narrowed = [i for i in range(model.n_parameters) if ranges.width_pct[i] < 0.9 * box[i]]
    assert narrowed, "no parameter narrowed by the data: the test would say nothing"
    for i in narrowed:
        assert abs(r.values[i] / true[i] - 1) * 100 <= ranges.width_pct[i], model.parameter_names[i]
    # The two balancing springs act in parallel through the axially stiff upper beam: only their
    # sum is seen, each one alone spans most of its bounds (measured: the whole 40 % box).
    assert not {"kbs", "kbs2"} & {model.parameter_names[i] for i in narrowed}


def test_exact_data_recover_every_identifiable_parameter():
    """Noise-free data; parameters whose effect on the data is at least 1e-3 of the largest
    come back to 1e-4. The rotary inertias with nominal 0 move the 7 frequencies and shapes
    10^4 times less: they are only weakly identifiable and come back to 1e-2 of their
    reference value."""
    frequencies, shapes = frame_data.generate(frequency_error=0.0, shape_error=0.0)
    configurations = frame.configurations(frequencies, shapes)
    model = configurations[0].model
    true = true_values(model)
    r = update(configurations, solver=SolverOptions(tol=1e-14))
    assert r.status == Status.SUCCESS
    d, G = data_jacobian(configurations, model.normalized(true))
    n_f = len(frequencies)
    relative = np.vstack([G[:n_f] / d[:n_f, None], G[n_f:]])   # frequencies relative, shapes as normalized
    effect = np.linalg.norm(relative, axis=0)
    strong = effect >= 1e-3 * effect.max()
    ref = np.array([p.reference for p in model.parameters])
    error = np.abs(r.values - true) / np.where(true != 0, np.abs(true), ref)
    weak = [p.name for p, s in zip(model.parameters, strong) if not s]
    assert set(weak) <= {"J3", "J5", "J7", "J9", "J11", "J12"}, weak
    assert np.all(error[strong] <= 1e-4), dict(zip(model.parameter_names, error))
    assert np.all(error <= 1e-2)


def test_damping_with_the_paper_test_case_1_exponents(noisy):
    configurations, r = noisy
    stage = identify_damping(configurations, r.xbar, frame.DAMPING.exponents)
    # The generating law (Y = 0, 0.5, 1) lies in the span of Y = 0, 0.25, ..., 1; what is left
    # is the frequency error of the updated model: measured 0.0164 % (Rayleigh 3.98 %; 0.0079 %
    # when the ceiling was set), the ceiling 1.2 times that (benchmarks/RESULTS.md, "Ceilings at
    # their measured figures").
    assert stage.caughey.mean_error_pct < 0.02
    assert stage.rayleigh.mean_error_pct > stage.caughey.mean_error_pct


def test_ranges_without_a_stated_tolerance_do_not_collapse_to_the_answer():
    """Cantilever, no shape data, no frequency tolerance: the window is the answer's own misfit.
    A parameter the frequencies barely see (the piezo patch's Young's modulus) must come out
    wide, not as a zero-width 'determined' range."""
    from vibupdate.examples import cantilever

    configurations = cantilever.configurations()
    r = update(configurations)
    ranges = parameter_ranges(configurations, r.xbar)
    width = dict(zip(ranges.names, ranges.width_pct))
    assert np.all(np.isfinite(ranges.width_pct))
    assert width["Ep"] > 100 and "Ep" not in ranges.determined(5.0)
    assert width["E"] < width["rho_p"] < width["Ep"]
    assert np.all(ranges.lower <= r.values * (1 + 1e-9)) and np.all(r.values <= ranges.upper * (1 + 1e-9))
