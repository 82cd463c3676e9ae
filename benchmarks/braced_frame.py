"""A 4-storey, 2-bay by 2-bay braced steel frame of the IASC-ASCE structural health monitoring
benchmark class, as a vibupdate model (12 or 120 DOFs) with noisy modal data.

Source of the definition: the benchmark's own model generator, ``cal_model.m`` of the Task
Group's MATLAB code (P. Lam, 2000-2001; E.A. Johnson, H.F. Lam, L.S. Katafygiotis, J.L. Beck,
"Phase I IASC-ASCE structural health monitoring benchmark problem using simulated data",
J. Eng. Mech. 130(1), 2004). What is taken from it, as facts: bays L = 1.25 m, storeys
H = 0.9 m; columns (A 1.133e-3 m^2, I 1.97e-6 and 0.664e-6 m^4, J 8.01e-9 m^4), beams
(A 1.430e-3, I 1.22e-6 vertical and 0.249e-6 horizontal, J 3.82e-8), braces as bars of
A 0.141e-3 m^2 forming an inverted V on each face of each storey; E 200 GPa, G = E / 2.6,
steel 7800 kg/m^3; lumped element masses (half the member at each end, with the polar term
of the twist); rigid floors about the plan centre; floor masses 4 x 800, 600, 600 and
400 kg (at the quadrant centres, each with the rotary inertia of a square slab of side L).
The 120-DOF model keeps each node's vertical translation and two out-of-plane rotations
beside the 3 rigid-floor DOFs per floor; the 12-DOF model restrains those (3 per floor).

Assumed here (not from the benchmark): the parameters are stiffness factors of element
groups, one for the braces and one for the columns of each storey (8, nominal 1, bounds
[0.2, 1.5]); the truth draws brace factors in [0.5, 1] and column factors in [0.9, 1.1]; the
data are the 6 lowest modes with 1 % frequency noise (std, interval +-3 std) and shapes at
the 12 floor DOFs with noise of 1 % of the largest entry and intervals of +-5 % of it. The
column orientation (strong axis along x) and the beams' strong axis vertical follow the
generator's reference nodes.

Used by `benchmarks/speed_peers.py`; ``python benchmarks/braced_frame.py`` prints the
nominal frequencies of both models.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

L, H = 1.25, 0.9
E, NU, RHO = 2.0e11, 0.3, 7800.0
# Iz bends a member in its local x'-y' plane, Iy in x'-z'; a column's y' is global y, a beam's vertical
COLUMN = dict(A=1.133e-3, Iz=0.664e-6, Iy=1.97e-6, J=8.01e-9)
BEAM = dict(A=1.430e-3, Iz=1.22e-6, Iy=0.249e-6, J=3.82e-8)
BRACE = dict(A=0.141e-3, Iy=0.0, Iz=0.0, J=0.0)
FLOOR_MASS = (800.0, 600.0, 600.0, 400.0)                      # each of the 4 quadrant masses, kg
N_STOREYS = 4


def _nodes():
    """Coordinates of the 9 x 5 nodes, floor by floor (floor 0 the fixed base), shape (45, 3)."""
    grid = np.array([(i * L, j * L) for j in range(3) for i in range(3)])
    return np.array([(x, y, f * H) for f in range(N_STOREYS + 1) for x, y in grid])


def _elements():
    """(i, j, group kind, storey, y'-direction hint) of every member: 9 columns, 12 beams, 8 braces
    per storey (116 in all)."""
    out = []
    node = lambda f, i, j: 9 * f + 3 * j + i   # noqa: E731
    for s in range(1, N_STOREYS + 1):
        for j in range(3):
            for i in range(3):
                out.append((node(s - 1, i, j), node(s, i, j), "column", s, (0.0, 1.0, 0.0)))
        for j in range(3):
            for i in range(2):
                out.append((node(s, i, j), node(s, i + 1, j), "beam", s, (0.0, 0.0, 1.0)))
        for i in range(3):
            for j in range(2):
                out.append((node(s, i, j), node(s, i, j + 1), "beam", s, (0.0, 0.0, 1.0)))
        # an inverted V on each face: bottom corners to the top mid-node
        for (a, b), mid in ((((0, 0), (2, 0)), (1, 0)), (((2, 0), (2, 2)), (2, 1)), (((2, 2), (0, 2)), (1, 2)),
                            (((0, 2), (0, 0)), (0, 1))):
            for corner in (a, b):
                out.append((node(s - 1, *corner), node(s, *mid), "brace", s, (0.0, 0.0, 1.0)))
    return out


def _member_matrices(xyz, elements):
    """Global 12 x 12 stiffness and lumped mass of every member, shapes (n_e, 12, 12)."""
    n_e = len(elements)
    i = np.array([e[0] for e in elements])
    j = np.array([e[1] for e in elements])
    d = xyz[j] - xyz[i]
    ell = np.linalg.norm(d, axis=1)
    ex = d / ell[:, None]
    hint = np.array([e[4] for e in elements])
    # a hint along the member (vertical braces cannot occur here) would be degenerate
    ey = hint - np.sum(hint * ex, axis=1)[:, None] * ex
    ey /= np.linalg.norm(ey, axis=1)[:, None]
    ez = np.cross(ex, ey)
    R = np.stack([ex, ey, ez], axis=1)                       # rows: local axes, (n_e, 3, 3)
    props = [{"column": COLUMN, "beam": BEAM, "brace": BRACE}[e[2]] for e in elements]
    A, Iy, Iz, J = (np.array([p[k] for p in props]) for k in ("A", "Iy", "Iz", "J"))
    G = E / (2 * (1 + NU))
    k = np.zeros((n_e, 12, 12))

    def put(a, b, value):   # a symmetric pair of entries of every member
        k[:, a, b] += value
        if a != b:
            k[:, b, a] += value

    ax, tw = E * A / ell, G * J / ell
    for a, b, s in ((0, 0, 1), (6, 6, 1), (0, 6, -1)):
        put(a, b, s * ax)
        put(3 + a, 3 + b, s * tw)
    # v (local y') bends about z' with Iz; w (local z') about y' with Iy, its couplings of opposite sign
    for I, v, t, sign in ((Iz, 1, 5, 1.0), (Iy, 2, 4, -1.0)):
        c12, c6, c4, c2 = 12 * E * I / ell**3, 6 * E * I / ell**2, 4 * E * I / ell, 2 * E * I / ell
        put(v, v, c12), put(6 + v, 6 + v, c12), put(v, 6 + v, -c12)
        put(v, t, sign * c6), put(v, 6 + t, sign * c6), put(t, 6 + v, -sign * c6), put(6 + v, 6 + t, -sign * c6)
        put(t, t, c4), put(6 + t, 6 + t, c4), put(t, 6 + t, c2)
    mbar = RHO * A
    Io = Iy + Iz
    m = np.zeros((n_e, 12))
    m[:, [0, 1, 2, 6, 7, 8]] = (mbar * ell / 2)[:, None]
    m[:, [3, 9]] = (RHO * Io * ell / 2)[:, None]
    T = np.zeros((n_e, 12, 12))
    for q in range(4):
        T[:, 3 * q:3 * q + 3, 3 * q:3 * q + 3] = R
    K = np.einsum("eji,ejk,ekl->eil", T, k, T)
    M = np.einsum("eji,ej,ejl->eil", T, m, T)
    return K, M, i, j


def _assemble(blocks, i, j, n_nodes, select):
    """Sum the members ``select`` (bool, shape (n_e,)) into a sparse (6 n_nodes)^2 matrix."""
    dofs = np.concatenate([6 * i[:, None] + np.arange(6), 6 * j[:, None] + np.arange(6)], axis=1)[select]
    rows = np.repeat(dofs, 12, axis=1).ravel()
    cols = np.tile(dofs, (1, 12)).ravel()
    return sp.csr_matrix((blocks[select].ravel(), (rows, cols)), shape=(6 * n_nodes, 6 * n_nodes))


def _rigid_floors(xyz, dofs_kept: bool) -> sp.csr_matrix:
    """The map from the model's DOFs to the node DOFs of floors 1-4 (6 per node, base left out):
    x, y and the in-plane rotation of each node follow its floor's (x, y, rz) about the plan
    centre; z and the two out-of-plane rotations are each a DOF of their own (120-DOF model)
    or restrained (12-DOF model)."""
    rows, cols, vals = [], [], []
    own = 3 * N_STOREYS
    for node in range(9, 9 * (N_STOREYS + 1)):
        f = node // 9 - 1
        x, y = xyz[node, 0] - L, xyz[node, 1] - L
        base, floor = 6 * (node - 9), 3 * f
        rows += [base, base, base + 1, base + 1, base + 5]
        cols += [floor, floor + 2, floor + 1, floor + 2, floor + 2]
        vals += [1.0, -y, 1.0, x, 1.0]
        if dofs_kept:
            for q in (2, 3, 4):
                rows.append(base + q)
                cols.append(own)
                vals.append(1.0)
                own += 1
    n = own if dofs_kept else 3 * N_STOREYS
    return sp.csr_matrix((vals, (rows, cols)), shape=(6 * 9 * N_STOREYS, n))


def _floor_masses() -> sp.csr_matrix:
    """Mass of the floors on the 12 floor DOFs (x, y, rz per floor), about the plan centre."""
    M = np.zeros((12, 12))
    r2 = 2 * (L / 2) ** 2
    for f, m in enumerate(FLOOR_MASS):
        total = 4 * m
        M[3 * f, 3 * f] = M[3 * f + 1, 3 * f + 1] = total
        M[3 * f + 2, 3 * f + 2] = total * (2 * L**2 / 12) + total * r2
    return sp.csr_matrix(M)


def parameter_names() -> list[str]:
    return [f"braces_{s}" for s in range(1, N_STOREYS + 1)] + [f"columns_{s}" for s in range(1, N_STOREYS + 1)]


def matrices(n_dofs: int = 120):
    """``(M, K_fixed, K_groups, dof_names)``: the mass, the stiffness of the members no
    parameter scales (beams), and the stiffness of each parameter's group (in
    `parameter_names` order), all sparse of shape (n_dofs, n_dofs)."""
    if n_dofs not in (12, 120):
        raise ValueError(f"the braced frame has 12 or 120 DOFs, got {n_dofs}")
    xyz = _nodes()
    elements = _elements()
    Ke, Me, i, j = _member_matrices(xyz, elements)
    free = (i >= 9) | (j >= 9)
    T = _rigid_floors(xyz, n_dofs == 120)
    # drop the base nodes (restrained): shift node numbers, keep only rows/cols of free nodes
    n_nodes = xyz.shape[0]
    keep = np.arange(6 * 9, 6 * n_nodes)

    def reduce(A):
        return (T.T @ A[keep][:, keep] @ T).tocsr()

    kinds = np.array([e[2] for e in elements])
    storeys = np.array([e[3] for e in elements])
    M = reduce(_assemble(Me, i, j, n_nodes, free))
    M[:12, :12] += _floor_masses()
    K_fixed = reduce(_assemble(Ke, i, j, n_nodes, kinds == "beam"))
    groups = [reduce(_assemble(Ke, i, j, n_nodes, (kinds == kind) & (storeys == s)))
              for kind in ("brace", "column") for s in range(1, N_STOREYS + 1)]
    names = [f"{q}{f}" for f in range(1, N_STOREYS + 1) for q in ("x", "y", "rz")]
    names += [f"q{k}" for k in range(n_dofs - 12)]
    return sp.csr_matrix(M), K_fixed, groups, names


def model(n_dofs: int = 120):
    """The frame as a vibupdate `AffineModel` with the 8 stiffness factors (`parameter_names`)."""
    import vibupdate as vu
    from vibupdate.model.build import from_files

    M, K_fixed, groups, names = matrices(n_dofs)
    params = [vu.Parameter(n, 1.0, 0.2, 1.5) for n in parameter_names()]
    K0 = K_fixed + sum(groups)
    return from_files(M, K0, params, dK={p.name: Kg for p, Kg in zip(params, groups)}, dofs=names)


MEASURED_DOFS = tuple(f"{q}{f}" for f in range(1, N_STOREYS + 1) for q in ("x", "y", "rz"))


def truth(seed: int) -> np.ndarray:
    """Damaged braces and slightly off columns, drawn per seed (module docstring), shape (8,)."""
    rng = np.random.default_rng(seed)
    return np.concatenate([rng.uniform(0.5, 1.0, N_STOREYS), rng.uniform(0.9, 1.1, N_STOREYS)])


def noisy_modes(model_, values: np.ndarray, seed: int, n_modes: int = 6):
    """The measured data at ``values``: ``(omega, omega_intervals, shapes, shape_halfwidth)``
    with omega (n_modes,) rad/s, shapes (12, n_modes) at `MEASURED_DOFS` (module docstring)."""
    import vibupdate as vu

    rng = np.random.default_rng(10_000 + seed)
    M, K = model_.matrices_at(values)
    w, Phi = vu.modes(M, K, n_modes)
    idx = [model_.dof(d) for d in MEASURED_DOFS]
    shapes = Phi[idx, :]
    shapes = shapes / np.max(np.abs(shapes), axis=0)
    noisy_w = w * (1 + 0.01 * rng.standard_normal(n_modes))
    intervals = np.stack([noisy_w * (1 - 0.03), noisy_w * (1 + 0.03)], axis=1)
    noisy_shapes = shapes + 0.01 * rng.standard_normal(shapes.shape)
    return noisy_w, intervals, noisy_shapes, 0.05


def configuration(model_, values, seed: int, n_modes: int = 6):
    """A vibupdate `Configuration` of the noisy data at ``values``."""
    from vibupdate.data.measured import Configuration, NaturalFrequency, ShapeInterval

    w, intervals, shapes, half = noisy_modes(model_, values, seed, n_modes)
    natural = tuple(
        NaturalFrequency(w[k], mode=k + 1, interval=tuple(intervals[k]),
                         shape=ShapeInterval({d: (shapes[q, k] - half, shapes[q, k] + half)
                                              for q, d in enumerate(MEASURED_DOFS)}))
        for k in range(n_modes))
    return Configuration("frame", model_, natural)


if __name__ == "__main__":
    import vibupdate as vu

    for n in (12, 120):
        m = model(n)
        w = vu.modes(*m.matrices_at(np.ones(8)), 8)[0]
        print(f"{n}-DOF model: {m.n_dofs} DOFs, lowest frequencies {np.round(w / 2 / np.pi, 2)} Hz")
