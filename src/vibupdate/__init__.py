"""vibupdate: model updating of vibrating systems.

Interval-based updating of mass and stiffness parameters from natural frequencies,
antiresonances and uncertain mode shapes by homotopy optimization with McCormick relaxations
(Richiedei, Tamellin, Trevisani, Mech. Mach. Theory 160 (2021) 104288), followed by
Caughey-series damping identification.
"""

from __future__ import annotations

import importlib

#: Where each public name is defined. They are imported on first use (PEP 562), so that
#: ``import vibupdate`` (and the command line's start) does not load numpy, scipy and the
#: solver until something asks for them; ``from vibupdate import update`` works as before.
_WHERE = {
    "AffineModel": "vibupdate.model.affine",
    "antiresonances": "vibupdate.modal.analysis",
    "flexible_modes": "vibupdate.modal.analysis",
    "mac": "vibupdate.modal.analysis",
    "modes": "vibupdate.modal.analysis",
    "receptance": "vibupdate.modal.analysis",
    "Assembly": "vibupdate.model.assembly",
    "System": "vibupdate.model.assembly",
    "Antiresonance": "vibupdate.data.measured",
    "Configuration": "vibupdate.data.measured",
    "NaturalFrequency": "vibupdate.data.measured",
    "ShapeInterval": "vibupdate.data.measured",
    "from_builder": "vibupdate.model.build",
    "from_files": "vibupdate.model.build",
    "FormulationOptions": "vibupdate.inverse.formulation.options",
    "SolverOptions": "vibupdate.inverse.homotopy",
    "PolishOptions": "vibupdate.inverse.polish",
    "Parameter": "vibupdate.model.parameters",
    "Status": "vibupdate.inverse.status",
    "UpdateResult": "vibupdate.inverse.update",
    "update": "vibupdate.inverse.update",
    "VerifyOptions": "vibupdate.inverse.verify",
}

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


def __getattr__(name: str):
    """A public name, imported from its module on first use (and then kept in the package)."""
    if name in _WHERE:
        value = getattr(importlib.import_module(_WHERE[name]), name)
        globals()[name] = value
        return value
    raise AttributeError(f"module 'vibupdate' has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_WHERE))
