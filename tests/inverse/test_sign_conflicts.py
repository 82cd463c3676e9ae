"""Interlacing signs are evidence, not a wall: a receptance whose pole/zero pattern cannot be
met is left out and reported (`vibupdate.inverse.interlacing.SignConflict`), and the run goes on.

The constructed case is a roving-hammer test of a free-free Euler-Bernoulli beam: one
accelerometer at the centre (a node of every antisymmetric mode) and one next to it, the
hammer at four points. At the centre the antisymmetric poles cancel with a zero and do not
show, so those zeros are not measured and the centre's patterns are broken at mode 2.
"""

import numpy as np
import pytest

import vibupdate as vu
from vibupdate.data.measured import Antiresonance, Configuration, NaturalFrequency
from vibupdate.inverse.interlacing import SignConflict, likely_cause
from vibupdate.inverse.update import prepare
from vibupdate.model.build import from_builder

N = 20
PARAMETERS = (vu.Parameter("E", 70e9, 55e9, 85e9, unit="Pa"),)
TRUTH = np.array([72e9])
POINTS = [(r, c) for r in ("y10", "y11") for c in ("y0", "y3", "y6", "y14")]


def beam(p):
    """A 1 m free-free beam, EI = E 1e-9 m^4, 1.62 kg/m."""
    asm = vu.Assembly("beam")
    for i in range(N + 1):
        asm.node(i, i / N)
    for i in range(N):
        asm.beam(i, i + 1, EI=p["E"] * 1e-9, mass_per_length=2700 * 6e-4)
    return asm.system()


@pytest.fixture(scope="module")
def roving():
    """Four flexible frequencies and every zero of the eight FRFs in their band, with 0.1 %
    noise (fixed seed); the zeros that sit on a pole (cancelled at the centre) are not seen."""
    model = from_builder(beam, PARAMETERS)
    M, K = model.matrices_at(TRUTH)
    w = vu.flexible_modes(M, K, 4)[0]
    rng = np.random.default_rng(7)
    natural = tuple(NaturalFrequency(wi * (1 + 1e-3 * rng.standard_normal()), mode=j + 1) for j, wi in enumerate(w))
    zeros = []
    for r, c in POINTS:
        z = vu.antiresonances(M, K, model.dof(r), model.dof(c))
        z = z[(z > 0.5 * w[0]) & (z < 1.02 * w[-1])]
        z = z[np.min(np.abs(z[:, None] / w[None, :] - 1), axis=1) > 1e-3]
        zeros += [Antiresonance(zi * (1 + 1e-3 * rng.standard_normal()), r, c) for zi in z]
    return Configuration("beam", model, natural, tuple(zeros)), Configuration("beam", model, natural, ())


def test_a_broken_pattern_is_dropped_and_named_not_refused(roving):
    """The old code refused the case ("infeasible sign pattern", exit 2 from the CLI)."""
    with_zeros, _ = roving
    notes = prepare([with_zeros]).notes
    assert notes and all(isinstance(n, SignConflict) for n in notes)
    # the FRFs dropped are those of the point on the node, the cause named as such
    assert {n.receptance[0] for n in notes} == {"y10"}
    assert all("near a node of mode 2" in n.cause for n in notes)
    assert all(n.message.startswith("interlacing signs of h_y10,") for n in notes)


def test_the_run_goes_on_and_agrees_with_the_frequencies(roving):
    with_zeros, frequencies = roving
    result = vu.update([with_zeros], probe=False)
    alone = vu.update([frequencies], probe=False)
    dropped = [w for w in result.warnings if w.startswith("interlacing signs of h_y10,")]
    assert dropped, result.warnings
    assert abs(result.values[0] / alone.values[0] - 1) < 5e-3


def test_the_likely_cause_of_a_conflict(roving):
    """Away from a node: no zero measured between the poles names a zero lost in noise or
    damping, one names a zero moved across a pole."""
    with_zeros, _ = roving
    blocks = [b for b in prepare([with_zeros]).blocks if b.kind == "natural"]
    modes = [1, 2, 3, 4]
    away = [b.__class__(**{**b.__dict__, "start": np.ones_like(b.start)}) for b in blocks]
    assert likely_cause(away, modes, 0, 3, ("y0", "y1"), 2, 0) == "a zero between these poles lost in noise or damping"
    assert "moved across a pole" in likely_cause(away, modes, 0, 3, ("y0", "y1"), 2, 1)
    assert "y10 is near a node of mode 2" in likely_cause(blocks, modes, 20, 6, ("y10", "y3"), 1, 1)
