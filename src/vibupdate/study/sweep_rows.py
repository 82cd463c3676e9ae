"""The rows file of a sweep (``samples.csv``): appended row by row and forced to disk as
tasks complete, read back on resume (a last line cut short by a stopped run is dropped),
rewritten sorted by sample index at the end. Floats are written with ``repr`` and so read
back exactly. A file whose data columns an earlier version named by position is renamed when
a sweep resumes it (`resumed_rows`)."""

from __future__ import annotations

import csv
import io
import os
from collections.abc import Callable, Mapping
from pathlib import Path


class RowWriter:
    """Appends rows to ``samples.csv`` and forces them to disk, one at a time."""

    def __init__(self, path: Path, fields: list[str]):
        self.path, self.fields = path, fields
        new = not path.exists() or path.stat().st_size == 0
        self.file = open(path, "a", newline="", encoding="utf-8")
        self.writer = csv.DictWriter(self.file, fieldnames=fields, extrasaction="ignore")
        if new:
            self.writer.writeheader()
            self._sync()

    def _sync(self):
        self.file.flush()
        os.fsync(self.file.fileno())

    def append(self, row: dict) -> None:
        self.writer.writerow(row)
        self._sync()

    def close(self):
        self.file.close()


def _parse(value: str):
    if value == "":
        return None
    try:
        return int(value)
    except ValueError:
        pass
    try:
        return float(value)
    except ValueError:
        return value


def read_rows(path) -> tuple[list[str], list[dict]]:
    """Header and rows of a ``samples.csv`` (numbers parsed, empty cells None). A last line
    cut short by a stopped run (no line end) is removed from the file."""
    path = Path(path)
    text = path.read_text(encoding="utf-8")
    if text and not text.endswith("\n"):
        text = text[: text.rfind("\n") + 1]
        with open(path, "w", newline="", encoding="utf-8") as f:
            f.write(text)
            f.flush()
            os.fsync(f.fileno())
    reader = csv.DictReader(io.StringIO(text, newline=""))
    rows = [{k: _parse(v) for k, v in r.items()} for r in reader]
    return list(reader.fieldnames or []), rows


def write_sorted(path: Path, fields: list[str], rows: list[dict]) -> None:
    """Replace ``path`` by the rows sorted by index (written beside it, then renamed)."""
    tmp = path.with_suffix(".csv.tmp")
    with open(tmp, "w", newline="", encoding="utf-8") as f:
        w = csv.DictWriter(f, fieldnames=fields, extrasaction="ignore")
        w.writeheader()
        for r in sorted(rows, key=lambda r: r["index"]):
            w.writerow({k: ("" if v is None else v) for k, v in r.items()})
        f.flush()
        os.fsync(f.fileno())
    tmp.replace(path)


def resumed_rows(path: Path, fields: list[str], earlier: Mapping[str, str], say: Callable[[str], None]) -> list[dict]:
    """The rows of the ``samples.csv`` a sweep resumes, whose header must be ``fields``.

    A header that is ``fields`` once the columns of ``earlier`` (an earlier version's names,
    ``"data:A:f1_hz"``, to today's, ``"data:A:mode3_hz"``) are renamed is the file of that
    version: it is rewritten at once under ``fields``, its values unchanged, and ``say`` names
    the renamed columns. Raises ValueError naming the file and the first differing column when
    the header is neither.
    """
    header, rows = read_rows(path)
    if not header or header == fields:
        return rows
    if [earlier.get(c, c) for c in header] != fields:
        k = next((i for i, (a, b) in enumerate(zip(header, fields)) if a != b), min(len(header), len(fields)))
        got, expected = (header[k] if k < len(header) else "(none)"), (fields[k] if k < len(fields) else "(none)")
        raise ValueError(f"cannot resume from {str(path)!r}: its column {k + 1} is {got!r}, this case gives "
                         f"{expected!r} ({len(header)} columns, this case {len(fields)}); resume with the version "
                         "that wrote it, or run the sweep again with another --out")
    rows = [{earlier.get(k, k): v for k, v in r.items()} for r in rows]
    write_sorted(path, fields, rows)
    say(f"{path.name}: columns named by position (an earlier version's) renamed to the data's names: "
        + ", ".join(f"{a} -> {earlier[a]}" for a in header if a in earlier and a.startswith("data:")))
    return rows
