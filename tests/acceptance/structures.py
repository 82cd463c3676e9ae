"""Parametric structures of the acceptance engine, written once and built two ways.

A `StructureSpec` is the ``[model] type = "elements"`` table of a case file held as data:
nodes, supports, beam or frame elements and lumped masses and springs, each property a
`Lin` (a linear expression of the updating parameters, docs/case-file.md). From it come

* the case-file route: `model_table` (the ``[model]`` table, and the Matrix Market or ``.npz``
  files when the spec is exported as matrices);
* the Python route: `affine_model` (`vibupdate.from_builder` on a builder that evaluates the
  expressions, differentiated by complex step; `vibupdate.from_files` on in-memory matrices
  for an exported spec), independent of the case file's expression parser.

Structures (SI units; every builder takes a `numpy.random.Generator` and returns the spec with
its `vibupdate.Parameter` s, grouped as described):

* `chain`: spring-mass chain along ``y1 .. yn`` grounded at one or both ends;
* `beam`: Euler-Bernoulli beam, clamped, pinned-pinned, on springs or free-free, optionally
  with lumped masses only (massless rotations, exported as matrices);
* `frame`: a planar portal frame with lumped masses at its knees, clamped or pinned on
  rotational springs.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np
import scipy.io
import scipy.sparse as sp

from vibupdate import Assembly, Parameter, from_builder, from_files

__all__ = ["Lin", "StructureSpec", "chain", "beam", "frame", "affine_model", "model_table", "matrices_at",
           "parameter_matrices", "given_matrices", "DENSE_MAX"]


@dataclass(frozen=True)
class Lin:
    """``const + sum(coef * p[name])``: an element property or lumped value."""

    const: float = 0.0
    terms: tuple[tuple[float, str], ...] = ()

    @classmethod
    def of(cls, coef: float, name: str) -> "Lin":
        return cls(0.0, ((float(coef), name),))

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(n for _, n in self.terms)

    def value(self, p):
        """The value at parameter values ``p`` (mapping; complex values for the complex step)."""
        return self.const + sum(c * p[n] for c, n in self.terms)

    def part(self, name: str) -> "Lin":
        """``d self / d p[name]`` as a constant."""
        return Lin(sum(c for c, n in self.terms if n == name), ())

    def text(self):
        """The case-file form: a number, or an expression string."""
        if not self.terms:
            return float(self.const)
        parts = [f"{c!r}*{n}" for c, n in self.terms]
        if self.const:
            parts.append(repr(float(self.const)))
        return " + ".join(parts)


@dataclass(frozen=True)
class StructureSpec:
    """One parametric structure (module docstring).

    Attributes
    ----------
    label : str
        Structure class for the tables (``"chain"``, ``"beam-free"``, ``"frame"`` ...).
    kind : {"beam", "frame"}
    nodes : tuple of (label, x, y)
    supports : dict
        ``{"clamp": [...], "pin": [...], "fix": [...]}`` as in the case file.
    elements : tuple of (family, n1, n2, {property: Lin})
    lumped : tuple of (family, dof, Lin, other)
        ``family`` ``"mass"`` or ``"spring"``; ``other`` None for a spring to ground.
    measurable : tuple of str
        DOFs a sensor can measure (translations).
    rigid_modes : int
        Rigid-body modes of the structure (zero frequencies, model modes ``1 .. rigid_modes``).
    export : {None, "mtx", "npz"}
        None: an elements model; else exported as matrix files of that format.
    massless : bool
        Rotations without mass (element mass lumped on the translations).
    given : tuple or None
        A model given as matrices, not built from elements: ``(M, K_fixed, {name: K_name}, dofs)``
        (sparse), its stiffness ``K_fixed + sum(p[name] K_name)`` and its mass ``M`` known
        (`given_matrices`); exported as matrix files (``export``).
    """

    label: str
    kind: str
    nodes: tuple
    supports: dict
    elements: tuple
    lumped: tuple
    measurable: tuple
    rigid_modes: int = 0
    export: str | None = None
    massless: bool = False
    given: tuple | None = field(default=None, compare=False, repr=False)

    def with_mass(self, dof: str, value: float) -> "StructureSpec":
        """The spec with one more (known) lumped mass: another configuration."""
        if self.given is not None:
            raise ValueError(f"{self.label}: a structure given as matrices takes no added mass")
        return replace(self, lumped=self.lumped + (("mass", dof, Lin(float(value)), None),))


# -- building ------------------------------------------------------------------------------


def _assembly(spec: StructureSpec, value) -> Assembly:
    """The spec as an `Assembly` with every `Lin` mapped to a number by ``value``."""
    asm = Assembly(spec.kind)
    labels, x, y = zip(*spec.nodes)
    asm.nodes(labels, x, y)
    for family, n1, n2, props in spec.elements:
        getattr(asm, family)(n1, n2, **{k: value(v) for k, v in props.items()})
    for family, dof, v, other in spec.lumped:
        if family == "mass":
            asm.mass(dof, value(v))
        else:
            asm.spring(dof, value(v), other)
    for label in spec.supports.get("clamp", []):
        asm.clamp(label)
    for label in spec.supports.get("pin", []):
        asm.pin(label)
    for dof in spec.supports.get("fix", []):
        asm.fix(dof)
    return asm


#: Models of more DOFs than this are handed to the truth kernels as sparse matrices
#: (`acceptance.truth.modes` then solves for the lowest modes alone); smaller ones dense.
DENSE_MAX = 400


def matrices_at(spec: StructureSpec, values: dict, dense: bool | None = None):
    """``M``, ``K`` (SI) and DOF names at physical parameter values: dense arrays, or, for a
    model of more than `DENSE_MAX` DOFs (``dense=None``) or with ``dense=False``, sparse CSC."""
    if spec.given is not None:
        M, K_fixed, parts, dofs = spec.given
        K = K_fixed + sum(values[name] * A for name, A in parts.items())
    else:
        system = _assembly(spec, lambda v: v.value(values)).system()
        M, K, dofs = system.M, system.K, system.dofs
    if dense is None:
        dense = len(dofs) <= DENSE_MAX
    if dense:
        return M.toarray(), K.toarray(), tuple(dofs)
    return sp.csc_matrix(M), sp.csc_matrix(K), tuple(dofs)


def given_matrices(label: str, M, K_fixed, parts: dict, dofs, measurable) -> StructureSpec:
    """A structure given as matrices (`StructureSpec.given`), written as ``.npz`` files."""
    given = (sp.csr_matrix(M), sp.csr_matrix(K_fixed), {n: sp.csr_matrix(A) for n, A in parts.items()}, tuple(dofs))
    return StructureSpec(label, "frame", (), {}, (), (), tuple(measurable), export="npz", given=given)


def parameter_matrices(spec: StructureSpec, parameters) -> tuple[np.ndarray, np.ndarray, dict, dict, tuple]:
    """``M0``, ``K0`` at the nominal values and ``dM/dp``, ``dK/dp`` per parameter (physical
    units), as an FE package exports them."""
    nominal = {p.name: p.nominal for p in parameters}
    M0, K0, dofs = matrices_at(spec, nominal, dense=True)
    dM, dK = {}, {}
    for p in parameters:
        if spec.given is not None:
            dM[p.name] = np.zeros_like(M0)
            dK[p.name] = spec.given[2][p.name].toarray() if p.name in spec.given[2] else np.zeros_like(K0)
            continue
        system = _assembly(spec, lambda v, name=p.name: v.part(name).const).system()
        dM[p.name], dK[p.name] = system.M.toarray(), system.K.toarray()
    return M0, K0, dM, dK, dofs


def affine_model(spec: StructureSpec, parameters, *, extra_mass: tuple | None = None):
    """The Python route's `AffineModel` (module docstring); ``extra_mass`` ``(dof, kg)`` of a
    further configuration."""
    if extra_mass is not None:
        spec = spec.with_mass(*extra_mass)
    if spec.export is None:
        def build(p):
            return _assembly(spec, lambda v: v.value(p)).system()

        return from_builder(build, list(parameters))
    M0, K0, dM, dK, dofs = parameter_matrices(spec, parameters)
    return from_files(sp.csr_matrix(M0), sp.csr_matrix(K0), list(parameters),
                      dM={n: sp.csr_matrix(A) for n, A in dM.items() if np.any(A)},
                      dK={n: sp.csr_matrix(A) for n, A in dK.items() if np.any(A)}, dofs=dofs)


def _write_matrix(path: Path, A: np.ndarray) -> None:
    if path.suffix == ".mtx":
        scipy.io.mmwrite(str(path), sp.coo_matrix(A), symmetry="symmetric")
    else:
        sp.save_npz(path, sp.csr_matrix(A))


def model_table(spec: StructureSpec, parameters, folder: Path) -> dict:
    """The ``[model]`` table of the case file (plain TOML values); an exported spec writes its
    matrix files into ``folder``."""
    if spec.export is not None:
        M0, K0, dM, dK, dofs = parameter_matrices(spec, parameters)
        ext = "." + spec.export
        _write_matrix(folder / f"M0{ext}", M0)
        _write_matrix(folder / f"K0{ext}", K0)
        table = {"type": "matrices", "M0": f"M0{ext}", "K0": f"K0{ext}", "dofs": list(dofs), "dM": {}, "dK": {}}
        for which, parts in (("dM", dM), ("dK", dK)):
            for name, A in parts.items():
                if np.any(A):
                    _write_matrix(folder / f"{which}_{name}{ext}", A)
                    table[which][name] = f"{which}_{name}{ext}"
        return table
    table = {"type": "elements", "kind": spec.kind,
             "nodes": [[label, float(x), float(y)] for label, x, y in spec.nodes]}
    table.update({k: list(v) for k, v in spec.supports.items() if v})
    for family in ("beam", "frame"):
        items = [{"nodes": [n1, n2], **{k: v.text() for k, v in props.items()}}
                 for f, n1, n2, props in spec.elements if f == family]
        if items:
            table[family] = items
    for family in ("mass", "spring"):
        items = []
        for f, dof, v, other in spec.lumped:
            if f == family:
                items.append({"dof": dof, "value": v.text(), **({"other": other} if other else {})})
        if items:
            table[family] = items
    return table


# -- parameter groups ------------------------------------------------------------------------


def _groups(rng: np.random.Generator, n_items: int, n_groups: int, fixed_share: float = 0.0) -> list[int]:
    """A group (0 .. n_groups - 1) for each item, every group used, or -1 (a known constant)
    for about ``fixed_share`` of the items left over."""
    n_groups = max(1, min(n_groups, n_items))
    order = rng.permutation(n_items)
    out = [-1] * n_items
    for g, i in enumerate(order[:n_groups]):
        out[i] = g
    for i in order[n_groups:]:
        out[i] = -1 if rng.random() < fixed_share else int(rng.integers(n_groups))
    return out


def _parameter(name: str, nominal: float, spread: float, unit: str) -> Parameter:
    return Parameter(name, nominal, nominal * (1 - spread), nominal * (1 + spread), unit=unit)


def _grouped(rng, values, groups, prefix, reference, spread, unit, params: dict) -> list[Lin]:
    """A `Lin` per item: ``(value / reference) * prefix{g}``, or the value itself for group -1."""
    out = []
    for v, g in zip(values, groups):
        if g < 0:
            out.append(Lin(float(v)))
            continue
        name = f"{prefix}{g + 1}"
        params.setdefault(name, _parameter(name, reference, spread, unit))
        out.append(Lin.of(v / reference, name))
    return out


# -- structures --------------------------------------------------------------------------------


def chain(rng: np.random.Generator, n: int, *, ends: str = "one", k_groups: int = 2, m_groups: int = 1,
          spread: float = 0.3, symmetric: bool = False, parallel: bool = False,
          uniform: bool = False) -> tuple[StructureSpec, list[Parameter]]:
    """Spring-mass chain ``y1 .. yn`` (N/m, kg), grounded at ``y1`` (``ends="one"``) or at both
    ends (``"both"``).

    ``symmetric``: both ends grounded, masses and interior springs mirror-symmetric and known
    except one interior group, end springs ``kL`` and ``kR``: swapping them leaves every
    frequency unchanged (an exact symmetry). ``parallel``: a second spring ``kp`` in parallel
    with the first, so that only their sum is seen (a parameter combination no data see).
    ``uniform``: nominal 1000 N/m and 1 kg everywhere (a shear building).
    """
    if symmetric:
        ends = "both"
    n_springs = n + (1 if ends == "both" else 0)
    k_nom = np.full(n_springs, 1000.0) if uniform or symmetric else rng.uniform(600.0, 1600.0, n_springs)
    m_nom = np.full(n, 1.0) if uniform or symmetric else rng.uniform(0.6, 1.6, n)
    if symmetric:
        k_nom = 0.5 * (k_nom + k_nom[::-1])
    params: dict = {}
    if symmetric:
        springs = [Lin.of(k_nom[0] / 1000.0, "kL")] + [Lin.of(k / 1000.0, "kc") for k in k_nom[1:-1]] + \
                  [Lin.of(k_nom[-1] / 1000.0, "kR")]
        for name in ("kL", "kc", "kR"):
            params[name] = _parameter(name, 1000.0, spread, "N/m")
        masses = [Lin(float(m)) for m in m_nom]
    else:
        springs = _grouped(rng, k_nom, _groups(rng, n_springs, k_groups), "k", 1000.0, spread, "N/m", params)
        masses = _grouped(rng, m_nom, _groups(rng, n, m_groups, 0.5), "m", 1.0, spread, "kg", params) \
            if m_groups > 0 else [Lin(float(m)) for m in m_nom]
    lumped = [("mass", f"y{i + 1}", masses[i], None) for i in range(n)]
    lumped.append(("spring", "y1", springs[0], None))
    lumped += [("spring", f"y{i + 1}", springs[i], f"y{i}") for i in range(1, n)]
    if ends == "both":
        lumped.append(("spring", f"y{n}", springs[n], None))
    if parallel:
        params["kp"] = _parameter("kp", 300.0, spread, "N/m")
        lumped.append(("spring", "y1", Lin.of(1.0, "kp"), None))
    nodes = tuple((i + 1, float(i + 1), 0.0) for i in range(n))
    label = "chain-symmetric" if symmetric else f"chain-{ends}"
    spec = StructureSpec(label, "beam", nodes, {"fix": [f"phi{i + 1}" for i in range(n)]}, (),
                         tuple(lumped), tuple(f"y{i + 1}" for i in range(n)))
    return spec, _ordered(params)


def _ordered(params: dict) -> list[Parameter]:
    return [params[k] for k in sorted(params, key=lambda s: (s.rstrip("0123456789"), len(s), s))]


#: Aluminium strip 25 x 5 mm: EI (N m^2) and rho A (kg/m).
STRIP_EI, STRIP_RHO_A = 18.0, 0.34


def beam(rng: np.random.Generator, n_el: int, *, support: str = "clamped", ei_groups: int = 2,
         m_groups: int = 1, tip_mass: bool = False, lumped_mass: bool = False, spread: float = 0.3,
         length: float = 1.0) -> tuple[StructureSpec, list[Parameter]]:
    """Beam of ``n_el`` elements, nodes ``0 .. n_el`` along ``length`` (m).

    ``support``: ``"clamped"`` (node 0), ``"pinned"`` (pinned at both ends), ``"springs"``
    (translational springs ``ks1``, ``ks2`` at the ends and a rotational spring ``kr`` at node
    0, parameters) or ``"free"`` (free-free, two rigid-body modes). ``lumped_mass``: the
    element mass lumped on the translations (rotations massless; exported as matrices).
    """
    params: dict = {}
    ei_nom = STRIP_EI * rng.uniform(0.85, 1.15, n_el)
    m_nom = STRIP_RHO_A * rng.uniform(0.9, 1.1, n_el)
    ei = _grouped(rng, ei_nom, _groups(rng, n_el, ei_groups), "EI", STRIP_EI, spread, "N m^2", params)
    rho_a = _grouped(rng, m_nom, _groups(rng, n_el, m_groups, 0.3), "rA", STRIP_RHO_A, spread, "kg/m", params) \
        if m_groups > 0 else [Lin(float(m)) for m in m_nom]
    h = length / n_el
    nodes = tuple((i, i * h, 0.0) for i in range(n_el + 1))
    elements, lumped = [], []
    for e in range(n_el):
        mpl = Lin(0.0) if lumped_mass else rho_a[e]
        elements.append(("beam", e, e + 1, {"EI": ei[e], "mass_per_length": mpl}))
        if lumped_mass:
            half = Lin(0.5 * h * rho_a[e].const, tuple((0.5 * h * c, n) for c, n in rho_a[e].terms))
            lumped += [("mass", f"y{e}", half, None), ("mass", f"y{e + 1}", half, None)]
    supports: dict = {}
    rigid = 0
    if support == "clamped":
        supports["clamp"] = [0]
    elif support == "pinned":
        supports["pin"] = [0, n_el]
    elif support == "springs":
        for name, nominal, unit in (("ks1", 2000.0, "N/m"), ("ks2", 2000.0, "N/m"), ("kr", 20.0, "N m/rad")):
            params[name] = _parameter(name, nominal, spread, unit)
        lumped += [("spring", "y0", Lin.of(1.0, "ks1"), None), ("spring", f"y{n_el}", Lin.of(1.0, "ks2"), None),
                   ("spring", "phi0", Lin.of(1.0, "kr"), None)]
    elif support == "free":
        rigid = 2
    else:
        raise ValueError(f"support must be clamped, pinned, springs or free, got {support!r}")
    if tip_mass:
        params["mt"] = _parameter("mt", 0.05, spread, "kg")
        lumped.append(("mass", f"y{n_el}", Lin.of(1.0, "mt"), None))
    fixed = {0} if support == "clamped" else {0, n_el} if support == "pinned" else set()
    measurable = tuple(f"y{i}" for i in range(n_el + 1) if i not in fixed)
    spec = StructureSpec(f"beam-{support}", "beam", nodes, supports, tuple(elements), tuple(lumped), measurable,
                         rigid_modes=rigid, massless=lumped_mass)
    return spec, _ordered(params)


def frame(rng: np.random.Generator, n_col: int = 3, n_beam: int = 4, *, base: str = "clamped",
          spread: float = 0.3, height: float = 1.0, span: float = 1.2) -> tuple[StructureSpec, list[Parameter]]:
    """Portal frame: columns ``a0 .. a{n_col}`` at x = 0 and ``b0 ..`` at x = ``span``, a beam
    ``a{n_col}, c1 .. c{n_beam-1}, b{n_col}`` at y = ``height`` (m); frame elements with
    ``EA = 1e4 EI`` tied to the same parameter; lumped masses ``mk`` at the knees; the feet
    clamped or pinned on rotational springs ``kr``. Parameters: ``EIc`` per column or shared,
    ``EIb``, ``rA`` (all members) and ``mk``."""
    params: dict = {}
    own = rng.random() < 0.5
    names = ("EIc1", "EIc2") if own else ("EIc1", "EIc1")
    for name in dict.fromkeys(names):
        params[name] = _parameter(name, 100.0, spread, "N m^2")
    params["EIb"] = _parameter("EIb", 60.0, spread, "N m^2")
    params["rA"] = _parameter("rA", 2.0, spread, "kg/m")
    params["mk"] = _parameter("mk", 0.5, spread, "kg")
    nodes = [(f"a{i}", 0.0, height * i / n_col) for i in range(n_col + 1)]
    nodes += [(f"b{i}", span, height * i / n_col) for i in range(n_col + 1)]
    nodes += [(f"c{j}", span * j / n_beam, height) for j in range(1, n_beam)]
    elements = []

    def member(n1, n2, ei_name):
        factor = float(rng.uniform(0.9, 1.1))
        ei = Lin.of(factor, ei_name)
        elements.append(("frame", n1, n2, {"EA": Lin.of(1e4 * factor, ei_name), "EI": ei,
                                           "mass_per_length": Lin.of(1.0, "rA")}))

    for i in range(n_col):
        member(f"a{i}", f"a{i + 1}", names[0])
        member(f"b{i}", f"b{i + 1}", names[1])
    chain_nodes = [f"a{n_col}"] + [f"c{j}" for j in range(1, n_beam)] + [f"b{n_col}"]
    for n1, n2 in zip(chain_nodes[:-1], chain_nodes[1:]):
        member(n1, n2, "EIb")
    lumped = [("mass", f"x{side}{n_col}", Lin.of(1.0, "mk"), None) for side in "ab"]
    lumped += [("mass", f"y{side}{n_col}", Lin.of(1.0, "mk"), None) for side in "ab"]
    if base == "clamped":
        supports = {"clamp": ["a0", "b0"]}
    else:
        supports = {"pin": ["a0", "b0"]}
        params["kr"] = _parameter("kr", 200.0, spread, "N m/rad")
        lumped += [("spring", "phia0", Lin.of(1.0, "kr"), None), ("spring", "phib0", Lin.of(1.0, "kr"), None)]
    measurable = tuple(f"{d}{label}" for label, _, _ in nodes if label not in ("a0", "b0") for d in "xy")
    spec = StructureSpec(f"frame-{base}", "frame", tuple(nodes), supports, tuple(elements), tuple(lumped),
                         measurable)
    return spec, _ordered(params)
