"""The rows file of a sweep (``samples.csv``): appended row by row and forced to disk as
tasks complete, read back on resume (a last line cut short by a stopped run is dropped),
rewritten sorted by sample index at the end. Floats are written with ``repr`` and so read
back exactly."""

from __future__ import annotations

import csv
import io
import os
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
