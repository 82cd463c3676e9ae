"""Case files (TOML): model, parameters, configurations, measured data and options.

The format is documented key by key in ``docs/case-file.md``. Paths are relative to the case
file. Every error names the key and the file. Reading a case validates everything that can
be checked without solving: the models are built, the data are attached to them.
"""

from __future__ import annotations

import importlib
import importlib.util
import json
import math
import re
import sys
import tomllib
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from types import SimpleNamespace

import numpy as np

from vibupdate.model.affine import AffineModel, Lumped, affine_from_builder, with_lumped
from vibupdate.model.assembly import Assembly
from vibupdate.inverse.formulation import FormulationOptions
from vibupdate.inverse.homotopy import SolverOptions
from vibupdate.inverse.polish import PolishOptions
from vibupdate.inverse.verify import VerifyOptions
from vibupdate.data.measured import Antiresonance, Configuration, NaturalFrequency, ShapeInterval
from vibupdate.io.measured_io import not_utf8, read_frequency_csv, read_shape_csv, read_uff_modes
from vibupdate.model.build import from_files
from vibupdate.model.parameters import Parameter

__all__ = ["Case", "DampingOptions", "LinearExpression", "load_case", "linear_expression"]


@dataclass(frozen=True)
class DampingOptions:
    """Second-stage options: Caughey exponents ``Y``, weights per mode number, and whether
    weights are relative (``W_ii = w_i / xi_i^2``, so the fit minimizes relative errors)."""

    exponents: tuple[float, ...] = (0.0, 1.0)
    mode_weights: tuple[tuple[int, float], ...] = ()
    relative: bool = False
    rationale: str = ""


@dataclass(frozen=True)
class Case:
    """A loaded case: everything a run needs."""

    name: str
    path: Path | None
    configurations: tuple[Configuration, ...]
    solver: SolverOptions
    formulation: FormulationOptions
    damping: DampingOptions | None
    frequency_tolerance: float = 0.0
    polish: PolishOptions = field(default_factory=PolishOptions)
    verification: VerifyOptions = field(default_factory=VerifyOptions)
    frfs: Mapping = field(default_factory=dict)
    """Per configuration whose data came from FRF files (``[configuration.frf]``), the
    measured receptances in the extraction band (`vibupdate.data.frf.FRFSet`): the report overlays
    them on the model FRFs."""


class _Where:
    """Error messages that name the file and the key."""

    def __init__(self, path: Path):
        self.path = path

    def error(self, key: str, message: str) -> ValueError:
        return ValueError(f"{self.path}: {key}: {message}")


_TYPE_NAMES = {str: "a string", bool: "true or false", int: "an integer", float: "a number",
               list: "an array", dict: "a table"}


def _has_type(value, expected) -> bool:
    """TOML types: an integer is a valid number; true/false is never a number."""
    if expected in (int, float):
        accepted = int if expected is int else (int, float)
        return isinstance(value, accepted) and not isinstance(value, bool)
    return isinstance(value, expected)


def _join(key: str, name: str) -> str:
    """``key.name``, with ``name`` quoted as TOML quotes it when it is not a bare key."""
    shown = name if re.fullmatch(r"[A-Za-z0-9_-]+", name) else json.dumps(name, ensure_ascii=False)
    return f"{key}.{shown}" if key else shown


def _check_table(table, allowed: dict, key: str, where: _Where, required=()) -> dict:
    if not isinstance(table, dict):
        raise where.error(key, f"must be a table, got {type(table).__name__}")
    for name in table:
        if name not in allowed:
            raise where.error(_join(key, name), f"unknown key; allowed here: {', '.join(sorted(allowed))}")
    for name in required:
        if name not in table:
            raise where.error(_join(key, name), "is required")
    for name, value in table.items():
        expected = allowed[name]
        if expected is None:
            continue
        if not _has_type(value, expected):
            raise where.error(_join(key, name), f"must be {_TYPE_NAMES.get(expected, expected)}, got {value!r}")
    return table


# -- linear expressions of parameters ---------------------------------------------------------

_NUM = r"(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?"
_NAME = r"[A-Za-z_]\w*"
_TERM = re.compile(
    rf"\s*([+-])?\s*(?:(?P<c1>{_NUM})\s*\*\s*(?P<n1>{_NAME})|(?P<n2>{_NAME})\s*\*\s*(?P<c2>{_NUM})"
    rf"|(?P<n3>{_NAME})|(?P<c3>{_NUM}))\s*"
)


@dataclass(frozen=True)
class LinearExpression:
    """``constant + sum_i coefficient_i * p[name_i]``: a value affine in the parameters.

    Calling it with a mapping of parameter values (real or complex, for the complex step of
    Eq. 15) gives the value; `coefficients` are the exact derivatives ``d value / d p_i`` in
    physical units.
    """

    constant: float
    coefficients: tuple[tuple[str, float], ...]

    def __call__(self, p):
        return self.constant + sum(c * p[n] for n, c in self.coefficients)


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

_ELEMENTS_KEYS = {"type": str, "kind": str, "nodes": list, "line": dict, "clamp": list, "pin": list,
                  "fix": list, "beam": list, "frame": list, "mass": list, "spring": list}


#: Most nodes of an elements model.
MAX_NODES = 100_000


def _label(value, key: str, where: _Where):
    """A node label: an integer or a string."""
    if isinstance(value, bool) or not isinstance(value, (int, str)):
        raise where.error(key, f"node labels are integers or strings, got {value!r}")
    return value


def _point(values, key: str, where: _Where) -> list[float]:
    """Coordinates ``[x]`` or ``[x, y]``, m, finite."""
    if not isinstance(values, list) or len(values) not in (1, 2) or not all(
            isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v) for v in values):
        raise where.error(key, f"coordinates are [x] or [x, y] in finite numbers (m), got {values!r}")
    return [float(v) for v in values]


def _elements_builder(spec: dict, names, where: _Where):
    _check_table(spec, _ELEMENTS_KEYS, "model", where, required=("kind",))
    kind = spec["kind"]
    if kind not in ("beam", "frame"):
        raise where.error("model.kind", f"must be 'beam' or 'frame', got {kind!r}")
    nodes = []
    if "line" in spec:
        line = _check_table(spec["line"], {"first": int, "last": int, "start": list, "end": list}, "model.line",
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
            _check_table(item, {"nodes": list, **{p: None for p in props}}, key, where, required=("nodes", *props))
            chain = [_label(n, f"{key}.nodes", where) for n in item["nodes"]]
            if len(chain) < 2:
                raise where.error(f"{key}.nodes", "needs at least two nodes")
            compiled = {p: expr(item[p], f"{key}.{p}") for p in props}
            elements.append((family, chain, compiled))
    lumped = []
    for family in ("mass", "spring"):
        for i, item in enumerate(spec.get(family, [])):
            key = f"model.{family}[{i + 1}]"
            _check_table(item, {"dof": str, "value": None, "other": str}, key, where, required=("dof", "value"))
            lumped.append((family, item["dof"], expr(item["value"], f"{key}.value"), item.get("other")))
    supports = {s: spec.get(s, []) for s in ("clamp", "pin", "fix")}

    def build(p):
        asm = Assembly(kind)
        for label, x, y in nodes:
            asm.node(label, x, y)
        for family, chain, c in elements:
            values = {name: f(p) for name, f in c.items()}
            for a, b in zip(chain, chain[1:]):
                getattr(asm, family)(a, b, **values)
        for family, dof, f, other in lumped:
            if family == "mass":
                asm.mass(dof, f(p))
            else:
                asm.spring(dof, f(p), other)
        for label in supports["clamp"]:
            asm.clamp(label)
        for label in supports["pin"]:
            asm.pin(label)
        for dof in supports["fix"]:
            asm.fix(dof)
        return asm.system()

    return build


def _load_callable(ref: str, base: Path, where: _Where):
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
    except ValueError as exc:
        if str(exc).startswith(str(where.path)):
            raise
        raise where.error("model.builder", f"cannot import {target!r}: {exc}") from None
    if not callable(getattr(module, func, None)):
        raise where.error("model.builder", f"{target!r} has no function {func!r}")
    return getattr(module, func)


def _base_model(spec: dict, options: dict, parameters, base: Path, where: _Where) -> AffineModel:
    """The model of `spec` before any configuration's additions."""
    names = [p.name for p in parameters]
    kind = spec.get("type")
    try:
        if kind == "elements":
            return affine_from_builder(_elements_builder(spec, names, where), parameters)
        if kind == "builder":
            _check_table(spec, {"type": str, "builder": str}, "model", where, required=("builder",))
            func = _load_callable(spec["builder"], base, where)

            def build(p):
                try:
                    return func(p, **options)
                except Exception as exc:  # the user's code: whatever it raises is bad input, named
                    hint = " (does the builder read a parameter the case does not define?)" \
                        if isinstance(exc, KeyError) else ""
                    raise ValueError(f"{spec['builder']} raised {type(exc).__name__}: {exc}{hint}") from None

            return affine_from_builder(build, parameters)
        if kind == "matrices":
            _check_table(spec, {"type": str, "M0": str, "K0": str, "dofs": list, "dM": dict, "dK": dict},
                         "model", where, required=("M0", "K0"))
            return from_files(base / spec["M0"], base / spec["K0"], parameters,
                              dM={n: base / f for n, f in spec.get("dM", {}).items()},
                              dK={n: base / f for n, f in spec.get("dK", {}).items()},
                              dofs=spec.get("dofs"))
    except ValueError as exc:
        if str(exc).startswith(str(where.path)):
            raise
        raise where.error("model.builder" if kind == "builder" else "model", str(exc)) from None
    raise where.error("model.type", f"must be 'elements', 'builder' or 'matrices', got {kind!r}")


def _configuration_model(spec: dict, cfg: dict, parameters, base: Path, where: _Where, key: str,
                         models: dict) -> AffineModel:
    """The model of one configuration: the case's model (built once per set of builder options,
    kept in ``models``) plus the configuration's lumped masses. Every model type takes the same
    path for the masses (`vibupdate.model.affine.with_lumped`), so their parameter dependence is
    part of the affine form."""
    names = [p.name for p in parameters]
    options = cfg.get("options", {})
    if options and spec.get("type") != "builder":
        raise where.error(f"{key}.options", "builder options are only read by a model of type 'builder'")
    tag = repr(sorted(options.items()))
    if tag not in models:
        models[tag] = _base_model(spec, options, parameters, base, where)
    additions = []
    for i, item in enumerate(cfg.get("mass", [])):
        k = f"{key}.mass[{i + 1}]"
        _check_table(item, {"dof": str, "value": None}, k, where, required=("dof", "value"))
        try:
            additions.append(Lumped("M", item["dof"], linear_expression(item["value"], names)))
        except ValueError as exc:
            raise where.error(f"{k}.value", str(exc)) from None
    try:
        return with_lumped(models[tag], additions)
    except ValueError as exc:
        raise where.error(f"{key}.mass", str(exc)) from None


# -- measured data ------------------------------------------------------------------------------

_CFG_KEYS = {"name": str, "natural_hz": list, "natural_weights": list, "natural_modes": list, "damping_ratios": list,
             "antiresonances": list, "frequencies_csv": str, "mode_shapes_csv": str, "mode_shapes_uff": str,
             "uff_tolerance": float, "interlacing": bool, "first_sign": list, "options": dict, "mass": list,
             "frf": dict}
_FRF_KEYS = {"files": list, "responses": list, "excitations": list, "kind": str, "g": bool, "re_im": bool,
             "map": dict, "band_hz": list, "modes": int, "first_mode": int, "confidence": float}


def _frf_data(spec: dict, base: Path, where: _Where, key: str):
    """Measured data extracted from FRF files (``[configuration.frf]``, docs/frf-extraction.md):
    natural-frequency and antiresonance dicts as the other sources give, plus intervals (Hz),
    mode and zero numbers, shape intervals ``{mode: {dof: (lo, hi)}}`` and the measured FRFs
    in the extraction band (`vibupdate.data.frf.FRFSet`)."""
    from vibupdate.data.extraction import extract
    from vibupdate.data.frf import read_frfs

    _check_table(spec, _FRF_KEYS, f"{key}.frf", where, required=("files",))
    band = spec.get("band_hz")
    if band is not None:
        band = tuple(2 * math.pi * b for b in _numbers(band, f"{key}.frf.band_hz", where))
    try:
        frfs = read_frfs([base / f for f in spec["files"]], spec.get("responses"), spec.get("excitations"),
                         spec.get("kind"), spec.get("g", False), spec.get("re_im", False), spec.get("map"))
        result = extract(frfs, band=band, n_modes=spec.get("modes"), confidence=spec.get("confidence", 0.95))
    except ValueError as exc:
        raise where.error(f"{key}.frf", str(exc)) from None
    first = spec.get("first_mode", 1)
    to_hz = 1.0 / (2 * math.pi)
    natural = [{"hz": m.omega * to_hz, "weight": 1.0, "damping_ratio": m.damping_ratio, "mode": first + k,
                "interval": tuple(v * to_hz for v in m.omega_interval), "damping_interval": m.damping_interval}
               for k, m in enumerate(result.modes)]
    zeros = [{"hz": z.omega * to_hz, "weight": 1.0, "response": z.response, "excitation": z.excitation,
              "index": z.index if first == 1 else None, "interval": tuple(v * to_hz for v in z.interval)}
             for z in result.zeros]
    shapes = {first + k: dict(m.shape_interval) for k, m in enumerate(result.modes)}
    return natural, zeros, shapes, frfs.band(*result.band)


def _numbers(values, key, where) -> list[float]:
    out = []
    for v in values:
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
            raise where.error(key, f"must be an array of numbers, got {v!r}")
        out.append(float(v))
    return out


def _configuration(cfg: dict, index: int, spec: dict, parameters, base: Path, where: _Where,
                   models: dict):
    """The configuration of one ``[[configuration]]`` table, and its measured FRFs (or None)."""
    key = f"configuration[{index}]"
    _check_table(cfg, _CFG_KEYS, key, where, required=("name",))
    key = f"configuration '{cfg['name']}'"
    if not 0 <= cfg.get("uff_tolerance", 0.05) < math.inf:
        raise where.error(f"{key}.uff_tolerance", f"must be a finite number >= 0, got {cfg['uff_tolerance']!r}")
    model = _configuration_model(spec, cfg, parameters, base, where, key, models)
    natural, zeros, shapes, frfs = [], [], {}, None
    if "frf" in cfg:
        mixed = [k for k in ("natural_hz", "antiresonances", "frequencies_csv", "mode_shapes_csv", "mode_shapes_uff")
                 if k in cfg]
        if mixed:
            raise where.error(f"{key}.frf", f"FRF files take the place of typed data; remove {', '.join(mixed)}")
        natural, zeros, shapes, frfs = _frf_data(cfg["frf"], base, where, key)
    try:
        if "frequencies_csv" in cfg:
            natural, zeros = read_frequency_csv(base / cfg["frequencies_csv"])
        if "mode_shapes_csv" in cfg:
            shapes = read_shape_csv(base / cfg["mode_shapes_csv"])
        if "mode_shapes_uff" in cfg:
            tol = float(cfg.get("uff_tolerance", 0.05))
            uff = read_uff_modes(base / cfg["mode_shapes_uff"])
            for k, mode in enumerate(uff, start=1):
                known = {d: v for d, v in mode["values"].items() if d in model.dofs}
                if not known:
                    raise ValueError(f"mode {k} of the UFF file has no DOF of the model")
                scale = tol * max(abs(v) for v in known.values())
                shapes[k] = {d: (v - scale, v + scale) for d, v in known.items()}
            if "natural_hz" not in cfg and "frequencies_csv" not in cfg:
                natural = [{"hz": m["hz"], "weight": 1.0, "damping_ratio": m["damping_ratio"]} for m in uff]
    except ValueError as exc:
        if str(exc).startswith(str(where.path)):
            raise
        raise where.error(key, str(exc)) from None
    if "natural_hz" in cfg:
        hz = _numbers(cfg["natural_hz"], f"{key}.natural_hz", where)
        weights = _numbers(cfg.get("natural_weights", [1.0] * len(hz)), f"{key}.natural_weights", where)
        ratios = cfg.get("damping_ratios")
        if len(weights) != len(hz):
            raise where.error(f"{key}.natural_weights", f"needs {len(hz)} entries, got {len(weights)}")
        if ratios is not None:
            ratios = _numbers(ratios, f"{key}.damping_ratios", where)
            if len(ratios) != len(hz):
                raise where.error(f"{key}.damping_ratios", f"needs {len(hz)} entries, got {len(ratios)}")
        modes = cfg.get("natural_modes")
        if modes is not None:
            if len(modes) != len(hz) or any(isinstance(m, bool) or not isinstance(m, int) or m < 1 for m in modes):
                raise where.error(f"{key}.natural_modes",
                                  f"needs {len(hz)} integers >= 1 (the model mode of each frequency), got {modes!r}")
        natural = [{"hz": h, "weight": w, "damping_ratio": None if ratios is None else ratios[i],
                    "mode": None if modes is None else modes[i]}
                   for i, (h, w) in enumerate(zip(hz, weights))]
    for i, item in enumerate(cfg.get("antiresonances", [])):
        k = f"{key}.antiresonances[{i + 1}]"
        _check_table(item, {"hz": float, "response": str, "excitation": str, "weight": float, "index": int}, k,
                     where, required=("hz", "response", "excitation"))
        if "index" in item and item["index"] < 1:
            raise where.error(f"{k}.index", f"must be an integer >= 1 (which zero of the receptance), got {item['index']!r}")
        zeros.append({"weight": 1.0, **item})
    from vibupdate.data.measured import declared_modes

    declared = declared_modes([SimpleNamespace(mode=f.get("mode")) for f in natural])  # reads only .mode
    for mode in shapes:
        if mode not in declared:
            raise where.error(key, f"a mode shape is given for mode {mode}, but the measured natural frequencies "
                                   f"are modes {declared}")
    first_sign = {}
    for i, item in enumerate(cfg.get("first_sign", [])):
        k = f"{key}.first_sign[{i + 1}]"
        _check_table(item, {"response": str, "excitation": str, "sign": int}, k, where,
                     required=("response", "excitation", "sign"))
        first_sign[(item["response"], item["excitation"])] = item["sign"]
    try:
        def rad(pair):  # optional intervals (extracted from FRFs), Hz -> rad/s
            return None if pair is None else tuple(2 * math.pi * v for v in pair)

        nat = tuple(
            NaturalFrequency.from_hz(f["hz"], weight=f["weight"], damping_ratio=f["damping_ratio"],
                                     shape=ShapeInterval(shapes[declared[k]]) if declared[k] in shapes else None,
                                     mode=f.get("mode"), interval=rad(f.get("interval")),
                                     damping_interval=f.get("damping_interval"))
            for k, f in enumerate(natural))
        zs = tuple(Antiresonance.from_hz(z["hz"], z["response"], z["excitation"], weight=z["weight"],
                                         index=z.get("index"), interval=rad(z.get("interval"))) for z in zeros)
        return Configuration(cfg["name"], model, nat, zs, interlacing=cfg.get("interlacing", True),
                             first_sign=first_sign), frfs
    except ValueError as exc:
        raise where.error(key, str(exc)) from None


# -- the whole file -----------------------------------------------------------------------------

_TOP_KEYS = {"case": str, "model": dict, "parameter": list, "configuration": list, "solver": dict,
             "formulation": dict, "damping": dict, "frequency_tolerance": float, "polish": dict,
             "verification": dict}
_POLISH_KEYS = {"enabled": bool, "shape_weight": float, "max_evaluations": int, "tol": float}
_VERIFICATION_KEYS = {"mac_min": float, "shape_slack": float, "fit_tolerance": float}
_SOLVER_KEYS = {"n_lambda": int, "step_growth": float, "min_step": float, "proximal": float, "max_iter": int, "max_cpu_time": float,
                "tol": float}
_FORMULATION_KEYS = {"shape_margin": float, "adjunct_margin": float, "sign_delta": float, "length_scale": float,
                     "weighting": str, "interlacing": bool, "reduction": str, "reduction_modes": int,
                     "reduction_threshold": int}
_DAMPING_KEYS = {"exponents": list, "mode_weights": dict, "relative": bool, "rationale": str}
_PARAMETER_KEYS = {"name": str, "unit": str, "nominal": float, "lower": float, "upper": float, "reference": float}


def _options(cls, table: dict, allowed: dict, key: str, where: _Where):
    _check_table(table, allowed, key, where)
    try:
        return cls(**table)
    except ValueError as exc:
        raise where.error(key, str(exc)) from None


def _damping(table: dict, where: _Where) -> DampingOptions:
    _check_table(table, _DAMPING_KEYS, "damping", where, required=("exponents",))
    exponents = tuple(_numbers(table["exponents"], "damping.exponents", where))
    weights = []
    for mode, w in table.get("mode_weights", {}).items():
        if not mode.isdigit() or int(mode) < 1:
            raise where.error(f"damping.mode_weights.{mode}", "keys are mode numbers (\"1\", \"2\", ...)")
        if isinstance(w, bool) or not isinstance(w, (int, float)) or not w > 0:
            raise where.error(f"damping.mode_weights.{mode}", f"must be a positive number, got {w!r}")
        weights.append((int(mode), float(w)))
    return DampingOptions(exponents, tuple(weights), table.get("relative", False), table.get("rationale", ""))


def load_case(path) -> Case:
    """Read and validate a case file; raises ValueError naming the file and the key."""
    path = Path(path)
    where = _Where(path)
    try:
        data = tomllib.loads(path.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise ValueError(f"case file {str(path)!r} does not exist") from None
    except UnicodeDecodeError as exc:
        raise ValueError(f"{path}: {not_utf8(path.read_bytes(), exc)}") from None
    except OSError as exc:
        raise ValueError(f"case file {str(path)!r} could not be read: {exc}") from None
    except tomllib.TOMLDecodeError as exc:
        raise ValueError(f"{path}: not valid TOML: {exc}") from None
    _check_table(data, _TOP_KEYS, "", where, required=("model", "parameter", "configuration"))
    parameters = []
    for i, item in enumerate(data["parameter"], start=1):
        key = f"parameter[{i}]"
        _check_table(item, _PARAMETER_KEYS, key, where, required=("name", "nominal", "lower", "upper"))
        try:
            parameters.append(Parameter(item["name"], item["nominal"], item["lower"], item["upper"],
                                        unit=item.get("unit", ""), reference=item.get("reference")))
        except ValueError as exc:
            raise where.error(key, str(exc)) from None
    base = path.parent
    models: dict = {}
    loaded = [_configuration(cfg, i, data["model"], parameters, base, where, models)
              for i, cfg in enumerate(data["configuration"], start=1)]
    configurations = tuple(c for c, _ in loaded)
    return Case(
        name=data.get("case", path.stem),
        path=path,
        configurations=configurations,
        solver=_options(SolverOptions, data.get("solver", {}), _SOLVER_KEYS, "solver", where),
        formulation=_options(FormulationOptions, data.get("formulation", {}), _FORMULATION_KEYS, "formulation", where),
        damping=_damping(data["damping"], where) if "damping" in data else None,
        frequency_tolerance=float(data.get("frequency_tolerance", 0.0)),
        polish=_options(PolishOptions, data.get("polish", {}), _POLISH_KEYS, "polish", where),
        verification=_options(VerifyOptions, data.get("verification", {}), _VERIFICATION_KEYS, "verification", where),
        frfs={c.name: f for c, f in loaded if f is not None},
    )
