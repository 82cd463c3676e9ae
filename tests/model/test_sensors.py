"""Sensors that read combinations of DOFs: their weights, the measurement map, the box they
imply on DOFs, and their use in the data map (values and exact Jacobian)."""

import functools

import numpy as np
import pytest
import scipy.linalg

import braced_floors as bf
from vibupdate import Parameter
from vibupdate.data.measured import Configuration, NaturalFrequency, ShapeInterval
from vibupdate.inverse.data_map import data_map
from vibupdate.model.affine import with_sensors
from vibupdate.model.build import from_files
from vibupdate.model.measurement import Sensor, dof_box, rigid_weights

L = bf.L
TRUTH = {"brace_1s": 0.6, "brace_2e": 0.75, "brace_4n": 0.85}
GROUPS = [f"brace_{s}{f}" for s in range(1, 5) for f in bf.FACES]


@functools.lru_cache(maxsize=1)
def _frame_model():
    """The rigid-floor braced frame with its 16 brace factors and 16 sensors, from the same
    element matrices the case files read (`braced_floors`)."""
    import scipy.sparse as sp

    names = bf.floor_dofs()
    position = {d: i for i, d in enumerate(names)}
    K0, M = np.zeros((12, 12)), np.zeros((12, 12))
    dK = {g: np.zeros((12, 12)) for g in GROUPS}
    for _, dofs, k, m, group in bf.elements():
        at = np.ix_([position[d] for d in dofs], [position[d] for d in dofs])
        K0[at] += k
        M[at] += m
        if group is not None:
            dK[group][at] += k
    model = from_files(sp.csr_matrix(M), sp.csr_matrix(K0), [Parameter(g, 1.0, 0.3, 1.5) for g in GROUPS],
                       dK={g: sp.csr_matrix(A) for g, A in dK.items()}, dofs=names)
    return with_sensors(model, [Sensor(n, tuple(w.items())) for n, w in bf.sensor_weights().items()])


def _exact_configuration(model, values, sensors, n_modes=6):
    K, M = bf.matrices(values)
    lam, phi = scipy.linalg.eigh(K, M)
    S = model.measurement(sensors)
    read = S @ phi[:, :n_modes]
    natural = tuple(NaturalFrequency(float(np.sqrt(lam[k])), mode=k + 1,
                                     shape=ShapeInterval({s: (read[q, k], read[q, k]) for q, s in enumerate(sensors)}))
                    for k in range(n_modes))
    return Configuration("test", model, natural)


def test_a_rigid_floor_sensor_reads_the_translation_plus_the_offset_times_the_rotation():
    floor = {"x": "f:x", "y": "f:y", "rz": "f:rz"}
    # x at (0, -L): u_x - y rz = u_x + L rz; y at (L, 0): u_y + x rz; an oblique one both
    assert rigid_weights(floor, [0.0, -L], [1.0, 0.0]) == {"f:x": 1.0, "f:rz": L}
    assert rigid_weights(floor, [L, 0.0], [0.0, 2.0]) == {"f:y": 1.0, "f:rz": L}
    w = rigid_weights(floor, [0.3, 0.4], [4.0, -3.0])
    assert w == pytest.approx({"f:x": 0.8, "f:y": -0.6, "f:rz": 0.3 * -0.6 - 0.4 * 0.8})
    assert rigid_weights(floor, [0.3, 0.4], [3.0, 4.0]) == pytest.approx({"f:x": 0.6, "f:y": 0.8})   # radial
    # a direction off the x axis by rounding (1e-14) reads no y: a floor that names only x and rz
    assert rigid_weights({"x": "f:x", "rz": "f:rz"}, [0.0, -L], [1.0, 1e-14]) == {"f:x": 1.0, "f:rz": L}
    with pytest.raises(ValueError, match="reads the body's 'y' \\(weight 1e-06\\)"):
        rigid_weights({"x": "f:x", "rz": "f:rz"}, [0.0, -L], [1.0, 1e-6])
    with pytest.raises(ValueError, match="reads the body's 'ry'.*do not name"):
        rigid_weights(floor, [0.0, 0.0, 0.5], [1.0, 0.0, 0.0])   # 0.5 m above the floor's plane it sees ry


def test_the_measurement_map_is_a_unit_row_for_a_dof_and_the_weights_for_a_sensor():
    model = _frame_model()
    S = model.measurement(["f2:y", "f1xs", "f3ye"]).toarray()
    assert S.shape == (3, 12)
    expected = np.zeros((3, 12))
    expected[0, model.dof("f2:y")] = 1.0
    expected[1, [model.dof("f1:x"), model.dof("f1:rz")]] = 1.0, L
    expected[2, [model.dof("f3:y"), model.dof("f3:rz")]] = 1.0, L
    assert np.array_equal(S, expected)
    with pytest.raises(ValueError, match="DOF 'f9xs' does not exist; the model's DOFs are f1:x, .*; its sensors are "
                                         "f1xs, f1xn"):
        model.measurement(["f9xs"])


def test_a_measurement_map_is_built_once_per_list_of_names(monkeypatch):
    """The map depends on the model and the names only: asked again, the same matrix, not a
    new build; another list is its own; a bad name raises every time (nothing kept)."""
    from dataclasses import replace

    import vibupdate.model.measurement as measurement

    model = replace(_frame_model())   # a model of its own: nothing kept yet
    built, real = [], measurement.measurement_rows
    monkeypatch.setattr(measurement, "measurement_rows", lambda *a: built.append(tuple(a[2])) or real(*a))
    first = model.measurement(["f2:y", "f1xs"])
    assert model.measurement(("f2:y", "f1xs")) is first and built == [("f2:y", "f1xs")]
    assert model.measurement(["f1xs"]).shape == (1, 12) and len(built) == 2
    for _ in range(2):
        with pytest.raises(ValueError, match="DOF 'f9xs' does not exist"):
            model.measurement(["f9xs"])
    assert len(built) == 4


@pytest.mark.parametrize("weights, message", [
    ((), "has no DOF weights"),
    ((("f1:x", 0.0),), "only zero weights"),
    ((("f1:x", 1.0), ("f1:x", 2.0)), "names DOF 'f1:x' twice"),
    ((("f1:x", float("nan")),), "must be a finite number"),
])
def test_a_sensor_without_a_usable_weight_list_is_refused(weights, message):
    with pytest.raises(ValueError, match=message):
        Sensor("s", weights)


def test_sensors_are_checked_against_the_model():
    model = _frame_model()
    with pytest.raises(ValueError, match="sensor 'a' reads DOF 'f5:x', which does not exist"):
        with_sensors(model, [Sensor("a", (("f5:x", 1.0),))])
    with pytest.raises(ValueError, match="sensor 'a' is declared twice"):
        with_sensors(model, [Sensor("a", (("f1:x", 1.0),)), Sensor("a", (("f1:y", 1.0),))])
    with pytest.raises(ValueError, match="sensor 'f1:x' has the name of a DOF"):
        with_sensors(model, [Sensor("f1:x", (("f1:x", 1.0),))])


def test_a_shape_at_plain_dofs_has_its_own_intervals_as_its_dof_box_without_building_the_map():
    """`ShapeInterval.on_dofs` of a shape whose names are all DOFs returns its intervals (what
    `dof_box` gives for unit rows, to the bit) without the measurement map; the box is not
    mass-normalized."""
    model = _frame_model()
    shape = ShapeInterval({"f2:y": (-1.0, 2.0), "f1:x": (0.1, 0.3), "f3:rz": (0.5, 0.7)}, mass_normalized=True)
    lower, upper = np.array(list(shape.bounds.values())).T
    idx, lo, hi = dof_box(model.measurement(list(shape.bounds)), lower, upper)
    box = shape.on_dofs(model)
    assert box.bounds == {model.dofs[i]: (a, b) for i, a, b in zip(idx, lo, hi)} and not box.mass_normalized
    assert list(box.bounds) == list(shape.bounds)


def test_the_box_on_dofs_is_the_intervals_of_plain_dofs_and_holds_the_dofs_four_sensors_give():
    model = _frame_model()
    idx, lo, hi = dof_box(model.measurement(["f2:y", "f1:x"]), np.array([-1.0, 0.1]), np.array([2.0, 0.3]))
    assert idx.tolist() == [model.dof("f2:y"), model.dof("f1:x")]
    assert lo.tolist() == [-1.0, 0.1] and hi.tolist() == [2.0, 0.3]     # to the bit
    # four sensors on floor 1 give its three DOFs; readings of a known motion within +-0.01
    names = ["f1xs", "f1xn", "f1yw", "f1ye"]
    u = np.zeros(12)
    u[[0, 1, 2]] = 0.3, -0.2, 0.05
    y = model.measurement(names) @ u
    idx, lo, hi = dof_box(model.measurement(names), y - 0.01, y + 0.01)
    assert sorted(idx.tolist()) == [0, 1, 2]
    assert np.all(lo <= u[idx]) and np.all(u[idx] <= hi) and np.all(hi - lo < 0.03)
    # two x sensors alone give x and rz, never y
    idx, _, _ = dof_box(model.measurement(names[:2]), y[:2] - 0.01, y[:2] + 0.01)
    assert sorted(idx.tolist()) == [0, 2]
    # a DOF and a sensor that share it: rz = (reading - x) / L; a DOF of floor 2 apart
    mixed = ["f1:x", "f1xs", "f2:y"]
    u[model.dof("f2:y")] = 0.7
    y = model.measurement(mixed) @ u
    idx, lo, hi = dof_box(model.measurement(mixed), y - 0.01, y + 0.01)
    assert idx.tolist() == [model.dof("f1:x"), model.dof("f1:rz"), model.dof("f2:y")]
    assert np.all(lo <= u[idx]) and np.all(u[idx] <= hi)
    assert hi[1] - lo[1] == pytest.approx(2 * 0.01 * 2 / L) and hi[2] - lo[2] == pytest.approx(0.02)


def _exact_at_truth():
    """The frame's exact data at every sensor, and the truth's ``xbar``."""
    model = _frame_model()
    values = {g: TRUTH.get(g, 1.0) for g in GROUPS}
    cfg = _exact_configuration(model, values, list(bf.sensor_weights()))
    return cfg, model.normalized([values[g] for g in GROUPS])


def test_shape_ratios_at_sensors_and_their_exact_jacobian():
    cfg, x = _exact_at_truth()
    dm = data_map(cfg, x)
    # exact data: every ratio of every sensor, the dependent fourth of each floor among them
    for s, ratios in zip(dm.shapes, dm.ratios):
        assert ratios.size == 15
        assert np.max(np.abs(ratios - s.midpoint)) <= 1e-10
    h = 1e-6
    for i in (0, 5, 13):
        step = np.zeros(x.size)
        step[i] = h
        fd = (np.concatenate(data_map(cfg, x + step, jacobian=False).ratios)
              - np.concatenate(data_map(cfg, x - step, jacobian=False).ratios)) / (2 * h)
        exact = np.concatenate([D[:, i] for D in dm.ratio_jacobians])
        assert np.max(np.abs(exact - fd)) <= 1e-6 * max(1.0, np.max(np.abs(fd)))


def test_a_dependent_sensor_is_data_its_value_moves_the_residual():
    # the fourth sensor of floor 2 is a combination of the other three's DOFs: a wrong value
    # there (and nowhere else) shows in the data map's residual, at its own entry
    cfg, x = _exact_at_truth()
    f = cfg.natural[0]
    bounds = dict(f.shape.bounds)
    moved = bounds["f2ye"][0] * 1.1
    bounds["f2ye"] = (moved, moved)
    wrong = Configuration("test", cfg.model, (NaturalFrequency(f.omega, mode=1, shape=ShapeInterval(bounds)),
                                          *cfg.natural[1:]))
    good = data_map(cfg, x, jacobian=False)
    bad = data_map(wrong, x, jacobian=False)
    res_good = good.ratios[0] - good.shapes[0].midpoint
    res_bad = bad.ratios[0] - bad.shapes[0].midpoint
    assert np.max(np.abs(res_good)) <= 1e-10
    names = [n for n in bf.sensor_weights() if n != f.shape.reference]
    off = np.flatnonzero(np.abs(res_bad) > 1e-8)
    assert [names[k] for k in off] == ["f2ye"]


def test_the_first_stage_bounds_the_dofs_the_sensor_intervals_give():
    # the block of a shape given at the 16 sensors: the 12 floor DOFs measured (the box the
    # readings imply), normalized at the largest, and the truth's mode within the box
    from vibupdate.inverse.formulation.blocks import natural_block
    from vibupdate.inverse.formulation.options import FormulationOptions
    from vibupdate.inverse.formulation.scaling import scaling_of

    model = _frame_model()
    sensors = list(bf.sensor_weights())
    K, M = bf.matrices(TRUTH)
    lam, phi = scipy.linalg.eigh(K, M)
    read = model.measurement(sensors) @ phi[:, 0]
    half = 0.02 * np.max(np.abs(read))
    shape = ShapeInterval({s: (v - half, v + half) for s, v in zip(sensors, read)})
    cfg = Configuration("test", model, (NaturalFrequency(float(np.sqrt(lam[0])), shape=shape),))
    options = FormulationOptions()
    scaling = scaling_of(model, options)
    blk = natural_block(cfg, 0, phi[:, 0], scaling, options)
    assert blk.measured.all() and np.count_nonzero(blk.fixed) == 1
    j = int(np.flatnonzero(blk.fixed)[0])
    box = shape.on_dofs(model)
    ref_mid = 0.5 * sum(box.bounds[model.dofs[j]]) / scaling.s[j]
    # the box holds the truth's mode; the block's entries are the box over its reference's midpoint
    lo, hi = (np.array([box.bounds[d][e] for d in model.dofs]) for e in (0, 1))
    assert np.all(lo <= phi[:, 0]) and np.all(phi[:, 0] <= hi)
    scaled = np.sort(np.stack([lo, hi]) / scaling.s / ref_mid, axis=0)
    free = ~blk.fixed
    np.testing.assert_allclose(blk.lower[free], scaled[0][free], rtol=1e-12)
    np.testing.assert_allclose(blk.upper[free], scaled[1][free], rtol=1e-12)
