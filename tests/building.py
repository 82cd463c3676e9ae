"""A planar multi-storey, multi-bay steel frame that grows by size, not by mesh refinement.

The scaling benchmark's refined frame reaches 30,000 DOFs by cutting a small frame into
0.5 mm elements, where rounding of ``K`` alone moves the data by 1e-4. The FE models users
export reach that size because the structure is large. This example is such a structure: a
building frame of ``storeys`` x ``bays`` with elements of an ordinary length (0.75 m on
0.3 m deep sections), so its size follows from how many storeys and bays it has.

Geometry (m): columns at ``x = j * BAY`` (``j = 0 .. bays``), floors at ``y = i * STOREY``
(``i = 1 .. storeys``); each column storey is split into `COLUMN_ELEMENTS` frame elements and
each beam span into `BEAM_ELEMENTS`; the column feet are clamped. Node labels: ``"c{j}.{i}"``
for the joint of column ``j`` at floor ``i``, ``"c{j}.{i}.{k}"`` inside a column storey,
``"b{j}.{i}.{k}"`` inside the beam of bay ``j`` at floor ``i``; DOFs ``x``, ``y``, ``phi``
per node (`Assembly` names).

Parameters, grouped as an FE user would: the storeys are split into `GROUPS` groups of
consecutive storeys (as equal as possible), and each group has a column stiffness factor
``Ec{g}`` and a beam stiffness factor ``Eb{g}`` (multiplying the steel modulus in ``EA`` and
``EI``) and a superimposed floor mass ``q{g}`` (kg/m along the beams of its floors). The
steel's own mass is known (not a parameter): it fixes the scale that frequencies and shapes
alone cannot (scaling every mass and stiffness together changes neither).

Data: the `N_MODES` lowest natural frequencies and the mode shapes at translational DOFs of
up to `MEASURED_FLOORS` floors (spread over the height, the roof included): ``x`` at the left
column and ``y`` at the quarter and three-quarter points of the first and last bays (where the
beams bend under sway; mid-span moves little).

It is a generated, sized model for the tests and `benchmarks/large_structure.py` (no data
files; every function takes ``storeys`` and ``bays``).
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np

from vibupdate.model.assembly import Assembly, System
from vibupdate.model.parameters import Parameter


STOREY = 3.0                 # m, storey height
BAY = 6.0                    # m, bay width
COLUMN_ELEMENTS = 4          # elements per column storey (0.75 m)
BEAM_ELEMENTS = 8            # elements per beam span (0.75 m)
E_STEEL = 210e9              # Pa
RHO_STEEL = 7850.0           # kg/m^3, known
#: Sections (area m^2, second moment m^4): an HEB 300-like column and an IPE 360-like beam.
COLUMN = (1.49e-2, 2.517e-4)
BEAM = (7.27e-3, 1.627e-4)
GROUPS = 4
N_MODES = 8
MEASURED_FLOORS = 6
#: Nominal superimposed floor mass (kg/m of beam) and the true values' pattern.
Q_NOMINAL = 600.0
#: True values relative to the nominal, per group: stiffness factors and floor masses.
_TRUE_EC = (1.06, 0.95, 1.03, 0.91)
_TRUE_EB = (0.93, 1.07, 0.98, 1.09)
_TRUE_Q = (1.12, 0.9, 1.05, 0.85)
#: Caughey (here Rayleigh-like) law of the measured damping ratios: exponents Y, beta.
DAMPING_LAW = ((0.0, 1.0), (0.05, 1.0e-4))


def parameters() -> tuple[Parameter, ...]:
    """The ``3 * GROUPS`` parameters: ``Ec{g}``, ``Eb{g}`` (factors on E, nominal 1, bounds
    0.5-1.5) and ``q{g}`` (kg/m, nominal `Q_NOMINAL`, bounds 0.5-1.5 times it)."""
    out = []
    for g in range(1, GROUPS + 1):
        out.append(Parameter(f"Ec{g}", 1.0, 0.5, 1.5, unit="-"))
        out.append(Parameter(f"Eb{g}", 1.0, 0.5, 1.5, unit="-"))
        out.append(Parameter(f"q{g}", Q_NOMINAL, 0.5 * Q_NOMINAL, 1.5 * Q_NOMINAL, unit="kg/m"))
    return tuple(out)


def truth() -> dict[str, float]:
    """The true parameter values that generate the exact data."""
    out = {}
    for g in range(GROUPS):
        out[f"Ec{g + 1}"] = _TRUE_EC[g]
        out[f"Eb{g + 1}"] = _TRUE_EB[g]
        out[f"q{g + 1}"] = _TRUE_Q[g] * Q_NOMINAL
    return out


def n_dofs(storeys: int, bays: int) -> int:
    """Number of free DOFs of a ``storeys`` x ``bays`` frame."""
    nodes = storeys * ((bays + 1) * COLUMN_ELEMENTS + bays * (BEAM_ELEMENTS - 1))
    return 3 * nodes


def _check_size(storeys, bays) -> None:
    if not isinstance(storeys, (int, np.integer)) or storeys < GROUPS:
        raise ValueError(f"a building needs at least {GROUPS} storeys (one per parameter group), got {storeys!r}")
    if not isinstance(bays, (int, np.integer)) or bays < 1:
        raise ValueError(f"a building needs at least 1 bay, got {bays!r}")


def _groups(storeys: int) -> np.ndarray:
    """Group (0-based) of each storey 1..storeys, shape (storeys,)."""
    return np.minimum((np.arange(storeys) * GROUPS) // storeys, GROUPS - 1)


@lru_cache(maxsize=None)
def _mesh(storeys: int, bays: int):
    """Node labels and coordinates, and per element kind the (first, second, storey) arrays."""
    _check_size(storeys, bays)
    labels, xs, ys = [], [], []
    for j in range(bays + 1):
        for i in range(storeys + 1):
            labels.append(f"c{j}.{i}")
            xs.append(j * BAY)
            ys.append(i * STOREY)
            if i < storeys:
                for k in range(1, COLUMN_ELEMENTS):
                    labels.append(f"c{j}.{i}.{k}")
                    xs.append(j * BAY)
                    ys.append((i + k / COLUMN_ELEMENTS) * STOREY)
    col_first, col_second, col_storey = [], [], []
    for j in range(bays + 1):
        for i in range(storeys):
            chain = [f"c{j}.{i}"] + [f"c{j}.{i}.{k}" for k in range(1, COLUMN_ELEMENTS)] + [f"c{j}.{i + 1}"]
            col_first += chain[:-1]
            col_second += chain[1:]
            col_storey += [i] * COLUMN_ELEMENTS
    beam_first, beam_second, beam_storey = [], [], []
    for i in range(1, storeys + 1):
        for j in range(bays):
            inner = [f"b{j}.{i}.{k}" for k in range(1, BEAM_ELEMENTS)]
            labels += inner
            xs += [(j + k / BEAM_ELEMENTS) * BAY for k in range(1, BEAM_ELEMENTS)]
            ys += [i * STOREY] * (BEAM_ELEMENTS - 1)
            chain = [f"c{j}.{i}"] + inner + [f"c{j + 1}.{i}"]
            beam_first += chain[:-1]
            beam_second += chain[1:]
            beam_storey += [i - 1] * BEAM_ELEMENTS
    return (tuple(labels), np.array(xs), np.array(ys),
            (tuple(col_first), tuple(col_second), np.array(col_storey)),
            (tuple(beam_first), tuple(beam_second), np.array(beam_storey)))


@lru_cache(maxsize=None)
def assembly(storeys: int, bays: int) -> Assembly:
    """The frame as an `Assembly` whose properties are linear in the 12 parameters: per group of
    storeys, the columns' ``EA``, ``EI`` scale with ``Ec``, the beams' with ``Eb``, and the beams'
    mass per length is the steel's plus ``q``."""
    from vibupdate.model.expressions import LinearExpression

    labels, xs, ys, columns, beams = _mesh(storeys, bays)
    group = _groups(storeys)
    asm = Assembly("frame")
    asm.nodes(labels, xs, ys)
    for (first, second, storey), (area, inertia), factor in ((columns, COLUMN, "Ec"), (beams, BEAM, "Eb")):
        first, second = np.asarray(first, dtype=object), np.asarray(second, dtype=object)
        for g in range(GROUPS):
            mine = group[storey] == g
            if not mine.any():
                continue
            name = f"{factor}{g + 1}"
            mass = (LinearExpression(RHO_STEEL * area, ((f"q{g + 1}", 1.0),)) if factor == "Eb"
                    else RHO_STEEL * area)
            asm.frames(tuple(first[mine]), tuple(second[mine]),
                       EA=LinearExpression(0.0, ((name, E_STEEL * area),)),
                       EI=LinearExpression(0.0, ((name, E_STEEL * inertia),)), mass_per_length=mass)
    for j in range(bays + 1):
        asm.clamp(f"c{j}.0")
    return asm


def build(p: dict, storeys: int, bays: int) -> System:
    """Mass and stiffness of the frame at the parameter values ``p`` (complex-safe)."""
    return assembly(storeys, bays).system(p)


@lru_cache(maxsize=None)
def model(storeys: int, bays: int):
    """The affine model of a ``storeys`` x ``bays`` frame, assembled directly from the linear
    properties (`vibupdate.model.build.from_assembly`)."""
    from vibupdate.model.build import from_assembly

    return from_assembly(assembly(storeys, bays), parameters())


def measured_dofs(storeys: int, bays: int) -> tuple[str, ...]:
    """Translational DOFs carrying the measured shapes (module docstring)."""
    n = min(storeys, MEASURED_FLOORS)
    floors = sorted({int(round(storeys * (k + 1) / n)) for k in range(n)})
    quarter, three = BEAM_ELEMENTS // 4, 3 * BEAM_ELEMENTS // 4
    out = []
    for i in floors:
        out.append(f"xc0.{i}")
        for j in sorted({0, bays - 1}):
            out += [f"yb{j}.{i}.{quarter}", f"yb{j}.{i}.{three}"]
    return tuple(out)


def exact_data(storeys: int, bays: int):
    """Exact data of the true model: natural frequencies (rad/s, shape (N_MODES,)), damping
    ratios of `DAMPING_LAW` (shape (N_MODES,)) and the mode shapes at `measured_dofs`
    (shape (n_measured, N_MODES), each mode scaled to unit largest measured entry)."""
    from vibupdate.damping.series import modal_damping
    from vibupdate.modal.analysis import modes

    m = model(storeys, bays)
    values = truth()
    M, K = m.matrices_at([values[p.name] for p in m.parameters])
    omega, Phi = modes(M, K, N_MODES)
    idx = [m.dof(d) for d in measured_dofs(storeys, bays)]
    shapes = Phi[idx]
    shapes = shapes / shapes[np.argmax(np.abs(shapes), axis=0), np.arange(N_MODES)]
    return omega, modal_damping(DAMPING_LAW[0], DAMPING_LAW[1], omega), shapes


def configurations(storeys: int, bays: int, shape_tolerance: float = 0.0):
    """The measured configuration with exact data; shapes as intervals of half-width
    ``shape_tolerance`` (0: points)."""
    from vibupdate.data.measured import Configuration, NaturalFrequency, ShapeInterval

    omega, ratios, shapes = exact_data(storeys, bays)
    dofs = measured_dofs(storeys, bays)
    natural = tuple(
        NaturalFrequency.from_hz(float(omega[k] / (2 * np.pi)), damping_ratio=float(ratios[k]),
                                 shape=ShapeInterval({d: (float(v) - shape_tolerance, float(v) + shape_tolerance)
                                                      for d, v in zip(dofs, shapes[:, k])}))
        for k in range(N_MODES))
    return [Configuration("building", model(storeys, bays), natural)]
