"""The ``[model]`` of a case file given element by element (``type = "element_matrices"``):
the element matrices, their groups, the ``[[parameter]]`` tables that scale groups (``elements``,
``scales``, ``each_group``), and the affine model they make (`vibupdate.model.element_groups`).
Errors name the file and the key (``docs/case-file.md``).
"""

from __future__ import annotations

import fnmatch
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from vibupdate.io.case_keys import ELEMENT_MATRICES_KEYS, Where, check_table
from vibupdate.model.affine import AffineModel
from vibupdate.model.element_groups import ElementMatrices, ElementScaling, affine_from_elements, element_matrices


#: The keys a ``[[parameter]]`` or ``[[candidate]]`` table may add in an element-matrices model.
GROUP_KEYS = ("elements", "scales", "each_group")


@dataclass(frozen=True)
class ElementSource:
    """The elements of a case's model and its named groups of elements.

    Attributes
    ----------
    elements : ElementMatrices
        Every element at the nominal parameters, before the supports are removed.
    groups : dict of str to tuple
        Group name -> element labels, in the order the groups were defined.
    fixed : tuple of str
        DOF names the supports remove (``fix``, and every DOF of a ``clamp`` node).
    """

    elements: ElementMatrices
    groups: dict
    fixed: tuple[str, ...]


def _label(text: str):
    """An element label read from a CSV cell: an integer when it is one, else the text."""
    try:
        return int(text)
    except ValueError:
        return text


def _element_table(path: Path) -> tuple[list, dict]:
    """Elements and groups of an element table (CSV): columns ``element``, ``K`` and optionally
    ``M``, ``dofs`` (DOF names separated by spaces), ``group``. ``K`` and ``M`` name ``.mtx`` or
    ``.npz`` files relative to the table; an ``.npz`` with arrays ``K`` (and ``M``, ``dofs``)
    holds the element's matrices and its DOF map itself."""
    from vibupdate.io.measured_io import csv_rows
    from vibupdate.model.build import load_matrix

    rows = csv_rows(path)
    if not rows:
        raise ValueError(f"{path}: the element table lists no element")
    missing = [c for c in ("element", "K") if c not in rows[0][1]]
    if missing:
        raise ValueError(f"{path}: an element table needs columns element, K (and optionally M, dofs, group); "
                         f"missing {', '.join(missing)}")
    elements, groups = [], {}
    for line, row in rows:
        label = _label(row["element"])
        K, M, dofs = _element_files(path.parent / row["K"], row.get("M"), path, line, load_matrix)
        if row.get("dofs"):
            dofs = row["dofs"].split()
        if dofs is None:
            raise ValueError(f"{path}: row {line}: element {label!r} needs its DOF names (column dofs, or an array "
                             f"'dofs' in {row['K']!r})")
        elements.append((label, [str(d) for d in dofs], K, M))
        if row.get("group"):
            groups.setdefault(row["group"], []).append(label)
    return elements, groups


def _element_files(file: Path, mass: str | None, table: Path, line: int, load_matrix):
    """``(K, M or None, dofs or None)`` of one row of an element table."""
    if not file.is_file():
        raise ValueError(f"{table}: row {line}: element file {str(file)!r} does not exist")
    K = M = dofs = None
    if file.suffix.lower() == ".npz":
        with np.load(file, allow_pickle=False) as data:
            if "K" in data.files:
                K = np.asarray(data["K"], dtype=float)
                M = np.asarray(data["M"], dtype=float) if "M" in data.files else None
                dofs = [str(d) for d in data["dofs"]] if "dofs" in data.files else None
    if K is None:
        K = load_matrix(file).toarray()
    if mass:
        M = load_matrix(table.parent / mass).toarray()
    return K, M, dofs


def read_element_source(spec: dict, base: Path, where: Where) -> ElementSource:
    """The elements, groups and supports of a ``[model]`` of ``type = "element_matrices"``."""
    from vibupdate.model.fe.abaqus_elements import read_abaqus_elements

    check_table(spec, ELEMENT_MATRICES_KEYS, "model", where, required=("elements",))
    files = spec["elements"] if isinstance(spec["elements"], list) else [spec["elements"]]
    if not files or not all(isinstance(f, str) for f in files):
        raise where.error("model.elements", f"must be a file name or an array of file names, got {spec['elements']!r}")
    tables = [f for f in files if f.lower().endswith(".csv")]
    groups: dict = {}
    try:
        if tables:
            if len(files) > 1:
                raise ValueError(f"an element table ({tables[0]}) is the only file of 'elements'; got {files}")
            listed, groups = _element_table(base / tables[0])
            elements = element_matrices(listed, source=str(base / tables[0]))
        else:
            elements = read_abaqus_elements([base / f for f in files])
    except ValueError as exc:
        raise where.error("model.elements", str(exc)) from None
    for name, labels in _groups(spec.get("groups", {}), base, where).items():
        groups.setdefault(name, []).extend(labels)
    fixed = []
    for i, dof in enumerate(spec.get("fix", []), start=1):
        if not isinstance(dof, str) or dof not in elements.dofs:
            raise where.error(f"model.fix[{i}]", f"must be a DOF of the elements (\"<node>:<dir>\"), got {dof!r}")
        fixed.append(dof)
    for i, node in enumerate(spec.get("clamp", []), start=1):
        prefix = f"{node}:"
        held = [d for d in elements.dofs if d.startswith(prefix)]
        if isinstance(node, bool) or not isinstance(node, (int, str)) or not held:
            raise where.error(f"model.clamp[{i}]", f"must be a node of the elements, got {node!r}")
        fixed += [d for d in held if d not in fixed]
    return ElementSource(elements, {k: tuple(v) for k, v in groups.items()}, tuple(fixed))


def _groups(value, base: Path, where: Where) -> dict:
    """``[model] groups``: a table of group name -> element labels, a CSV file with columns
    ``element``, ``group``, or an Abaqus input file (``.inp``) whose element sets are the groups."""
    from vibupdate.io.measured_io import csv_rows

    if isinstance(value, str) and value.lower().endswith(".inp"):
        from vibupdate.model.fe.abaqus_elements import read_abaqus_element_sets

        try:
            return read_abaqus_element_sets(base / value)
        except ValueError as exc:
            raise where.error("model.groups", str(exc)) from None
    if isinstance(value, str):
        path = base / value
        try:
            rows = csv_rows(path)
        except ValueError as exc:
            raise where.error("model.groups", str(exc)) from None
        if not rows:
            raise where.error("model.groups", f"{path}: lists no element")
        if any(c not in rows[0][1] for c in ("element", "group")):
            raise where.error("model.groups", f"{path}: needs columns element, group; has {list(rows[0][1])}")
        out: dict = {}
        for _, row in rows:
            out.setdefault(row["group"], []).append(_label(row["element"]))
        return out
    if not isinstance(value, dict):
        raise where.error("model.groups", f"must be a table (group = [elements]) or a CSV file name, got {value!r}")
    for name, labels in value.items():
        if not isinstance(labels, list) or not labels or any(isinstance(e, bool) or not isinstance(e, (int, str))
                                                             for e in labels):
            raise where.error(f"model.groups.{name}", f"must be an array of element labels, got {labels!r}")
    return {name: list(labels) for name, labels in value.items()}


def expand_group_parameters(items, table: str, source: ElementSource | None, where: Where):
    """The ``[[parameter]]`` (or ``[[candidate]]``) tables with each ``each_group`` table made
    one table per group it matches: ``each_group`` is a group name pattern (``*``, ``?``,
    ``[...]`` as in file names) or an array of them, ``name`` holds ``{group}``, and each
    table scales its group (``elements = [group]``). Tables without it are kept as they are."""
    if not isinstance(items, list):
        return items
    out = []
    for i, item in enumerate(items, start=1):
        key = f"{table}[{i}]"
        used = [k for k in GROUP_KEYS if isinstance(item, dict) and k in item]
        if used and source is None:
            raise where.error(f"{key}.{used[0]}", "element groups are read by a model of type 'element_matrices'")
        if not isinstance(item, dict) or "each_group" not in item:
            out.append(item)
            continue
        if "elements" in item:
            raise where.error(f"{key}.each_group", "give either each_group (one parameter per group) or elements")
        patterns = item["each_group"] if isinstance(item["each_group"], list) else [item["each_group"]]
        if not patterns or not all(isinstance(p, str) for p in patterns):
            raise where.error(f"{key}.each_group", f"must be a group name pattern or an array of them, got "
                                                   f"{item['each_group']!r}")
        name = item.get("name")
        if not isinstance(name, str) or "{group}" not in name:
            raise where.error(f"{key}.name", f"must hold {{group}}, replaced by each group's name, got {name!r}")
        matched = []
        for pattern in patterns:
            found = [g for g in source.groups if fnmatch.fnmatchcase(g, pattern)]
            if not found:
                raise where.error(f"{key}.each_group", f"{pattern!r} matches no group (groups: "
                                                       f"{', '.join(source.groups) or 'none'})")
            matched += [g for g in found if g not in matched]
        rest = {k: v for k, v in item.items() if k != "each_group"}
        out += [{**rest, "name": name.replace("{group}", g), "elements": g} for g in matched]
    return out


def _scaling(item: dict, key: str, source: ElementSource, where: Where) -> ElementScaling:
    """The elements one parameter table scales (``elements``: a group name, or an array of
    element labels and group names) and which matrix (``scales``)."""
    given = item["elements"] if isinstance(item["elements"], list) else [item["elements"]]
    labels = set(source.elements.labels)
    chosen = []
    for entry in given:
        if isinstance(entry, str) and entry in source.groups:
            chosen += source.groups[entry]
        elif not isinstance(entry, bool) and isinstance(entry, (int, str)) and entry in labels:
            chosen.append(entry)
        else:
            raise where.error(f"{key}.elements", f"{entry!r} is neither a group ({', '.join(source.groups) or 'none'}) "
                                                 f"nor an element of {source.elements.source}")
    scales = item.get("scales", "K")
    if scales not in ("K", "M"):
        raise where.error(f"{key}.scales", f"must be 'K' (stiffness) or 'M' (mass), got {scales!r}")
    return ElementScaling(tuple(dict.fromkeys(chosen)), scales)


def element_model(source: ElementSource, items: list, parameters, where: Where) -> AffineModel:
    """The affine model of an element-matrices ``[model]``: ``items`` are the parameter and
    candidate tables (expanded, `expand_group_parameters`), in the order of ``parameters``."""
    scaling = {}
    for item, p in zip(items, parameters):
        if "elements" in item:
            scaling[p.name] = _scaling(item, f"parameter '{p.name}'", source, where)
        elif "scales" in item:
            raise where.error(f"parameter '{p.name}'.scales", "says which matrix of its elements a parameter scales: "
                                                             "give the elements (elements = [...] or a group name)")
    try:
        return affine_from_elements(source.elements, parameters, scaling, fixed=source.fixed)
    except ValueError as exc:
        raise where.error("model", str(exc)) from None
