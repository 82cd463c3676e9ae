"""The summary of a sweep, ``sweep.json``: counts of the outcomes and, per parameter (in its
unit) and per predicted frequency (Hz), the range and the 5/50/95 % quantiles over the
verified samples (`summarize`), and the object `vibupdate.study.sweep.run_sweep` returns."""

from __future__ import annotations

from collections import Counter
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from vibupdate.io.case_types import Case
from vibupdate.study.sampling import SamplingOptions, data_intervals


@dataclass(frozen=True)
class SweepSummary:
    """What ``sweep.json`` holds (see `summarize`) and where the run wrote it."""

    document: dict
    out_dir: Path

    @property
    def samples(self) -> int:
        return self.document["samples"]

    @property
    def verified(self) -> int:
        return self.document["verified"]

    @property
    def failed(self) -> int:
        return self.document["failed"]

    def parameter(self, name: str) -> dict:
        for p in self.document["parameters"]:
            if p["name"] == name:
                return p
        raise ValueError(f"no parameter {name!r} in the sweep; parameters: "
                         f"{', '.join(p['name'] for p in self.document['parameters'])}")


def _stats(values) -> dict:
    v = np.asarray([x for x in values if x is not None], dtype=float)
    v = v[np.isfinite(v)]   # a value that is not finite has no place in a range or a quantile
    if v.size == 0:
        return {"min": None, "max": None, "q05": None, "q50": None, "q95": None}
    q = np.quantile(v, [0.05, 0.5, 0.95])
    return {"min": float(v.min()), "max": float(v.max()), "q05": float(q[0]), "q50": float(q[1]),
            "q95": float(q[2])}


def summarize(case: Case, rows: list[dict], settings: dict, ends: list[dict] = ()) -> dict:
    """The ``sweep.json`` document: counts, and per parameter (in its unit) and per predicted
    frequency (Hz) the range and the 5/50/95 % quantiles over the verified samples.

    A parameter's ``min`` and ``max`` are over the verified answers and the line ``ends`` of
    verified samples (rows of ``line_ends.csv``); ``answers_min``, ``answers_max`` and the
    quantiles over the answers alone. A predicted frequency is named as the data are
    (`vibupdate.data.names`): ``label`` (its column of ``samples.csv`` after ``pred:``,
    ``"A:mode3_hz"``), ``configuration``, ``kind`` and ``name`` (``"mode 3 (measured 1)"``,
    ``"zero 4 of h_y1,y1"``)."""
    outcomes = [r["outcome"] for r in rows]
    ok = [r for r in rows if r["outcome"] == "verified"]
    verified = {r["index"] for r in ok}
    ends = [e for e in ends if e["index"] in verified]
    params = []
    for p in case.configurations[0].model.parameters:
        s = _stats(r.get(f"p:{p.name}") for r in ok)
        reached = [v for v in [s["min"], s["max"], *(e.get(f"p:{p.name}") for e in ends)] if v is not None]
        whole = {"min": min(reached), "max": max(reached)} if reached else {}
        width = p.upper - p.lower
        spread = None if s["min"] is None or width <= 0 else (s["q95"] - s["q05"]) / width
        params.append({"name": p.name, "unit": p.unit, **s, **whole, "answers_min": s["min"],
                       "answers_max": s["max"], "nominal": p.nominal, "lower": p.lower,
                       "upper": p.upper, "spread_of_bounds": spread})
    predictions = []
    for d in data_intervals(case.configurations, case.frequency_tolerance, SamplingOptions(**settings["sampling"])):
        if d.kind == "damping":
            continue
        predictions.append({"label": d.label, "configuration": d.configuration, "kind": d.kind, "name": d.name,
                            "measured_hz": d.value, "interval_hz": [d.lower, d.upper],
                            **_stats(r.get(f"pred:{d.label}") for r in ok)})
    failures = dict(Counter(str(r["status"]) for r in rows if r["outcome"] == "failed"))
    return {"case": case.name, "samples": len(rows), "verified": outcomes.count("verified"),
            "unverified": outcomes.count("unverified"), "failed": outcomes.count("failed"), "line_ends": len(ends),
            "failed_by_status": failures, "seed": settings["seed"], "sampling": settings["sampling"],
            "parameters": params, "predictions": predictions}
