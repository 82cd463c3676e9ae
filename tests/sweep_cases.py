"""Chain case files for the sweep, batch and multistart tests (tiny models, known truth)."""

import numpy as np

from helpers import chain_model
from vibupdate import modes

TRUTH = {"k1": 1100.0, "k3": 900.0, "m2": 1.15, "m5": 0.85}


def chain_frequencies_hz(truth, n_masses=5):
    model = chain_model(n_masses, list(truth))
    M, K = model.matrices(model.normalized([truth[p.name] for p in model.parameters]))
    omega, _ = modes(M, K, n_masses)
    return omega / (2 * np.pi)


def chain_case_text(truth=TRUTH, n_masses=5, tolerance=0.005, name="chain", spread=0.3):
    """A case file of the spring-mass chain of ``helpers.chain_builder``: parameters ``truth``
    (others at 1000 N/m and 1 kg), natural frequencies of the true model measured."""
    hz = chain_frequencies_hz(truth, n_masses)
    lines = [f'case = "{name}"', f"frequency_tolerance = {tolerance}", "",
             "[model]", 'type = "elements"', 'kind = "beam"',
             "nodes = [" + ", ".join(f"[{i}, {float(i)}]" for i in range(1, n_masses + 1)) + "]",
             "fix = [" + ", ".join(f'"phi{i}"' for i in range(1, n_masses + 1)) + "]", ""]
    for i in range(1, n_masses + 1):
        value = f'"m{i}"' if f"m{i}" in truth else "1.0"
        lines += ["[[model.mass]]", f'dof = "y{i}"', f"value = {value}", ""]
    for i in range(1, n_masses + 1):
        value = f'"k{i}"' if f"k{i}" in truth else "1000.0"
        lines += ["[[model.spring]]", f'dof = "y{i}"', f"value = {value}"]
        if i > 1:
            lines.append(f'other = "y{i - 1}"')
        lines.append("")
    for name_ in truth:
        nominal = 1000.0 if name_.startswith("k") else 1.0
        lines += ["[[parameter]]", f'name = "{name_}"', f'unit = "{"N/m" if name_.startswith("k") else "kg"}"',
                  f"nominal = {nominal}", f"lower = {nominal * (1 - spread)}", f"upper = {nominal * (1 + spread)}", ""]
    lines += ["[[configuration]]", 'name = "A"', "natural_hz = [" + ", ".join(repr(float(h)) for h in hz) + "]"]
    return "\n".join(lines) + "\n"


def write_chain_case(path, **kwargs):
    path.write_text(chain_case_text(**kwargs), encoding="utf-8")
    return path
