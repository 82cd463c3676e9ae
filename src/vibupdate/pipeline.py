"""The whole job in one call: data in, results out (DESIGN.md data flow).

The CLI is a thin layer over these functions.
"""

from __future__ import annotations

import importlib
from collections.abc import Callable, Sequence
from pathlib import Path

from vibupdate.examples import EXAMPLES
from vibupdate.homotopy import SolverOptions
from vibupdate.measured import Configuration
from vibupdate.results import results_document, write_results
from vibupdate.update import UpdateResult, update

__all__ = ["run_example", "run_update", "example_names", "example_module"]


def example_names() -> list[str]:
    """Names of the bundled examples."""
    return sorted(EXAMPLES)


def example_module(name: str):
    """The module of a bundled example (``configurations()``, ``paper_values()``)."""
    if name not in EXAMPLES:
        raise ValueError(f"unknown example {name!r}; bundled examples: {', '.join(example_names())}")
    return importlib.import_module(f"vibupdate.examples.{EXAMPLES[name]}")


def _identifiability(result: UpdateResult) -> dict:
    s = result.sensitivity
    return {
        "rank": s["rank"],
        "condition": s["condition"],
        "singular_values": s["singular_values"],
        "column_norm": {p.name: float(v) for p, v in zip(result.parameters, s["column_norm"])},
    }


def run_update(case: str, configurations: Sequence[Configuration], out_dir, *,
               solver: SolverOptions | None = None, progress: Callable[[str], None] | None = None,
               extra: dict | None = None) -> tuple[UpdateResult, dict]:
    """First stage on ``configurations``; writes ``out_dir/results.json``."""
    say = progress or (lambda message: None)
    result = update(configurations, solver=solver, progress=say)
    say(f"{result.status.value}: {result.message} ({result.seconds:.2f} s)")
    document = results_document(
        case, configurations, updated_xbar=result.xbar, problem_size=result.problem_size,
        solver=result.solver_record(),
        extra={"identifiability": _identifiability(result), **(extra or {})},
    )
    path = write_results(Path(out_dir) / "results.json", document)
    say(f"wrote {path}")
    return result, document


def run_example(name: str, out_dir, *, solver: SolverOptions | None = None,
                progress: Callable[[str], None] | None = None) -> dict:
    """Run a bundled example end to end; returns the ``results.json`` document."""
    say = progress or (lambda message: None)
    module = example_module(name)
    configurations = module.configurations()
    model = configurations[0].model
    say(f"example {name}: {len(configurations)} configuration(s), {model.n_parameters} parameters, "
        f"{model.n_dofs} DOFs")
    paper = module.paper_values() if hasattr(module, "paper_values") else None
    _, document = run_update(name, configurations, out_dir, solver=solver, progress=say,
                             extra={"paper": paper} if paper else None)
    return document
