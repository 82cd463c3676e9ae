"""A planar two-storey frame at the scale of the paper's test case 1 (Section 5.2, Tables 2-4).

Test case 1 (a five-link flexible mechanism, 30 DOFs, 29 parameters, 7 modes with uncertain
shapes) cannot be rebuilt: its geometry and measured shapes are not published. This example
has the same size and the same kinds of parameters, with a known true parameter set that
generates the "measured" data, so that recovery can be checked.

Geometry (m): columns at x = 0 and x = 1.2 from y = 0 to 1.6 (nodes every 0.4), floor beams at
y = 0.8 and 1.6 with a node at mid-span, and a diagonal brace from (0, 0.8) to (1.2, 1.6).
Both feet are pinned with a rotational spring (a motor, ``kr1``, ``kr2``); horizontal balancing
springs ``kbs`` and ``kbs2`` act at the top nodes: 10 free nodes x 3 DOFs + 2 foot rotations = 32 DOFs.

A calibrated payload of known mass (`PAYLOAD`, kg) sits at the middle of the upper beam, a
node with no mass parameter: it fixes the scale that frequencies and shapes alone cannot (the
paper's mechanism has a known gravity stiffness ``Kg`` in that role).

Parameters (29, as in Table 2): one density ``rho``; Young's moduli ``E1``..``E5`` of the five
members (left column, right column, lower beam, upper beam, brace); springs ``kbs``, ``kr1``,
``kr2``; lumped masses ``m3``..``m12`` at the free nodes; rotary inertias ``J3``..``J12``, four
with a nominal value and six with nominal 0 and an upper bound (as ``JB,1`` ... in Table 2).
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np

from vibupdate.model.assembly import Assembly, System
from vibupdate.io.case_types import Case, DampingOptions
from vibupdate.examples import read_table
from vibupdate.inverse.formulation.options import FormulationOptions
from vibupdate.inverse.homotopy import SolverOptions
from vibupdate.data.measured import Configuration, NaturalFrequency, ShapeInterval
from vibupdate.model.build import from_builder
from vibupdate.model.parameters import Parameter


NODES = {
    1: (0.0, 0.0), 2: (1.2, 0.0),
    3: (0.0, 0.4), 4: (0.0, 0.8), 5: (0.0, 1.2), 6: (0.0, 1.6),
    7: (1.2, 0.4), 8: (1.2, 0.8), 9: (1.2, 1.2), 10: (1.2, 1.6),
    11: (0.6, 0.8), 12: (0.6, 1.6),
}
MEMBERS = {  # Young's modulus parameter -> chain of nodes
    "E1": [1, 3, 4, 5, 6],
    "E2": [2, 7, 8, 9, 10],
    "E3": [4, 11, 8],
    "E4": [6, 12, 10],
    "E5": [4, 10],
}
SECTION = {"E1": (0.030, 0.012), "E2": (0.030, 0.012), "E3": (0.030, 0.010), "E4": (0.030, 0.010),
           "E5": (0.020, 0.006)}  # width, height (m) of the rectangular sections
FREE_NODES = list(range(3, 13))
PAYLOAD = (12, 1.5)          # node, known mass (kg)
N_MODES = 7
#: Translational DOFs that are "measured" (accelerometers): x and y of every free node.
MEASURED_DOFS = tuple(f"{d}{n}" for n in FREE_NODES for d in ("x", "y"))
#: Seeded errors of the bundled data (`tests/frame_data.py` generates them).
FREQUENCY_ERROR = 0.003      # relative standard deviation of the measured frequencies
SHAPE_ERROR = 0.02           # standard deviation of shape entries, relative to the largest entry
SEED = 20210224


def parameters() -> tuple[Parameter, ...]:
    """The 29 updating parameters (nominal, bounds) read from the bundled table."""
    return tuple(
        Parameter(r["name"], float(r["nominal"]), float(r["lower"]), float(r["upper"]), unit=r["unit"],
                  reference=float(r["reference"]) if r["reference"] else None)
        for r in read_table("frame_parameters.csv")
    )


def truth() -> dict[str, float]:
    """The true parameter values that generate the measured data."""
    return {r["name"]: float(r["true"]) for r in read_table("frame_parameters.csv")}


@lru_cache(maxsize=None)
def _mesh(subdivisions: int):
    """Geometry of the frame refined ``subdivisions`` times: extra node labels and
    coordinates, and per member the chain of node labels its elements join."""
    extra_labels, extra_xy, chains = [], [], {}
    for name, chain in MEMBERS.items():
        labels = []
        for a, c in zip(chain, chain[1:]):
            (xa, ya), (xc, yc) = NODES[a], NODES[c]
            labels.append(a)
            for k in range(1, subdivisions):
                label = f"{a}-{c}.{k}"
                extra_labels.append(label)
                extra_xy.append((xa + (xc - xa) * k / subdivisions, ya + (yc - ya) * k / subdivisions))
                labels.append(label)
        labels.append(chain[-1])
        chains[name] = (tuple(labels[:-1]), tuple(labels[1:]))
    xy = np.array(extra_xy, dtype=float).reshape(-1, 2)
    return tuple(extra_labels), xy, chains


def build(p: dict, subdivisions: int = 1) -> System:
    """Mass and stiffness of the frame (complex-safe in the parameter values).

    ``subdivisions`` splits every element into that many equal elements (the refined meshes
    of the scaling benchmark); the extra nodes are labelled ``"a-c.k"``. The elements of a
    member are added as one batch.
    """
    asm = Assembly("frame")
    for label, (x, y) in NODES.items():
        asm.node(label, x, y)
    extra_labels, extra_xy, chains = _mesh(int(subdivisions))
    asm.nodes(extra_labels, extra_xy[:, 0], extra_xy[:, 1])
    for name, (first, second) in chains.items():
        b, h = SECTION[name]
        area, inertia = b * h, b * h**3 / 12
        asm.frames(first, second, EA=p[name] * area, EI=p[name] * inertia, mass_per_length=p["rho"] * area)
    asm.pin(1)
    asm.pin(2)
    asm.spring("phi1", p["kr1"])
    asm.spring("phi2", p["kr2"])
    asm.spring("x6", p["kbs"])
    asm.spring("x10", p["kbs2"])
    node, payload = PAYLOAD
    asm.mass(f"x{node}", payload)
    asm.mass(f"y{node}", payload)
    for n in FREE_NODES:
        if n != node:
            asm.mass(f"x{n}", p[f"m{n}"])
            asm.mass(f"y{n}", p[f"m{n}"])
        asm.mass(f"phi{n}", p[f"J{n}"])
    return asm.system()


@lru_cache(maxsize=None)
def model(subdivisions: int = 1):
    """The affine model (complex-step parameter matrices)."""
    return from_builder(lambda p: build(p, subdivisions), parameters())


def configurations(frequencies=None, shapes=None, subdivisions: int = 1) -> list[Configuration]:
    """The measured configuration: bundled data by default, or the given tables (for the
    model refined ``subdivisions`` times)."""
    if frequencies is None:
        frequencies = [{k: float(v) if k != "dof" else v for k, v in r.items()}
                       for r in read_table("frame_frequencies.csv")]
        shapes = [{**r, "mode": int(r["mode"]), "value": float(r["value"]), "tolerance": float(r["tolerance"])}
                  for r in read_table("frame_shapes.csv")]
    natural = []
    for f in sorted(frequencies, key=lambda r: r["mode"]):
        k = int(f["mode"])
        entries = {s["dof"]: s for s in shapes if int(s["mode"]) == k}
        interval = ShapeInterval({d: (s["value"] - s["tolerance"], s["value"] + s["tolerance"])
                                  for d, s in entries.items()}) if entries else None
        natural.append(NaturalFrequency.from_hz(f["hz"], shape=interval, damping_ratio=f.get("damping_ratio")))
    return [Configuration("frame", model(subdivisions), tuple(natural))]


#: Damping identified as the paper did for test case 1: Y = [0, 0.25, 0.5, 0.75, 1], unweighted.
DAMPING = DampingOptions(exponents=(0.0, 0.25, 0.5, 0.75, 1.0),
                         rationale="unweighted, as in the paper's test case 1")


def case() -> Case:
    return Case("frame", None, tuple(configurations()), SolverOptions(), FormulationOptions(), DAMPING,
                frequency_tolerance=3 * FREQUENCY_ERROR)


def reference_columns() -> dict:
    """This example's truth beside the updated parameters, and the paper's figures of test
    case 1 (Tables 1 and 3), as reference columns of the report's tables
    (`vibupdate.report.table.with_reference`)."""
    return {
        "columns": {"parameters": {"true": truth()},
                    "summary": {"paper (Tables 1, 3)": {"mean_error_nominal_pct": 5.7, "mean_error_updated_pct": 1.5,
                                                        "n_mode_unknowns": 210, "n_adjunct_unknowns": 0,
                                                        "n_lifted": 868}}},
        "errors": {"parameters": {"error %": ["updated", "true"]}},
        "notes": {"parameters": [f"true: the values the synthetic data were drawn from (frequency error "
                                 f"{FREQUENCY_ERROR}, shape error {SHAPE_ERROR}, seed {SEED})"],
                  "summary": ["paper: its problem size (Table 1) leaves every entry of every vector unknown, here "
                              "one is fixed for normalization"]},
    }
