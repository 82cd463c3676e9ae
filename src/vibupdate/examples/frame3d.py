"""A three-dimensional space frame with a known truth, the fixture of the FE-code readers.

A building frame of ``bays_x`` x ``bays_y`` bays and ``stories`` storeys (bay 5 m x 4 m,
storey 3.5 m), every column and floor beam split into two 12-DOF beam elements (axial,
torsion and bending in both planes, Euler-Bernoulli, consistent mass). Nodes carry six DOFs
named ``"<node>:<dir>"``, ``dir`` in ``x, y, z, rx, ry, rz``; node numbers are
``1000 * level + index`` (level 0 is the base).

Parameters (property groups, docs/fe-models.md, "Worked example per code"): ``E_col``,
``E_beam``, ``rho_col``, ``m_floor`` (floor mass per unit area, lumped at the floor nodes by
tributary length of the massless beams), ``k_base`` (rotational springs at the base nodes);
optionally ``d_beam`` (m), the depth of the rectangular beam section (width `BEAM_WIDTH`), in
which the section's properties are polynomials: the model is *not* affine in it.

A known payload of `PAYLOAD` kg sits on each roof corner node (translational mass, no
parameter): it fixes the scale that modal data alone cannot.

The rotations of the beams' mid-span nodes carry no mass (the beams are massless and the floor
mass is translational), so ``M`` is singular on that set (`FrameModel.massless`). The base
translations are constrained: `matrices` leaves them out unless ``constrained=True``, which
keeps them (with their stiffness terms) as some FE codes write the unconstrained matrices.

The 3 x 2 bays, 4-storey default has 1,020 DOFs (176 nodes; 204 massless rotations).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from functools import lru_cache

import numpy as np
import scipy.sparse as sp


#: Directions of the six DOFs of a node, in order.
DIRECTIONS = ("x", "y", "z", "rx", "ry", "rz")
#: Nominal parameter values (SI).
NOMINAL = {"E_col": 210e9, "E_beam": 200e9, "rho_col": 7850.0, "m_floor": 400.0, "k_base": 4e7, "d_beam": 0.4}
#: Width of the rectangular beam section, m.
BEAM_WIDTH = 0.2
#: Column section: area (m^2), second moments Iy, Iz (m^4), torsion constant J (m^4).
#: Known mass on each roof corner node, kg.
PAYLOAD = 2000.0
COLUMN = (1.2e-2, 1.6e-4, 1.6e-4, 2.4e-4)
POISSON = 0.3
BAY = (5.0, 4.0)
STOREY = 3.5


def element_stiffness(L, A, Iy, Iz, J, E=1.0, G=None):
    """Local stiffness of a 3-D Euler-Bernoulli beam element, shape (12, 12), N/m units.

    DOF order per node ``u, v, w, theta_x, theta_y, theta_z`` (local x along the element);
    ``Iz`` bends in the local x-y plane, ``Iy`` in x-z. ``G`` defaults to ``E / (2 (1 + nu))``.
    """
    G = E / (2 * (1 + POISSON)) if G is None else G
    k = np.zeros((12, 12))
    a, t = E * A / L, G * J / L
    k[np.ix_([0, 6], [0, 6])] = a * np.array([[1, -1], [-1, 1]])
    k[np.ix_([3, 9], [3, 9])] = t * np.array([[1, -1], [-1, 1]])
    for (v, r, EI, s) in ((1, 5, E * Iz, 1.0), (2, 4, E * Iy, -1.0)):
        idx = [v, r, v + 6, r + 6]
        b = EI / L ** 3 * np.array([[12, 6 * L, -12, 6 * L], [6 * L, 4 * L * L, -6 * L, 2 * L * L],
                                    [-12, -6 * L, 12, -6 * L], [6 * L, 2 * L * L, -6 * L, 4 * L * L]])
        sign = np.array([1, s, 1, s])
        k[np.ix_(idx, idx)] = b * np.outer(sign, sign)
    return k


def element_mass(L, A, J, rho=1.0):
    """Local consistent mass of the same element, shape (12, 12), kg; polar inertia ``rho J L``."""
    m = np.zeros((12, 12))
    mass = rho * A * L
    m[np.ix_([0, 6], [0, 6])] = mass / 6 * np.array([[2, 1], [1, 2]])
    m[np.ix_([3, 9], [3, 9])] = rho * J * L / 6 * np.array([[2, 1], [1, 2]])
    for (v, r, s) in ((1, 5, 1.0), (2, 4, -1.0)):
        idx = [v, r, v + 6, r + 6]
        b = mass / 420 * np.array([[156, 22 * L, 54, -13 * L], [22 * L, 4 * L * L, 13 * L, -3 * L * L],
                                   [54, 13 * L, 156, -22 * L], [-13 * L, -3 * L * L, -22 * L, 4 * L * L]])
        sign = np.array([1, s, 1, s])
        m[np.ix_(idx, idx)] = b * np.outer(sign, sign)
    return m


def rotation(p1, p2):
    """Rows: local x, y, z axes in global coordinates (local z horizontal for columns)."""
    ex = (p2 - p1) / np.linalg.norm(p2 - p1)
    ref = np.array([1.0, 0.0, 0.0]) if abs(ex[2]) > 0.9 else np.array([0.0, 0.0, 1.0])
    ey = np.cross(ref, ex)
    ey /= np.linalg.norm(ey)
    return np.vstack([ex, ey, np.cross(ex, ey)])


def beam_section(d):
    """Area (m^2), Iy (vertical bending), Iz, J (m^4) of the ``b x d`` rectangle, ``d > b``; J by the
    thin-rectangle formula ``b^3 d / 3 - 0.21 b^4`` (linear in d; Iy is cubic)."""
    b = BEAM_WIDTH
    return b * d, b * d ** 3 / 12, d * b ** 3 / 12, b ** 3 * d / 3 - 0.21 * b ** 4


@dataclass(frozen=True)
class FrameModel:
    """The frame's topology and its matrices as functions of the parameters.

    Attributes
    ----------
    nodes : dict of int to ndarray, shape (3,)
        Node number -> coordinates, m (the base nodes included).
    dofs : tuple of str, length n
        DOF names of the constrained model, in matrix order.
    all_dofs : tuple of str
        DOF names with the base translations (``constrained=True``).
    massless : tuple of str
        DOFs with no mass (rotations of the beams' mid-span nodes).
    groups : dict of str to tuple of int
        Parameter name -> nodes of its property group.
    columns, beams : tuple of (int, int)
        Node pairs of the column and beam elements.
    floor_area : dict of int to float
        Floor node -> tributary floor area, m^2 (its mass is ``m_floor`` times it).
    payload : tuple of int
        Roof corner nodes carrying `PAYLOAD`.
    """

    nodes: dict
    dofs: tuple
    all_dofs: tuple
    massless: tuple
    groups: dict
    columns: tuple
    beams: tuple
    floor_area: dict
    payload: tuple
    _parts: dict

    def matrices(self, values: Mapping | None = None, constrained: bool = False):
        """``(K, M)`` at ``values`` (missing names take `NOMINAL`), CSR, shapes (n, n) in N/m and kg."""
        p = {**NOMINAL, **(values or {})}
        unknown = sorted(set(p) - set(NOMINAL))
        if unknown:
            raise ValueError(f"frame3d has no parameter {unknown[0]!r}; expected one of {', '.join(NOMINAL)}")
        A, Iy, Iz, J = beam_section(p["d_beam"])
        P = self._parts
        K = (p["E_col"] * P["Kc"] + p["k_base"] * P["Ks"]
             + p["E_beam"] * (A * P["KbA"] + Iy * P["KbIy"] + Iz * P["KbIz"] + J * P["KbJ"]))
        M = p["rho_col"] * P["Mc"] + p["m_floor"] * P["Mf"] + P["Mp"]
        if not constrained:
            keep = P["free"]
            K, M = K[keep][:, keep], M[keep][:, keep]
        return sp.csr_matrix(K), sp.csr_matrix(M)


@lru_cache(maxsize=8)
def frame3d(bays_x: int = 3, bays_y: int = 2, stories: int = 4) -> FrameModel:
    """The frame of ``bays_x`` x ``bays_y`` bays and ``stories`` storeys (module docstring)."""
    for name, value in (("bays_x", bays_x), ("bays_y", bays_y), ("stories", stories)):
        if not isinstance(value, int) or value < 1:
            raise ValueError(f"{name} must be an integer >= 1, got {value!r}")
    nodes, corner = {}, {}
    for level in range(stories + 1):
        for i in range(bays_x + 1):
            for j in range(bays_y + 1):
                label = 1000 * level + len([k for k in corner if k[0] == level]) + 1
                corner[(level, i, j)] = label
                nodes[label] = np.array([i * BAY[0], j * BAY[1], level * STOREY])
    counter = {level: (bays_x + 1) * (bays_y + 1) for level in range(stories + 1)}

    def mid(level, a, b):
        counter[level] += 1
        label = 1000 * level + counter[level]
        nodes[label] = 0.5 * (nodes[a] + nodes[b])
        return label

    columns, beams, floor_mass = [], [], {}
    for level in range(1, stories + 1):
        for i in range(bays_x + 1):
            for j in range(bays_y + 1):
                lo, hi = corner[(level - 1, i, j)], corner[(level, i, j)]
                m = mid(level, lo, hi)
                columns += [(lo, m), (m, hi)]
        spans = [((level, i, j), (level, i + 1, j)) for i in range(bays_x) for j in range(bays_y + 1)]
        spans += [((level, i, j), (level, i, j + 1)) for i in range(bays_x + 1) for j in range(bays_y)]
        for a, b in spans:
            a, b = corner[a], corner[b]
            m = mid(level, a, b)
            beams += [(a, m), (m, b)]
            span = np.linalg.norm(nodes[b] - nodes[a])
            width = BAY[1] if nodes[b][0] != nodes[a][0] else BAY[0]
            # floor area shared by the beam's three nodes: half a bay either side, 1/4 1/2 1/4
            for node, share in ((a, 0.25), (m, 0.5), (b, 0.25)):
                floor_mass[node] = floor_mass.get(node, 0.0) + share * span * width / 2
    order = sorted(nodes)
    index = {label: k for k, label in enumerate(order)}
    n = 6 * len(order)
    all_dofs = tuple(f"{label}:{d}" for label in order for d in DIRECTIONS)

    def assemble(elements, local):
        rows, cols, vals = [], [], []
        for a, b in elements:
            R = rotation(nodes[a], nodes[b])
            T = np.kron(np.eye(4), R)
            k = T.T @ local(np.linalg.norm(nodes[b] - nodes[a])) @ T
            idx = np.r_[6 * index[a]:6 * index[a] + 6, 6 * index[b]:6 * index[b] + 6]
            rows.append(np.repeat(idx, 12))
            cols.append(np.tile(idx, 12))
            vals.append(k.ravel())
        return sp.csr_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))), shape=(n, n))

    A, Iy, Iz, J = COLUMN
    unit = {"A": (1, 0, 0, 0), "Iy": (0, 1, 0, 0), "Iz": (0, 0, 1, 0), "J": (0, 0, 0, 1)}
    parts = {
        "Kc": assemble(columns, lambda L: element_stiffness(L, A, Iy, Iz, J)),
        "Mc": assemble(columns, lambda L: element_mass(L, A, J)),
        **{f"Kb{name}": assemble(beams, lambda L, u=u: element_stiffness(L, *u))
           for name, u in unit.items()},
    }
    base = [corner[(0, i, j)] for i in range(bays_x + 1) for j in range(bays_y + 1)]
    spring = np.zeros(n)
    for label in base:
        spring[6 * index[label] + 3:6 * index[label] + 6] = 1.0
    parts["Ks"] = sp.diags(spring).tocsr()
    lumped = np.zeros(n)
    for label, area in floor_mass.items():
        lumped[6 * index[label]:6 * index[label] + 3] = area
    parts["Mf"] = sp.diags(lumped).tocsr()
    payload = np.zeros(n)
    for i in range(bays_x + 1):
        for j in range(bays_y + 1):
            k = 6 * index[corner[(stories, i, j)]]
            payload[k:k + 3] = PAYLOAD
    parts["Mp"] = sp.diags(payload).tocsr()
    base_translations = {f"{label}:{d}" for label in base for d in ("x", "y", "z")}
    free = np.array([k for k, name in enumerate(all_dofs) if name not in base_translations])
    parts["free"] = free
    dofs = tuple(all_dofs[k] for k in free)
    mid_beam = sorted({b for e in beams for b in e} - set(corner.values()))
    massless = tuple(f"{label}:{d}" for label in mid_beam for d in ("rx", "ry", "rz"))
    groups = {"E_col": tuple(sorted({v for e in columns for v in e})),
              "E_beam": tuple(sorted({v for e in beams for v in e})),
              "rho_col": tuple(sorted({v for e in columns for v in e})),
              "m_floor": tuple(sorted(floor_mass)), "k_base": tuple(base),
              "d_beam": tuple(sorted({v for e in beams for v in e}))}
    roof = tuple(corner[(stories, i, j)] for i in range(bays_x + 1) for j in range(bays_y + 1))
    return FrameModel(nodes, dofs, all_dofs, massless, groups, tuple(columns), tuple(beams), floor_mass, roof, parts)
