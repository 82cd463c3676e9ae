"""Optional extras: which feature needs which installable extra, and one check for all of them.

``pip install vibupdate`` installs the core: `vibupdate.update`, a whole run of a case file or
a bundled example, its ``results.json``, ``report.md`` and matrices. Each extra adds the
packages of one group of features (`EXTRAS`); ``[all]`` is every extra. A feature whose extra
is missing calls `require`, which raises `MissingExtra` (an ImportError) naming the extra and
the command that installs it; the command line turns it into one line and exit code 2.
"""

from __future__ import annotations

import importlib
import importlib.util
import sys
from dataclasses import dataclass


@dataclass(frozen=True)
class Extra:
    """One optional extra: the modules it provides and what they are for."""

    modules: tuple[str, ...]
    purpose: str


#: The optional extras by name (the names of ``[project.optional-dependencies]``).
EXTRAS = {
    "plots": Extra(("matplotlib",), "PNG plots of a run, a sweep and an FRF extraction"),
    "frf": Extra(("pyuff",), "reading Universal File Format (UFF) files"),
    "study": Extra(("distributed",), "sweep, batch, sampled ranges and multistart on Dask"),
    "certify": Extra(("clarabel",), "certified parameter ranges (LP relaxations)"),
    "fe": Extra(("opensees", "ansys.mapdl.reader"), "models from FE codes: OpenSees builders, ANSYS .full files"),
}


class MissingExtra(ImportError):
    """A feature was asked for whose optional extra is not installed.

    ``extra`` names the extra, ``feature`` what needed it; the message says both and how to
    install the extra.
    """

    def __init__(self, extra: str, feature: str):
        self.extra = extra
        self.feature = feature
        super().__init__(f"{feature} needs the optional extra [{extra}]: {install_hint(extra)}")


def install_hint(extra: str) -> str:
    """The command that installs ``extra``."""
    return f'pip install "vibupdate[{extra}]"'


def skipped(extra: str, what: str) -> str:
    """The one-line note of a run that left ``what`` (plural) out because ``extra`` is missing."""
    return f"{what} skipped: they need the optional extra [{extra}] ({install_hint(extra)})"


def _extra(name: str) -> Extra:
    if name not in EXTRAS:
        raise ValueError(f"unknown optional extra {name!r}; extras: {', '.join(EXTRAS)}")
    return EXTRAS[name]


def available(extra: str) -> bool:
    """Whether every module of ``extra`` can be imported (they are imported to find out)."""
    for module in _extra(extra).modules:
        try:
            importlib.import_module(module)
        except ImportError:
            return False
    return True


def installed(extra: str) -> bool:
    """Whether every module of ``extra`` is installed, found without importing it (a module
    set to None in ``sys.modules`` counts as missing, as an import of it fails): for a run that
    only needs to know whether to plan plots, whose drawing reports its own failure."""
    for module in _extra(extra).modules:
        if module in sys.modules:
            if sys.modules[module] is None:
                return False
            continue
        try:
            if importlib.util.find_spec(module) is None:
                return False
        except (ImportError, ValueError):
            return False
    return True


def require(extra: str, feature: str, modules: tuple[str, ...] | None = None) -> None:
    """Raise `MissingExtra` unless ``extra`` is installed.

    Parameters
    ----------
    extra : str
        A key of `EXTRAS`.
    feature : str
        What needs it, as the subject of the message: "reading UFF files", "vibupdate sweep".
    modules : tuple of str, optional
        The modules of the extra this feature needs (default: all of them; an OpenSees model
        does not need the ANSYS reader).
    """
    for module in modules if modules is not None else _extra(extra).modules:
        try:
            importlib.import_module(module)
        except ImportError as exc:
            raise MissingExtra(extra, feature) from exc
