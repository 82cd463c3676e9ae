"""The space frame of `vibupdate.examples.frame3d` built with the openseespy API: the builder of
``vibupdate example fe-opensees`` and the OpenSees route's test fixture. OpenSees forms its own
element matrices (``elasticBeamColumn``): its K equals the generator's to rounding, but its M
differs, so the updating is checked against the matrices OpenSees itself produces at the truth.

The columns' mass is lumped (``-mass`` alone: translational, every rotation massless): with
``-cMass`` the 3-D ``elasticBeamColumn`` of opensees 0.1.32 gives a mass singular along
combinations of rotations, which no massless-DOF condensation handles (`benchmarks/RESULTS.md`,
"Shrinking data, modal, damping, model and examples")."""

from __future__ import annotations

from vibupdate.examples.frame3d import COLUMN, NOMINAL, PAYLOAD, POISSON, beam_section, frame3d


def build_frame(p: dict, size=(3, 2, 4)) -> None:
    """Build the frame at parameter values ``p`` (missing names: nominal) in the OpenSees domain."""
    from vibupdate.model.fe.opensees import openseespy

    ops = openseespy()
    p = {**NOMINAL, **p}
    frame = frame3d(*size)
    ops.model("basic", "-ndm", 3, "-ndf", 6)
    for label, xyz in frame.nodes.items():
        ops.node(label, *map(float, xyz))
    base = frame.groups["k_base"]
    ops.uniaxialMaterial("Elastic", 1, float(p["k_base"]))
    for k, label in enumerate(base):
        ops.fix(label, 1, 1, 1, 0, 0, 0)
        anchor = 900000 + label
        ops.node(anchor, *map(float, frame.nodes[label]))
        ops.fix(anchor, 1, 1, 1, 1, 1, 1)
        ops.element("zeroLength", 800000 + k, anchor, label, "-mat", 1, 1, 1, "-dir", 4, 5, 6)
    ops.geomTransf("Linear", 1, 1.0, 0.0, 0.0)     # columns: local z along global x
    ops.geomTransf("Linear", 2, 0.0, 0.0, 1.0)     # beams: local z vertical
    A, Iy, Iz, J = COLUMN
    E = float(p["E_col"])
    for k, (a, b) in enumerate(frame.columns, start=1):
        ops.element("elasticBeamColumn", k, a, b, A, E, E / (2 * (1 + POISSON)), J, Iy, Iz, 1,
                    "-mass", float(p["rho_col"]) * A)   # lumped: see the module docstring
    A, Iy, Iz, J = beam_section(float(p["d_beam"]))
    E = float(p["E_beam"])
    for k, (a, b) in enumerate(frame.beams, start=len(frame.columns) + 1):
        ops.element("elasticBeamColumn", k, a, b, A, E, E / (2 * (1 + POISSON)), J, Iy, Iz, 2)
    for label, area in frame.floor_area.items():
        m = float(p["m_floor"]) * area + (PAYLOAD if label in frame.payload else 0.0)
        ops.mass(label, m, m, m, 0.0, 0.0, 0.0)
