"""Declared correspondence, verification before success, polish, exact derivatives.

Every case is a known truth written here; none is shipped with the package.
"""

import numpy as np
import pytest

from helpers import chain_model
from vibupdate.io.results import frequencies_of
from vibupdate import Antiresonance, Configuration, NaturalFrequency, ShapeInterval, antiresonances, modes
from vibupdate.inverse.correlation import model_frequencies
from vibupdate.inverse.data_map import describe_direction, sensitivity
from vibupdate.ranges.identifiability import parameter_ranges
from vibupdate.modal.sensitivities import antiresonance_derivatives, frequency_derivatives, shape_ratio_derivatives
from vibupdate.inverse.status import Status
from vibupdate.inverse.update import update
from vibupdate.inverse.verify import VerifyOptions, verify


def spectrum(model, xbar):
    M, K = model.matrices(xbar)
    return modes(M, K)


# --- exact derivatives -------------------------------------------------------------------

def central(f, x, h=1e-5):
    return np.column_stack([(f(x + h * e) - f(x - h * e)) / (2 * h) for e in np.eye(x.size)])


def test_analytic_sensitivities_equal_central_differences():
    model = chain_model(5, ["k1", "k2", "k4", "m2", "m3", "m5"])
    x = np.array([0.05, -0.1, 0.08, 0.02, -0.04, 0.1])
    omega, Phi = spectrum(model, x)
    D = frequency_derivatives(model, omega, Phi)
    Dn = central(lambda y: spectrum(model, y)[0], x)
    assert np.max(np.abs(D - Dn)) <= 1e-6 * np.max(np.abs(D))
    r, c = model.dof("y2"), model.dof("y4")
    z, Dz = antiresonance_derivatives(model, x, r, c)
    Dzn = central(lambda y: antiresonances(*model.matrices(y), r, c), x)
    assert z.size >= 2
    assert np.max(np.abs(Dz - Dzn)) <= 1e-6 * np.max(np.abs(Dz))
    entries, ref = [0, 1, 3, 4], 2

    def ratios(y, k=2):
        w, P = spectrum(model, y)
        return P[entries, k] / P[ref, k]

    Ds = shape_ratio_derivatives(model, x, omega[2], Phi[:, 2], entries, ref)
    assert np.max(np.abs(Ds - central(ratios, x))) <= 1e-6 * np.max(np.abs(Ds))


def test_exact_scale_symmetry_is_found_and_named():
    names = ["k1", "k2", "k3", "m1", "m2", "m3"]
    model = chain_model(3, names)
    omega, Phi = spectrum(model, np.zeros(6))
    nat = tuple(NaturalFrequency(w, shape=ShapeInterval.from_values({f"y{j + 1}": Phi[j, k] for j in range(3)}, 0.01))
                for k, w in enumerate(omega))
    cfg = Configuration("S", model, nat)
    s = sensitivity([cfg], np.zeros(6))
    assert s.rank == 5, s.singular_values
    null = s.null_directions
    assert null.shape == (1, 6)
    assert abs(null[0] @ np.ones(6) / np.sqrt(6)) > 1 - 1e-9
    text = describe_direction(names, null[0])
    assert all(n in text for n in names)
    # the linearized ranges see the symmetry: nothing is "determined"
    ranges = parameter_ranges([cfg], np.zeros(6), frequency_tolerance=1e-3)
    assert ranges.determined(5.0) == []
    assert np.all(ranges.width_pct > 20)   # the bounds are +-30 %: the scale direction spans most of them


# --- declared correspondence -------------------------------------------------------------

def test_declared_modes_pair_reports_with_the_right_model_modes():
    """Modes 2-3 of a shear building measured: declared, they are fitted and reported as such."""
    truth = np.array([0.1, -0.05, 0.08])
    model = chain_model(3, ["k1", "k2", "k3"])
    omega, _ = spectrum(model, truth)
    nat = (NaturalFrequency(omega[1], mode=2), NaturalFrequency(omega[2], mode=3))
    result = update([Configuration("B", model, nat)])
    assert result.status == Status.SUCCESS, result.message
    rows = frequencies_of(result.correlation)
    assert [r.model_index for r in rows] == [2, 3]
    assert all(r.error_updated_pct < 1e-6 for r in rows)
    nominal, _ = spectrum(model, np.zeros(3))
    assert [r.nominal_hz for r in rows] == pytest.approx(nominal[1:3] / (2 * np.pi))


def test_antiresonance_indices_pair_with_the_declared_zero():
    model = chain_model(4, ["k2", "m3"])
    r, c = model.dof("y1"), model.dof("y1")
    z0 = antiresonances(*model.matrices(), r, c)
    truth = np.array([0.05, -0.08])
    z = antiresonances(*model.matrices(truth), r, c)
    data = (Antiresonance(z[0], "y1", "y1", index=1), Antiresonance(z[2], "y1", "y1", index=3))
    cfg = Configuration("Z", model, antiresonances=data)
    rows = model_frequencies(cfg).antiresonances
    assert rows == pytest.approx(z0[[0, 2]])
    # defaults without poles: consecutive from the lowest zero
    plain = Configuration("Z", model, antiresonances=(Antiresonance(z[0], "y1", "y1"), Antiresonance(z[2], "y1", "y1")))
    assert [a.index for a in plain.antiresonances] == [1, 2]


def test_driving_point_subset_of_zeros_is_accepted():
    """Six natural frequencies and three driving-point zeros."""
    truth = {"k2": 1080.0, "k5": 930.0, "m3": 1.1, "m6": 0.9}
    model = chain_model(6, list(truth))
    x = model.normalized([truth[p.name] for p in model.parameters])
    omega, _ = spectrum(model, x)
    r = model.dof("y1")
    z = antiresonances(*model.matrices(x), r, r)
    nat = tuple(NaturalFrequency(w) for w in omega)
    zeros = tuple(Antiresonance(z[i], "y1", "y1") for i in (0, 2, 4))
    for interlacing in (False, True):
        cfg = Configuration("D", model, nat, zeros, interlacing=interlacing)
        assert [a.index for a in cfg.antiresonances] == [1, 3, 5]
        result = update([cfg])
        assert result.status == Status.SUCCESS, result.message
        np.testing.assert_allclose(result.values, [truth[p.name] for p in model.parameters], rtol=1e-6)


# --- verification ------------------------------------------------------------------------

def test_verify_flags_a_skipped_mode():
    """Measured modes 1, 2, 4 of a model entered as 1, 2, 3: the check names the mismatch."""
    model = chain_model(5, ["k1", "m2"])
    omega, _ = spectrum(model, np.zeros(2))
    cfg = Configuration("V", model, tuple(NaturalFrequency(omega[k]) for k in (0, 1, 3)))
    f = model_frequencies(cfg)
    checks = {c.name: c for c in verify([cfg], np.zeros(2), nominal=[f], updated=[f], lower_bound=0.0, n_blocks=3)}
    assert not checks["mode_order"].passed
    assert "declared mode 3" in checks["mode_order"].message and "model mode 4" in checks["mode_order"].message


def test_mode_order_lets_a_declared_mode_inside_its_measurement_interval_pass():
    """Two grounded unit masses weakly coupled: modes 0.02 % apart. Measured with 0.1 %
    intervals, the first value lies nearer the model's second mode, but the declared first mode
    lies inside its interval: the data cannot tell them apart, and `mode_order` passes. The same
    values taken as exact (no interval) still fail it."""
    from vibupdate import Assembly, Parameter, from_builder

    def build(p):
        asm = Assembly("beam")
        for i in (1, 2):
            asm.node(i, float(i))
            asm.fix(f"phi{i}")
            asm.mass(f"y{i}", 1.0)
        asm.spring("y1", p["k1"])
        asm.spring("y2", 1000.0)
        asm.spring("y1", 0.1, "y2")
        return asm.system()

    model = from_builder(build, [Parameter("k1", 1000.3, 900.0, 1100.0)])
    omega, _ = spectrum(model, np.zeros(1))
    assert 1e-4 < omega[1] / omega[0] - 1 < 5e-4
    values = (omega[1] * (1 - 1e-5), omega[1] * (1 + 2e-4))   # both nearer the second mode
    for half, passes in ((1e-3, True), (0.0, False)):
        nat = tuple(NaturalFrequency(w, interval=(w * (1 - half), w * (1 + half)) if half else None) for w in values)
        cfg = Configuration("C", model, nat)
        f = model_frequencies(cfg)
        checks = {c.name: c for c in verify([cfg], np.zeros(1), nominal=[f], updated=[f], lower_bound=0.0,
                                            n_blocks=2)}
        assert checks["mode_order"].passed == passes, checks["mode_order"].message


def test_flipped_sign_shape_interval_is_not_success():
    """A shape interval with the wrong sign: never success, a warning naming mode and DOF."""
    truth = {"k1": 1100.0, "k3": 900.0, "m2": 1.15, "m5": 0.85}
    model = chain_model(5, list(truth))
    x = model.normalized([truth[p.name] for p in model.parameters])
    omega, Phi = spectrum(model, x)
    nat = []
    for k in range(3):
        values = {f"y{j + 1}": Phi[j, k] for j in range(5)}
        if k == 1:
            values["y4"] = -values["y4"]     # the flipped entry
        nat.append(NaturalFrequency(omega[k], shape=ShapeInterval.from_values(values, 0.02 * np.abs(Phi[:, k]).max())))
    result = update([Configuration("F", model, tuple(nat))])
    assert result.status != Status.SUCCESS
    assert not result.success
    text = " ".join(result.warnings)
    assert "mode 2" in text and "'y4'" in text, text


def test_cantilever_polished_to_the_classical_optimum_with_interlacing_kept():
    from vibupdate.examples import cantilever

    configurations = cantilever.configurations()
    result = update(configurations)
    assert result.status == Status.SUCCESS, result.message
    assert result.mean_error() <= 0.48
    assert result.polish is not None and result.polish.kept
    for cfg in configurations:
        f = model_frequencies(cfg, result.xbar)
        (r, c), = cfg.receptances()
        z = f.zeros_all[(r, c)]
        w = f.omega_all
        assert np.count_nonzero((z > w[0]) & (z < w[1])) == 1   # measured: a zero between modes 1 and 2
        assert np.count_nonzero((z > w[1]) & (z < w[2])) == 0   # and none between 2 and 3


# --- ranges at verified answers ----------------------------------------------------------

def test_truth_inside_the_ranges_on_20_noisy_chains():
    names = ["k1", "k2", "k3", "k4", "k5"]
    model = chain_model(5, names)
    lo, hi = model.bounds()
    sigma = 1e-3
    inside, report = 0, []
    for seed in range(20):
        rng = np.random.default_rng(seed)
        x_true = rng.uniform(0.5 * lo, 0.5 * hi)
        omega, _ = spectrum(model, x_true)
        noisy = omega * (1 + sigma * rng.standard_normal(omega.size))
        cfg = Configuration("N", model, tuple(NaturalFrequency(w) for w in np.sort(noisy)))
        result = update([cfg])
        if not result.success:
            report.append((seed, result.status.value))
            continue
        ranges = parameter_ranges([cfg], result.xbar, frequency_tolerance=3 * sigma)
        true_values = model.physical(x_true)
        ok = np.all((ranges.lower <= true_values * (1 + 1e-9)) & (true_values <= ranges.upper * (1 + 1e-9)))
        inside += bool(ok)
        report.append((seed, bool(ok)))
    assert inside >= 19, report


# --- reproductions on a chain with a local oscillator --------------------------------------

def local_oscillator_model():
    """Four masses in a chain and a light oscillator (``kloc``, ``mloc``) hung on mass 2, whose
    mode the nominal model puts above the band (21.6 Hz) and the truths below inside it."""
    from vibupdate import Assembly, Parameter, from_builder

    def build(p):
        a = Assembly("beam")
        for i in range(1, 6):
            a.node(i, float(i))
            a.fix(f"phi{i}")
        for i in range(1, 5):
            a.mass(f"y{i}", 1.0)
        a.mass("y5", p["mloc"])
        a.spring("y1", p["k1"])
        for i in range(2, 5):
            a.spring(f"y{i - 1}", p[f"k{i}"], f"y{i}")
        a.spring("y2", p["kloc"], "y5")
        return a.system()

    params = [Parameter(f"k{i}", 1000.0, 500.0, 1500.0) for i in range(1, 5)]
    params += [Parameter("kloc", 3000.0, 300.0, 6000.0), Parameter("mloc", 0.2, 0.1, 0.3)]
    return from_builder(build, params)


def local_truth(model, kloc):
    true = {"k1": 1090.0, "k2": 920.0, "k3": 1080.0, "k4": 910.0, "kloc": kloc, "mloc": 0.2}
    return model.normalized([true[p.name] for p in model.parameters])


@pytest.mark.parametrize("picked", [(0, 1, 2, 4), (0, 2, 3, 4)])
def test_a_skipped_mode_is_never_success(picked):
    """Frequencies only; the homotopy's nearest-eigenvalue fit skips a mode (reproduced: the
    first-stage answer fails the mode-order check). The final answer is either verified with
    the declared modes or not a success."""
    model = local_oscillator_model()
    omega, _ = spectrum(model, local_truth(model, 700.0))
    cfg = Configuration("L", model, tuple(NaturalFrequency(omega[k]) for k in picked))
    result = update([cfg])

    def mode_order(xbar):
        f = model_frequencies(cfg, xbar, derivatives=True)
        checks = verify([cfg], xbar, nominal=[f], updated=[f], lower_bound=None, n_blocks=len(picked))
        return next(c for c in checks if c.name == "mode_order")

    assert not mode_order(result.first_stage_xbar).passed, "the first stage did not skip here"
    if result.success:
        assert mode_order(result.xbar).passed
    else:
        assert result.status == Status.NOT_VERIFIED
        assert any(w.startswith(("mode_order", "correspondence", "fit")) for w in result.warnings)


def test_vector_boxes_that_exclude_the_truth_are_widened():
    """Problem 1; the truth's 4th mode is the oscillator's, the nominal 4th a chain mode: with
    unit margins the box of the unmeasured oscillator entry excludes the true vector of
    modes 2 and 4 and the relaxation's lower bound proves it (data stated precise to 0.1 %).
    The update widens the boxes and finds the truth."""
    from vibupdate.inverse.formulation.options import FormulationOptions
    from vibupdate.inverse.update import prepare
    from vibupdate.inverse.verify import VerifyOptions

    model = local_oscillator_model()
    x_true = local_truth(model, 700.0)
    omega, Phi = spectrum(model, x_true)
    nat = tuple(NaturalFrequency(omega[k], shape=ShapeInterval.from_values(
        {f"y{j + 1}": Phi[j, k] for j in range(4)}, 1e-3 * np.abs(Phi[:4, k]).max())) for k in range(5))
    cfg = Configuration("B", model, nat)
    tight = FormulationOptions(shape_margin=1.0)
    problem = prepare([cfg], tight)
    outside = []
    for b, blk in enumerate(problem.blocks):
        mid = Phi[:4, b]
        ratio = Phi[4, b] / mid[np.argmax(np.abs(mid))]
        if not blk.lower[4] <= ratio <= blk.upper[4]:
            outside.append(b + 1)
    assert outside == [2, 4]
    result = update([cfg], formulation=tight, verification=VerifyOptions(frequency_tolerance=1e-3))
    assert len(result.attempts) >= 2
    assert result.attempts[0].relaxation_lower_bound > 1e-4
    assert result.attempts[-1].relaxation_lower_bound < 1e-6
    assert result.attempts[-1].shape_margin >= 10.0
    assert result.status == Status.SUCCESS, result.message
    np.testing.assert_allclose(result.xbar, x_true, atol=5e-3)


def test_antiresonance_derivatives_on_the_sparse_path(monkeypatch):
    """Above the dense limit the zeros and their left/right vectors come from shift-invert;
    the derivatives equal those of the dense path (validated against central differences on
    a small model above)."""
    from vibupdate.modal import eigen
    from vibupdate.modal.analysis import DENSE_LIMIT

    n = DENSE_LIMIT + 10
    model = chain_model(n, ["k4", "m6", "k8"])
    x = np.array([0.05, -0.1, 0.08])
    r, c = model.dof("y1"), model.dof("y3")
    z, D = antiresonance_derivatives(model, x, r, c, n_zeros=4)
    assert z.size == 4
    monkeypatch.setattr(eigen, "DENSE_LIMIT", 10 * n)   # the one size limit of the modal kernels
    z_dense, D_dense = antiresonance_derivatives(model, x, r, c, n_zeros=4)
    assert z == pytest.approx(z_dense, rel=1e-9)
    assert np.max(np.abs(D - D_dense)) <= 1e-6 * np.max(np.abs(D_dense))
    assert np.count_nonzero(np.abs(D_dense).max(axis=0) > 1e-12) == 3


def _exported_frame_data(subdivisions: int, shift: float = 0.0):
    """Exact point data of the refined frame's true model as another program would export them:
    the same stiffness matrix with every stored entry rounded differently (one unit, random
    signs); ``shift`` moves one data point of mode 1."""
    import scipy.sparse as sp

    from vibupdate.data.measured import Configuration, NaturalFrequency, ShapeInterval
    from vibupdate.examples import frame
    from vibupdate.modal.analysis import modes

    model = frame.model(subdivisions)
    truth = frame.truth()
    values = np.array([truth[p.name] for p in model.parameters])
    M, K = model.matrices_at(values)
    rng = np.random.default_rng(1)
    U = sp.triu(K, format="coo")
    D = sp.coo_matrix((U.data * np.finfo(float).eps * rng.choice([-1.0, 1.0], U.nnz), (U.row, U.col)), shape=K.shape)
    omega, Phi = modes(M, (K + D + sp.triu(D, k=1, format="coo").T).tocsr(), frame.N_MODES)
    idx = [model.dof(d) for d in frame.MEASURED_DOFS]
    shapes = Phi[idx] / np.abs(Phi[idx]).max(axis=0)
    shapes[3, 0] += shift
    natural = tuple(NaturalFrequency(w, shape=ShapeInterval({d: (v, v) for d, v in zip(frame.MEASURED_DOFS, shapes[:, k])}))
                    for k, w in enumerate(omega))
    return Configuration("frame", model, natural), model.normalized(values)


@pytest.mark.parametrize("shift, passes", [(0.0, True), (1e-5, False)])
def test_point_shape_data_are_held_to_the_exact_half_width(shift, passes):
    """The true model of the frame refined to 1,553 DOFs against its own exact point data,
    exported with other rounding: its ratios miss the points by 2.1e-9 (measured), within the
    stated half-width of exact data (`exact_half_width`, 1e-6 of the largest entry). A data
    point moved by 1e-5 fails when the model-form tolerance is 0 (the model is the truth's);
    within the default 0.02 it passes as limited by the model's form, and the exact data as
    limited by the measurement."""
    from vibupdate.inverse.correlation import model_frequencies

    cfg, x = _exported_frame_data(40, shift)
    f = model_frequencies(cfg, x)
    misfit = max(np.abs(f.Phi[cfg.model.dof(d), k] / f.Phi[cfg.model.dof(n.shape.reference), k] - lo).max()
                 for k, n in enumerate(cfg.natural) for d, (lo, _) in n.shape.ratio_bounds().items())
    assert misfit > 1e-9
    checks = {c.name: c for c in verify([cfg], x, nominal=[f], updated=[f], lower_bound=None, n_blocks=7,
                                        options=VerifyOptions(shape_tolerance=0.0))}
    assert checks["shape_intervals"].passed is passes, checks["shape_intervals"].message
    if not passes:
        assert "half-widths outside" in checks["shape_intervals"].message
    loose = {c.name: c for c in verify([cfg], x, nominal=[f], updated=[f], lower_bound=None, n_blocks=7)}
    assert loose["shape_intervals"].passed
    assert loose["shape_intervals"].limited_by == ("measurement" if passes else "model_form")


def _common_scaling_miss(q, shape):
    from vibupdate.inverse.admissible import scaling_miss

    lo, hi = np.array(list(shape.bounds.values())).T
    return scaling_miss(q, lo, hi)


def test_a_shape_is_judged_at_its_best_common_scaling():
    shape = ShapeInterval({"a": (0.9, 1.1), "b": (0.4, 0.6), "c": (-0.3, -0.1)})
    assert _common_scaling_miss(np.array([2.0, 1.0, -0.4]), shape) == 0.0      # inside at s = 0.5
    assert _common_scaling_miss(np.array([-2.0, -1.0, 0.4]), shape) == 0.0     # the sign is free
    # a = b in the model: the common scaling s must lie in [0.9 - 0.1 t, 1.1 + 0.1 t] and in
    # [0.4 - 0.1 t, 0.6 + 0.1 t] (intervals widened by t half-widths), first possible at t = 1.5
    miss = _common_scaling_miss(np.array([1.0, 1.0, -0.2]), shape)
    assert abs(miss - 1.5) < 1e-9
