"""No figure can stop a report: every formatter of the terminal tables and of report.md takes
None, NaN, +-inf, huge and tiny values; results.json stays strict JSON and reads back."""

import copy
import json
import math
import re

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from outputs_helpers import write_case

from vibupdate.io.results import RunResult, load_results, validate_document, write_results
from vibupdate.report.document import markdown_report, terminal_text
from vibupdate.report.numbers import fmt

NASTY = [math.nan, math.inf, -math.inf, None, 1e308, -1e308, 5e-324, 1e-300, 0.0, np.float64("nan"),
         np.float32("inf")]


@pytest.mark.parametrize("value, spec, text", [
    (None, "9.2f", "        -"), (math.nan, "6.2f", "   n/a"), (math.inf, ".3g", "inf"),
    (-math.inf, "9.4f", "     -inf"),
    (1e300, "9.2f", "1.00e+300"), (5e-324, ".4g", "4.941e-324"), (2.5, "9.2f", "     2.50"), ("x", "6.2f", "     x"),
    (np.float64(1.5), ".2f", "1.50"), (3.5, "d", "3.5"), (7, ">2", " 7"), (np.int64(3), "d", "3"),
])
def test_fmt_writes_every_value_as_readable_text_of_the_field_width(value, spec, text):
    assert fmt(value, spec) == text


@pytest.fixture(scope="module")
def full_document(tmp_path_factory):
    """A results document of a real run (damping, linearized ranges) with every further
    section the report reads: reference columns, certified and sampled ranges, a multistart."""
    from vibupdate.io.case import load_case
    from vibupdate.pipeline import run_case

    folder = tmp_path_factory.mktemp("numbers")
    case = load_case(write_case(folder))
    paper = {"columns": {"frequencies": {"paper updated [Hz]": {"A/natural/1": 37.3}},
                         "parameters": {"paper": {"E": 7.4e10, "rho": 2600.0}, "true": {"E": 7.5e10, "rho": 2600.0}},
                         "damping": {"paper Rayleigh": {"A/1": 0.02}, "paper Caughey": {"A/1": 0.019}},
                         "summary": {"paper": {"mean_error_nominal_pct": 5.6, "mean_error_updated_pct": 0.6,
                                               "mean_damping_error_rayleigh_pct": 84.5, "mean_damping_error_pct": 16.6,
                                               "n_mode_unknowns": 1, "n_adjunct_unknowns": 0, "n_lifted": 2}}},
             "errors": {"frequencies": {"paper err %": ["paper updated [Hz]", "measured"]},
                        "parameters": {"error %": ["updated", "true"]},
                        "damping": {"paper Caughey err %": ["paper Caughey", "measured"]}},
             "notes": {"summary": ["paper: a note"]}}
    run = run_case(case, folder / "out", paper=paper)
    doc = run.as_document()
    names = [p["name"] for p in doc["parameters"]]
    ident = doc["identifiability"]
    ident["certified"] = {
        "definition": "S: ...", "message": "certified", "passes": 2, "n_lps": 8, "seconds": 0.5, "root_seconds": 0.1,
        "ranges": {n: {"lower": 0.9 * p["updated"], "upper": 1.1 * p["updated"], "width_pct": 20.0, "certified": True,
                       "root_lower": 0.8 * p["updated"], "root_upper": 1.2 * p["updated"]}
                   for n, p in zip(names, doc["parameters"])}}
    ident["sampled"] = {"samples": 8, "verified": 6, "unverified": 1, "failed": 1, "line_ends": 2, "seed": 0,
                        "distribution": "uniform",
                        "ranges": {n: {"unit": p["unit"], "min": 0.95 * p["updated"], "max": 1.05 * p["updated"],
                                       "q05": p["updated"], "q50": p["updated"], "q95": p["updated"],
                                       "answers_min": p["updated"], "answers_max": p["updated"]}
                                   for n, p in zip(names, doc["parameters"])}}
    ident["multistart"] = {"starts": 4, "failed": 1, "distinct_minima": 2, "x_tol": 1e-3, "seed": 0,
                           "minima": [{"objective": 1e-20, "starts": 2, "values": {n: 1.0 for n in names}},
                                      {"objective": 3e-3, "starts": 1, "values": {n: 2.0 for n in names}}]}
    ident["undetermined_combinations"] = ["+0.71 E -0.71 rho"]
    assert doc["damping"] and ident["ranges"]
    return doc, run


def _float_leaves(obj, path=()):
    """Paths of every float in a document (ints, counts and indices are not figures)."""
    if isinstance(obj, dict):
        for k, v in obj.items():
            yield from _float_leaves(v, path + (k,))
    elif isinstance(obj, list):
        for i, v in enumerate(obj):
            yield from _float_leaves(v, path + (i,))
    elif isinstance(obj, float):
        yield path


def _set(doc, path, value):
    for key in path[:-1]:
        doc = doc[key]
    doc[path[-1]] = value


def _texts(doc):
    return [terminal_text(doc), markdown_report(doc, [("plot", "p.png")], ["a note"])]


def test_the_untouched_document_renders(full_document):
    doc, _ = full_document
    texts = _texts(doc)
    assert "## Parameters" in texts[-1] and "certified outer" in texts[0]
    assert "paper err %" in texts[0] and "| paper Caughey err % |" in texts[-1]


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(data=st.data())
def test_no_figure_of_any_value_stops_the_tables_or_the_report(full_document, data):
    base, _ = full_document
    leaves = list(_float_leaves(base))
    doc = copy.deepcopy(base)
    chosen = data.draw(st.lists(st.sampled_from(leaves), min_size=1, max_size=len(leaves), unique=True))
    for path in chosen:
        _set(doc, path, data.draw(st.sampled_from(NASTY)))
    for text in _texts(doc):
        assert isinstance(text, str)
        assert not re.search(r"\bnan\b", text.lower())   # a word of its own: not "antiresonance"


def test_every_figure_non_finite_at_once(full_document):
    """The worst document: every float NaN, then every float +inf, then every float None."""
    base, _ = full_document
    for value in (math.nan, math.inf, None, 1e308):
        doc = copy.deepcopy(base)
        for path in _float_leaves(base):
            _set(doc, path, value)
        report = _texts(doc)[-1]
        assert "## Frequencies" in report


#: Figures a run computes (not inputs such as bounds or measured values, which are checked
#: finite when the case is read).
COMPUTED = [("parameters", 0, "updated"), ("parameters", 1, "xbar"), ("xbar", 0), ("frequencies", 0, "updated_hz"),
            ("frequencies", 1, "error_updated_pct"), ("summary", "mean_error_updated_pct"),
            ("damping", 0, "identified"), ("damping", 0, "error_pct"), ("damping", 1, "rayleigh"),
            ("solver", "objective"), ("solver", "relaxation_lower_bound"), ("solver", "steps", 0, "objective"),
            ("identifiability", "condition"), ("identifiability", "singular_values", 0),
            ("identifiability", "column_norm", "E"), ("identifiability", "ranges", "E", "width_pct")]


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(data=st.data())
def test_non_finite_results_are_strict_json_null_match_the_schema_and_load_back(full_document, tmp_path_factory,
                                                                                  data):
    _, run = full_document
    doc = run.as_document()
    chosen = data.draw(st.lists(st.sampled_from(COMPUTED), min_size=1, unique=True))
    for path in chosen:
        _set(doc, path, data.draw(st.sampled_from([math.nan, math.inf, -math.inf])))
    path = tmp_path_factory.mktemp("json") / "results.json"
    write_results(path, RunResult.from_document(doc))

    def refuse(token):
        raise AssertionError(f"results.json holds the non-JSON token {token}")

    written = json.loads(path.read_text(), parse_constant=refuse)
    validate_document(written)
    for leaf in chosen:
        value = written
        for key in leaf:
            value = value[key]
        assert value is None
    assert load_results(path).as_document() == written
