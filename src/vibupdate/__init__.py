"""vibupdate: model updating of vibrating systems.

Interval-based updating of mass and stiffness parameters from natural frequencies,
antiresonances and uncertain mode shapes by homotopy optimization with McCormick relaxations
(Richiedei, Tamellin, Trevisani, Mech. Mach. Theory 160 (2021) 104288), followed by
Caughey-series damping identification.
"""

from vibupdate.affine import AffineModel
from vibupdate.analysis import antiresonances, mac, modes, receptance
from vibupdate.assembly import Assembly, System
from vibupdate.measured import Antiresonance, Configuration, NaturalFrequency, ShapeInterval
from vibupdate.model import from_builder, from_files
from vibupdate.parameters import Parameter

__version__ = "0.1.0"

__all__ = [
    "AffineModel",
    "Antiresonance",
    "Assembly",
    "Configuration",
    "NaturalFrequency",
    "Parameter",
    "ShapeInterval",
    "System",
    "antiresonances",
    "from_builder",
    "from_files",
    "mac",
    "modes",
    "receptance",
]
