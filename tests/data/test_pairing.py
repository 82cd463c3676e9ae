"""Default zero indices (`vibupdate.data.pairing`): which zero of the model each measured
antiresonance is, when the case does not say."""

import numpy as np
import pytest

from vibupdate import Antiresonance, Assembly, Configuration, NaturalFrequency, Parameter, antiresonances, from_builder
from vibupdate.data.pairing import declare
from vibupdate.modal.analysis import flexible_modes


def chain(n_masses, walls=True):
    """Masses y1..yn with springs k1..k(n-1) between them, unit masses; with ``walls``, also
    k0 (wall-y1) and kn (yn-wall), else free-free. With every spring at its nominal 1000 N/m the
    chain is symmetric, and its middle mass (n odd) is a node of every antisymmetric mode."""
    ends = (0, n_masses) if walls else ()

    def build(p):
        asm = Assembly("beam")
        for i in range(1, n_masses + 1):
            asm.node(i, float(i))
            asm.fix(f"phi{i}")
            asm.mass(f"y{i}", 1.0)
        for i in range(1, n_masses):
            asm.spring(f"y{i}", p.get(f"k{i}", 1000.0), f"y{i + 1}")
        for i in ends:
            asm.spring(f"y{max(i, 1)}", p.get(f"k{i}", 1000.0))
        return asm.system()

    names = range(n_masses + 1) if walls else range(1, n_masses)
    return from_builder(build, [Parameter(f"k{i}", 1000.0, 700.0, 1300.0) for i in names])


def measured_at(model, truth, point):
    """Every flexible natural frequency and every zero of ``h_point,point`` of the model at
    ``truth``, undeclared (the default pairing decides), and the zeros' true indices."""
    M, K = model.matrices_at(truth)
    omega = flexible_modes(M, K)[0]
    zeros = antiresonances(M, K, model.dof(point), model.dof(point))
    cfg = Configuration("test", model, tuple(NaturalFrequency(w) for w in omega),
                        tuple(Antiresonance(z, point, point) for z in zeros))
    return cfg, list(range(1, zeros.size + 1))


def test_a_driving_point_on_a_node_of_the_symmetric_nominal_model_is_counted_by_interlacing():
    """The symmetric nominal chain puts zeros of the middle mass's receptance exactly on the
    poles of its antisymmetric modes; the structure, a little asymmetric, moves each to one side.
    Counting the nominal model's zeros below a mode numbered every zero above the first such pole
    one too high; interlacing numbers them as the structure has them."""
    model = chain(5)
    truth = [1000.0, 1100.0, 950.0, 1050.0, 900.0, 1000.0]
    cfg, true_index = measured_at(model, truth, "y3")
    _, zeros = declare(cfg)
    assert [z.index for z in zeros] == true_index


@pytest.mark.parametrize("n_masses", [3, 5, 7, 9])
def test_driving_points_of_random_asymmetric_chains_keep_their_true_indices(n_masses):
    """A family: for every driving point of the chain (on nodes of the nominal modes or not) and
    8 random truths within the boxes, the default indices are the true ones. (The count at the
    nominal point gets these right as well: this shows that interlacing changes nothing where
    the nominal model has no zero on a pole.)"""
    rng = np.random.default_rng(n_masses)
    model = chain(n_masses)
    wrong = []
    for _ in range(8):
        truth = rng.uniform(700.0, 1300.0, n_masses + 1)
        for point in (f"y{i}" for i in range(1, n_masses + 1)):
            cfg, true_index = measured_at(model, truth, point)
            got = [z.index for z in declare(cfg)[1]]
            if got != true_index:
                wrong.append((point, got, true_index))
    assert not wrong, wrong[:3]


def test_driving_points_of_free_free_chains_count_the_zero_below_the_first_mode():
    """Another boundary condition: free-free chains (a rigid-body mode, so one zero lies below
    the first flexible mode) of 3, 5 and 7 masses, their middle mass on a node of the symmetric
    nominal model's first flexible mode; 6 random truths, every point: the true indices."""
    rng = np.random.default_rng(1)
    wrong = []
    for n in (3, 5, 7):
        model = chain(n, walls=False)
        for _ in range(6):
            truth = rng.uniform(700.0, 1300.0, n - 1)
            for point in (f"y{i}" for i in range(1, n + 1)):
                cfg, true_index = measured_at(model, truth, point)
                got = [a.index for a in declare(cfg)[1]]
                if got != true_index:
                    wrong.append((n, point, got))
    assert not wrong, wrong[:3]
