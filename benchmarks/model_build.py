"""Build time of a case file's elements model: direct affine assembly against complex step.

Run:  python benchmarks/model_build.py [--sizes 3000 30000] [--parameters 12 48] [--repeat 3]

The model is a planar building frame written as a case file's ``[model]`` table
(``type = "elements"``, as a dict): ``storeys`` x ``bays`` of 3 m, every column and beam one
chain of four 0.75 m frame elements, columns clamped at the base. Parameters come in groups of
storeys (as many groups as a third of the parameters): per group the columns' Young's modulus
(in ``EA`` and ``EI``), the beams' Young's modulus and a superimposed floor mass (in the
beams' ``mass_per_length``, which also has the steel's constant part). Sizes:

    ~3,000 DOFs: 16 x 8 (2,880 free DOFs); ~30,000 DOFs: 48 x 30 (30,816 free DOFs).

Three ways to the same `AffineModel`, each timed in the same process (best of ``--repeat``):

* ``direct``: `vibupdate.io.case_model.base_model`, what a case file now does (read the
  table, `Assembly.affine_parts`, the admissibility check of the nominal matrices, the single
  safety check);
* ``complex step, vectorized``: `from_builder` on ``assembly.system`` of the same assembly
  (``2 n_x + 2`` calls, each evaluating every element in one batched call): the competent
  complex-step peer;
* ``complex step, per element``: the builder the case file used before (a fresh `Assembly`
  per call, elements added pair by pair), only at the smaller size (it is the slowest).

The matrices of the three are compared (largest difference relative to the largest entry).
"""

from __future__ import annotations

import argparse
import json
import os
import time

os.environ.setdefault("OMP_NUM_THREADS", "1")

SIZES = {3000: (16, 8), 30000: (48, 30)}
STOREY, BAY, PER_MEMBER = 3.0, 3.0, 4


def building_spec(storeys: int, bays: int, groups: int) -> dict:
    """The ``[model]`` table of the building: nodes, one frame chain per member, clamps."""
    nodes, chains = [], []
    joint = lambda s, b: f"j{s}_{b}"
    for s in range(storeys + 1):
        for b in range(bays + 1):
            nodes.append([joint(s, b), b * BAY, s * STOREY])
    group = lambda s: min(groups - 1, (s - 1) * groups // storeys)
    for s in range(1, storeys + 1):
        g = group(s)
        for b in range(bays + 1):             # columns below floor s
            inner = [f"c{s}_{b}_{k}" for k in range(1, PER_MEMBER)]
            nodes += [[n, b * BAY, (s - 1 + k / PER_MEMBER) * STOREY] for k, n in enumerate(inner, start=1)]
            chains.append({"nodes": [joint(s - 1, b), *inner, joint(s, b)], "EA": f"0.0110*Ec{g}",
                           "EI": f"1.9e-4*Ec{g}", "mass_per_length": 86.0})
        for b in range(bays):                 # beams of floor s
            inner = [f"b{s}_{b}_{k}" for k in range(1, PER_MEMBER)]
            nodes += [[n, (b + k / PER_MEMBER) * BAY, s * STOREY] for k, n in enumerate(inner, start=1)]
            chains.append({"nodes": [joint(s, b), *inner, joint(s, b + 1)], "EA": f"0.0085*Eb{g}",
                           "EI": f"1.6e-4*Eb{g}", "mass_per_length": f"67.0 + 1500*q{g}"})
    return {"type": "elements", "kind": "frame", "nodes": nodes, "frame": chains,
            "clamp": [joint(0, b) for b in range(bays + 1)]}


def building_parameters(groups: int):
    from vibupdate import Parameter

    out = []
    for g in range(groups):
        out += [Parameter(f"Ec{g}", 210e9, 150e9, 260e9, "Pa"), Parameter(f"Eb{g}", 210e9, 150e9, 260e9, "Pa"),
                Parameter(f"q{g}", 0.5, 0.2, 1.0, "kN/m^2 x 1.5 m")]
    return out


def per_element_builder(spec: dict, names):
    """The elements builder as the case file had it before the direct path: a fresh
    `Assembly` per call, nodes and elements added one by one with numbers."""
    from pathlib import Path

    from vibupdate import Assembly
    from vibupdate.io.case_keys import Where
    from vibupdate.io.case_model import element_nodes, linear_expression

    nodes = element_nodes(spec, Where(Path("case.toml")))
    chains = [(item["nodes"], {k: linear_expression(item[k], names) for k in ("EA", "EI", "mass_per_length")})
              for item in spec["frame"]]

    def build(p):
        asm = Assembly("frame")
        for label, x, y in nodes:
            asm.node(label, x, y)
        for chain, props in chains:
            values = {k: f(p) for k, f in props.items()}
            for a, b in zip(chain, chain[1:]):
                asm.frame(a, b, **values)
        for label in spec["clamp"]:
            asm.clamp(label)
        return asm.system()

    return build


def _best(fn, repeat: int):
    best, out = float("inf"), None
    for _ in range(repeat):
        t0 = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - t0)
    return best, out


def _difference(a, b) -> float:
    worst = 0.0
    for A, B in [(a.M0, b.M0), (a.K0, b.K0), *zip(a.M_par, b.M_par), *zip(a.K_par, b.K_par)]:
        scale = abs(B).max() if B.nnz else 1.0
        D = A - B
        worst = max(worst, abs(D).max() / scale if D.nnz else 0.0)
    return worst


def measure(size: int, n_parameters: int, repeat: int, per_element: bool) -> dict:
    from pathlib import Path

    from vibupdate import from_builder
    from vibupdate.io.case_keys import Where
    from vibupdate.io.case_model import _elements_assembly, base_model

    storeys, bays = SIZES[size]
    spec = building_spec(storeys, bays, n_parameters // 3)
    parameters = building_parameters(n_parameters // 3)
    names = [p.name for p in parameters]
    where = Where(Path("case.toml"))
    direct_s, direct = _best(lambda: base_model(spec, {}, parameters, Path("."), where), repeat)
    assembly = _elements_assembly(spec, names, where)
    step_s, stepped = _best(lambda: from_builder(assembly.system, parameters), repeat)
    row = {"size": size, "dofs": direct.n_dofs, "elements": PER_MEMBER * len(spec["frame"]),
           "parameters": n_parameters, "direct_s": round(direct_s, 4), "complex_step_s": round(step_s, 4),
           "ratio": round(step_s / direct_s, 2), "max_difference": _difference(direct, stepped)}
    if per_element:
        old_s, old = _best(lambda: from_builder(per_element_builder(spec, names), parameters), 1)
        row.update(per_element_s=round(old_s, 3), per_element_ratio=round(old_s / direct_s, 1),
                   per_element_difference=_difference(direct, old))
    return row


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=sorted(SIZES), choices=sorted(SIZES))
    parser.add_argument("--parameters", type=int, nargs="+", default=[12, 48])
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--per-element", action="store_true",
                        help="also time the previous per-element builder (at the smallest size only)")
    args = parser.parse_args(argv)
    for size in args.sizes:
        for n in args.parameters:
            if n % 3:
                parser.error(f"--parameters must be multiples of 3 (groups of three), got {n}")
            load = os.getloadavg()[0]
            row = measure(size, n, args.repeat, args.per_element and size == min(args.sizes))
            row["load_average"] = [round(load, 1), round(os.getloadavg()[0], 1)]
            print(json.dumps(row), flush=True)


if __name__ == "__main__":
    main()
