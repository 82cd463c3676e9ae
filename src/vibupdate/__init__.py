"""vibupdate: model updating of vibrating systems.

Interval-based updating of mass and stiffness parameters from natural frequencies,
antiresonances and uncertain mode shapes by homotopy optimization with McCormick relaxations
(Richiedei, Tamellin, Trevisani, Mech. Mach. Theory 160 (2021) 104288), followed by
Caughey-series damping identification.
"""

from vibupdate.model.affine import AffineModel
from vibupdate.modal.analysis import antiresonances, flexible_modes, mac, modes, receptance
from vibupdate.model.assembly import Assembly, System
from vibupdate.data.measured import Antiresonance, Configuration, NaturalFrequency, ShapeInterval
from vibupdate.model.build import from_builder, from_files
from vibupdate.inverse.formulation.options import FormulationOptions
from vibupdate.inverse.homotopy import SolverOptions
from vibupdate.inverse.polish import PolishOptions
from vibupdate.model.parameters import Parameter
from vibupdate.inverse.status import Status
from vibupdate.inverse.update import UpdateResult, update
from vibupdate.inverse.verify import VerifyOptions

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
    "flexible_modes",
    "receptance",
    "update",
]
