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
from vibupdate.formulation import FormulationOptions
from vibupdate.homotopy import SolverOptions
from vibupdate.polish import PolishOptions
from vibupdate.parameters import Parameter
from vibupdate.status import Status
from vibupdate.update import UpdateResult, update
from vibupdate.verify import VerifyOptions

__version__ = "0.1.0"

__all__ = [
    "AffineModel",
    "Antiresonance",
    "FormulationOptions",
    "PolishOptions",
    "VerifyOptions",
    "SolverOptions",
    "Status",
    "UpdateResult",
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
    "update",
]
