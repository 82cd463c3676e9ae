"""A tiny case (a clamped beam, two parameters, one configuration) that runs end to end in
about a second, for the tests of the output folder and the command line."""

from __future__ import annotations

import hashlib
from pathlib import Path

# Natural frequencies and the first antiresonance of the tip's driving point of the model below
# at E = 75 GPa, rho = 2600 kg/m^3 (computed with vibupdate.modes and antiresonances, 4
# decimals); the damping ratios are made up.
TINY_CASE = """\
case = "tiny"

[model]
type = "elements"
kind = "beam"
line = { first = 1, last = 4, start = [0.0], end = [0.3] }
clamp = [4]

[[model.beam]]
nodes = [1, 2, 3, 4]
EI = "2.0e-10*E"
mass_per_length = "1.6e-4*rho"

[[parameter]]
name = "E"
unit = "Pa"
nominal = 70e9
lower = 50e9
upper = 90e9

[[parameter]]
name = "rho"
unit = "kg/m^3"
nominal = 2700.0
lower = 2000.0
upper = 3400.0

[[configuration]]
name = "A"
natural_hz = [37.3397, 234.7489]
damping_ratios = [0.02, 0.01]
antiresonances = [{ hz = 164.0447, response = "y1", excitation = "y1" }]

[solver]
n_lambda = 2
"""


def write_case(folder: Path, text: str = TINY_CASE, name: str = "case.toml") -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / name
    path.write_text(text, encoding="utf-8")
    return path


def snapshot(folder: Path) -> dict[str, str]:
    """Every file under ``folder`` (relative path) with the SHA-1 of its bytes."""
    return {str(p.relative_to(folder)): hashlib.sha1(p.read_bytes()).hexdigest()
            for p in sorted(Path(folder).rglob("*")) if p.is_file()}
