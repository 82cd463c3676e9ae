"""vibupdate: model updating of vibrating systems.

Interval-based updating of mass and stiffness parameters from natural frequencies,
antiresonances and uncertain mode shapes by homotopy optimization with McCormick relaxations
(Richiedei, Tamellin, Trevisani, Mech. Mach. Theory 160 (2021) 104288), followed by
Caughey-series damping identification.
"""

from __future__ import annotations

import importlib

#: Where each public name is defined: the names listed here (and ``__version__``) are the
#: library's public surface; the modules behind them are internal. They are imported on first
#: use (PEP 562), so that ``import vibupdate`` (and the command line's start) does not load
#: numpy, scipy and the solver until something asks for them.
_WHERE = {
    "AffineModel": "vibupdate.model.affine",
    "antiresonances": "vibupdate.modal.zeros",
    "flexible_modes": "vibupdate.modal.analysis",
    "mac": "vibupdate.modal.analysis",
    "modes": "vibupdate.modal.eigen",
    "receptance": "vibupdate.modal.receptance",
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
    "VerifyOptions": "vibupdate.inverse.admissible",
    "Case": "vibupdate.io.case_types",
    "DampingOptions": "vibupdate.io.case_types",
    "load_case": "vibupdate.io.case",
    "run_case": "vibupdate.pipeline",
    "RunResult": "vibupdate.io.results",
    "load_results": "vibupdate.io.results",
    "FRFSet": "vibupdate.data.frf",
    "read_frfs": "vibupdate.data.frf",
    "Extraction": "vibupdate.data.extraction",
    "extract": "vibupdate.data.extraction",
    "DampingStage": "vibupdate.damping.stage",
    "identify_damping": "vibupdate.damping.stage",
    "caughey_matrix": "vibupdate.damping.models",
    "parameter_ranges": "vibupdate.ranges.identifiability",
    "certified_ranges": "vibupdate.ranges.certify",
    "suggest_case": "vibupdate.study.suggest",
    "ImportedModel": "vibupdate.io.fe_import",
    "import_model": "vibupdate.io.fe_import",
}

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
    "Case",
    "DampingOptions",
    "load_case",
    "run_case",
    "RunResult",
    "load_results",
    "FRFSet",
    "read_frfs",
    "Extraction",
    "extract",
    "DampingStage",
    "identify_damping",
    "caughey_matrix",
    "parameter_ranges",
    "certified_ranges",
    "suggest_case",
    "ImportedModel",
    "import_model",
]


def __getattr__(name: str):
    """A public name, imported from its module on first use (and then kept in the package)."""
    if name in _WHERE:
        value = getattr(importlib.import_module(_WHERE[name]), name)
    elif name == "__version__":     # the installed distribution's, as pyproject.toml states it
        from importlib.metadata import version

        value = version("vibupdate")
    else:
        raise AttributeError(f"module 'vibupdate' has no attribute {name!r}")
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_WHERE) | {"__version__"})
