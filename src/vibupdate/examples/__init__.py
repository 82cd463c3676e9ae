"""Bundled examples: models and measured data that ship with the package.

``vibupdate example --list`` shows them; each module exposes ``configurations()`` and
``parameters()``.
"""

from __future__ import annotations

import csv
from importlib import resources

__all__ = ["EXAMPLES", "read_table"]

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
