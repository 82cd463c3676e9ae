"""Case files (TOML): model, parameters, configurations, measured data and options.

The format is documented key by key in ``docs/case-file.md``. Paths are relative to the case
file. Every error names the key and the file. Reading a case validates everything that can
be checked without solving: the models are built, the data are attached to them.

Four modules: this one reads the file (parameters, configurations and their measured data,
options) into a `Case`; `vibupdate.io.case_types` defines `Case` and `DampingOptions` (both
importable from here too); `vibupdate.io.case_keys` holds the schema (allowed keys and types) and
the checks that name file and key; `vibupdate.io.case_model` builds the models and compiles the
linear expressions of parameters (`vibupdate.io.case_model.LinearExpression`).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import replace
from pathlib import Path
from types import SimpleNamespace

from vibupdate.inverse.formulation.options import FormulationOptions
from vibupdate.inverse.homotopy import SolverOptions
from vibupdate.inverse.polish import PolishOptions
from vibupdate.inverse.verify import VerifyOptions
from vibupdate.data.measured import Antiresonance, Configuration, NaturalFrequency, ShapeInterval
from vibupdate.io.measured_io import not_utf8, read_frequency_csv, read_shape_csv, read_uff_modes
from vibupdate.io.case_keys import (
    CFG_KEYS,
    DAMPING_KEYS,
    FORMULATION_KEYS,
    FRF_KEYS,
    PARAMETER_KEYS,
    POLISH_KEYS,
    SOLVER_KEYS,
    TOP_KEYS,
    VERIFICATION_KEYS,
    Where,
    check_table,
    numbers,
)
from vibupdate.io.case_model import configuration_model
from vibupdate.io.case_types import Case, DampingOptions
from vibupdate.io.case_sensors import case_sensors
from vibupdate.model.parameters import Parameter
from vibupdate.options import problem as option_problem


# -- measured data ------------------------------------------------------------------------------

def _frf_data(spec: dict, base: Path, where: Where, key: str, mass_normalized: bool = False, model=None):
    """Measured data extracted from FRF files (``[configuration.frf]``, docs/frf-extraction.md):
    natural-frequency and antiresonance dicts as the other sources give, plus intervals (Hz),
    mode and zero numbers, shape intervals ``{mode: {dof: (lo, hi)}}`` and the measured FRFs
    in the extraction band (`vibupdate.data.frf.FRFSet`). With ``mass_normalized`` the shapes
    must be mass-normalized, which needs a driving-point FRF. The modes' numbers: ``natural_modes``,
    else consecutive from ``first_mode``, else by the shapes' MAC with the nominal ``model``'s
    modes where that is unambiguous (`vibupdate.data.pairing.modes_by_shape`), else consecutive
    from 1."""
    from vibupdate.data.extraction import extract
    from vibupdate.data.frf import FRFWarning, read_frfs
    from vibupdate.io.outputs import collected

    check_table(spec, FRF_KEYS, f"{key}.frf", where, required=("files",))
    for name, what in (("modes", "how many modes to keep"), ("first_mode", "the model mode of the lowest "
                                                                              "extracted mode; modes count from 1")):
        if name in spec and spec[name] < 1:
            raise where.error(f"{key}.frf.{name}", f"must be an integer >= 1 ({what}), got {spec[name]!r}")
    if "confidence" in spec and not 0 < spec["confidence"] < 1:
        raise where.error(f"{key}.frf.confidence", f"must be between 0 and 1 (e.g. 0.95), got {spec['confidence']!r}")
    bands = {k: numbers(spec[k], f"{key}.frf.{k}", where) for k in ("band_hz", "fit_band_hz") if k in spec}
    for k, hz in bands.items():
        if len(hz) != 2 or not 0 < hz[0] < hz[1]:
            raise where.error(f"{key}.frf.{k}", f"must be [low, high] in Hz with 0 < low < high, got {spec[k]!r}")
    band, fit_band = (tuple(2 * math.pi * b for b in bands[k]) if k in bands else None
                      for k in ("band_hz", "fit_band_hz"))
    try:
        with collected(FRFWarning) as doubts:  # said with the extraction's notes
            frfs = read_frfs([base / f for f in spec["files"]], spec.get("responses"), spec.get("excitations"),
                             spec.get("kind"), spec.get("g", False), spec.get("re_im", False), spec.get("map"))
        if spec.get("reciprocal", False):
            frfs = frfs.reciprocal()
        result = extract(frfs, band=band, n_modes=spec.get("modes"), confidence=spec.get("confidence", 0.95),
                         fit_band=fit_band, window=spec.get("window"),
                         keep_outer_zeros=spec.get("keep_outer_zeros", False),
                         window_decay=spec.get("window_decay"), window_tau=spec.get("window_tau"),
                         keep_noisy_zeros=spec.get("keep_noisy_zeros", False), joint=spec.get("joint", True))
    except ValueError as exc:
        raise where.error(f"{key}.frf", str(exc)) from None
    first = spec.get("first_mode", 1)
    numbers_of = [first + k for k in range(len(result.modes))]
    paired = None
    if "natural_modes" in spec:   # modes the test skipped: the zeros' indices come from the nominal model
        numbers_of, first = _stated_modes(spec, result, where, key), None
    elif "first_mode" not in spec and model is not None:
        from vibupdate.data.pairing import modes_by_shape

        paired = modes_by_shape([dict(m.shape_interval) for m in result.modes], model)
        if paired is not None and paired != numbers_of:
            numbers_of, first = paired, None
    to_hz = 1.0 / (2 * math.pi)
    natural = [{"hz": m.omega * to_hz, "weight": 1.0, "damping_ratio": m.damping_ratio, "mode": numbers_of[k],
                "interval": tuple(v * to_hz for v in m.omega_interval), "damping_interval": m.damping_interval}
               for k, m in enumerate(result.modes)]
    zeros = [{"hz": z.omega * to_hz, "weight": 1.0, "response": z.response, "excitation": z.excitation,
              "index": z.declared_index(first), "interval": tuple(v * to_hz for v in z.interval)}
             for z in result.zeros]
    shapes = {numbers_of[k]: dict(m.shape_interval) for k, m in enumerate(result.modes)}
    if mass_normalized and not result.mass_normalized:
        raise where.error(f"{key}.mass_normalized_shapes", "the extracted shapes are not mass-normalized: that needs "
                                                           "a driving-point FRF (a response equal to its excitation) "
                                                           f"among {', '.join(f'h_{r},{c}' for r, c in frfs.pairs)}")
    notes = tuple(doubts) + tuple(result.notes(modes=numbers_of))
    if paired is not None and first is None:
        notes += (f"the extracted modes ({', '.join(f'{m.omega / (2 * math.pi):.5g}' for m in result.modes)} Hz) are "
                  f"model modes {paired} by the MAC of their shapes with the nominal model's modes, not 1-"
                  f"{len(paired)}: a mode between them was not seen (state natural_modes, or first_mode, in "
                  "[configuration.frf] to number them otherwise)",)
    return natural, zeros, shapes, frfs.band(*result.band), notes


def _stated_modes(spec: dict, result, where: Where, key: str) -> list[int]:
    """The model modes ``[configuration.frf] natural_modes`` states for the extracted modes: one
    integer >= 1 per mode, rising (a mode the test did not see is left out), without
    ``first_mode``."""
    modes = spec["natural_modes"]
    name = f"{key}.frf.natural_modes"
    if "first_mode" in spec:
        raise where.error(name, "states every extracted mode's number; remove first_mode")
    if not all(isinstance(m, int) and not isinstance(m, bool) and m >= 1 for m in modes) \
            or any(b <= a for a, b in zip(modes, modes[1:])):
        raise where.error(name, f"must be rising integers >= 1 (model modes), got {modes!r}")
    if len(modes) != len(result.modes):
        found = ", ".join(f"{m.omega / (2 * math.pi):.5g}" for m in result.modes)
        raise where.error(name, f"gives {len(modes)} mode numbers, but the extraction found {len(result.modes)} "
                                f"modes ({found} Hz): one number per extracted mode")
    return list(modes)


def _zeros_between_dofs(zeros: list[dict], model) -> tuple[list[dict], tuple[str, ...]]:
    """The extracted antiresonances of receptances between two DOFs of ``model``, and one note
    per FRF whose response or excitation is a sensor (a combination of DOFs): its zeros are not
    used. An antiresonance is fitted as an eigenvalue of the adjunct pencil of a response DOF
    and an excitation DOF (``docs/method.md``), which a sensor's receptance ``w^T H c`` is not;
    the FRF's poles and its shapes at the sensor are used as any other."""
    def sensor(name):
        return name not in model.dofs and model.measures(name)

    kept, dropped = [], {}
    for z in zeros:
        if sensor(z["response"]) or sensor(z["excitation"]):
            dropped.setdefault((z["response"], z["excitation"]), []).append(z["hz"])
        else:
            kept.append(z)
    notes = []
    for (r, c), hz in dropped.items():
        if sensor(r) and sensor(c):
            which = (f"response and its excitation are the sensor {r!r} (a combination of DOFs)" if r == c else
                     f"response {r!r} and its excitation {c!r} are sensors (combinations of DOFs)")
        else:
            which = f"{'response' if sensor(r) else 'excitation'} {r if sensor(r) else c!r} is a sensor (a " \
                    "combination of DOFs)"
        notes.append(f"the antiresonances of h_{r},{c} ({len(hz)}, at {', '.join(f'{h:.6g}' for h in hz)} Hz) "
                     f"are not used: its {which}, and antiresonances are fitted between DOFs of the model only; "
                     "its natural frequencies and shapes are used")
    return kept, tuple(notes)


def _file_data(cfg: dict, model, base: Path, where: Where, key: str, natural, zeros, shapes):
    """Natural frequencies, antiresonances and shape intervals read from the CSV and UFF files
    a configuration names (``frequencies_csv``, ``mode_shapes_csv``, ``mode_shapes_uff``)."""
    try:
        if "frequencies_csv" in cfg:
            natural, zeros = read_frequency_csv(base / cfg["frequencies_csv"])
        if "mode_shapes_csv" in cfg:
            shapes = read_shape_csv(base / cfg["mode_shapes_csv"], (*model.dofs, *(s.name for s in model.sensors)))
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
    return natural, zeros, shapes


def _typed_natural(cfg: dict, where: Where, key: str) -> list[dict]:
    """The natural frequencies typed in the case file (``natural_hz`` with its weights, damping
    ratios and declared modes)."""
    hz = numbers(cfg["natural_hz"], f"{key}.natural_hz", where)
    weights = numbers(cfg.get("natural_weights", [1.0] * len(hz)), f"{key}.natural_weights", where)
    ratios = cfg.get("damping_ratios")
    if len(weights) != len(hz):
        raise where.error(f"{key}.natural_weights", f"needs {len(hz)} entries, got {len(weights)}")
    if ratios is not None:
        ratios = numbers(ratios, f"{key}.damping_ratios", where)
        if len(ratios) != len(hz):
            raise where.error(f"{key}.damping_ratios", f"needs {len(hz)} entries, got {len(ratios)}")
    modes = cfg.get("natural_modes")
    if modes is not None:
        if len(modes) != len(hz) or any(isinstance(m, bool) or not isinstance(m, int) or m < 1 for m in modes):
            raise where.error(f"{key}.natural_modes",
                              f"needs {len(hz)} integers >= 1 (the model mode of each frequency), got {modes!r}")
        rising = next((i for i in range(1, len(modes)) if modes[i] <= modes[i - 1]), None)
        if rising is not None:
            what = "is given twice" if modes[rising] == modes[rising - 1] else "comes after a higher one"
            raise where.error(f"{key}.natural_modes", f"mode {modes[rising]} {what} ({modes!r}): each measured "
                                                      "frequency is one model mode, rising with the frequencies")
    return [{"hz": h, "weight": w, "damping_ratio": None if ratios is None else ratios[i],
             "mode": None if modes is None else modes[i]}
            for i, (h, w) in enumerate(zip(hz, weights))]


#: Keys that qualify ``natural_hz`` entry by entry, and the column of the frequency CSV that
#: carries the same datum.
TYPED_COMPANIONS = {"damping_ratios": "damping_ratio", "natural_weights": "weight", "natural_modes": "mode"}


def _check_typed_companions(cfg: dict, where: Where, key: str) -> None:
    """Refuse a key that qualifies ``natural_hz`` (`TYPED_COMPANIONS`) in a configuration whose
    natural frequencies come from elsewhere (a CSV table, FRF files, a UFF file): it would be
    ignored, so the data it gives would silently not be used."""
    if "natural_hz" in cfg:
        return
    source = next((k for k in ("frequencies_csv", "frf", "mode_shapes_uff") if k in cfg), None)
    for companion, column in TYPED_COMPANIONS.items():
        if companion not in cfg:
            continue
        if source == "frequencies_csv":
            raise where.error(f"{key}.{companion}", f"{companion} goes with natural_hz, but the natural frequencies "
                                                    f"come from frequencies_csv ({cfg['frequencies_csv']}); give "
                                                    f"them in its '{column}' column and remove {companion}")
        move = ("; state the extracted modes' numbers in [configuration.frf] instead"
                if source == "frf" and companion == "natural_modes" else "")
        raise where.error(f"{key}.{companion}", f"{companion} goes with natural_hz, which this configuration does not "
                                                "give" + (f" (its natural frequencies come from {source})" if source
                                                          else "") + f"; remove {companion}{move}")


def _typed_zeros(cfg: dict, where: Where, key: str) -> list[dict]:
    """The antiresonances typed in the case file (``[[configuration.antiresonances]]``)."""
    zeros = []
    for i, item in enumerate(cfg.get("antiresonances", [])):
        k = f"{key}.antiresonances[{i + 1}]"
        check_table(item, {"hz": float, "response": str, "excitation": str, "weight": float, "index": int}, k,
                    where, required=("hz", "response", "excitation"))
        if "index" in item and item["index"] < 1:
            raise where.error(f"{k}.index",
                              f"must be an integer >= 1 (which zero of the receptance), got {item['index']!r}")
        zeros.append({"weight": 1.0, **item})
    return zeros


def _first_signs(cfg: dict, where: Where, key: str) -> dict:
    """``{(response, excitation): sign}`` of the ``[[configuration.first_sign]]`` tables."""
    first_sign = {}
    for i, item in enumerate(cfg.get("first_sign", [])):
        k = f"{key}.first_sign[{i + 1}]"
        check_table(item, {"response": str, "excitation": str, "sign": int}, k, where,
                    required=("response", "excitation", "sign"))
        first_sign[(item["response"], item["excitation"])] = item["sign"]
    return first_sign


def _configuration(cfg: dict, index: int, spec: dict, parameters, base: Path, where: Where,
                   models: dict, sensors=()):
    """The configuration of one ``[[configuration]]`` table, and its measured FRFs (or None)."""
    from vibupdate.data.pairing import declared_modes

    key = f"configuration[{index}]"
    check_table(cfg, CFG_KEYS, key, where, required=("name",))
    key = f"configuration '{cfg['name']}'"
    if not 0 <= cfg.get("uff_tolerance", 0.05) < math.inf:
        raise where.error(f"{key}.uff_tolerance", f"must be a finite number >= 0, got {cfg['uff_tolerance']!r}")
    model = configuration_model(spec, cfg, parameters, base, where, key, models)
    if sensors:
        from vibupdate.model.affine import with_sensors

        try:
            model = with_sensors(model, sensors)
        except ValueError as exc:
            raise where.error("sensor", str(exc)) from None
    natural, zeros, shapes, frfs, notes = [], [], {}, None, ()
    given = [k for k in ("natural_hz", "frequencies_csv") if k in cfg]
    if len(given) == 2:
        raise where.error(f"{key}.natural_hz", "natural_hz and frequencies_csv both give the natural frequencies; "
                                               "keep one of them")
    _check_typed_companions(cfg, where, key)
    if "frf" in cfg:
        mixed = [k for k in ("natural_hz", "antiresonances", "frequencies_csv", "mode_shapes_csv", "mode_shapes_uff")
                 if k in cfg]
        if mixed:
            raise where.error(f"{key}.frf", f"FRF files take the place of typed data; remove {', '.join(mixed)}")
        natural, zeros, shapes, frfs, notes = _frf_data(cfg["frf"], base, where, key,
                                                        cfg.get("mass_normalized_shapes", False), model)
        zeros, dropped = _zeros_between_dofs(zeros, model)
        notes = notes + dropped
    natural, zeros, shapes = _file_data(cfg, model, base, where, key, natural, zeros, shapes)
    if "natural_hz" in cfg:
        natural = _typed_natural(cfg, where, key)
    zeros = zeros + _typed_zeros(cfg, where, key)
    declared = declared_modes([SimpleNamespace(mode=f.get("mode")) for f in natural])  # reads only .mode
    for mode in shapes:
        if mode not in declared:
            source = cfg.get("mode_shapes_csv") or cfg.get("mode_shapes_uff") or "the FRF extraction"
            raise where.error(key, f"a mode shape is given for mode {mode} ({source}), but the measured natural "
                                   f"frequencies are modes {declared}")
    first_sign = _first_signs(cfg, where, key)
    try:
        def rad(pair):  # optional intervals (extracted from FRFs), Hz -> rad/s
            return None if pair is None else tuple(2 * math.pi * v for v in pair)

        nat = tuple(
            NaturalFrequency.from_hz(f["hz"], weight=f["weight"], damping_ratio=f["damping_ratio"],
                                     shape=ShapeInterval(shapes[declared[k]], cfg.get("mass_normalized_shapes", False))
                                     if declared[k] in shapes else None,
                                     mode=f.get("mode"), interval=rad(f.get("interval")),
                                     damping_interval=f.get("damping_interval"))
            for k, f in enumerate(natural))
        zs = tuple(Antiresonance.from_hz(z["hz"], z["response"], z["excitation"], weight=z["weight"],
                                         index=z.get("index"), interval=rad(z.get("interval"))) for z in zeros)
        return Configuration(cfg["name"], model, nat, zs, interlacing=cfg.get("interlacing", True),
                             first_sign=first_sign), (frfs, notes, bool(natural) and all(
                                                 f.get("mode") is None for f in natural))
    except ValueError as exc:
        raise where.error(key, str(exc)) from None


# -- the whole file -----------------------------------------------------------------------------

def _options(cls, table: dict, allowed: dict, key: str, where: Where):
    """The option object of the case file's ``[key]``: each value checked against its
    declaration (`vibupdate.options`), in the words the Python API uses."""
    check_table(table, allowed, key, where)
    for name, value in table.items():
        why = option_problem(key, name, value)
        if why is not None:
            raise ValueError(f"{where.path}: {why}")
    return cls(**table)


def _damping(table: dict, where: Where) -> DampingOptions:
    check_table(table, DAMPING_KEYS, "damping", where, required=("exponents",))
    exponents = tuple(numbers(table["exponents"], "damping.exponents", where))
    weights = []
    for mode, w in table.get("mode_weights", {}).items():
        if not mode.isdigit() or int(mode) < 1:
            raise where.error(f"damping.mode_weights.{mode}", "keys are mode numbers (\"1\", \"2\", ...)")
        if isinstance(w, bool) or not isinstance(w, (int, float)) or not w > 0:
            raise where.error(f"damping.mode_weights.{mode}", f"must be a positive number, got {w!r}")
        weights.append((int(mode), float(w)))
    return DampingOptions(exponents, tuple(weights), table.get("relative", False), table.get("rationale", ""))


def load_case(path) -> Case:
    """Read and validate a case file (docs/case-file.md).

    Parameters
    ----------
    path : str or Path
        The case's TOML file; files it names are found relative to its folder.

    Returns
    -------
    Case
        The configurations with their models and data, and the options of every stage.

    Raises
    ------
    ValueError
        Naming the file and the key, when the file cannot be read, is not TOML, or holds a
        value that is not what the key expects.
    """
    import tomllib   # here: a bundled example builds its case without TOML

    path = Path(path)
    where = Where(path)
    try:
        data = tomllib.loads(path.read_text(encoding="utf-8-sig"))
    except FileNotFoundError:
        raise ValueError(f"case file {str(path)!r} does not exist") from None
    except UnicodeDecodeError as exc:
        raise ValueError(f"{path}: {not_utf8(path.read_bytes(), exc)}") from None
    except OSError as exc:
        raise ValueError(f"case file {str(path)!r} could not be read: {exc}") from None
    except tomllib.TOMLDecodeError as exc:
        raise ValueError(f"{path}: not valid TOML: {exc}") from None
    # a case whose parameters are all still to be chosen among its candidates (`vibupdate suggest`)
    check_table(data, TOP_KEYS, "", where,
                required=("model", "configuration") + (() if "candidate" in data else ("parameter",)))
    base = path.parent
    source, items = _element_groups(data, base, where)
    parameters = _parameters(items["parameter"], "parameter", where)
    candidates = _parameters(items["candidate"], "candidate", where)
    twice = sorted({p.name for p in parameters} & {p.name for p in candidates})
    if twice:
        raise where.error("candidate", f"{', '.join(map(repr, twice))} is declared both as a [[parameter]] and as a "
                                       f"[[candidate]]; declare each name once")
    models = _element_models(source, items, parameters + candidates, where)
    sensors = case_sensors(data, base, where)
    loaded = [_configuration(cfg, i, data["model"], parameters + candidates, base, where, models, sensors)
              for i, cfg in enumerate(data["configuration"], start=1)]
    configurations, frequency_notes = _frequency_types(data, tuple(c for c, _ in loaded), where)
    pool = ()
    if candidates:   # held at their nominal values: exact, see vibupdate.model.affine.restricted
        from vibupdate.model.affine import restricted

        pool = configurations
        configurations = tuple(replace(c, model=restricted(c.model, [p.name for p in parameters])) for c in pool)
    return Case(
        name=data.get("case", path.stem),
        path=path,
        configurations=configurations,
        solver=_options(SolverOptions, data.get("solver", {}), SOLVER_KEYS, "solver", where),
        formulation=_options(FormulationOptions, data.get("formulation", {}), FORMULATION_KEYS, "formulation", where),
        damping=_damping(data["damping"], where) if "damping" in data else None,
        frequency_tolerance=float(data.get("frequency_tolerance", 0.0)),
        polish=_options(PolishOptions, data.get("polish", {}), POLISH_KEYS, "polish", where),
        verification=_options(VerifyOptions, data.get("verification", {}), VERIFICATION_KEYS, "verification", where),
        frfs={c.name: f for c, (f, _, _) in loaded if f is not None},
        frf_notes={c.name: n for c, (_, n, _) in loaded if n},
        undeclared_modes=tuple(c.name for c, (_, _, u) in loaded if u),
        frequency_notes=frequency_notes,
        inputs=(path, *_named_files(data, base)),
        sensors=_sensors(data["model"], configurations, base, where),
        candidates=tuple(candidates),
        pool=pool,
    )


def _element_groups(data: dict, base: Path, where: Where):
    """The elements of a ``[model]`` of ``type = "element_matrices"`` (None for another model)
    and the ``[[parameter]]`` and ``[[candidate]]`` tables with their ``each_group`` tables
    expanded, one per group (`vibupdate.io.case_elements`)."""
    from vibupdate.io.case_elements import expand_group_parameters, read_element_source

    spec = data["model"]
    source = read_element_source(spec, base, where) \
        if isinstance(spec, dict) and spec.get("type") == "element_matrices" else None
    items = {table: expand_group_parameters(data.get(table, []), table, source, where)
             for table in ("parameter", "candidate")}
    return source, items


def _element_models(source, items: dict, parameters, where: Where) -> dict:
    """The cache of models of `configuration_model`, holding the element-matrices model when
    there is one (it needs the parameters' element groups, which the cache's builder does not see)."""
    from vibupdate.io.case_elements import element_model
    from vibupdate.io.case_model import model_tag

    if source is None:
        return {}
    tables = [*items["parameter"], *items["candidate"]]
    return {model_tag({}): element_model(source, tables, parameters, where)}


def _frequency_types(data: dict, configurations, where: Where):
    """The configurations with their measured frequencies made natural, and the notes of the
    configurations where damped and natural differ by more than the measured intervals: the
    rule of ``frequency_type`` in ``docs/case-file.md`` (`vibupdate.data.measured.natural_from_damped`,
    `damped_shift`)."""
    from vibupdate.data.measured import damped_shift, natural_from_damped

    default = data.get("frequency_type")
    if default is not None and default not in ("natural", "damped"):
        raise where.error("frequency_type", f"must be 'natural' or 'damped', got {default!r}")
    tolerance = data.get("frequency_tolerance", 0.0)
    tolerance = tolerance if isinstance(tolerance, (int, float)) and 0 < tolerance < 1 else None
    converted, notes = [], {}
    for cfg, configuration in zip(data["configuration"], configurations):
        key = f"configuration '{configuration.name}'"
        stated = cfg.get("frequency_type", default)
        if stated not in (None, "natural", "damped"):
            raise where.error(f"{key}.frequency_type", f"must be 'natural' or 'damped', got {stated!r}")
        if stated == "damped" and "frf" in cfg:
            raise where.error(f"{key}.frequency_type", "frequencies extracted from FRFs are natural ones (the poles' "
                                                       "magnitudes); 'damped' is for typed or tabled data")
        beyond = []
        for k, f in enumerate(configuration.natural, start=1):
            if f.damping_ratio is None:
                if stated == "damped":
                    raise where.error(f"{key}.frequency_type", f"'damped' converts each frequency with its damping "
                                                               f"ratio; frequency {k} ({f.freq_hz:.6g} Hz) has none")
                continue
            if not f.damping_ratio < 1:    # refused by check and run (vibupdate.io.validation)
                if stated == "damped":
                    raise where.error(f"{key}.damping_ratios", f"frequency {k} at {f.freq_hz:.6g} Hz: "
                                                               f"{f.damping_ratio!r} is not a damping ratio below 1")
                continue
            shift = damped_shift(f.damping_ratio)
            top = f.interval[1] if f.interval is not None else (f.omega * (1 + tolerance) if tolerance else None)
            if top is not None and f.omega * (1 + shift) > top:
                beyond.append(f"frequency {k} at {f.freq_hz:.6g} Hz: {100 * shift:.2g} % > "
                              f"{100 * (top / f.omega - 1):.2g} %")
        if stated == "damped":
            configuration = replace(configuration, natural=tuple(natural_from_damped(f) for f in configuration.natural))
        converted.append(configuration)
        if beyond and stated == "damped":
            notes[configuration.name] = (
                "the damped frequencies were made natural, omega_n = omega_d / sqrt(1 - zeta^2), which moves "
                "them by more than their measured interval (" + "; ".join(beyond) + ")",)
        elif beyond and stated is None and "frf" not in cfg:     # extracted from FRFs: natural by construction
            notes[configuration.name] = (
                "its damping ratios make natural frequencies higher than damped ones by more than the measured "
                "interval (" + "; ".join(beyond) + "); the frequencies are taken as natural: if they are damped ones "
                "(FRF peaks, imaginary parts of the poles), state frequency_type = \"damped\", else "
                "frequency_type = \"natural\"",)
    return tuple(converted), notes


def _check_name(name: str, scales_elements: bool, key: str, where: Where) -> None:
    """A parameter's name: one the model's expressions can use (a Python identifier: letters,
    digits and ``_``, not starting with a digit, not a keyword), or, for a parameter that
    scales element groups (never written in an expression), any text without blanks."""
    import keyword

    if scales_elements:
        if not name or any(c.isspace() for c in name):
            raise where.error(key, f"{name!r}: a parameter name must be non-empty and hold no blanks")
        return
    if not name.isidentifier() or keyword.iskeyword(name):
        raise where.error(key, f"{name!r} is not a name the model's expressions can use: expected letters, digits "
                               "and underscores, not starting with a digit (e.g. 'k_lc')")


def _parameters(items, table: str, where: Where) -> list[Parameter]:
    """The ``[[parameter]]`` or ``[[candidate]]`` tables as `Parameter` s."""
    if not isinstance(items, list):
        raise where.error(table, f"must be an array of tables ([[{table}]]), got {items!r}")
    out, seen = [], {}
    for i, item in enumerate(items, start=1):
        key = f"{table}[{i}]"
        check_table(item, PARAMETER_KEYS, key, where, required=("name", "nominal", "lower", "upper"))
        _check_name(item["name"], "elements" in item, f"{key}.name", where)
        if item["name"] in seen:
            raise where.error(f"{key}.name", f"{item['name']!r} is declared twice ({table}[{seen[item['name']]}] and "
                                             f"{key}); declare each name once")
        seen[item["name"]] = i
        try:
            out.append(Parameter(item["name"], item["nominal"], item["lower"], item["upper"],
                                 unit=item.get("unit", ""), reference=item.get("reference")))
        except ValueError as exc:
            raise where.error(key, str(exc)) from None
    return out


def _sensors(spec: dict, configurations, base: Path, where: Where) -> tuple[dict, ...]:
    """``[model] sensors`` of a matrices model, read and checked against its DOFs."""
    from vibupdate.io.case_model import read_sensors

    if not isinstance(spec, dict) or "sensors" not in spec:
        return ()
    return read_sensors(base / spec["sensors"], configurations[0].model.dofs, where)


def _named_files(data, base: Path) -> list[Path]:
    """Every existing file that a string value of the case file names, relative to ``base``
    (a builder's ``"module.py:function"`` names ``module.py``)."""
    found = []
    if isinstance(data, Mapping):
        for value in data.values():
            found += _named_files(value, base)
    elif isinstance(data, list):
        for value in data:
            found += _named_files(value, base)
    elif isinstance(data, str) and 0 < len(data) < 4096 and "\n" not in data:
        for text in (data, data.rsplit(":", 1)[0]):
            try:
                path = base / text
                if path.is_file():
                    found.append(path)
                    break
            except (OSError, ValueError):
                continue
    return found
