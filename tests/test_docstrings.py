"""Every public name of ``vibupdate`` has a numpydoc docstring, and so has every public method
and property that its public classes define themselves (they are the surface a user calls:
``model.matrices(p)``, ``result.verdict``, ``frfs.band(...)``; what a class inherits from ``str``,
``Enum`` or ``object`` is documented there).

The check is numpydoc's own validator (``numpydoc.validate``), held to the codes in ``CODES``:
a docstring; a summary on one line, capitalised and ended by a period; sections numpydoc knows,
in its order; ``Parameters`` naming exactly the signature's parameters, in order, each with a
type and a description; ``Returns`` (with a description) when the code returns a value,
``Yields`` for a generator. The codes left out are wording and layout (``SS05`` the summary's
verb form, ``GL02`` where the closing quotes sit, ``PR08``/``PR09`` capitals and periods inside
descriptions) or sections the project does not ask for (``ES01``, ``SA01``, ``EX01``).

One addition of ours: numpydoc reads a class's ``Parameters`` as its constructor's arguments.
A dataclass's constructor arguments are its fields, and the project documents them once, under
``Attributes``; an enumeration documents its members there. For those classes the ``Parameters``
codes are replaced by a check that ``Attributes`` names exactly the fields (each with a type and
a description) or the members (each with a description). The convention is written in
docs/testing.md ("Docstrings").
"""

from __future__ import annotations

import dataclasses
import enum
import functools
import importlib
import inspect
import typing

import numpydoc.validate as numpydoc_validate  # in the `test` extra of pyproject.toml
from numpydoc.docscrape import NumpyDocString

import vibupdate

#: numpydoc's codes that every public docstring is held to.
CODES = frozenset({
    "GL06", "GL07", "GL08",                      # known sections, in order; a docstring at all
    "SS01", "SS02", "SS03", "SS06",              # a one-line summary, capitalised, with a period
    "PR01", "PR02", "PR03", "PR04", "PR07",      # Parameters = the signature, typed, described
    "RT01", "RT03", "YD01",                      # Returns (described) or Yields when there is one
})

#: The codes that ``Attributes`` replaces on dataclasses and enumerations.
PARAMETER_CODES = frozenset({"PR01", "PR02", "PR03", "PR04", "PR07"})


def _attribute_names(cls: type) -> tuple[list[str], bool] | None:
    """The names a class's ``Attributes`` must hold and whether each needs a type, or None
    when the class is neither a dataclass nor an enumeration."""
    if dataclasses.is_dataclass(cls):
        return [f.name for f in dataclasses.fields(cls)], True
    if isinstance(cls, type) and issubclass(cls, enum.Enum):
        return [member.name for member in cls], False
    return None


def _attribute_errors(cls: type) -> list[str]:
    """What is wrong with the ``Attributes`` section of a dataclass or an enumeration."""
    wanted = _attribute_names(cls)
    if wanted is None:
        return []
    names, typed = wanted
    entries = NumpyDocString(inspect.getdoc(cls) or "")["Attributes"]
    written = [name for entry in entries for name in entry.name.split(", ")]  # "M0, K0 : ..."
    errors = []
    missing = [name for name in names if name not in written]
    extra = [name for name in written if name not in names]
    if missing:
        errors.append(f"Attributes does not name {missing}")
    if extra:
        errors.append(f"Attributes names {extra}, which are not "
                      + ("fields" if typed else "members"))
    for entry in entries:
        if typed and not entry.type.strip():
            errors.append(f"attribute {entry.name!r} has no type")
        if not "".join(entry.desc).strip():
            errors.append(f"attribute {entry.name!r} has no description")
    return errors


def _load(path: str):
    """The object at an import path: the longest prefix that imports as a module, then
    attributes."""
    parts = path.split(".")
    for split in range(len(parts), 0, -1):
        try:
            obj = importlib.import_module(".".join(parts[:split]))
        except ModuleNotFoundError:
            continue
        for name in parts[split:]:
            obj = getattr(obj, name)
        return obj
    raise ModuleNotFoundError(path)


def docstring_errors(path: str) -> list[str]:
    """``CODE message`` for each fault of the docstring of the object at import path ``path``
    (``"vibupdate.update"``, ``"vibupdate.model.affine.AffineModel.matrices"``)."""
    report = numpydoc_validate.validate(path)
    obj = _load(path)
    replaced = inspect.isclass(obj) and _attribute_names(obj) is not None
    errors = [f"{code} {message}" for code, message in report["errors"]
              if code in CODES and not (replaced and code in PARAMETER_CODES)]
    if inspect.isclass(obj):
        errors += [f"AT {message}" for message in _attribute_errors(obj)]
    return errors


def _public_members(cls: type) -> list[str]:
    """The public methods, class methods, static methods and properties a class defines."""
    kinds = (property, functools.cached_property, classmethod, staticmethod)
    return [name for name, value in vars(cls).items()
            if not name.startswith("_") and (inspect.isfunction(value) or isinstance(value, kinds))]


def record_types() -> list[type]:
    """The dataclasses and enumerations a loaded ``results.json`` holds: ``RunResult``'s field
    types, their fields' types, and so on (`vibupdate.io.records.field_types` resolves them)."""
    from vibupdate.io.records import field_types

    found: dict[type, None] = {}

    def walk(tp) -> None:
        for arg in typing.get_args(tp):
            walk(arg)
        if isinstance(tp, type) and (dataclasses.is_dataclass(tp) or issubclass(tp, enum.Enum)) and tp not in found:
            found[tp] = None
            if dataclasses.is_dataclass(tp):
                for hint in field_types(tp).values():
                    walk(hint)

    walk(_load("vibupdate.io.results.RunResult"))
    return list(found)


def public_paths() -> list[str]:
    """Import paths of the facade's names, of the types a loaded ``results.json`` holds, and of
    the public members of those classes."""
    classes = [getattr(vibupdate, name) for name in vibupdate.__all__]
    paths = [f"vibupdate.{name}" for name in vibupdate.__all__]
    for cls in record_types():
        if cls not in classes:
            classes.append(cls)
            paths.append(f"{cls.__module__}.{cls.__qualname__}")
    for obj in classes:
        if inspect.isclass(obj):
            paths += [f"{obj.__module__}.{obj.__qualname__}.{member}" for member in _public_members(obj)]
    return paths


def test_every_public_docstring_passes_numpydoc():
    """One assertion for the whole surface, listing every fault, so one run shows all of them."""
    paths = public_paths()
    assert len(paths) > len(vibupdate.__all__)         # the classes' members are in the scope
    assert "vibupdate.io.records.SolverRecord" in paths and "vibupdate.io.records.WidenedBox" in paths
    assert {"StepRecord", "Check", "Attempt", "Verdict", "Sought", "Start", "Alternative", "Search"} <= {
        cls.__name__ for cls in record_types()}
    faults = [f"{path}: {error}" for path in paths for error in docstring_errors(path)]
    assert not faults, f"{len(faults)} docstring faults:\n" + "\n".join(faults)


# ---------------------------------------------------------------------------------------------
# The checker on constructed docstrings: it finds each kind of fault and passes a good one.


def good_function(frequency, weights=None):
    """Scale a frequency by its weights.

    Parameters
    ----------
    frequency : float
        Angular frequency, rad/s.
    weights : numpy.ndarray of shape (n,), optional
        Weights, one per row.

    Returns
    -------
    float
        The scaled frequency, rad/s.
    """
    return frequency


def missing_and_extra(frequency, weights=None):
    """Scale a frequency by its weights.

    Parameters
    ----------
    frequency : float
        Angular frequency, rad/s.
    damping : float
        Not a parameter of this function.

    Returns
    -------
    float
        The scaled frequency, rad/s.
    """
    return frequency


def no_returns(frequency):
    """Scale a frequency.

    Parameters
    ----------
    frequency : float
        Angular frequency, rad/s.
    """
    return frequency


def untyped(frequency):
    """scale a frequency
    over two lines

    Parameters
    ----------
    frequency
    """


@dataclasses.dataclass(frozen=True)
class GoodRecord:
    """A record.

    Attributes
    ----------
    label : str
        Its name.
    value : float
        Its value, Hz.
    """

    label: str
    value: float


@dataclasses.dataclass(frozen=True)
class BadRecord:
    """A record.

    Attributes
    ----------
    label
        Its name, without a type.
    colour : str
        Not a field.
    """

    label: str
    value: float


class Colour(enum.Enum):
    """A colour.

    Attributes
    ----------
    RED
        The first one.
    """

    RED = "red"
    BLUE = "blue"


def _codes(obj) -> set[str]:
    return {error.split()[0] for error in docstring_errors(f"{__name__}.{obj.__qualname__}")}


def test_the_checker_passes_a_complete_docstring():
    assert _codes(good_function) == set()
    assert _codes(GoodRecord) == set()


def test_the_checker_finds_a_missing_and_an_unknown_parameter():
    assert {"PR01", "PR02"} <= _codes(missing_and_extra)


def test_the_checker_finds_a_missing_returns_section():
    assert "RT01" in _codes(no_returns)


def test_the_checker_finds_a_poor_summary_and_an_untyped_parameter():
    assert {"SS02", "SS03", "SS06", "PR04", "PR07"} <= _codes(untyped)


def test_the_checker_holds_a_dataclass_to_its_fields():
    errors = docstring_errors(f"{__name__}.BadRecord")
    assert any("does not name ['value']" in error for error in errors), errors
    assert any("['colour'], which are not fields" in error for error in errors), errors
    assert any("attribute 'label' has no type" in error for error in errors), errors


def test_the_checker_holds_an_enumeration_to_its_members():
    errors = docstring_errors(f"{__name__}.Colour")
    assert any("does not name ['BLUE']" in error for error in errors), errors
