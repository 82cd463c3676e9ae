"""The whole job in one call: data in, results out (DESIGN.md data flow).

The CLI is a thin layer over these functions.
"""

from __future__ import annotations

import importlib
from collections.abc import Callable
from pathlib import Path

from vibupdate.examples import EXAMPLES
from vibupdate.results import results_document, write_results

__all__ = ["run_example", "example_names"]


def example_names() -> list[str]:
    """Names of the bundled examples."""
    return sorted(EXAMPLES)


def _example_module(name: str):
    if name not in EXAMPLES:
        raise ValueError(f"unknown example {name!r}; bundled examples: {', '.join(example_names())}")
    return importlib.import_module(f"vibupdate.examples.{EXAMPLES[name]}")


def run_example(name: str, out_dir, *, progress: Callable[[str], None] | None = None) -> dict:
    """Run a bundled example and write ``out_dir/results.json``; returns the document."""
    say = progress or (lambda message: None)
    module = _example_module(name)
    configurations = module.configurations()
    say(f"example {name}: {len(configurations)} configuration(s), "
        f"{configurations[0].model.n_parameters} parameters, {configurations[0].model.n_dofs} DOFs")
    document = results_document(name, configurations)
    path = write_results(Path(out_dir) / "results.json", document)
    say(f"wrote {path}")
    return document
