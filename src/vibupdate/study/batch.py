"""Batches of cases on one engine: a fleet of nominally identical structures, or one structure
tested every day (``docs/cli.md``, ``vibupdate batch``).

Each case file is one Dask task running `vibupdate.pipeline.run_case` into its own results
folder under the batch's output directory (named after the case file; a repeated name gets
a ``-2``, ``-3`` suffix); ``summary.csv`` and ``summary.md`` gather them, a case that cannot
be read or updated a row with its error, never dropped. The summaries are listed in the
batch's own manifest (`vibupdate.io.outputs`, command ``batch``).
"""

from __future__ import annotations

import csv
from collections.abc import Callable, Sequence
from pathlib import Path

from vibupdate.extras import require


#: The files a batch writes into its output directory beside the case folders.
SUMMARY_FILES = ("summary.csv", "summary.md")


def run_one(path: str, out_dir: str) -> dict:
    """Run one case file into ``out_dir``; its row of the summary table."""
    from vibupdate.io.case import load_case
    from vibupdate.pipeline import run_case

    row = {"case_file": path, "results": out_dir}
    try:
        case = load_case(path)
        document = run_case(case, out_dir).as_document()
    except ValueError as exc:
        return {**row, "case": Path(path).stem, "status": "bad_input", "message": str(exc)}
    solver, summary = document["solver"], document.get("summary", {})
    row.update(case=case.name, status=solver["status"], message=solver["message"],
               objective=solver["objective"], mean_error_updated_pct=summary.get("mean_error_updated_pct"),
               seconds=solver["seconds"])
    row.update({f"{p['name']} [{p['unit']}]" if p.get("unit") else p["name"]: p["updated"]
                for p in document["parameters"]})
    return row


def _folders(paths: Sequence[str], out: Path) -> list[Path]:
    used: dict[str, int] = {}
    folders = []
    for p in paths:
        stem = Path(p).stem if Path(p).stem != "case" else Path(p).resolve().parent.name
        used[stem] = used.get(stem, 0) + 1
        folders.append(out / (stem if used[stem] == 1 else f"{stem}-{used[stem]}"))
    return folders


def summary_markdown(rows: Sequence[dict], fields: Sequence[str]) -> str:
    """The summary table as markdown (numbers to 6 significant digits), drawn as the report's
    tables are (`vibupdate.report.table`)."""
    from vibupdate.report.table import Column, Table, markdown

    table = Table("", tuple(Column(f, spec=".6g") for f in fields),
                  tuple(tuple(r.get(f) for f in fields) for r in rows))
    return "\n".join(markdown(table))


def run_batch(paths: Sequence, out_dir, *, workers: int | None = None, scheduler: str | None = None,
              client=None, progress: Callable[[str], None] | None = None) -> list[dict]:
    """Run every case file as a Dask task; write the folders and the summary; return its rows.

    Parameters
    ----------
    paths : sequence of str or Path
        Case files (readable at the same path on the workers).
    out_dir : str or Path
        One folder per case, ``summary.csv`` and ``summary.md``.
    workers, scheduler, client
        The engine (`vibupdate.study.engine.open_client`).
    """
    require("study", "running on Dask")
    from distributed import as_completed

    from vibupdate import __version__
    from vibupdate.io.interrupted import Interrupted
    from vibupdate.io.outputs import write_published
    from vibupdate.study.engine import Progress, open_client

    say = progress or (lambda message: None)
    if not paths:
        raise ValueError("a batch needs at least one case file")
    files = [str(Path(p).resolve()) for p in paths]
    missing = [p for p in files if not Path(p).is_file()]
    if missing:
        raise ValueError(f"case file {missing[0]!r} does not exist")
    from vibupdate.io.outputs import prepare_output

    out = Path(out_dir)
    # the summary files only: case folders are checked by their runs, other files are kept
    prepare_output(out, force=True, planned=SUMMARY_FILES, command="batch")
    out.mkdir(parents=True, exist_ok=True)
    target = prepare_output(out, force=True, planned=SUMMARY_FILES, command="batch")
    folders = _folders(files, out)
    rows: list[dict | None] = [None] * len(files)
    try:
        with open_client(workers, scheduler, client=client) as c:
            futures = {c.submit(run_one, f, str(d), pure=False, retries=2): k
                       for k, (f, d) in enumerate(zip(files, folders))}
            tick = Progress(len(files), say, every=0.0)
            for fut in as_completed(list(futures)):
                k = futures[fut]
                try:
                    rows[k] = fut.result()
                except Exception as exc:  # a task lost for good, or an unexpected error in a case: its row says so
                    rows[k] = {"case_file": files[k], "case": Path(files[k]).stem, "results": str(folders[k]),
                               "status": "task_error", "message": f"{type(exc).__name__}: {exc}"}
                tick.tick(failed=rows[k]["status"] not in ("success", "acceptable"))
    except KeyboardInterrupt:
        raise Interrupted(_kept(out, folders)) from None
    fields = ["case", "status", "objective", "mean_error_updated_pct", "seconds"]
    for r in rows:
        fields += [k for k in r if k not in fields and k not in ("message", "case_file", "results")]
    fields += ["message", "results"]
    write_published(target, lambda staged: _write_summary(staged, rows, fields), case="batch", version=__version__)
    say(f"wrote {out}/ ({len(rows)} case folders, summary.csv, summary.md)")
    return rows


def _kept(out: Path, folders: list[Path]) -> str:
    """The line of an interrupted batch: the case folders its finished runs wrote (each a
    complete results folder); the staging folders of the runs it stopped are removed (the
    cluster is closed by then, so no run writes any more)."""
    import shutil

    from vibupdate.io.outputs import first_of, is_partial

    for entry in out.iterdir() if out.is_dir() else ():
        if is_partial(entry.name) and entry.is_dir():
            shutil.rmtree(entry, ignore_errors=True)
    done = [d.name for d in folders if (d / "results.json").is_file()]   # each published whole by its run
    if not done:
        return f"no case finished; nothing written in {out}/"
    return f"kept the results of {len(done)} of {len(folders)} case(s) in {out}/ ({first_of(done)}); no summary written"


def _write_summary(folder: Path, rows: list[dict], fields: list[str]) -> None:
    with open(folder / "summary.csv", "w", newline="", encoding="utf-8") as f:
        w = csv.DictWriter(f, fieldnames=fields, extrasaction="ignore")
        w.writeheader()
        w.writerows(rows)
    (folder / "summary.md").write_text(summary_markdown(rows, [f for f in fields if f != "results"]),
                                       encoding="utf-8")
