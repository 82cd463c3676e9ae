"""Sampling sweep: which parameter values do the data intervals allow? (``docs/cli.md``, "What
the data allow").

Each of many data sets drawn inside the measured intervals (`vibupdate.study.sampling`) is
updated as `vibupdate.pipeline.run_case` would and is one task on a Dask cluster
(`vibupdate.study.engine`). A sample's ``outcome`` is ``verified`` (``update(...).success``),
``unverified`` (status ``not_verified``) or ``failed`` (no usable answer; the error in
``message``). Nothing is dropped: every sample is a row of ``samples.csv``, appended and
flushed as it completes (``resume=True`` submits only the others; a sample's data depend on
``(seed, index)`` alone); the ranges of ``sweep.json`` are over the verified rows and the ends
of the lines along exact null directions (`vibupdate.study.extent`, ``line_ends.csv``), the
quantiles over the answers alone.
"""

from __future__ import annotations

import hashlib
import os
import time
from collections.abc import Callable
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from vibupdate.extras import require
from vibupdate.io.case import load_case
from vibupdate.io.case_types import Case
from vibupdate.io.interrupted import Interrupted
from vibupdate.inverse.correlation import model_frequencies
from vibupdate.data.measured import TWO_PI
from vibupdate.data.names import mode_column, zero_column
from vibupdate.inverse.reduction import wants_reduction
from vibupdate.study.engine import case_digest
from vibupdate.study.sampling import SamplingOptions, data_intervals, draw_configurations, positional_labels
from vibupdate.study.sweep_files import (
    ENDS_FILE,
    SAMPLES_FILE,
    SETTINGS_FILE,
    planned_files,
    prepare_sweep_folder,
    settings_of,
    sweep_listing,
    write_settings,
    write_summary,
)
from vibupdate.study.sweep_rows import RowWriter, read_rows, resumed_rows, write_sorted
from vibupdate.study.sweep_summary import SweepSummary, summarize


#: Columns whose values depend on the run (timing, worker), not on the sample.
RUN_COLUMNS = ("seconds", "cpu_seconds", "worker")
#: Key of a task's row under which it returns its line ends (not a column of ``samples.csv``).
ENDS_KEY = "_line_ends"
#: Proximal weight of the random-start solve (`vibupdate.study.multistart.random_start_solve`).
START_PROXIMAL = 1e-3

#: Worker-side cache of cases loaded from files: (path, digest) -> Case; one entry per load.
_CASES: dict[tuple[str, str], Case] = {}


@dataclass(frozen=True)
class CaseSource:
    """A case file as workers see it: its absolute path and the SHA-256 of its text."""

    path: str
    digest: str


def case_source(path) -> CaseSource:
    """Describe a case file for the workers (it must be readable at the same path there)."""
    path = Path(path).resolve()
    try:
        data = path.read_bytes()
    except OSError as exc:
        raise ValueError(f"case file {str(path)!r} could not be read: {exc}") from None
    return CaseSource(str(path), hashlib.sha256(data).hexdigest())


def _resolve(case) -> Case:
    if isinstance(case, Case):
        return case
    key = (case.path, case.digest)
    if key not in _CASES:
        if case_source(case.path).digest != case.digest:
            raise ValueError(f"case file {case.path!r} changed since the sweep started")
        _CASES[key] = load_case(case.path)
    return _CASES[key]


# -- one sample -------------------------------------------------------------------------------

def columns(case: Case, sampling: SamplingOptions) -> list[str]:
    """Header of ``samples.csv`` (``docs/outputs.md``, "The columns of `samples.csv`"; the data
    named by `vibupdate.data.names`)."""
    cfgs = case.configurations
    names = [f"p:{p.name}" for p in cfgs[0].model.parameters]
    sampled = data_intervals(cfgs, case.frequency_tolerance, sampling)
    predicted = [f"pred:{d.label}" for d in sampled if d.kind != "damping"]
    data = [f"data:{d.label}" for d in sampled]
    damping = []
    if any(f.damping_ratio is not None for c in cfgs for f in c.natural):
        exponents = (case.damping.exponents if case.damping else (0.0, 1.0))
        damping = [f"beta{i}" for i in range(len(exponents))]
    return ["index", "outcome", "status", "start", "objective", *names, "line_ends", *predicted, *data, *damping,
            "seconds", "cpu_seconds", "worker", "message"]


def end_columns(case: Case) -> list[str]:
    """Header of ``line_ends.csv`` (``docs/outputs.md``; each row a `vibupdate.study.extent.LineEnd`)."""
    return ["index", "direction", "side", "distance", "stop",
            *[f"p:{p.name}" for p in case.configurations[0].model.parameters]]


def _outcome(result) -> str:
    from vibupdate.inverse.status import Status

    if result.success:
        return "verified"
    return "unverified" if result.status == Status.NOT_VERIFIED else "failed"


def run_sample(case, index: int, seed: int, sampling: SamplingOptions) -> dict:
    """Draw sample ``index`` and update it; one row of ``samples.csv`` (never raises on a
    failed solve or inconsistent drawn data: those are rows with ``outcome = "failed"``).
    The row carries the sample's line ends (`vibupdate.study.extent`) under ``ENDS_KEY``, as
    rows of ``line_ends.csv``.

    Parameters
    ----------
    case : Case or CaseSource
        The case (a source is loaded once per process and cached).
    index, seed : int
    sampling : SamplingOptions
    """
    from vibupdate.pipeline import damping_stage
    from vibupdate.inverse.update import update

    start, cpu = time.perf_counter(), time.process_time()
    case = _resolve(case)
    row: dict = {"index": index, "worker": os.getpid()}
    tolerance = case.frequency_tolerance if sampling.frequency_tolerance is None else sampling.frequency_tolerance
    verification = replace(case.verification, frequency_tolerance=tolerance) if tolerance > 0 else case.verification
    try:
        cfgs, drawn = draw_configurations(case.configurations, case.frequency_tolerance, seed, index, sampling)
        row.update({f"data:{k}": v for k, v in drawn.items()})
        # the case's own options, as `vibupdate run` uses them; the sweep's own random start follows
        result = update(cfgs, formulation=case.formulation, solver=case.solver, polish=case.polish,
                        verification=verification, probe=False)
    except ValueError as exc:
        row.update(outcome="failed", status="bad_data", message=str(exc), seconds=time.perf_counter() - start,
                   cpu_seconds=time.process_time() - cpu)
        return row
    row.update(outcome=_outcome(result), status=result.status.value, objective=result.objective,
               message=result.message, start="homotopy")
    model = cfgs[0].model
    xbar, frequencies, ends = result.xbar, None, []
    if result.success and (sampling.random_start or sampling.walk):
        xbar, frequencies, ends, kept = _beyond_homotopy(case, cfgs, seed, index, result, sampling, verification)
        if kept is not None:
            row["objective"], row["start"] = kept, "random"
    row["line_ends"] = len(ends)
    row[ENDS_KEY] = ends
    row.update({f"p:{p.name}": float(v) for p, v in zip(model.parameters, model.physical(xbar))})
    for cfg, freqs in zip(cfgs, frequencies or [model_frequencies(c, xbar) for c in cfgs]):
        row.update({f"pred:{mode_column(cfg.name, f.mode)}": float(w) / TWO_PI
                    for f, w in zip(cfg.natural, freqs.natural)})
        row.update({f"pred:{zero_column(cfg.name, a.response, a.excitation, a.index)}": float(w) / TWO_PI
                    for a, w in zip(cfg.antiresonances, freqs.antiresonances)})
    if row["outcome"] != "failed" and any(f.damping_ratio is not None for c in cfgs for f in c.natural):
        try:
            stage, _, _ = damping_stage(replace(case, configurations=cfgs), xbar, lambda message: None)
            row.update({f"beta{i}": float(b) for i, b in enumerate(stage.caughey.beta)})
        except ValueError as exc:
            row["message"] += f"; damping stage: {exc}"
    row["seconds"] = time.perf_counter() - start
    row["cpu_seconds"] = time.process_time() - cpu
    return row


def _beyond_homotopy(case: Case, cfgs, seed: int, index: int, result, sampling: SamplingOptions, verification):
    """After a verified homotopy answer: the random start's answer when it is accepted, then
    the walk along the null directions at the kept answer.

    Returns ``(xbar, frequencies, ends, objective)``: the kept answer, its paired model data,
    the rows of its line ends, and the random start's objective (None when the homotopy's
    answer stands)."""
    model = cfgs[0].model
    accept = _acceptance(case, cfgs, result, sampling, verification)
    xbar, frequencies, objective, ends = result.xbar, accept.answer, None, []
    if sampling.random_start and not wants_reduction(cfgs, case.formulation):
        other = _random_start(case, cfgs, seed, index, accept)
        if other is not None:
            xbar, objective, frequencies = other
    if sampling.walk:
        from vibupdate.study.extent import walk_null_directions

        for e in walk_null_directions(cfgs, xbar, accept, freqs=frequencies):
            values = model.physical(e.xbar)
            ends.append({"index": index, "direction": e.direction, "side": e.side, "distance": e.distance,
                         "stop": e.stop, **{f"p:{p.name}": float(v) for p, v in zip(model.parameters, values)}})
    return xbar, frequencies, ends, objective


def _acceptance(case: Case, cfgs, result, sampling: SamplingOptions, verification):
    """The test of other answers of the sample (`vibupdate.study.extent.Acceptance`), against
    its verified homotopy answer ``result``."""
    from vibupdate.study.extent import Acceptance

    half = np.array([0.5 * (d.upper - d.lower) / d.value for d
                     in data_intervals(case.configurations, case.frequency_tolerance, sampling) if d.kind != "damping"])
    return Acceptance(cfgs, result, half, verification)


def _random_start(case: Case, cfgs, seed: int, index: int, accept) -> tuple | None:
    """``(xbar, objective, frequencies)`` of a random-start solve of the sample
    (`vibupdate.study.multistart.random_start_solve`) when it converged and ``accept``
    (`vibupdate.study.extent.Acceptance`) takes its answer; None otherwise."""
    from vibupdate.study.multistart import build_solver, random_start_solve
    from vibupdate.study.sampling import sample_rng

    problem, backend = build_solver(cfgs, case.formulation, case.solver)
    other = random_start_solve(problem, backend, sample_rng(seed, index, stream=1), proximal=START_PROXIMAL)
    if not other["ok"]:
        return None
    xbar = np.asarray(other["xbar"])
    updated = accept.frequencies(xbar)
    if updated is None:
        return None
    return xbar, float(other["objective"]), updated


# -- the run ----------------------------------------------------------------------------------------

def run_sweep(case, out_dir, samples: int, *, seed: int = 0, sampling: SamplingOptions | None = None,
              workers: int | None = None, scheduler: str | None = None, client=None, resume: bool = False,
              force: bool = False, retries: int = 3, plots: bool = True,
              progress: Callable[[str], None] | None = None) -> SweepSummary:
    """Sweep ``samples`` data sets of ``case`` on Dask; write ``out_dir``; return the summary.

    Parameters
    ----------
    case : Case, str or Path
        A loaded case, or the path of a case file (workers load it once each; it must be at
        the same path on every worker).
    out_dir : str or Path
        ``samples.csv`` (one row per sample, sorted by index at the end), ``line_ends.csv``
        (the ends of the walks along null directions), ``sweep.json``,
        ``sweep-settings.json`` and the plots.
    samples : int
        Number of samples (indices ``0 .. samples - 1``).
    seed : int
        Seed of the sweep; sample ``i`` depends on ``(seed, i)`` only.
    sampling : SamplingOptions, optional
    workers, scheduler, client
        The engine (`vibupdate.study.engine.open_client`).
    resume : bool
        Finish the sweep in ``out_dir`` (same case, seed and sampling; ``samples`` may grow).
    force : bool
        Start a new sweep in a folder that holds other files, as ``--force`` of ``vibupdate
        sweep`` does (``docs/cli.md``; `vibupdate.study.sweep_files.prepare_sweep_folder`).
    retries : int
        Retries of a task whose worker was lost.
    plots : bool
        Write the PNG plots (`vibupdate.report.sweep_plots`).
    progress : callable, optional
        Receives progress lines.
    """
    say = progress or (lambda message: None)
    if isinstance(samples, bool) or not isinstance(samples, int) or samples < 1:
        raise ValueError(f"the number of samples must be an integer >= 1, got {samples!r}")
    if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
        raise ValueError(f"the seed must be an integer >= 0, got {seed!r}")
    sampling = sampling or SamplingOptions()
    if isinstance(case, Case):
        loaded, source, digest = case, None, case_digest(case)
    else:
        source = case_source(case)
        loaded, digest = load_case(source.path), source.digest
    if sampling.frequency_tolerance is not None:  # the workers' draws take it from `sampling`
        loaded = replace(loaded, frequency_tolerance=sampling.frequency_tolerance)
    data_intervals(loaded.configurations, loaded.frequency_tolerance, sampling)  # bad data: error before any work
    out = Path(out_dir)
    settings = settings_of(seed, sampling, digest, loaded)
    created, kept = prepare_sweep_folder(out, settings, resume, force=force, planned=planned_files(loaded),
                                         inputs=() if source is None else (source.path,))
    if kept:
        say(kept)
    try:
        with sweep_listing(out, settings, SETTINGS_FILE, SAMPLES_FILE, ENDS_FILE) as listing:
            if not resume:
                write_settings(out, settings)
            return _sweep(loaded, source, digest, out, settings, samples, seed, sampling, resume, workers, scheduler,
                          client, retries, plots, say, listing)
    except BaseException as exc:
        stopped = _after_stop(out, created)
        if isinstance(exc, KeyboardInterrupt):
            raise Interrupted(stopped) from None
        raise


def _after_stop(out: Path, created: list[str]) -> str:
    """What a sweep stopped before its end keeps: its rows (listed in its manifest with the
    hashes of their content, `sweep_listing`), or, when no sample finished, nothing: the files
    this run ``created`` are removed (and the folder, when it made it and it is left empty), so
    that the same command runs again without a word. Returns the interrupted command's line."""
    rows = read_rows(out / SAMPLES_FILE)[1] if (out / SAMPLES_FILE).is_file() else []
    if rows:
        return (f"kept {len(rows)} sample row(s) in {out}/{SAMPLES_FILE}; finish the sweep with the same command "
                "and --resume")
    for name in created:
        if name and (out / name).is_file():
            (out / name).unlink()
    if "" in created and out.is_dir() and not any(out.iterdir()):
        out.rmdir()
    return "no sample finished; nothing kept" + (f" ({out}/ removed)" if "" in created and not out.exists() else "")


def _sweep(loaded: Case, source, digest, out: Path, settings, samples, seed, sampling, resume, workers, scheduler,
           client, retries, plots, say, listing) -> SweepSummary:
    """`run_sweep` in its checked folder."""
    from vibupdate.study.engine import Progress, open_client

    fields, end_fields = columns(loaded, sampling), end_columns(loaded)
    rows: list[dict] = []
    ends: list[dict] = []
    if resume and (out / SAMPLES_FILE).exists():
        earlier = {f"{side}:{old}": f"{side}:{new}" for old, new in positional_labels(loaded.configurations).items()
                   for side in ("pred", "data")}
        rows = resumed_rows(out / SAMPLES_FILE, fields, earlier, say)
        rows = [r for r in rows if isinstance(r["index"], int) and r["index"] < samples]
    done = {r["index"] for r in rows}
    if resume and (out / ENDS_FILE).exists():
        # ends are written before their sample's row: ends of a sample without a row are redone
        ends = [e for e in read_rows(out / ENDS_FILE)[1] if e["index"] in done]
        write_sorted(out / ENDS_FILE, end_fields, ends)
    todo = [i for i in range(samples) if i not in done]
    if resume:
        say(f"resuming: {len(done)} of {samples} samples done, {len(todo)} to go")
    writers = (RowWriter(out / SAMPLES_FILE, fields), RowWriter(out / ENDS_FILE, end_fields))
    n_workers, wall = 0, 0.0
    try:
        if todo:
            with open_client(workers, scheduler, client=client) as c:
                n_workers = len(c.scheduler_info(n_workers=-1)["workers"])
                say(f"sweep of {loaded.name!r}: {samples} samples on {n_workers} Dask worker(s)")
                start = time.perf_counter()
                new_rows, new_ends = _run_tasks(c, loaded if source is None else source, todo, seed, sampling,
                                                digest, retries, writers, Progress(samples, say, already=len(done)))
                rows, ends = rows + new_rows, ends + new_ends
                wall = time.perf_counter() - start
    finally:
        for w in writers:
            w.close()
    write_sorted(out / SAMPLES_FILE, fields, rows)
    write_sorted(out / ENDS_FILE, end_fields, ends)
    document = summarize(loaded, rows, settings, ends)
    submitted = set(todo)
    new = [r for r in rows if r["index"] in submitted and isinstance(r.get("seconds"), float)]
    document["timing"] = {
        "note": ("this run only, from the first submission to the last result (cluster start-up excluded); "
                 "overhead = (wall x workers - time inside the tasks) / tasks; task_cpu_seconds_mean is the CPU "
                 "time of a task's process, below its wall time when other processes took the cores; timings "
                 "vary with the load"),
        "tasks": len(new), "workers": n_workers, "task_phase_wall_seconds": wall,
        "task_seconds_mean": float(np.mean([r["seconds"] for r in new])) if new else None,
        "task_cpu_seconds_mean": (float(np.mean([r["cpu_seconds"] for r in new]))
                                  if new and all(isinstance(r.get("cpu_seconds"), float) for r in new) else None),
        "overhead_per_task_seconds": (wall * n_workers - sum(r["seconds"] for r in new)) / len(new) if new else None,
    }
    write_summary(out, loaded, rows, document, ends, listing, say, plots)
    say(f"{document['verified']} verified, {document['unverified']} unverified, {document['failed']} failed "
        f"of {document['samples']} samples; wrote {out}/")
    return SweepSummary(document, out)


def _run_tasks(c, payload, todo, seed, sampling, digest, retries, writers, progress) -> tuple[list[dict], list[dict]]:
    """Submit the samples ``todo``; write each row (after its line ends) as it arrives."""
    require("study", "running on Dask")
    from distributed import as_completed

    if isinstance(payload, Case):
        [payload] = c.scatter([payload], broadcast=True, hash=False)
    futures = {}
    for i in todo:
        f = c.submit(run_sample, payload, i, seed, sampling, key=f"vibupdate-sample-{digest[:16]}-{seed}-{i}",
                     retries=retries, pure=False)
        futures[f.key] = (f, i)
    rows, ends = [], []
    for f in as_completed([f for f, _ in futures.values()]):
        index = futures[f.key][1]
        try:
            row = f.result()
        except Exception as exc:  # a task lost for good (e.g. its workers kept dying): a failed row
            row = {"index": index, "outcome": "failed", "status": "task_error",
                   "message": f"{type(exc).__name__}: {exc}"}
        f.release()
        sample_ends = row.pop(ENDS_KEY, [])
        for e in sample_ends:
            writers[1].append(e)
        writers[0].append(row)
        rows.append(row)
        ends += sample_ends
        progress.tick(failed=row["outcome"] == "failed")
    return rows, ends
