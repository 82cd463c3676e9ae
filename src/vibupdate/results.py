"""The ``results.json`` contract of every run (DESIGN.md, "Results file").

Keys may be added, never renamed. Frequencies are in Hz, percentages are absolute relative
errors times 100 (Eqs. 26-27), ``index`` is 1-based within its kind and configuration.
"""

from __future__ import annotations

import json
import math
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from vibupdate.correlation import frequency_rows, model_frequencies
from vibupdate.measured import Configuration

__all__ = ["results_document", "write_results", "load_results"]


def _mean(values) -> float | None:
    values = [v for v in values if v is not None and math.isfinite(v)]
    return float(np.mean(values)) if values else None


def results_document(case: str, configurations: Sequence[Configuration], *, updated_xbar=None,
                     problem_size: dict | None = None, solver: dict | None = None,
                     damping: Sequence[dict] | None = None, damping_summary: dict | None = None,
                     extra: dict | None = None) -> dict:
    """Assemble the ``results.json`` document.

    Parameters
    ----------
    case : str
        Name of the case.
    configurations : sequence of Configuration
    updated_xbar : ndarray, shape (n_x,), optional
        Updated normalized parameters; without it only the nominal columns are filled.
    problem_size, solver : dict, optional
        Sections of the contract produced by the updating stage.
    damping : sequence of dict, optional
        Rows ``{"configuration", "mode", "measured", "identified", "error_pct"}``.
    damping_summary : dict, optional
        ``mean_damping_error_pct`` and ``mean_damping_error_rayleigh_pct``.
    extra : dict, optional
        Additional top-level keys.
    """
    model = configurations[0].model
    nominal = [model_frequencies(c) for c in configurations]
    updated = None if updated_xbar is None else [model_frequencies(c, updated_xbar) for c in configurations]
    rows = frequency_rows(configurations, nominal, updated)
    values = None if updated_xbar is None else model.physical(updated_xbar)
    parameters = [
        {"name": p.name, "unit": p.unit, "nominal": p.nominal, "lower": p.lower, "upper": p.upper,
         "updated": None if values is None else float(values[i])}
        for i, p in enumerate(model.parameters)
    ]
    summary = {
        "mean_error_nominal_pct": _mean(r["error_nominal_pct"] for r in rows),
        "mean_error_updated_pct": _mean(r["error_updated_pct"] for r in rows),
        "mean_damping_error_pct": None,
        "mean_damping_error_rayleigh_pct": None,
    }
    summary.update(damping_summary or {})
    doc = {
        "case": case,
        "parameters": parameters,
        "frequencies": rows,
        "damping": list(damping or []),
        "summary": summary,
        "problem_size": problem_size or {},
        "solver": solver or {},
    }
    doc.update(extra or {})
    return doc


def _clean(obj):
    """JSON-safe copy: numpy scalars to Python, NaN/inf to None."""
    if isinstance(obj, dict):
        return {str(k): _clean(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_clean(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return _clean(obj.tolist())
    if isinstance(obj, (np.floating, float)):
        return float(obj) if math.isfinite(obj) else None
    if isinstance(obj, np.integer):
        return int(obj)
    return obj


def write_results(path, document: dict) -> Path:
    """Write ``document`` as JSON to ``path`` (directories created); returns the path."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_suffix(".json.tmp")
    tmp.write_text(json.dumps(_clean(document), indent=2) + "\n", encoding="utf-8")
    tmp.replace(path)
    return path


def load_results(path) -> dict:
    """Read a ``results.json`` file."""
    path = Path(path)
    try:
        return json.loads(path.read_text(encoding="utf-8"))
    except (OSError, json.JSONDecodeError) as exc:
        raise ValueError(f"results file {str(path)!r} could not be read: {exc}") from None
