"""One table model for the terminal and ``report.md``: a `Table` is built once from the
results, and `text` and `markdown` render the same cells, so the two never disagree.

Reference columns (published values of a bundled example, the truth of a synthetic one) are
data, not code: `with_reference` appends those a results document carries (``paper``) to the
table they name, matched to its rows by key."""

from __future__ import annotations

from dataclasses import dataclass, replace

from vibupdate.options import finite
from vibupdate.report.numbers import MISSING, fmt


@dataclass(frozen=True)
class Column:
    """A column: its name, unit (``""`` for none) and the format of its numbers."""

    name: str
    unit: str = ""
    spec: str = ".4g"

    @property
    def header(self) -> str:
        return f"{self.name} [{self.unit}]" if self.unit else self.name


@dataclass(frozen=True)
class Table:
    """A table of results.

    Attributes
    ----------
    title : str
        Shown above the table in the terminal (the report has its section headings).
    columns : tuple of Column
    rows : tuple of tuple
        Cell values: numbers (formatted with their column's ``spec``) or text (as it is).
    keys : tuple of str
        One key per row, matching reference columns to rows (``"A/natural/1"``, ``"E"``).
    notes : tuple of str
        Sentences shown below the table.
    """

    title: str
    columns: tuple[Column, ...]
    rows: tuple[tuple, ...]
    keys: tuple[str, ...] = ()
    notes: tuple[str, ...] = ()

    def cells(self) -> list[list[str]]:
        """The rows as text, the same in both renderings: one line, never empty (a missing
        figure is `MISSING`), spaces single (two apart columns in the terminal) and no ``|``
        (it would split a markdown cell)."""
        return [[_cell(v, c.spec) for v, c in zip(row, self.columns)] for row in self.rows]


def _cell(value, spec: str) -> str:
    text = value if isinstance(value, str) else fmt(value, spec)
    return " ".join(text.replace("|", "/").split()) or MISSING


def text(table: Table) -> str:
    """Fixed-width text for the terminal: the title, the first column left-aligned, the others
    right-aligned, two spaces apart."""
    rows = [[c.header for c in table.columns]] + table.cells()
    widths = [max(len(r[i]) for r in rows) for i in range(len(table.columns))]
    lines = ["  ".join(c.ljust(w) if i == 0 else c.rjust(w) for i, (c, w) in enumerate(zip(r, widths))).rstrip()
             for r in rows]
    return "\n".join([table.title] + lines + list(table.notes))


def markdown(table: Table) -> list[str]:
    """The lines of a markdown table and its notes (one paragraph each)."""
    rows = [[c.header for c in table.columns]] + table.cells()
    rule = "|" + "|".join("---:" if i else "---" for i in range(len(table.columns))) + "|"
    lines = ["| " + " | ".join(r) + " |" for r in rows]
    return [lines[0], rule] + lines[1:] + [""] + [line for note in table.notes for line in (note, "")]


def error_pct(value, reference):
    """``100 |value - reference| / |reference|``; None where either is missing or not
    finite, or the reference is 0."""
    if not (finite(value) and finite(reference)) or reference == 0:
        return None
    return 100 * abs(value - reference) / abs(reference)


def with_reference(table: Table, reference, name: str) -> Table:
    """``table`` with the reference columns given for it.

    Parameters
    ----------
    table : Table
    reference : ReferenceColumns or None
        `vibupdate.io.results.ReferenceColumns`: each of its ``columns`` for this table is
        appended with its values by row key, then each error column, ``100 |value -
        reference| / |reference|`` of two named columns, then the notes.
    name : str
        The table's name in ``reference``.
    """
    columns = ((reference.columns if reference else None) or {}).get(name) or {}
    errors = ((reference.errors if reference else None) or {}).get(name) or {}
    notes = tuple(((reference.notes if reference else None) or {}).get(name) or ())
    cols, rows = list(table.columns), [list(r) for r in table.rows]
    for column, values in columns.items():
        cols.append(Column(column))
        for row, key in zip(rows, table.keys):
            row.append(values.get(key))
    for column, (value, against) in errors.items():
        i, j = ([c.name for c in cols].index(n) for n in (value, against))
        cols.append(Column(column, spec=".2f"))
        for row in rows:
            row.append(error_pct(row[i], row[j]))
    return replace(table, columns=tuple(cols), rows=tuple(map(tuple, rows)), notes=table.notes + notes)
