"""Small models shared by the tests."""

import re
from pathlib import Path

import numpy as np

from vibupdate import Assembly, Parameter, from_builder


def uniform_cantilever(n_elements, length=1.0, EI=1.0, rho_a=1.0):
    asm = Assembly("beam")
    for i in range(n_elements + 1):
        asm.node(i, i * length / n_elements)
    for i in range(n_elements):
        asm.beam(i, i + 1, EI=EI, mass_per_length=rho_a)
    asm.clamp(0)
    return asm.system()


def chain_builder(n_masses):
    """Spring-mass chain fixed at the left: parameters k1..kn (springs), m1..mn (masses)."""

    def build(p):
        asm = Assembly("beam")
        for i in range(1, n_masses + 1):
            asm.node(i, float(i))
        for i in range(1, n_masses + 1):
            asm.fix(f"phi{i}")
            asm.mass(f"y{i}", p.get(f"m{i}", 1.0))
        asm.spring("y1", p.get("k1", 1000.0))
        for i in range(2, n_masses + 1):
            asm.spring(f"y{i - 1}", p.get(f"k{i}", 1000.0), f"y{i}")
        return asm.system()

    return build


def chain_model(n_masses, names, nominal=None, spread=0.3, reference=None):
    """Affine chain model with the listed parameters (k*, m*) varying +-spread."""
    nominal = nominal or {}
    params = []
    for name in names:
        v = nominal.get(name, 1000.0 if name.startswith("k") else 1.0)
        params.append(Parameter(name, v, v * (1 - spread), v * (1 + spread)))
    return from_builder(chain_builder(n_masses), params)


def random_spd(rng, n, cond=10.0):
    Q, _ = np.linalg.qr(rng.standard_normal((n, n)))
    return Q @ np.diag(np.linspace(1.0, cond, n)) @ Q.T


#: The case file of docs/case-file.md (its first TOML block), as the docs show it.
CASE_FILE_EXAMPLE = re.search(r"```toml\n(.*?)```",
                              (Path(__file__).resolve().parents[1] / "docs" / "case-file.md").read_text(),
                              re.S).group(1)
