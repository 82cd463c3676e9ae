"""The elements model of a case file: its affine form is assembled directly from the linear
expressions of the parameters, and equals the complex-step form of the same model built
element by element with numbers (the path every elements model took before)."""

from pathlib import Path

import numpy as np
import pytest

from vibupdate import Assembly, Parameter, from_builder
from vibupdate.io.case import load_case
from vibupdate.io.case_keys import Where
from vibupdate.io.case_model import element_nodes, base_model, linear_expression
from vibupdate.model import elements

WHERE = Where(Path("case.toml"))

BEAM = {
    "type": "elements", "kind": "beam",
    "line": {"first": 1, "last": 9, "start": [0.0], "end": [0.8]},
    "clamp": [1], "pin": [9], "fix": ["phi5"],
    "beam": [
        {"nodes": [1, 2, 3, 4], "EI": "2.1e-10*E", "mass_per_length": "1.6e-4*rho"},
        # a property with two parameters (EI) and `s` in both properties of one chain ...
        {"nodes": [4, 5, 6], "EI": "2.1e-10*E + 3.6e-13*Ep", "mass_per_length": "1.6e-4*rho + 0.01*s"},
        # ... and in a property of another chain
        {"nodes": [6, 7, 8, 9], "EI": "1e-10*E + 20*s", "mass_per_length": 0.43},
    ],
    "mass": [{"dof": "y5", "value": "m + 0.01"}, {"dof": "phi8", "value": 1e-5}],
    "spring": [{"dof": "y3", "value": "k"}, {"dof": "phi2", "value": "0.5*k - 100", "other": "phi3"}],
}
BEAM_PARAMETERS = [Parameter("E", 70e9, 60e9, 80e9), Parameter("rho", 2700.0, 2500.0, 2900.0),
                   Parameter("Ep", 3e9, 2e9, 4e9), Parameter("s", 1.0, 0.5, 1.5),
                   Parameter("m", 0.02, 0.0, 0.04), Parameter("k", 1000.0, 500.0, 2000.0),
                   Parameter("unused", 1.0, 0.5, 2.0)]

FRAME = {
    "type": "elements", "kind": "frame",
    "nodes": [[1, 0.0, 0.0], [2, 0.0, 1.5], [3, 0.0, 3.0], [4, 1.0, 3.0], [5, 2.0, 3.0],
              [6, 2.0, 1.5], [7, 2.0, 0.0], [8, 1.0, 1.5]],
    "clamp": [1], "pin": [7], "fix": ["x8"],
    "frame": [
        {"nodes": [1, 2, 3], "EA": "0.01*E", "EI": "8e-6*E", "mass_per_length": "0.01*rho"},
        # Eb in two properties, EA with two parameters
        {"nodes": [3, 4, 5], "EA": "0.012*E + 0.001*Eb", "EI": "1e-5*Eb", "mass_per_length": "0.012*rho + 2*q"},
        {"nodes": [5, 6, 7], "EA": "0.01*E", "EI": "8e-6*E", "mass_per_length": "0.01*rho"},
        {"nodes": [2, 8, 5], "EA": "0.002*Eb", "EI": "1e-7*Eb + 1e-8*E", "mass_per_length": 5.4},
    ],
    "mass": [{"dof": "y4", "value": "q"}, {"dof": "phi4", "value": "0.01*q + 0.001"}],
    "spring": [{"dof": "x3", "value": "k", "other": "x5"}, {"dof": "y6", "value": "0.5*k + 100"}],
}
FRAME_PARAMETERS = [Parameter("E", 200e9, 180e9, 220e9), Parameter("Eb", 210e9, 150e9, 250e9),
                    Parameter("rho", 7850.0, 7000.0, 8500.0), Parameter("q", 3.0, 1.0, 5.0),
                    Parameter("k", 1e5, 5e4, 2e5)]


def reference_builder(spec, names):
    """The model of ``spec`` built from numbers, element by element, at each parameter value
    (complex values kept): the builder that `from_builder` differentiates by complex step."""
    compile_ = lambda v: linear_expression(v, names)
    props = {"beam": ("EI", "mass_per_length"), "frame": ("EA", "EI", "mass_per_length")}

    def build(p):
        asm = Assembly(spec["kind"])
        for label, x, y in element_nodes(spec, WHERE):
            asm.node(label, x, y)
        for item in spec.get(spec["kind"], []):
            values = {k: compile_(item[k])(p) for k in props[spec["kind"]]}
            for a, b in zip(item["nodes"], item["nodes"][1:]):
                getattr(asm, spec["kind"])(a, b, **values)
        for item in spec.get("mass", []):
            asm.mass(item["dof"], compile_(item["value"])(p))
        for item in spec.get("spring", []):
            asm.spring(item["dof"], compile_(item["value"])(p), item.get("other"))
        for label in spec.get("clamp", []):
            asm.clamp(label)
        for label in spec.get("pin", []):
            asm.pin(label)
        for dof in spec.get("fix", []):
            asm.fix(dof)
        return asm.system()

    return build


def _relative(A, B) -> float:
    scale = abs(B).max() if B.nnz else 1.0
    return abs(A - B).max() / scale if (A - B).nnz else 0.0


@pytest.mark.parametrize("spec, parameters", [(BEAM, BEAM_PARAMETERS), (FRAME, FRAME_PARAMETERS)],
                         ids=["beam", "frame"])
def test_direct_affine_form_equals_the_complex_step_form(spec, parameters):
    names = [p.name for p in parameters]
    direct = base_model(spec, {}, parameters, Path("."), WHERE)
    stepped = from_builder(reference_builder(spec, names), parameters)
    assert direct.dofs == stepped.dofs
    for A, B in [(direct.M0, stepped.M0), (direct.K0, stepped.K0),
                 *zip(direct.M_par, stepped.M_par), *zip(direct.K_par, stepped.K_par)]:
        assert _relative(A, B) <= 1e-14
        assert set(zip(*A.nonzero())) == set(zip(*B.nonzero()))
    # every parameter enters somewhere except `unused`; supports removed the same DOFs
    active = [A.nnz + B.nnz > 0 for A, B in zip(direct.M_par, direct.K_par)]
    assert active == [n != "unused" for n in names]
    rng = np.random.default_rng(3)
    build = reference_builder(spec, names)
    for _ in range(3):
        values = [rng.uniform(p.lower, p.upper) for p in parameters]
        exact = build(dict(zip(names, values)))
        M, K = direct.matrices_at(values)
        assert _relative(M, exact.M) <= 1e-13 and _relative(K, exact.K) <= 1e-13


def _chain(groups: int, n_elements: int = 48):
    """A straight frame of ``n_elements`` in ``groups`` chains, each chain's stiffness its own
    parameter ``E<g>``, the mass per length of every chain ``rho``."""
    per = n_elements // groups
    spec = {"type": "elements", "kind": "frame", "line": {"first": 0, "last": n_elements, "start": [0.0, 0.0],
                                                         "end": [4.0, 1.0]},
            "clamp": [0], "frame": [{"nodes": list(range(g * per, (g + 1) * per + 1)), "EA": f"0.01*E{g}",
                                     "EI": f"1e-6*E{g}", "mass_per_length": "0.01*rho"} for g in range(groups)]}
    parameters = [Parameter(f"E{g}", 200e9, 150e9, 250e9) for g in range(groups)]
    return spec, parameters + [Parameter("rho", 7850.0, 7000.0, 8500.0)]


def _count_elements(monkeypatch):
    """Count the elements evaluated by the batched frame element function."""
    counted = []
    original = elements.frame_matrices

    def counting(EA, EI, mass_per_length, dx, dy, rotary_inertia=0.0):
        counted.append(np.size(dx))
        return original(EA, EI, mass_per_length, dx, dy, rotary_inertia)

    monkeypatch.setattr(elements, "frame_matrices", counting)
    return counted


@pytest.mark.parametrize("groups", [2, 8])
def test_element_evaluations_do_not_grow_with_the_parameter_count(monkeypatch, groups):
    n_elements = 48
    spec, parameters = _chain(groups, n_elements)
    counted = _count_elements(monkeypatch)
    model = base_model(spec, {}, parameters, Path("."), WHERE)
    assert model.n_parameters == groups + 1
    # nominal, the safety check, then each element once per parameter it involves
    # (its own E<g> and rho): 4 evaluations per element whatever the number of groups
    assert sum(counted) == 4 * n_elements
    counted.clear()
    from_builder(reference_builder(spec, [p.name for p in parameters]), parameters)
    # the complex-step path: 2 n_x + 2 builder calls, each evaluating every element
    assert sum(counted) == (2 * (groups + 1) + 2) * n_elements


@pytest.mark.parametrize("edit, message", [
    (lambda s: s["frame"][1].update(nodes=[3, 4, 9]), r"case\.toml: model: node 9 does not exist"),
    (lambda s: s["mass"].append({"dof": "y9", "value": 1.0}), r"case\.toml: model: DOF 'y9' does not exist"),
    (lambda s: s["nodes"].append([9, 1.0, 3.0]) or s["frame"].append(
        {"nodes": [4, 9], "EA": 1.0, "EI": 1.0, "mass_per_length": 1.0}),
     r"case\.toml: model: element length must be positive and finite, got 0\.0 m"),
    (lambda s: s["nodes"].append([4, 1.0, 3.0]), r"case\.toml: model: node 4 is defined twice"),
    (lambda s: s["mass"].append({"dof": "y2", "value": "-2000*q"}),
     r"case\.toml: model: nominal model: the mass matrix M is not positive semidefinite"),
    (lambda s: s["frame"][0].update(EI="8e-6*E + z"), r"case\.toml: model\.frame\[1\]\.EI: .*'z', which is not a parameter"),
    (lambda s: s.update(fix=["x99"]), r"case\.toml: model: DOF 'x99' does not exist"),
])
def test_bad_elements_input_gives_the_same_clear_error(edit, message):
    import copy

    spec = copy.deepcopy(FRAME)
    edit(spec)
    with pytest.raises(ValueError, match=message):
        base_model(spec, {}, FRAME_PARAMETERS, Path("."), WHERE)


def test_case_file_elements_model_builds_directly(tmp_path, monkeypatch):
    """A whole case file takes the direct path: no builder is differentiated."""
    import vibupdate.model.affine as affine

    def refuse(*args, **kwargs):
        raise AssertionError("the elements model was differentiated by complex step")

    monkeypatch.setattr(affine, "complex_step_jacobians", refuse)
    root = Path(__file__).resolve().parents[2]
    case = load_case(root / "examples" / "cantilever" / "case.toml")
    assert case.configurations[0].model.n_parameters == 7
