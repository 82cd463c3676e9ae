"""One table model (`vibupdate.report.table`): the terminal and report.md show the same cells,
and an example's reference columns join the tables they name."""

import contextlib
import importlib.util
import io
import re
from pathlib import Path

import pytest

from vibupdate.cli import main
from vibupdate.io.results import ReferenceColumns, load_results
from vibupdate.report.document import TERMINAL, tables
from vibupdate.report.table import Column, Table, markdown, text, with_reference


def _text_cells(printed: str, table: Table) -> list[list[str]]:
    """The header and rows of ``table`` as the terminal printed them, split at the gaps
    between columns (two spaces or more)."""
    lines = printed.splitlines()
    start = lines.index(table.title.splitlines()[-1]) + 1
    return [re.split(r"\s{2,}", line.strip()) for line in lines[start:start + 1 + len(table.rows)]]


def _markdown_cells(report: str, table: Table) -> list[list[str]]:
    """The header and rows of ``table`` as report.md has them."""
    header = "| " + " | ".join(c.header for c in table.columns) + " |"
    lines = report.splitlines()
    start = lines.index(header)
    rows = [lines[start]] + lines[start + 2:start + 2 + len(table.rows)]
    return [row[2:-2].split(" | ") for row in rows]


def test_a_table_renders_the_same_cells_as_text_and_markdown():
    table = Table("Demo", (Column("name"), Column("f", "Hz", ".2f"), Column("n", spec="d")),
                  (("a", 1.234, 3), ("b|c", None, float("nan"))), keys=("a", "b"), notes=("a note",))
    assert table.cells() == [["a", "1.23", "3"], ["b/c", "-", "n/a"]]
    assert text(table).splitlines() == ["Demo", "name  f [Hz]    n", "a       1.23    3", "b/c        -  n/a",
                                        "a note"]
    assert markdown(table) == ["| name | f [Hz] | n |", "|---|---:|---:|", "| a | 1.23 | 3 |", "| b/c | - | n/a |",
                               "", "a note", ""]


def test_reference_columns_join_by_row_key_with_their_errors_and_notes():
    table = Table("T", (Column("name"), Column("updated")), (("a", 2.0), ("b", 5.0)), keys=("a", "b"))
    reference = ReferenceColumns.from_dict({"columns": {"T": {"true": {"a": 1.0, "c": 9.0}}},
                                            "errors": {"T": {"error %": ["updated", "true"]}},
                                            "notes": {"T": ["true: the truth"]}})
    joined = with_reference(table, reference, "T")
    assert [c.name for c in joined.columns] == ["name", "updated", "true", "error %"]
    assert joined.cells() == [["a", "2", "1", "100.00"], ["b", "5", "-", "-"]]
    assert joined.notes == ("true: the truth",)
    assert with_reference(table, reference, "other") == table
    older = ReferenceColumns.from_dict({"frequencies": [{"configuration": "A", "paper_updated_hz": 1.0}],
                                        "summary": {}})   # before the columns
    assert with_reference(table, older, "T") == table and with_reference(table, None, "T") == table


def _conflicting_case(folder):
    """The chain whose driving-point shape is biased, of the diagnosis's run test: the run
    fails a check and shows which data conflict."""
    path = Path(__file__).parents[1] / "pipeline" / "test_diagnosis_run.py"
    spec = importlib.util.spec_from_file_location("diagnosis_run_case", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return str(module.write_case(folder, 0.10))


@pytest.fixture(scope="module", params=["cantilever", "frame", "conflicting"])
def example_run(request, tmp_path_factory):
    folder = tmp_path_factory.mktemp(request.param)
    out = folder / "out"
    args = (["run", _conflicting_case(folder)] if request.param == "conflicting"
            else ["example", request.param]) + ["--out", str(out)]
    printed = io.StringIO()
    with contextlib.redirect_stdout(printed):
        assert main(args) == (1 if request.param == "conflicting" else 0)
    return request.param, printed.getvalue(), (out / "report.md").read_text(), load_results(out / "results.json")


def test_the_terminal_and_the_report_show_the_same_cells_of_every_table(example_run):
    name, printed, report, run = example_run
    shown = tables(run)          # from the reloaded results.json: the same cells as the run printed and wrote
    assert {"frequencies", "parameters", "summary", "checks", "steps"} <= set(shown)
    assert {"ranges", "damping"} <= set(shown) if name != "conflicting" else {"trials", "best"} <= set(shown)
    for key, table in shown.items():
        cells = [[c.header for c in table.columns]] + table.cells()
        assert _markdown_cells(report, table) == cells, key
        if key in TERMINAL:
            assert _text_cells(printed, table) == cells, key
    # every markdown table of the report is one of them
    assert sum(line.startswith("|---") for line in report.splitlines()) == len(shown)


def test_the_examples_reference_columns_join_their_tables(example_run):
    name, printed, report, run = example_run
    shown = tables(run)
    headers = {key: [c.name for c in t.columns] for key, t in shown.items()}
    if name == "conflicting":
        assert run.paper is None   # no reference: the tables have their own columns only
        assert len(shown["frequencies"].columns) == 7 and len(shown["parameters"].columns) == 6
        return
    if name == "cantilever":
        assert headers["frequencies"][-2:] == ["paper updated (Table 5) [Hz]", "paper err %"]
        assert headers["parameters"][-1] == "paper (Table 6)"
        assert headers["damping"][-3:] == ["paper Rayleigh (Table 7)", "paper Caughey (Table 7)", "paper Caughey err %"]
        first = shown["frequencies"].cells()[0]
        assert first[:3] == ["A", "mode 1", "73.40"] and first[-2:] == ["73.4", "0.00"]
        assert shown["summary"].cells()[0][-1] == "5.6" and "paper updated (Table 5) [Hz]" in printed
    else:
        assert headers["parameters"][-2:] == ["true", "error %"] and headers["summary"][-1] == "paper (Tables 1, 3)"
        assert "true: the values the synthetic data were drawn from" in report
    assert "paper" not in " ".join(headers["ranges"] + headers["checks"] + headers["steps"])
