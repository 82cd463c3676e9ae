"""Bundled examples: models and measured data that ship with the package.

``vibupdate example --list`` shows them; each module exposes ``configurations()`` and
``parameters()``.
"""

from __future__ import annotations

import csv
from importlib import resources
from pathlib import Path


#: Example name -> module name inside this package.
EXAMPLES = {
    "cantilever": "cantilever",
    "frame": "frame",
}


def read_table(filename: str) -> list[dict[str, str]]:
    """Rows of a bundled CSV file (lines starting with ``#`` are comments)."""
    text = resources.files(__name__).joinpath("data", filename).read_text(encoding="utf-8")
    lines = [line for line in text.splitlines() if line.strip() and not line.startswith("#")]
    return list(csv.DictReader(lines))


def new_folder(out) -> None:
    """Make ``out`` for a worked example that writes its input files; an existing folder must be
    empty, so that no file of the user's is overwritten."""
    out = Path(out)
    if out.exists() and (not out.is_dir() or any(out.iterdir())):
        raise ValueError(f"output folder {str(out)!r} exists and is not empty; name a new folder")
    out.mkdir(parents=True, exist_ok=True)
