"""The models of a case file: the ``[model]`` table (elements, a Python builder or matrix
files) built into an `AffineModel`, each configuration's lumped additions, and the linear
expressions of parameters that element properties and lumped values are written in
(``docs/case-file.md``). Errors name the file and the key (`vibupdate.io.case_keys`).
"""

from __future__ import annotations

import importlib
import importlib.util
import math
import re
import sys
from pathlib import Path

import numpy as np

from vibupdate.io.case_keys import ELEMENTS_KEYS, MATRICES_KEYS, Where, check_table
from vibupdate.model.affine import AffineModel, Lumped, affine_from_assembly, affine_from_builder, with_lumped
from vibupdate.model.assembly import Assembly
from vibupdate.model.build import from_files
from vibupdate.model.expressions import LinearExpression


# -- linear expressions of parameters ---------------------------------------------------------

_NUM = r"(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?"
_NAME = r"[A-Za-z_]\w*"
_TERM = re.compile(
    rf"\s*([+-])?\s*(?:(?P<c1>{_NUM})\s*\*\s*(?P<n1>{_NAME})|(?P<n2>{_NAME})\s*\*\s*(?P<c2>{_NUM})"
    rf"|(?P<n3>{_NAME})|(?P<c3>{_NUM}))\s*"
)


def linear_expression(text, names) -> LinearExpression:
    """Compile ``"2.13e-10*E + 3.6e-13*Ep + 0.01"`` into a `LinearExpression`.

    Terms are ``coefficient*name``, ``name*coefficient``, ``name`` or a number, joined by ``+``
    or ``-``; names must be parameter names. A plain number is a constant.
    """
    if isinstance(text, (int, float)) and not isinstance(text, bool):
        if not math.isfinite(text):
            raise ValueError(f"expected a finite number, got {text!r}")
        return LinearExpression(float(text), ())
    if not isinstance(text, str):
        raise ValueError(f"expected a number or an expression of parameters, got {text!r}")
    constant, coefficients, pos, s = 0.0, {}, 0, text.strip()
    while pos < len(s):
        m = _TERM.match(s, pos)
        if not m or m.end() == pos or (pos and not m.group(1)):
            raise ValueError(f"cannot read {text!r} as a linear expression of parameters near {s[pos:]!r}")
        sign = -1.0 if m.group(1) == "-" else 1.0
        name = m.group("n1") or m.group("n2") or m.group("n3")
        coef = m.group("c1") or m.group("c2") or m.group("c3")
        coef = sign * (float(coef) if coef else 1.0)
        if not math.isfinite(coef):
            raise ValueError(f"{text!r} has a coefficient that is not a finite number")
        if name is None:
            constant += coef
        elif name not in names:
            raise ValueError(f"{text!r} names {name!r}, which is not a parameter ({', '.join(names)})")
        else:
            coefficients[name] = coefficients.get(name, 0.0) + coef
        pos = m.end()
    if pos == 0:
        raise ValueError("empty expression")
    return LinearExpression(constant, tuple(coefficients.items()))


# -- models ---------------------------------------------------------------------------------------

#: Most nodes of an elements model.
MAX_NODES = 100_000


def _label(value, key: str, where: Where):
    """A node label: an integer or a string."""
    if isinstance(value, bool) or not isinstance(value, (int, str)):
        raise where.error(key, f"node labels are integers or strings, got {value!r}")
    return value


def _point(values, key: str, where: Where) -> list[float]:
    """Coordinates ``[x]`` or ``[x, y]``, m, finite."""
    if not isinstance(values, list) or len(values) not in (1, 2) or not all(
            isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v) for v in values):
        raise where.error(key, f"coordinates are [x] or [x, y] in finite numbers (m), got {values!r}")
    return [float(v) for v in values]


def element_nodes(spec: dict, where: Where) -> list[tuple]:
    """``(label, x, y)`` of every node of an elements model (``model.line`` then
    ``model.nodes``), coordinates in m."""
    nodes = []
    if "line" in spec:
        line = check_table(spec["line"], {"first": int, "last": int, "start": list, "end": list}, "model.line",
                           where, required=("first", "last", "start", "end"))
        labels = range(line["first"], line["last"] + 1)
        if not 2 <= len(labels) <= MAX_NODES:
            raise where.error("model.line", f"first..last must give 2 to {MAX_NODES} nodes, got {len(labels)}")
        start, end = (np.array(_point(line[k], f"model.line.{k}", where)) for k in ("start", "end"))
        if start.size != end.size:
            raise where.error("model.line", f"start and end must both be [x] or both [x, y], got {line['start']!r} "
                                            f"and {line['end']!r}")
        for k, label in enumerate(labels):
            xy = start + (end - start) * k / (len(labels) - 1)
            nodes.append((label, float(xy[0]), float(xy[1]) if xy.size > 1 else 0.0))
    for i, item in enumerate(spec.get("nodes", []), start=1):
        key = f"model.nodes[{i}]"
        if not isinstance(item, list) or len(item) not in (2, 3):
            raise where.error(key, f"each node is [label, x] or [label, x, y], got {item!r}")
        xy = _point(item[1:], key, where)
        nodes.append((_label(item[0], key, where), xy[0], xy[1] if len(xy) > 1 else 0.0))
    if not nodes:
        raise where.error("model", "needs nodes (model.nodes or model.line)")
    if len(nodes) > MAX_NODES:
        raise where.error("model.nodes", f"at most {MAX_NODES} nodes, got {len(nodes)}")
    return nodes


def _elements_assembly(spec: dict, names, where: Where) -> Assembly:
    """The elements model of ``spec`` (``type = "elements"``) as an `Assembly` whose
    properties and lumped values are `LinearExpression` s of the parameters ``names``.

    ``assembly.system(p)`` is the model at parameter values ``p``; `affine_from_assembly`
    assembles its affine form directly."""
    check_table(spec, ELEMENTS_KEYS, "model", where, required=("kind",))
    kind = spec["kind"]
    if kind not in ("beam", "frame"):
        raise where.error("model.kind", f"must be 'beam' or 'frame', got {kind!r}")
    nodes = element_nodes(spec, where)
    for support in ("clamp", "pin"):
        for i, label in enumerate(spec.get(support, []), start=1):
            _label(label, f"model.{support}[{i}]", where)
    for i, dof in enumerate(spec.get("fix", []), start=1):
        if not isinstance(dof, str):
            raise where.error(f"model.fix[{i}]", f"must be a DOF name (a string), got {dof!r}")

    def expr(value, key):
        try:
            return linear_expression(value, names)
        except ValueError as exc:
            raise where.error(key, str(exc)) from None

    elements = []
    for family, props in (("beam", ("EI", "mass_per_length")), ("frame", ("EA", "EI", "mass_per_length"))):
        for i, item in enumerate(spec.get(family, [])):
            key = f"model.{family}[{i + 1}]"
            check_table(item, {"nodes": list, "rotary_inertia": None, **{p: None for p in props}}, key, where,
                        required=("nodes", *props))
            chain = [_label(n, f"{key}.nodes", where) for n in item["nodes"]]
            if len(chain) < 2:
                raise where.error(f"{key}.nodes", "needs at least two nodes")
            compiled = {p: expr(item[p], f"{key}.{p}") for p in (*props, "rotary_inertia") if p in item}
            elements.append((family, chain, compiled))
    lumped = []
    for family in ("mass", "spring"):
        for i, item in enumerate(spec.get(family, [])):
            key = f"model.{family}[{i + 1}]"
            check_table(item, {"dof": str, "value": None, "other": str}, key, where, required=("dof", "value"))
            if family == "spring" and item.get("other") == item["dof"]:
                raise where.error(f"{key}.other", f"is the spring's own DOF {item['dof']!r}: a spring joins two "
                                                  "different DOFs (leave 'other' out for a spring to ground)")
            lumped.append((family, item["dof"], expr(item["value"], f"{key}.value"), item.get("other")))

    asm = Assembly(kind)
    labels, x, y = zip(*nodes)
    asm.nodes(labels, x, y)
    for family, chain, values in elements:
        getattr(asm, f"{family}s")(chain[:-1], chain[1:], **values)
    for family, dof, value, other in lumped:
        if family == "mass":
            asm.mass(dof, value)
        else:
            asm.spring(dof, value, other)
    for label in spec.get("clamp", []):
        asm.clamp(label)
    for label in spec.get("pin", []):
        asm.pin(label)
    for dof in spec.get("fix", []):
        asm.fix(dof)
    return asm


def load_callable(ref: str, base: Path, where: Where):
    """The function a ``model.builder`` entry names: ``module:function`` or ``file.py:function``
    (a file relative to ``base``, the case file's folder); a case-file error otherwise."""
    if not isinstance(ref, str) or ":" not in ref:
        raise where.error("model.builder", f"must be 'module:function' or 'file.py:function', got {ref!r}")
    target, func = ref.rsplit(":", 1)
    try:
        if target.endswith(".py"):
            file = (base / target).resolve()
            spec = importlib.util.spec_from_file_location(f"vibupdate_case_{file.stem}", file)
            if spec is None or not file.is_file():
                raise where.error("model.builder", f"file {str(file)!r} does not exist")
            module = importlib.util.module_from_spec(spec)
            sys.modules[spec.name] = module
            spec.loader.exec_module(module)
        else:
            module = importlib.import_module(target)
    except (ImportError, TypeError) as exc:   # TypeError: a relative name such as '..x'
        raise where.error("model.builder", f"cannot import {target!r}: {exc}") from None
    except SystemExit as exc:   # a module that ends the program when imported
        raise where.error("model.builder", f"importing {target!r} called sys.exit({exc.code!r}); a builder module "
                                           "must define its function without ending the program") from None
    except ValueError as exc:
        if str(exc).startswith(str(where.path)):
            raise
        raise where.error("model.builder", f"cannot import {target!r}: {exc}") from None
    if not callable(getattr(module, func, None)):
        raise where.error("model.builder", f"{target!r} has no function {func!r}")
    return getattr(module, func)


def base_model(spec: dict, options: dict, parameters, base: Path, where: Where) -> AffineModel:
    """The model of `spec` before any configuration's additions."""
    names = [p.name for p in parameters]
    kind = spec.get("type")
    try:
        if kind == "elements":
            return affine_from_assembly(_elements_assembly(spec, names, where), parameters)
        if kind == "builder":
            check_table(spec, {"type": str, "builder": str}, "model", where, required=("builder",))
            func = load_callable(spec["builder"], base, where)

            def build(p):
                try:
                    return func(p, **options)
                except SystemExit as exc:
                    raise ValueError(f"{spec['builder']} called sys.exit({exc.code!r}); a builder must return the "
                                     "model's matrices") from None
                except Exception as exc:  # the user's code: whatever it raises is bad input, named
                    hint = " (does the builder read a parameter the case does not define?)" \
                        if isinstance(exc, KeyError) else ""
                    raise ValueError(f"{spec['builder']} raised {type(exc).__name__}: {exc}{hint}") from None

            return affine_from_builder(build, parameters)
        if kind == "matrices":
            check_table(spec, MATRICES_KEYS, "model", where, required=("M0", "K0"))
            return from_files(base / spec["M0"], base / spec["K0"], parameters,
                              dM={n: base / f for n, f in spec.get("dM", {}).items()},
                              dK={n: base / f for n, f in spec.get("dK", {}).items()},
                              dofs=spec.get("dofs"), matrix_precision=matrix_precision(spec, where))
    except ValueError as exc:
        if str(exc).startswith(str(where.path)):
            raise
        raise where.error("model.builder" if kind == "builder" else "model", str(exc)) from None
    raise where.error("model.type", f"must be 'elements', 'builder', 'matrices' or 'element_matrices', got {kind!r}")


#: Coarsest ``matrix_precision`` accepted: matrices known to fewer than about 2 significant
#: digits cannot tell a rigid-body mode from a flexible one.
COARSEST_PRECISION = 1e-2


def matrix_precision(spec: dict, where: Where) -> float | None:
    """``matrix_precision`` of a ``[model]`` of matrices: the relative precision of the entries
    of the matrix files, a number in ``[eps, COARSEST_PRECISION)``; None (double precision) when
    the key is absent."""
    if "matrix_precision" not in spec:
        return None
    value = float(spec["matrix_precision"])
    eps = float(np.finfo(float).eps)
    if not eps <= value < COARSEST_PRECISION:
        raise where.error("model.matrix_precision",
                          f"must be a relative precision from {eps:.3g} (double precision) to below "
                          f"{COARSEST_PRECISION:g}, got {spec['matrix_precision']!r}")
    return value


def model_tag(options: dict) -> str:
    """The key of a case's model built with the builder ``options`` in the cache of models
    (`configuration_model`); an element-matrices model, built by `vibupdate.io.case.load_case`
    with its parameters' groups, is stored under ``model_tag({})``."""
    return repr(sorted(options.items()))


def configuration_model(spec: dict, cfg: dict, parameters, base: Path, where: Where, key: str,
                         models: dict) -> AffineModel:
    """The model of one configuration: the case's model (built once per set of builder options,
    kept in ``models``) plus the configuration's lumped masses. Every model type takes the same
    path for the masses (`vibupdate.model.affine.with_lumped`), so their parameter dependence is
    part of the affine form."""
    names = [p.name for p in parameters]
    options = cfg.get("options", {})
    if options and spec.get("type") != "builder":
        raise where.error(f"{key}.options", "builder options are only read by a model of type 'builder'")
    tag = model_tag(options)
    if tag not in models:
        models[tag] = base_model(spec, options, parameters, base, where)
    additions = []
    for i, item in enumerate(cfg.get("mass", [])):
        k = f"{key}.mass[{i + 1}]"
        check_table(item, {"dof": str, "value": None}, k, where, required=("dof", "value"))
        try:
            additions.append(Lumped("M", item["dof"], linear_expression(item["value"], names)))
        except ValueError as exc:
            raise where.error(f"{k}.value", str(exc)) from None
    try:
        return with_lumped(models[tag], additions)
    except ValueError as exc:
        raise where.error(f"{key}.mass", str(exc)) from None


def read_sensors(path: Path, dofs, where: Where) -> tuple[dict, ...]:
    """The measured points of an imported FE mesh (``[model] sensors``, written by
    `vibupdate import`): rows ``sensor, dof, sign, distance_m`` and optionally ``nx, ny, nz``
    (the unit direction the sensor reads, needed for an oblique DOF ``"<node>:n<k>"``), each
    DOF one of the model's. Each row gives a dict with those keys and ``direction`` (a list of
    3 floats; for a file without ``nx, ny, nz``, the signed axis of an x, y or z DOF; else None)."""
    from vibupdate.io.measured_io import csv_number, csv_rows

    known = set(dofs)
    out = []
    try:
        rows = csv_rows(path)
    except ValueError as exc:
        raise where.error("model.sensors", str(exc)) from None
    for line, row in rows:
        missing = [c for c in ("sensor", "dof", "sign", "distance_m") if c not in row]
        if missing:
            raise where.error("model.sensors", f"{path}: needs columns sensor, dof, sign, distance_m (and "
                                               f"optionally nx, ny, nz); missing {missing}")
        if row["dof"] not in known:
            raise where.error("model.sensors", f"{path}: row {line}: sensor {row['sensor']!r} measures "
                                               f"{row['dof']!r}, which is not a DOF of the model")
        try:
            sign = csv_number(row["sign"], "sign", path, line)
            if sign not in (1.0, -1.0):
                raise ValueError(f"{path}: row {line}: sign must be 1 or -1, got {row['sign']!r}")
            out.append({"sensor": row["sensor"], "dof": row["dof"], "sign": sign,
                        "distance_m": csv_number(row["distance_m"], "distance_m", path, line),
                        "direction": _sensor_direction(row, sign, path, line)})
        except ValueError as exc:
            raise where.error("model.sensors", str(exc)) from None
    return tuple(out)


def _sensor_direction(row: dict, sign: float, path: Path, line: int) -> list | None:
    """The unit direction of one row of a sensors file (`read_sensors`)."""
    from vibupdate.io.measured_io import csv_number
    from vibupdate.model.fe.oblique import AXES, OBLIQUE_DOF

    given = [row.get(k, "") for k in ("nx", "ny", "nz")]
    if any(given):
        n = np.array([csv_number(t, k, path, line) for t, k in zip(given, ("nx", "ny", "nz"))])
        if abs(np.linalg.norm(n) - 1) > 1e-6:
            raise ValueError(f"{path}: row {line}: nx, ny, nz must be a unit vector, got {n.tolist()} (length "
                             f"{np.linalg.norm(n):.6g})")
        return n.tolist()
    if OBLIQUE_DOF.match(row["dof"]):
        raise ValueError(f"{path}: row {line}: sensor {row['sensor']!r} reads the oblique DOF {row['dof']!r}: "
                         "its direction nx, ny, nz is needed")
    axis = row["dof"].rsplit(":", 1)[-1]
    return (sign * np.eye(3)[AXES.index(axis)]).tolist() if axis in AXES else None
