"""Families of known-truth problems beyond the random draw: the problems users bring.

Each maker draws one problem from a seed alone; its docstring says what a right answer is (the
budgets are in `acceptance.criteria`). Two kinds:

* out of family (``in_family=False``): the data come from another model than the one updated
  (model-form error) or carry an error that excludes the truth (measurement error). The truth
  is then not an answer; what is judged is that no answer claims to fit data it misses, that
  the answer is no further from the data than the nominal model, and, where one group of data
  is wrong by construction, that the diagnosis ranks it first;
* in family, on data the random draw never makes: modes spaced down to 0.1 %, antiresonances
  of cross receptances (also of a symmetric ring), mass-normalized shapes. The truth satisfies every datum; the budgets of
  an in-family problem hold.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from acceptance import structures as S
from acceptance import truth as T
from acceptance.measure import draw_truth, measure
from acceptance.problem import ConfigData, Natural, Problem
from vibupdate import Parameter

__all__ = ["coarse_mesh", "root_spring", "sensor_masses", "biased_channel", "frequency_shift", "misnumbered_zero",
           "close_modes",
           "cross_receptance", "symmetric_ring", "hidden_mode", "mass_normalized", "many_dofs", "many_parameters",
           "shear_building", "caughey_damping", "dashpot_damping", "frf_test", "DAMPING_EXPONENTS",
           "MAKERS"]

TWO_PI = 2.0 * np.pi


def _rng(family: str, seed: int) -> np.random.Generator:
    return np.random.default_rng([20261206, sum(map(ord, family)), seed])


def _noise(rng) -> float:
    return float(10 ** rng.uniform(-3, -2.3))   # 0.1 % to 0.5 %


def _refined(spec: S.StructureSpec, factor: int) -> tuple[S.StructureSpec, dict]:
    """The beam ``spec`` with each element split in ``factor`` (same properties), and the map of
    its DOF names to the fine mesh's."""
    n_el = len(spec.elements)
    x = [xx for _, xx, _ in spec.nodes]
    nodes = []
    for i in range(n_el):
        nodes += [(i * factor + k, x[i] + (x[i + 1] - x[i]) * k / factor, 0.0) for k in range(factor)]
    nodes.append((n_el * factor, x[-1], 0.0))
    elements = []
    for fam, n1, n2, props in spec.elements:
        elements += [(fam, n1 * factor + k, n1 * factor + k + 1, props) for k in range(factor)]
    names = {f"{d}{i}": f"{d}{i * factor}" for i in range(n_el + 1) for d in ("y", "phi")}
    lumped = tuple((fam, names[dof], v, names.get(other) if other else None) for fam, dof, v, other in spec.lumped)
    supports = {k: [lab * factor for lab in v] if k != "fix" else [names[d] for d in v]
                for k, v in spec.supports.items()}
    fine = replace(spec, nodes=tuple(nodes), elements=tuple(elements), lumped=lumped, supports=supports,
                   measurable=tuple(names[d] for d in spec.measurable))
    return fine, names


def _rename(data: ConfigData, back: dict) -> ConfigData:
    """Data measured on another mesh under the model's DOF names."""
    natural = tuple(replace(n, shape={back[d]: v for d, v in n.shape.items()}) if n.shape else n for n in data.natural)
    zeros = tuple(replace(z, response=back[z.response], excitation=back[z.excitation]) for z in data.zeros)
    return replace(data, natural=natural, zeros=zeros)


def _beam_case(rng, n_el: int):
    spec, params = S.beam(rng, n_el, support="clamped", ei_groups=int(rng.integers(1, 3)), m_groups=1)
    return spec, params, draw_truth(rng, params)


def coarse_mesh(seed: int) -> Problem:
    """Model-form error: a clamped beam of 3-6 elements updated from the frequencies (and the tip
    driving point's antiresonances) of the same beam meshed 8 times finer, measured with 0.1-0.5 %
    noise. A right answer: ``success`` only when every datum is admissible for the coarse model;
    never further from the data than the nominal model."""
    rng = _rng("coarse_mesh", seed)
    spec, params, truth = _beam_case(rng, int(rng.integers(3, 7)))
    fine, names = _refined(spec, 8)
    noise = _noise(rng)
    n_el = len(spec.elements)
    kind = "P4" if rng.random() < 0.5 else "P2"
    data = measure(fine, params, truth, kind=kind, rng=rng, noise=noise, n_modes=int(rng.integers(3, 5)),
                   receptances=[(names[f"y{n_el}"],) * 2] if kind == "P4" else None, avoid_poles=True)
    back = {v: k for k, v in names.items()}
    return Problem(f"coarse{seed}", spec, tuple(params), truth, (_rename(data, back),), noise, 0.0, seed,
                   family="coarse_mesh", in_family=False, compromise=True, note="8x finer mesh's data")


def root_spring(seed: int) -> Problem:
    """Model-form error: a clamped beam model; the data (frequencies with 0.1-0.5 % noise, shapes
    at a few translations) come from the same beam whose root turns on a rotational spring of
    5-50 EI/L, which the model lacks. A right answer: ``success`` only when every datum is
    admissible; never further from the data than the nominal model."""
    rng = _rng("root_spring", seed)
    spec, params, truth = _beam_case(rng, int(rng.integers(4, 9)))
    kr = float(rng.uniform(5.0, 50.0) * S.STRIP_EI)
    actual = replace(spec, supports={"fix": ["y0"]}, lumped=spec.lumped + (("spring", "phi0", S.Lin(kr), None),))
    noise = _noise(rng)
    meas = list(spec.measurable)
    sensors = [meas[i] for i in sorted(rng.choice(len(meas), size=min(4, len(meas)), replace=False))]
    kind = "P1" if rng.random() < 0.5 else "P2"
    data = measure(actual, params, truth, kind=kind, rng=rng, noise=noise, shape_noise=noise,
                   n_modes=int(rng.integers(3, 5)), sensors=sensors)
    return Problem(f"root{seed}", spec, tuple(params), truth, (data,), noise, noise if kind == "P1" else 0.0, seed,
                   family="root_spring", in_family=False, compromise=True,
                   note=f"unmodelled root spring {kr:.4g} N m/rad")


def sensor_masses(seed: int) -> Problem:
    """Model-form error: a chain or beam whose data (frequencies and shapes, 0.1-0.5 % noise) were
    measured with an accelerometer of 2-6 % of the structure's mass per DOF at every sensor, which
    the model lacks. A right answer: ``success`` only when every datum is admissible; never
    further from the data than the nominal model."""
    rng = _rng("sensor_masses", seed)
    if rng.random() < 0.5:
        spec, params = S.chain(rng, int(rng.integers(4, 9)), k_groups=int(rng.integers(1, 4)), m_groups=1)
        per_dof = 1.0
    else:
        spec, params = S.beam(rng, int(rng.integers(4, 9)), support="clamped", ei_groups=2, m_groups=1)
        per_dof = S.STRIP_RHO_A / len(spec.elements)
    truth = draw_truth(rng, params)
    meas = list(spec.measurable)
    sensors = [meas[i] for i in sorted(rng.choice(len(meas), size=min(int(rng.integers(3, 6)), len(meas)),
                                                  replace=False))]
    actual = spec
    for dof in sensors:
        actual = actual.with_mass(dof, float(rng.uniform(0.02, 0.06) * per_dof))
    noise = _noise(rng)
    data = measure(actual, params, truth, kind="P1", rng=rng, noise=noise, shape_noise=noise,
                   n_modes=int(rng.integers(3, 5)), sensors=sensors)
    return Problem(f"sensors{seed}", spec, tuple(params), truth, (data,), noise, noise, seed, family="sensor_masses",
                   in_family=False, compromise=True, note="unmodelled sensor masses")



def _chain_or_beam(rng, sizes: tuple[int, int], k_groups_top: int, chain_masses: int):
    """Half the time a chain of ``sizes`` masses (1 to ``k_groups_top - 1`` stiffness groups,
    ``chain_masses`` mass groups), else a clamped beam of ``sizes`` elements (2 EI groups, 1
    mass group): the structures most families draw, in the draw order they always used."""
    if rng.random() < 0.5:
        return S.chain(rng, int(rng.integers(*sizes)), k_groups=int(rng.integers(1, k_groups_top)),
                       m_groups=chain_masses)
    return S.beam(rng, int(rng.integers(*sizes)), support="clamped", ei_groups=2, m_groups=1)

def biased_channel(seed: int) -> Problem:
    """Measurement error excluding the truth: frequencies and shapes (0.1-0.3 % noise) of a chain
    or beam, one sensor's entry scaled by 1 +- (8-20 %) in every mode (a wrong calibration). A
    right answer: never ``success`` for a model that misses an interval; the diagnosis ranks
    that sensor (group ``A/dof/DOF``) first."""
    rng = _rng("biased_channel", seed)
    spec, params = _chain_or_beam(rng, (4, 8), k_groups_top=4, chain_masses=0)
    truth = draw_truth(rng, params)
    noise = float(10 ** rng.uniform(-3, -2.5))
    meas = list(spec.measurable)
    sensors = [meas[i] for i in sorted(rng.choice(len(meas), size=min(int(rng.integers(4, 7)), len(meas)),
                                                  replace=False))]
    data = measure(spec, params, truth, kind="P1", rng=rng, noise=noise, shape_noise=noise, n_modes=4,
                   sensors=sensors)
    shaped = [n for n in data.natural if n.shape]
    common = [d for d in sensors if all(d in n.shape for n in shaped)]
    pick = common[int(rng.integers(len(common)))]
    bias = float(rng.choice([-1.0, 1.0]) * rng.uniform(0.08, 0.2))
    natural = tuple(replace(n, shape={d: (lo * (1 + bias), hi * (1 + bias)) if d == pick else (lo, hi)
                                      for d, (lo, hi) in n.shape.items()}) if n.shape else n for n in data.natural)
    data = replace(data, natural=natural)
    return Problem(f"biased{seed}", spec, tuple(params), truth, (data,), noise, noise, seed, family="biased_channel",
                   in_family=False, expected_first=f"A/dof/{pick}", note=f"sensor {pick} biased by {bias:+.3f}")


def misnumbered_zero(seed: int) -> Problem:
    """Measurement error excluding the truth: the frequencies and the antiresonances between them
    of a driving point or a cross receptance of a chain or beam (exact, or 0.1-0.5 % noise), every
    index stated, one of them one off (a slip: the highest measured zero whose next or previous
    index keeps the indices rising and names a zero of the model stated as that one). A right
    answer: never ``success`` for a model that misses an interval; the diagnosis ranks that zero
    (group ``A/antiresonance/R,C/INDEX``) first."""
    rng = _rng("misnumbered_zero", seed)
    for _ in range(50):
        spec, params = _chain_or_beam(rng, (4, 9), k_groups_top=4, chain_masses=1)
        truth = draw_truth(rng, params)
        meas = list(spec.measurable)
        r, c = (meas[i] for i in rng.choice(len(meas), size=2, replace=bool(rng.random() < 0.5)))
        M, K, dofs = S.matrices_at(spec, truth)
        n_zeros = T.zeros(M, K, dofs.index(r), dofs.index(c))[0].size
        noise = 0.0 if rng.random() < 0.5 else _noise(rng)
        n_modes = min(int(rng.integers(3, 6)), int(np.count_nonzero(T.modes(M, K)[0] > 0)))
        data = measure(spec, params, truth, kind="P4", rng=rng, noise=noise, n_modes=n_modes, receptances=[(r, c)],
                       avoid_poles=True)
        index = [0] + [z.index for z in data.zeros] + [n_zeros + 1]
        slips = [(k, index[k + 1] + d) for k in reversed(range(len(data.zeros))) for d in (1, -1)
                 if index[k] < index[k + 1] + d < index[k + 2]]   # still rising, a zero the model has
        if slips:
            break
    zeros = list(data.zeros)
    k, slip = slips[0]
    zeros[k] = replace(zeros[k], index=slip)
    data = replace(data, zeros=tuple(zeros), declare=True)
    return Problem(f"slip{seed}", spec, tuple(params), truth, (data,), noise, 0.0, seed, family="misnumbered_zero",
                   in_family=False, expected_first=f"A/antiresonance/{r},{c}/{slip}",
                   note=f"zero of h_{r},{c} at {zeros[k].hz:.5g} Hz stated as zero {slip}")


def frequency_shift(seed: int) -> Problem:
    """Measurement error excluding the truth: every frequency (natural and antiresonance) of a
    random problem's data shifted by the same 0.5-2 % (a temperature change), its intervals with
    it. A right answer: never ``success`` for a model that misses an interval."""
    rng = _rng("frequency_shift", seed)
    from acceptance.generator import random_problem

    base = random_problem(int(rng.integers(0, 10 ** 6)))
    while base.exact:   # a noisy random problem: its intervals are what the shift moves
        base = random_problem(int(rng.integers(0, 10 ** 6)))
    shift = float(rng.choice([-1.0, 1.0]) * rng.uniform(0.005, 0.02))
    data = tuple(replace(c, natural=tuple(replace(n, hz=n.hz * (1 + shift)) for n in c.natural),
                         zeros=tuple(replace(z, hz=z.hz * (1 + shift)) for z in c.zeros)) for c in base.data)
    return replace(base, case_id=f"shift{seed}", data=data, seed=seed, family="frequency_shift", in_family=False,
                   note=f"every frequency shifted by {100 * shift:+.2f} % (from {base.case_id})")


def _twin_chains(rng, n: int, coupling: float):
    """Two chains of ``n`` unit masses, each grounded at its first mass, their tips joined by a
    spring ``kc``: parameters ``kA``, ``kB`` (the springs of each chain) and ``kc``."""
    lumped = []
    for side, first in (("A", 1), ("B", n + 1)):
        lumped += [("mass", f"y{first + i}", S.Lin(1.0), None) for i in range(n)]
        lumped.append(("spring", f"y{first}", S.Lin.of(1.0, f"k{side}"), None))
        lumped += [("spring", f"y{first + i}", S.Lin.of(1.0, f"k{side}"), f"y{first + i - 1}") for i in range(1, n)]
    lumped.append(("spring", f"y{n}", S.Lin.of(1.0, "kc"), f"y{2 * n}"))
    nodes = tuple((i, float(i), 0.0) for i in range(1, 2 * n + 1))
    spec = S.StructureSpec("twin-chains", "beam", nodes, {"fix": [f"phi{i}" for i in range(1, 2 * n + 1)]}, (),
                           tuple(lumped), tuple(f"y{i}" for i in range(1, 2 * n + 1)))
    params = [S._parameter("kA", 1000.0, 0.3, "N/m"), S._parameter("kB", 1000.0, 0.3, "N/m"),
              S._parameter("kc", 1000.0 * coupling, 0.5, "N/m")]
    return spec, params


def close_modes(seed: int) -> Problem:
    """In family: two nearly equal chains joined at their tips by a weak spring, so their modes
    come in pairs, the closest pair spaced from under 0.1 % to a few %; frequencies (exact, or with noise under a tenth of the closest
    spacing) and, half of the time, shapes at a few masses of both chains. A right answer: as
    for any in-family problem (verified, the determined parameters at the truth or its mirror
    image ``kA <-> kB``)."""
    rng = _rng("close_modes", seed)
    n = int(rng.integers(2, 5))
    spec, params = _twin_chains(rng, n, coupling=float(10 ** rng.uniform(-3, -1.5)))
    k = 1000.0 * float(rng.uniform(0.8, 1.2))
    truth = {"kA": k, "kB": k * (1 + float(rng.uniform(-0.004, 0.004))),
             "kc": params[2].nominal * float(rng.uniform(0.7, 1.4))}
    M, K, _ = S.matrices_at(spec, truth)
    w = T.modes(M, K)[0]
    n_modes = int(rng.integers(2, min(6, w.size) + 1))
    spacing = float(np.min(np.diff(w[:n_modes]) / w[1:n_modes]))
    exact = rng.random() < 0.5
    noise = 0.0 if exact else min(0.1 * spacing / 3, 0.002)
    kind = "P1" if rng.random() < 0.5 else "P2"
    sensors = [f"y{n}", f"y{2 * n}", "y1", f"y{n + 1}"]
    data = measure(spec, params, truth, kind=kind, rng=rng, noise=noise, shape_noise=noise, n_modes=n_modes,
                   sensors=sensors)
    symmetric = abs(truth["kA"] - truth["kB"]) <= 1e-12
    return Problem(f"close{seed}", spec, tuple(params), truth, (data,), noise, noise if kind == "P1" else 0.0, seed,
                   symmetries=((("kA", "kB"),),), family="close_modes",
                   note=f"closest spacing {100 * spacing:.3g} %" + (" symmetric" if symmetric else ""))


def cross_receptance(seed: int) -> Problem:
    """In family: a chain or beam with the frequencies and the antiresonances of a cross
    receptance ``h_rc`` (r != c) between them, or the antiresonances alone, exact or with 0.1-0.5 %
    noise. A right answer: as for any in-family problem."""
    rng = _rng("cross_receptance", seed)
    spec, params = _chain_or_beam(rng, (4, 9), k_groups_top=4, chain_masses=1)
    truth = draw_truth(rng, params)
    meas = list(spec.measurable)
    noise = 0.0 if rng.random() < 0.5 else _noise(rng)
    M, K, dofs = S.matrices_at(spec, truth)
    for _ in range(20):
        r, c = (meas[i] for i in rng.choice(len(meas), size=2, replace=False))
        z = T.zeros(M, K, dofs.index(r), dofs.index(c))[0]
        if z.size >= 2:
            break
    kind = "P4" if rng.random() < 0.6 else "P3"
    n_modes = min(int(rng.integers(3, 6)), int(np.count_nonzero(T.modes(M, K)[0] > 0)))
    data = measure(spec, params, truth, kind=kind, rng=rng, noise=noise, n_modes=n_modes, receptances=[(r, c)],
                   zero_indices=list(range(1, min(z.size, 3) + 1)), avoid_poles=True)
    if not data.zeros:   # no zero between the measured poles: the first zeros alone
        kind = "P3"
        data = measure(spec, params, truth, kind=kind, rng=rng, noise=noise, receptances=[(r, c)],
                       zero_indices=list(range(1, min(z.size, 3) + 1)), avoid_poles=True)
    return Problem(f"cross{seed}", spec, tuple(params), truth, (data,), noise, 0.0, seed, family="cross_receptance",
                   note=f"zeros of h_{r},{c}")


def _ring(n: int):
    """``n`` unit masses on a ring of springs, each also grounded: ``kA`` the ring springs of one
    half, ``kB`` of the other, ``kg`` the ground springs. Cyclic at the nominal point (repeated
    frequencies, zeros of cross receptances on poles); mirror-symmetric at every point."""
    lumped = [("mass", f"y{i}", S.Lin(1.0), None) for i in range(1, n + 1)]
    lumped += [("spring", f"y{i}", S.Lin.of(1.0, "kg"), None) for i in range(1, n + 1)]
    lumped += [("spring", f"y{i % n + 1}", S.Lin.of(1.0, "kA" if i <= n // 2 else "kB"), f"y{i}")
               for i in range(1, n + 1)]
    nodes = tuple((i, float(i), 0.0) for i in range(1, n + 1))
    spec = S.StructureSpec("ring", "beam", nodes, {"fix": [f"phi{i}" for i in range(1, n + 1)]}, (),
                           tuple(lumped), tuple(f"y{i}" for i in range(1, n + 1)))
    params = [S._parameter("kA", 5000.0, 0.3, "N/m"), S._parameter("kB", 5000.0, 0.3, "N/m"),
              S._parameter("kg", 1000.0, 0.3, "N/m")]
    return spec, params


def symmetric_ring(seed: int) -> Problem:
    """In family: a ring of 6-12 masses (`_ring`), cyclic at the nominal point, the truth drawn
    in the boxes; the lowest 4-6 frequencies with the antiresonances between them of the driving
    point at ``y1`` and of a cross receptance from ``y1`` (the indices left to the default: the
    nominal model's repeated frequencies put zeros on poles; stated where zeros of the cross
    receptance left or joined the real axis, which no default counts), exact or with noise under a tenth of
    the closest spacing. A right answer: as for any in-family problem (the truth or its mirror
    image ``kA <-> kB``)."""
    rng = _rng("symmetric_ring", seed)
    n = int(rng.integers(6, 13))
    spec, params = _ring(n)
    truth = draw_truth(rng, params)
    M, K, _ = S.matrices_at(spec, truth)
    w = T.modes(M, K)[0]
    n_modes = int(rng.integers(4, 7))
    spacing = float(np.min(np.diff(w[:n_modes]) / w[1:n_modes]))
    noise = 0.0 if rng.random() < 0.5 else min(_noise(rng), 0.1 * spacing / 3)
    for c in (f"y{i}" for i in rng.permutation(np.arange(2, n // 2 + 2))):   # one with zeros between the poles
        data = measure(spec, params, truth, kind="P4", rng=rng, noise=noise, n_modes=n_modes,
                       receptances=[("y1", "y1"), ("y1", c)], declare=False, avoid_poles=True)
        if any(z.excitation == c for z in data.zeros):
            break
    M0, K0, dofs = S.matrices_at(spec, {p.name: p.nominal for p in params})
    pair = dofs.index("y1"), dofs.index(c)
    left = T.zeros(M0, K0, *pair)[0].size - T.zeros(M, K, *pair)[0].size   # real zeros lost (+) or gained (-)
    if left:   # no default counts them (docs/notes/data-and-formulation.md): the data say which zeros
        data = replace(data, declare=True)
    return Problem(f"ring{seed}", spec, tuple(params), truth, (data,), noise, 0.0, seed,
                   symmetries=((("kA", "kB"),),), family="symmetric_ring",
                   note=f"{n} masses, zeros of h_y1,y1 and h_y1,{c}, closest spacing {100 * spacing:.3g} %"
                   + (f"; {abs(left)} zeros of h_y1,{c} {'left' if left > 0 else 'joined'} the real axis: indices stated" if left else ""))


def hidden_mode(seed: int) -> Problem:
    """In family: a chain or beam tested with its exciter near a node of one of its modes, so
    that no FRF shows that mode (its modal constant at the exciter under 1 % of the largest
    there among the measured modes): the lowest 4-6 frequencies but that one (their modes stated), with the
    antiresonances between the measured poles of the driving point and of a cross receptance
    from the exciter, less the zero of each that sits next to the hidden pole (it cancels the
    pole); the zero indices left to the default, stated where no default can count them (zeros
    that crossed a measured pole between the nominal model and the truth; two zeros within 2 % of the
    hidden pole). Exact or with 0.1-0.5 % noise. A right answer: as for any in-family problem."""
    rng = _rng("hidden_mode", seed)
    for _ in range(100):
        spec, params = _chain_or_beam(rng, (5, 10), k_groups_top=4, chain_masses=1)
        truth = draw_truth(rng, params)
        M, K, dofs = S.matrices_at(spec, truth)
        w, Phi = T.modes(M, K)
        flexible = np.flatnonzero(w > 0)[:int(rng.integers(4, 7))]
        meas = list(spec.measurable)
        constants = Phi[np.ix_([dofs.index(d) for d in meas], flexible)] ** 2      # of the driving points
        share = constants[:, 1:-1] / constants.max(axis=1, keepdims=True)
        i, k = np.unravel_index(np.argmin(share), share.shape)
        if share[i, k] <= 0.01 and len(meas) > 1:
            break
    r, hidden = meas[i], int(flexible[1 + k])
    c = meas[(i + 1 + int(rng.integers(len(meas) - 1))) % len(meas)]
    noise = 0.0 if rng.random() < 0.5 else _noise(rng)
    modes = [int(m) + 1 for m in flexible if m != hidden]
    data = measure(spec, params, truth, kind="P4", rng=rng, noise=noise, modes=modes, receptances=[(r, r), (c, r)],
                   declare="modes", avoid_poles=True)
    zeros = list(data.zeros)
    for pair in ((r, r), (c, r)):   # the zero next to the hidden pole cancels it: no FRF shows it
        mine = [z for z in zeros if (z.response, z.excitation) == pair]
        if mine:
            near = min(mine, key=lambda z: abs(TWO_PI * z.hz / w[hidden] - 1))
            if abs(TWO_PI * near.hz / w[hidden] - 1) < 0.05:
                zeros.remove(near)
    data = replace(data, zeros=tuple(zeros))
    # no default counts zeros that crossed a measured pole between the nominal model and the truth, nor
    # says which of two zeros within 2 % of the hidden pole a test would see: those state indices
    M0, K0, _ = S.matrices_at(spec, {p.name: p.nominal for p in params})
    w0 = T.modes(M0, K0)[0]
    edges, edges0 = w[np.array(modes) - 1], w0[np.array(modes) - 1]    # the measured poles
    why = []
    for pair in ((r, r), (c, r)):
        z = T.zeros(M, K, dofs.index(pair[0]), dofs.index(pair[1]))[0]
        z0 = T.zeros(M0, K0, dofs.index(pair[0]), dofs.index(pair[1]))[0]
        if not np.array_equal(np.histogram(z, edges)[0], np.histogram(z0, edges0)[0]):
            why.append(f"zeros of h_{pair[0]},{pair[1]} crossed a measured pole")
        if pair[0] == pair[1] and z.size > 1 and np.sort(np.abs(z / w[hidden] - 1))[1] < 0.02:
            why.append("two zeros within 2 % of the hidden pole")
    if why:
        data = replace(data, declare=True)
    return Problem(f"hidden{seed}", spec, tuple(params), truth, (data,), noise, 0.0, seed, family="hidden_mode",
                   note=f"mode {hidden + 1} hidden at the exciter {r} (constant {share[i, k]:.2g}); zeros of "
                        f"h_{r},{r} and h_{c},{r}" + (f"; indices stated ({', '.join(why)})" if why else ""))


def mass_normalized(seed: int) -> Problem:
    """In family: a chain or beam whose shapes are mass-normalized (``phi^T M phi = 1``, entries
    in 1/sqrt(kg) times the DOF's unit, a common sign free), with their frequencies, exact or with
    0.1-0.5 % noise on frequencies and relative noise of the same size on the shape entries; the
    masses are parameters too (mass-normalized shapes separate them from the stiffnesses). A
    right answer: as for any in-family problem."""
    rng = _rng("mass_normalized", seed)
    spec, params = _chain_or_beam(rng, (3, 8), k_groups_top=3, chain_masses=1)
    truth = draw_truth(rng, params)
    noise = 0.0 if rng.random() < 0.5 else _noise(rng)
    meas = list(spec.measurable)
    sensors = [meas[i] for i in sorted(rng.choice(len(meas), size=min(int(rng.integers(2, 5)), len(meas)),
                                                  replace=False))]
    M, K, dofs = S.matrices_at(spec, truth)
    w, Phi = T.modes(M, K)
    n_modes = min(int(rng.integers(2, 5)), int(np.count_nonzero(w > 0)))   # a 3-DOF chain has 3 modes
    base = measure(spec, params, truth, kind="P2", rng=rng, noise=noise, n_modes=n_modes)
    natural = []
    for n in base.natural:
        phi = Phi[[dofs.index(d) for d in sensors], n.mode - 1]
        phi = phi * np.sign(phi[np.argmax(np.abs(phi))])
        half = np.maximum(3 * noise * np.abs(phi), 1e-9 * np.max(np.abs(phi)))
        mid = phi + (noise * np.abs(phi) * rng.standard_normal(phi.size).clip(-3, 3) if noise else 0.0)
        natural.append(Natural(n.hz, n.mode, {d: (float(m - h), float(m + h)) for d, m, h in zip(sensors, mid, half)}))
    data = replace(base, natural=tuple(natural))
    return Problem(f"massnorm{seed}", spec, tuple(params), truth, (data,), noise, noise, seed,
                   family="mass_normalized", mass_normalized=True, note="mass-normalized shapes")


#: The exponents of the true Caughey damping of `caughey_damping` (Rayleigh first).
DAMPING_EXPONENTS = ((0.0, 1.0), (0.0, 1.0, 2.0), (-1.0, 0.0, 1.0), (0.0, 0.5, 1.0), (-0.5, 0.5))


def _caughey(rng, omega: np.ndarray, rigid: bool) -> tuple[np.ndarray, np.ndarray]:
    """Exponents from `DAMPING_EXPONENTS` (none negative for a model with rigid-body modes,
    ``rigid``) and coefficients whose modal damping ratios are 0.5-5 % (log-uniform) at as many of
    the modes ``omega`` (rad/s, ascending) as there are terms, spread from the lowest to the
    highest, and positive over ``(0, 1.6 omega[-1]]``; drawn again until they are."""
    grid = np.geomspace(1e-6, 1.6, 2000) * omega[-1]
    sets = [Y for Y in DAMPING_EXPONENTS if not rigid or min(Y) >= 0]
    for _ in range(100):
        Y = np.array(sets[int(rng.integers(len(sets)))])
        anchors = omega[np.unique(np.linspace(0, omega.size - 1, min(Y.size, omega.size)).round().astype(int))]
        Y = Y[:anchors.size]
        A = np.column_stack([T.caughey_ratios(Y, np.eye(Y.size)[j], anchors) for j in range(Y.size)])
        beta = np.linalg.solve(A, 10 ** rng.uniform(np.log10(0.005), np.log10(0.05), Y.size))
        if np.all(T.caughey_ratios(Y, beta, grid) > 0):
            return Y, beta
    raise RuntimeError("no positive Caughey damping drawn in 100 tries")


def caughey_damping(seed: int) -> Problem:
    """In family: a chain, a clamped beam or a free-free beam (two rigid-body modes) whose true
    damping is a Caughey series (`DAMPING_EXPONENTS`: Rayleigh, or two or three other terms, none
    negative with rigid-body modes) with modal damping ratios of
    0.5-5 % at the measured modes and positive up to 1.6 times the highest; 3-6 measured modes
    with their frequencies (exact or with 0.1-0.5 % noise) and damping ratios (exact, or with
    2-10 % relative noise), typed in the case file or in its frequency table, fitted with the
    true exponents; half the problems add a second configuration with a known added mass (the
    same series on its own mass and stiffness), and half of those with exact ratios give damped
    frequencies (``frequency_type = "damped"``). A right answer: as for any in-family problem, its damping fit the least
    squares of the measured ratios at its own frequencies (exact on exact data), and negative
    modal damping of the fitted series warned of."""
    rng = _rng("caughey_damping", seed)
    if rng.random() < 0.2:
        spec, params = S.beam(rng, int(rng.integers(4, 9)), support="free", ei_groups=2, m_groups=1)
    else:
        spec, params = _chain_or_beam(rng, (3, 8), k_groups_top=3, chain_masses=1)
    truth = draw_truth(rng, params)
    noise = 0.0 if rng.random() < 0.5 else _noise(rng)
    n_modes = min(int(rng.integers(3, 7)), len(spec.measurable))
    extras = [None]
    if rng.random() < 0.5:   # a second configuration with a known added mass: one series, the same coefficients
        per_dof = 1.0 if spec.label.startswith("chain") else S.STRIP_RHO_A / len(spec.elements)
        meas = list(spec.measurable)
        extras.append((meas[int(rng.integers(len(meas)))], float(rng.uniform(0.1, 0.3) * per_dof)))
    data, omegas = [], []
    for name, extra in zip("AB", extras):
        data.append(measure(spec, params, truth, kind="P2", rng=rng, noise=noise, n_modes=n_modes, name=name,
                            extra_mass=extra))
        M, K, _ = S.matrices_at(spec.with_mass(*extra) if extra else spec, truth)
        omegas.append(T.modes(M, K)[0][[n.mode - 1 for n in data[-1].natural]])
    Y, beta = _caughey(rng, np.sort(np.concatenate(omegas)), spec.rigid_modes > 0)
    sigma = 0.0 if rng.random() < 0.5 else float(rng.uniform(0.02, 0.1))
    for k, omega in enumerate(omegas):
        ratios = T.caughey_ratios(Y, beta, omega) * (1 + sigma * rng.standard_normal(omega.size).clip(-3, 3))
        data[k] = replace(data[k], natural=tuple(replace(n, damping=float(z)) for n, z in zip(data[k].natural, ratios)))
    damped = sigma == 0 and bool(rng.random() < 0.5)   # exact ratios make damped frequencies natural exactly
    return Problem(f"damp{seed}", spec, tuple(params), truth, tuple(data), noise, 0.0, seed,
                   csv=bool(rng.random() < 0.3), family="caughey_damping",
                   damping=(tuple(Y.tolist()), tuple(beta.tolist())), damping_noise=sigma, damped=damped,
                   note=f"Caughey damping Y = {Y.tolist()}, {len(data)} configuration(s), ratios "
                   + ("exact" if sigma == 0 else f"with {100 * sigma:.1f} % noise")
                   + (", damped frequencies" if damped else ""))


def dashpot_damping(seed: int) -> Problem:
    """Model-form error in the damping: a chain or clamped beam damped by Rayleigh damping (1 % at
    its first and highest measured modes) and one dashpot to ground at a random DOF, whose share of
    the first mode's damping is 1-5 % (non-proportional: complex modes). Its data are what a modal
    test identifies of 3-6 modes: the poles' magnitudes as natural frequencies (with 0.1-0.5 %
    noise) and their real parts over them as damping ratios, fitted with Rayleigh damping
    or another series of `DAMPING_EXPONENTS`. A right answer: ``success`` only when every datum
    is admissible; never further from the data than the nominal model; the damping fit the least
    squares of the measured ratios at its own frequencies, and negative modal damping of it
    warned of."""
    import scipy.linalg as la

    rng = _rng("dashpot_damping", seed)
    spec, params = _chain_or_beam(rng, (3, 8), k_groups_top=3, chain_masses=1)
    truth = draw_truth(rng, params)
    noise = _noise(rng)   # noisy: the case then holds frequencies to their intervals alone (`emit.model_form`)
    base = measure(spec, params, truth, kind="P2", rng=rng, noise=noise,
                   n_modes=min(int(rng.integers(3, 7)), len(spec.measurable)))
    M, K, dofs = S.matrices_at(spec, truth)
    w, Phi = T.modes(M, K)
    modes = [n.mode - 1 for n in base.natural]
    a, b = np.linalg.solve([[1 / (2 * w[modes[0]]), w[modes[0]] / 2], [1 / (2 * w[modes[-1]]), w[modes[-1]] / 2]],
                           [0.01, 0.01])
    C = a * M + b * K
    d = dofs.index(spec.measurable[int(rng.integers(len(spec.measurable)))])
    C[d, d] += float(rng.uniform(0.01, 0.05)) * 2 * w[modes[0]] / max(Phi[d, modes[0]] ** 2, 1e-12)
    n = M.shape[0]
    poles = la.eigvals(np.block([[np.zeros((n, n)), np.eye(n)], [-la.solve(M, K), -la.solve(M, C)]]))
    poles = poles[poles.imag > 0]
    poles = poles[np.argsort(np.abs(poles))]
    natural = tuple(replace(m, hz=float(abs(poles[k]) / TWO_PI * m.hz / (w[k] / TWO_PI)),
                            damping=float(-poles[k].real / abs(poles[k]))) for m, k in zip(base.natural, modes))
    Y = DAMPING_EXPONENTS[int(rng.integers(len(DAMPING_EXPONENTS)))]
    return Problem(f"dashpot{seed}", spec, tuple(params), truth, (replace(base, natural=natural),), noise, 0.0, seed,
                   csv=bool(rng.random() < 0.3), family="dashpot_damping", in_family=False, damping=(Y, ()),
                   note=f"Rayleigh damping and a dashpot at {dofs[d]}, fitted with Y = {list(Y)}")


def frf_test(seed: int) -> Problem:
    """Data as a shaker test gives them: a chain or clamped beam (4-8 DOFs or elements) with
    Rayleigh damping (0.5-2 % at its first and its highest measured mode), its receptances from an
    exciter at a random DOF to every translation, over a span holding its 3-5 lowest modes and the
    next, 4,000 lines, three repeats with 0.5 % noise and a -60 dB floor, as table files the case's
    ``[configuration.frf]`` names with no mode numbers (the extracted shapes number them). The
    judge holds the answer to the true frequencies of the modes in the band within 0.9 % (its own
    intervals: the run's come from the extraction). A right answer: ``success`` only when every
    true frequency is within 0.9 %; never further from them than the nominal model. Case-file
    route only (a Python user numbers the extracted modes by hand)."""
    rng = _rng("frf_test", seed)
    if rng.random() < 0.5:
        spec, params = S.chain(rng, int(rng.integers(4, 9)), k_groups=int(rng.integers(1, 3)), m_groups=1)
    else:
        spec, params = S.beam(rng, int(rng.integers(4, 9)), support="clamped", ei_groups=2, m_groups=1)
    truth = draw_truth(rng, params)
    M, K, dofs = S.matrices_at(spec, truth)
    w, _ = T.modes(M, K)
    n = min(int(rng.integers(3, 6)), w.size)
    zeta = float(rng.uniform(0.005, 0.02))
    a, b = np.linalg.solve([[1 / (2 * w[0]), w[0] / 2], [1 / (2 * w[n - 1]), w[n - 1] / 2]], [zeta, zeta])
    translations = [d for d in spec.measurable if d.startswith(("x", "y"))]
    top = w[n] if w.size > n else 1.3 * w[n - 1]
    frf = {"exciter": translations[int(rng.integers(len(translations)))], "responses": translations,
           "rayleigh": (float(a), float(b)), "span_hz": (0.3 * w[0] / TWO_PI, 1.15 * top / TWO_PI), "lines": 4000,
           "band_hz": (0.5 * w[0] / TWO_PI, 1.1 * w[n - 1] / TWO_PI), "repeats": 3, "noise": 0.005, "floor": 1e-3,
           "seed": int(rng.integers(2 ** 31))}
    data = ConfigData("A", tuple(Natural(float(w[k] / TWO_PI), k + 1) for k in range(n)))
    return Problem(f"frf{seed}", spec, tuple(params), truth, (data,), 0.003, 0.0, seed, family="frf_test",
                   in_family=False, frf=frf, note=f"FRFs from {frf['exciter']} to {len(translations)} DOFs, "
                                                  f"{n} modes, {100 * zeta:.2g} % damping")


def _zoned_beam(rng, n_el: int, zones: int, m_groups: int = 1) -> tuple[S.StructureSpec, list]:
    """A clamped beam of ``n_el`` elements whose EI parameters are ``zones`` contiguous stretches
    (``EI1`` at the root ...), each element's nominal EI drawn +-15 % about the strip's; one mass
    parameter ``rA1`` over the whole beam (``m_groups=1``) or none (``0``: masses known)."""
    spec, params = S.beam(rng, n_el, support="clamped", ei_groups=1, m_groups=m_groups)
    zone_params = {f"EI{z + 1}": S._parameter(f"EI{z + 1}", S.STRIP_EI, 0.3, "N m^2") for z in range(zones)}
    elements = []
    for e, (fam, n1, n2, props) in enumerate(spec.elements):
        (coef, _), = props["EI"].terms
        elements.append((fam, n1, n2, {**props, "EI": S.Lin.of(coef, f"EI{e * zones // n_el + 1}")}))
    spec = replace(spec, elements=tuple(elements))
    return spec, list(zone_params.values()) + [p for p in params if not p.name.startswith("EI")]


def _sensors(rng, spec, count: int) -> list[str]:
    meas = list(spec.measurable)
    return [meas[i] for i in sorted(rng.choice(len(meas), size=min(count, len(meas)), replace=False))]


def _zoned_chain(rng, n: int, zones: int) -> tuple[S.StructureSpec, list]:
    """A chain of ``n`` masses grounded at ``y1``, its springs in ``zones`` contiguous stretches
    (``k1`` at the ground ...), each spring's and mass's nominal drawn as `structures.chain`
    draws them, and one mass parameter ``m1`` over every mass."""
    spec, params = S.chain(rng, n, k_groups=1, m_groups=1)
    zone_params = {f"k{z + 1}": S._parameter(f"k{z + 1}", 1000.0, 0.3, "N/m") for z in range(zones)}
    lumped, spring = [], 0
    for fam, dof, v, other in spec.lumped:
        if fam == "spring":
            (coef, _), = v.terms
            v = S.Lin.of(coef, f"k{spring * zones // n + 1}")
            spring += 1
        lumped.append((fam, dof, v, other))
    spec = replace(spec, lumped=tuple(lumped))
    return spec, list(zone_params.values()) + [p for p in params if p.name.startswith("m")]


def _chain_size(rng) -> int:
    """A chain's mass count, 50 to 5,000, log-uniform: the first draw of `many_dofs`."""
    return int(np.round(10 ** rng.uniform(np.log10(50), np.log10(5000))))


def many_dofs(seed: int) -> Problem:
    """In family, size: a spring-mass chain of 50-5,000 masses (the count drawn log-uniformly;
    one DOF each), its springs in 2-3 contiguous zones and one mass parameter; the first 3-5
    frequencies, exact or with 0.1-0.5 % noise, and half of the time shapes at 4-6 masses. Above
    400 DOFs the library takes its sparse kernels, its reduction and its reduced polish rounds,
    and the judge its sparse truth kernel (`acceptance.truth`). A chain, not a beam: a beam's
    stiffness condition grows as the fourth power of its element count, and at 4,426 DOFs three
    eigen-solvers gave its first frequency 2e-5 to 6e-5 apart, which no exact datum can be held
    to. A right answer: as for any in-family problem."""
    rng = _rng("many_dofs", seed)
    n = _chain_size(rng)
    spec, params = _zoned_chain(rng, n, int(rng.integers(2, 4)))
    truth = draw_truth(rng, params)
    noise = 0.0 if rng.random() < 0.5 else _noise(rng)
    kind = "P1" if rng.random() < 0.5 else "P2"
    sensors = _sensors(rng, spec, int(rng.integers(4, 7))) if kind == "P1" else None
    data = measure(spec, params, truth, kind=kind, rng=rng, noise=noise, shape_noise=noise,
                   n_modes=int(rng.integers(3, 6)), sensors=sensors)
    return Problem(f"dofs{seed}", spec, tuple(params), truth, (data,), noise, noise if kind == "P1" else 0.0, seed,
                   family="many_dofs", note=f"{n} DOFs")


def many_parameters(seed: int) -> Problem:
    """In family, size: 20-40 parameters. Half the time a chain of 20-40 known masses grounded at
    one end, each spring its own parameter; else a clamped beam of 40-80 elements, its EI in
    20-40 contiguous zones (masses known). Data: the first 6-10 frequencies with shapes at every
    translation, exact or with 0.1-0.3 % noise. A right answer: as for any in-family problem."""
    rng = _rng("many_parameters", seed)
    n_par = int(rng.integers(20, 41))
    if rng.random() < 0.5:
        spec, params = S.chain(rng, n_par, k_groups=n_par, m_groups=0)
    else:
        spec, params = _zoned_beam(rng, 2 * n_par, n_par, m_groups=0)
    truth = draw_truth(rng, params)
    noise = 0.0 if rng.random() < 0.5 else float(10 ** rng.uniform(-3, -2.5))
    data = measure(spec, params, truth, kind="P1", rng=rng, noise=noise, shape_noise=noise,
                   n_modes=int(rng.integers(6, 11)), sensors=list(spec.measurable))
    return Problem(f"params{seed}", spec, tuple(params), truth, (data,), noise, noise, seed,
                   family="many_parameters", note=f"{len(params)} parameters, {len(spec.measurable)} sensors")


def _braced_frame():
    """`benchmarks/braced_frame.py` (the 4-storey 2x2-bay braced frame), loaded from its file."""
    import importlib.util
    from pathlib import Path

    path = Path(__file__).resolve().parents[2] / "benchmarks" / "braced_frame.py"
    spec = importlib.util.spec_from_file_location("acceptance_braced_frame", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def shear_building(seed: int) -> Problem:
    """Model-form error: the 12-DOF rigid-floor (shear-building) model of a 4-storey, 2x2-bay
    braced steel frame (`benchmarks/braced_frame.py`), 8 stiffness factors (braces and columns
    per storey, nominal 1 in [0.2, 1.5]), updated from the 6 lowest modes of the frame's 120-DOF
    model at a drawn truth (brace factors 0.5-1, column factors 0.9-1.1): frequencies with
    0.5-1 % noise and shapes at the 12 floor DOFs with the same absolute noise on the ratios. A
    right answer: ``success`` only when every datum is admissible for the 12-DOF model; never
    further from the data than the nominal model; the judge reports the answer's distance to
    its own weighted least-squares compromise (`acceptance.judge.compromise`)."""
    rng = _rng("shear_building", seed)
    bf = _braced_frame()
    params = [Parameter(name, 1.0, 0.2, 1.5) for name in bf.parameter_names()]
    specs = {}
    for n in (12, 120):
        M, K_fixed, groups, names = bf.matrices(n)
        specs[n] = S.given_matrices(f"shear-building-{n}", M, K_fixed, dict(zip(bf.parameter_names(), groups)), names,
                                    bf.MEASURED_DOFS)
    values = np.concatenate([rng.uniform(0.5, 1.0, bf.N_STOREYS), rng.uniform(0.9, 1.1, bf.N_STOREYS)])
    truth = dict(zip(bf.parameter_names(), map(float, values)))
    noise = float(rng.uniform(0.005, 0.01))
    data = measure(specs[120], params, truth, kind="P1", rng=rng, noise=noise, shape_noise=noise, n_modes=6,
                   sensors=list(bf.MEASURED_DOFS))
    return Problem(f"shear{seed}", specs[12], tuple(params), truth, (data,), noise, noise, seed,
                   family="shear_building", in_family=False, compromise=True,
                   note="12-DOF shear-building model, 120-DOF frame's data")


#: Every family maker by family name.
MAKERS = {f.__name__: f for f in (coarse_mesh, root_spring, sensor_masses, biased_channel, frequency_shift,
                                  misnumbered_zero, close_modes, cross_receptance, symmetric_ring, hidden_mode,
                                  mass_normalized, many_dofs, many_parameters, shear_building, caughey_damping,
                                  dashpot_damping, frf_test)}
