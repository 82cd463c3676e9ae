"""Each option declared once (`vibupdate.options`): the option classes, the case loader and the
case-file documentation read the same declaration, so a value is refused in the same words
from Python and from a case file."""

import dataclasses
import re
from pathlib import Path

import pytest
from outputs_helpers import TINY_CASE

import vibupdate as vu
from vibupdate.io import case_keys
from vibupdate.io.case import load_case
from vibupdate.options import OPTIONS, TABLES, declared, markdown_table

ROOT = Path(__file__).resolve().parents[2]
CLASSES = {"solver": vu.SolverOptions, "formulation": vu.FormulationOptions, "polish": vu.PolishOptions,
           "verification": vu.VerifyOptions}


def test_every_field_of_the_option_classes_is_declared_with_its_default():
    for table, cls in CLASSES.items():
        fields = {f.name: f.default for f in dataclasses.fields(cls)}
        fields.pop("rotation_prefixes", None)      # DOF-name prefixes: not a case-file option, no range
        fields.pop("backend", None)                # a name in the backend registry, checked there
        assert fields == {o.name: o.default for o in declared(table)}, table


def test_the_case_loader_accepts_exactly_the_declared_case_file_keys():
    keys = {"solver": case_keys.SOLVER_KEYS, "formulation": case_keys.FORMULATION_KEYS,
            "polish": case_keys.POLISH_KEYS, "verification": case_keys.VERIFICATION_KEYS}
    for table in TABLES:
        assert set(keys[table]) == {o.name for o in declared(table, case_file=True)}, table


def test_every_declared_default_is_valid():
    for option in OPTIONS:
        assert option.refuses(option.default) is None, option.name


@pytest.mark.parametrize("table", TABLES)
def test_the_option_tables_of_the_case_file_page_are_the_declarations(table):
    text = (ROOT / "docs" / "case-file.md").read_text(encoding="utf-8")
    head = f"### `[{table}]`\n\n"
    start = text.index(head) + len(head)
    documented = text[start:text.index("\n\n", start)]
    assert documented == markdown_table(table), f"docs/case-file.md [{table}] should read:\n{markdown_table(table)}"


def _toml(value) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, str):
        return f'"{value}"'
    return repr(value)


REFUSED = [("solver", "step_growth", 1000.0, "in [1, 100]"), ("solver", "step_growth", 0.5, "in [1, 100]"),
           ("solver", "n_lambda", 0, "from 1 to 10000"), ("solver", "n_lambda", 2.5, "from 1 to 10000"),
           ("solver", "max_iter", 2_000_000, "from 1 to 1000000"), ("solver", "proximal", 2.0, "in [0, 1]"),
           ("solver", "tol", 0.0, "in (0, 1)"), ("solver", "max_cpu_time", float("inf"), "> 0"),
           ("solver", "relaxation_solver", "osqp", "'piqp' or 'nlp'"),
           ("formulation", "shape_margin", 1e300, "in [1, 10000]"), ("formulation", "sign_delta", 1.0, "in (0, 1)"),
           ("formulation", "length_scale", -1.0, "> 0"), ("formulation", "reduction", "guyan", "'craig-bampton'"),
           ("formulation", "interlacing", 1, "true or false"),
           ("verification", "exact_half_width", -1.0, "in [0, 1)"), ("polish", "max_evaluations", 0, ">= 1"),
           ("polish", "reduced_rounds", -1, ">= 0"), ("polish", "enabled", "yes", "true or false"),
           ("verification", "mac_min", 1.5, "in [0, 1]"), ("verification", "natural_tolerance", 1.0, "in [0, 1)")]


@pytest.mark.parametrize("table, name, value, expected", REFUSED)
def test_a_value_is_refused_identically_by_the_api_and_the_case_file(tmp_path, table, name, value, expected):
    with pytest.raises(ValueError) as api:
        CLASSES[table](**{name: value})
    message = str(api.value)
    assert message.startswith(f"{table}.{name}: must be ") and expected in message
    assert message.endswith(f"got {value!r}")
    text = re.sub(rf"(?m)^{name} = .*\n", "", TINY_CASE)      # the case's own setting, if any
    line = f"{name} = {_toml(value)}\n"
    text = text.replace(f"[{table}]\n", f"[{table}]\n{line}", 1) if f"[{table}]" in text else \
        f"{text}\n[{table}]\n{line}"
    path = tmp_path / "case.toml"
    path.write_text(text)
    with pytest.raises(ValueError) as loaded:
        load_case(path)
    assert str(loaded.value) == f"{path}: {message}"


def test_numpy_numbers_are_accepted_as_numbers_and_integers():
    import numpy as np

    options = vu.SolverOptions(n_lambda=np.int64(10), step_growth=np.float64(1.5))
    assert options.n_lambda == 10 and options.step_growth == 1.5
    with pytest.raises(ValueError, match=re.escape("solver.step_growth: must be finite and in [1, 100], got nan")):
        vu.SolverOptions(step_growth=float("nan"))
