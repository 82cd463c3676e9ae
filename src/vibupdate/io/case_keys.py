"""The case-file schema: the keys allowed in each table of a case file with their TOML types,
and the checks that name the file and the key of every error (``docs/case-file.md``).

Reading a case (`vibupdate.io.case`) and building its models (`vibupdate.io.case_model`) both
check their tables here.
"""

from __future__ import annotations

import json
import math
import re
from pathlib import Path

from vibupdate.options import declared


class Where:
    """Error messages that name the file and the key."""

    def __init__(self, path: Path):
        self.path = path

    def error(self, key: str, message: str) -> ValueError:
        """The bad-input error at ``key`` of this file; a ``message`` that already starts with
        the key (the library names the configuration in its own errors) is not prefixed twice."""
        return ValueError(f"{self.path}: {key}: {message.removeprefix(f'{key}: ')}")


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


#: Keys of earlier versions and what replaced them, said when a case file uses one.
RENAMED = {"fit_tolerance": "now natural_tolerance and antiresonance_tolerance, the model-form tolerances beyond "
                            "each frequency's measurement interval (docs/method.md)",
           "shape_weight": "removed: the polish weighs every datum by its admissible interval; set "
                           "[verification] shape_tolerance (docs/polish-and-verification.md)",
           "shape_slack": "removed: a shape is admissible within its interval plus [verification] "
                          "shape_tolerance (docs/polish-and-verification.md)"}


def check_table(table, allowed: dict, key: str, where: Where, required=()) -> dict:
    if not isinstance(table, dict):
        raise where.error(key, f"must be a table, got {type(table).__name__}")
    for name in table:
        if name not in allowed:
            hint = f" ({RENAMED[name]})" if name in RENAMED and (
                RENAMED[name].split()[1] in allowed or RENAMED[name].startswith("removed")) else ""
            raise where.error(_join(key, name), f"unknown key{hint}; allowed here: {', '.join(sorted(allowed))}")
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


def numbers(values, key, where) -> list[float]:
    out = []
    for v in values:
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
            raise where.error(key, f"must be an array of numbers, got {v!r}")
        out.append(float(v))
    return out


# -- the keys of each table (None: any type, checked where it is read) ---------------------------

TOP_KEYS = {"case": str, "model": dict, "parameter": list, "candidate": list, "configuration": list, "solver": dict,
             "formulation": dict, "damping": dict, "frequency_tolerance": float, "polish": dict,
             "verification": dict, "frequency_type": str, "sensor": list, "sensors": str}
# The option tables: their keys from the declarations, each value checked there (vibupdate.options).
POLISH_KEYS = {o.name: None for o in declared("polish", case_file=True)}
VERIFICATION_KEYS = {o.name: None for o in declared("verification", case_file=True)}
SOLVER_KEYS = {o.name: None for o in declared("solver", case_file=True)}
FORMULATION_KEYS = {o.name: None for o in declared("formulation", case_file=True)}
DAMPING_KEYS = {"exponents": list, "mode_weights": dict, "relative": bool, "rationale": str}
PARAMETER_KEYS = {"name": str, "unit": str, "nominal": float, "lower": float, "upper": float, "reference": float,
                  "elements": None, "scales": str, "each_group": None}
CFG_KEYS = {"name": str, "natural_hz": list, "natural_weights": list, "natural_modes": list, "damping_ratios": list,
             "antiresonances": list, "frequencies_csv": str, "mode_shapes_csv": str, "mode_shapes_uff": str,
             "uff_tolerance": float, "interlacing": bool, "first_sign": list, "options": dict, "mass": list,
             "frf": dict, "mass_normalized_shapes": bool, "frequency_type": str}
FRF_KEYS = {"files": list, "responses": list, "excitations": list, "kind": str, "g": bool, "re_im": bool,
             "map": dict, "band_hz": list, "fit_band_hz": list, "modes": int, "first_mode": int, "natural_modes": list,
             "confidence": float, "joint": bool,
             "window": str, "reciprocal": bool, "keep_outer_zeros": bool, "window_decay": float,
             "window_tau": float, "keep_noisy_zeros": bool}

#: Keys of a ``[model]`` table of ``type = "matrices"``.
MATRICES_KEYS = {"type": str, "M0": str, "K0": str, "dofs": list, "dM": dict, "dK": dict, "sensors": str,
                 "matrix_precision": float}
#: Keys of a ``[model]`` table of ``type = "element_matrices"`` (`vibupdate.io.case_elements`).
ELEMENT_MATRICES_KEYS = {"type": str, "elements": None, "groups": None, "fix": list, "clamp": list}
ELEMENTS_KEYS = {"type": str, "kind": str, "nodes": list, "line": dict, "clamp": list, "pin": list,
                  "fix": list, "beam": list, "frame": list, "mass": list, "spring": list}
