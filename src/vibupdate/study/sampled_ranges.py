"""Sampled ranges and a multistart inside ``vibupdate run`` (``--samples N``; ``docs/outputs.md``,
"Ranges side by side").

A `SampledRanges` is the ``study`` of `vibupdate.pipeline.run_case`: after the update it runs
the sweep of `vibupdate.study.sweep` and a multistart of the point estimate
(`vibupdate.study.multistart`) on one Dask client, and returns the ``identifiability``
sections ``sampled`` and ``multistart``, a writer of its files into the results folder, and
the answers it reports (`reported_answers`: verified sampled answers and line ends,
normalized), which the certified ranges must hold; the multistart's minima are not verified
answers and are not among them. The pipeline does not import this module.
"""

from __future__ import annotations

import tempfile
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import ClassVar

from vibupdate.study.sampling import SamplingOptions


#: What the study adds to a results folder.
FILES = ("samples.csv", "line_ends.csv", "sampled_hist.png", "sampled_pairs.png")
#: The per-parameter figures of a sweep kept in ``identifiability.sampled.ranges``.
KEYS = ("unit", "min", "max", "q05", "q50", "q95", "answers_min", "answers_max")


def sampled_section(document: dict) -> dict:
    """``identifiability.sampled`` from a ``sweep.json`` document."""
    return {"samples": document["samples"], "verified": document["verified"],
            "unverified": document["unverified"], "failed": document["failed"],
            "line_ends": document.get("line_ends", 0), "seed": document["seed"],
            "distribution": document["sampling"]["distribution"],
            "ranges": {p["name"]: {k: p.get(k) for k in KEYS} for p in document["parameters"]}}


def reported_answers(model, rows: list[dict], ends: list[dict]) -> list[tuple[str, object]]:
    """``(label, xbar)`` of every verified sampled answer and every line end of a verified
    sample (the points the sampled range is taken over), ``xbar`` normalized, shape (n_x,)."""
    names = [f"p:{p.name}" for p in model.parameters]
    verified = sorted(r["index"] for r in rows if r["outcome"] == "verified")
    by_index = {r["index"]: r for r in rows}
    out = [(f"sample {i}", model.normalized([by_index[i][n] for n in names])) for i in verified]
    kept = set(verified)
    out += [(f"line end {e['direction']}{'+' if e['side'] > 0 else '-'} of sample {e['index']}",
             model.normalized([e[n] for n in names])) for e in ends if e["index"] in kept]
    return out


@dataclass(frozen=True)
class SampledRanges:
    """The sampled ranges and the multistart of a run (module docstring).

    Attributes
    ----------
    samples : int
        Data sets drawn (>= 1).
    starts : int
        Random starts of the multistart (0: none).
    seed : int
        Sample and start ``i`` depend on ``(seed, i)`` only.
    sampling : SamplingOptions
    workers, scheduler, client
        The engine (`vibupdate.study.engine.open_client`).
    """

    samples: int
    starts: int = 20
    seed: int = 0
    sampling: SamplingOptions = field(default_factory=SamplingOptions)
    workers: int | None = None
    scheduler: str | None = None
    client: object = field(default=None, compare=False, repr=False)
    #: Names of the files the study writes into the results folder.
    files: ClassVar[tuple[str, ...]] = FILES

    def __post_init__(self):
        for name in ("samples", "starts", "seed"):
            value = getattr(self, name)
            least = 1 if name == "samples" else 0
            if isinstance(value, bool) or not isinstance(value, int) or value < least:
                raise ValueError(f"the number of {'random starts' if name == 'starts' else name} must be an "
                                 f"integer >= {least}, got {value!r}")

    def check(self, case) -> None:
        """Raise ValueError, before any work, when the case's data cannot be sampled (a
        frequency with neither an interval nor a tolerance)."""
        from vibupdate.study.sampling import data_intervals

        data_intervals(case.configurations, case.frequency_tolerance, self.sampling)

    def __call__(self, case, result, say: Callable[[str], None]) -> tuple[dict, Callable[[Path], list], list]:
        """Run the sweep and the multistart of ``case``; the sections, the folder writer and
        the reported answers (`reported_answers`).

        ``result`` (the run's `UpdateResult`) is not used: the samples are updated from
        scratch, so the sampled ranges do not depend on the run's answer.
        """
        from vibupdate.study.engine import open_client
        from vibupdate.study.multistart import multistart
        from vibupdate.study.sweep import ENDS_FILE, SAMPLES_FILE, columns, end_columns, run_sweep
        from vibupdate.study.sweep_rows import read_rows

        sections = {}
        with tempfile.TemporaryDirectory(prefix="vibupdate-sampled-") as tmp, \
                open_client(self.workers, self.scheduler, client=self.client) as c:
            try:
                summary = run_sweep(case, Path(tmp) / "sweep", self.samples, seed=self.seed, sampling=self.sampling,
                                    client=c, plots=False, progress=say)
            except KeyboardInterrupt:   # the rows were the run's scratch, removed with it: nothing is kept
                raise KeyboardInterrupt from None
            rows = read_rows(Path(tmp) / "sweep" / SAMPLES_FILE)[1]
            ends = read_rows(Path(tmp) / "sweep" / ENDS_FILE)[1]
            sections["sampled"] = sampled_section(summary.document)
            if self.starts:
                ms = multistart(case, self.starts, seed=self.seed, client=c, progress=say)
                sections["multistart"] = {**ms.as_dict(case.configurations[0].model.parameters), "seed": self.seed}
        document, fields, end_fields = summary.document, columns(case, self.sampling), end_columns(case)

        def write(folder: Path) -> list[tuple[str, str]]:
            """The rows first, then the plots: a plot that fails is left out with an
            `vibupdate.io.outputs.OutputWarning` (a note of the run), never the run."""
            from vibupdate.io.outputs import drawn
            from vibupdate.report.sweep_plots import least_determined, plot_histograms, plot_pairs
            from vibupdate.study.sweep_rows import write_sorted

            write_sorted(folder / SAMPLES_FILE, fields, rows)
            write_sorted(folder / ENDS_FILE, end_fields, ends)
            images = []
            if drawn(folder / "sampled_hist.png", plot_histograms, document, rows):
                images.append(("sampled parameters (verified answers of data sets drawn inside the intervals)",
                               "sampled_hist.png"))
            names = least_determined(document)
            if len(names) >= 2 and drawn(folder / "sampled_pairs.png", plot_pairs, document, rows, names, ends):
                images.append(("sampled pairs of the least-determined parameters", "sampled_pairs.png"))
            return images

        return sections, write, reported_answers(case.configurations[0].model, rows, ends)
