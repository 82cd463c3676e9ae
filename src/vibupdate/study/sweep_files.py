"""The files of a sweep's folder besides its rows: the settings a resume checks, the sweep's
manifest (`vibupdate.io.manifests`, command ``sweep``), ``sweep.json`` with the plots (a plot
that fails is a warning there, never the sweep) and ``multistart.json``."""

from __future__ import annotations

import json
from pathlib import Path

from vibupdate.io.case_types import Case
from vibupdate.io.records import json_text
from vibupdate.study.sampling import SamplingOptions


SAMPLES_FILE = "samples.csv"
SETTINGS_FILE = "sweep-settings.json"
SUMMARY_FILE = "sweep.json"
MULTISTART_FILE = "multistart.json"
#: The ends of the walks along null directions (`vibupdate.study.extent`), one row per end.
ENDS_FILE = "line_ends.csv"


def settings_of(seed: int, sampling: SamplingOptions, digest: str, case: Case) -> dict:
    """The content of ``sweep-settings.json``: what a resumed sweep must share."""
    return {"case": case.name, "case_digest": digest, "seed": seed, "sampling": sampling.as_dict(),
            "frequency_tolerance": case.frequency_tolerance}


def planned_files(case: Case) -> list[str]:
    """Every file a sweep of ``case`` may write (`vibupdate sweep --multistart` included)."""
    from vibupdate.report.sweep_plots import plot_names

    return [SETTINGS_FILE, SAMPLES_FILE, ENDS_FILE, SUMMARY_FILE, MULTISTART_FILE, *plot_names(case)]


def prepare_sweep_folder(out: Path, settings: dict, resume: bool, *, force: bool = False, planned=(),
                         inputs=()) -> tuple[list[str], str | None]:
    """Check the sweep's folder before any work; raises ValueError naming the folder when it
    does not fit.

    A new sweep needs an empty or new, writable folder; with ``force``, one whose files it
    will not overwrite (``planned``: `planned_files`): the files of an earlier sweep there that
    are unchanged since it wrote them are removed now (a sweep writes in place), every other
    file is kept. A resumed sweep needs the same settings as the folder's. ``inputs`` (the case
    file and its data) are never removed.

    Returns the files the new sweep creates (the folder itself as ``""`` first when it makes
    it; none for a resume) and the line naming the files kept (None when none).
    """
    from vibupdate.io.manifests import manifest_name
    from vibupdate.io.outputs import kept_note, prepare_output

    if resume and force:
        raise ValueError("--resume and --force exclude each other: --resume finishes the sweep in --out, --force "
                         "starts a new one beside the files there")
    # a folder or a new name, writable: before anything is made
    target = prepare_output(out, command="sweep", force=True, inputs=inputs)
    file = out / SETTINGS_FILE
    if resume:
        if not file.exists():
            raise ValueError(f"nothing to resume in {str(out)!r}: no {SETTINGS_FILE}")
        old = json.loads(file.read_text(encoding="utf-8"))
        for key in ("case_digest", "seed", "sampling", "frequency_tolerance"):
            if old.get(key) != settings.get(key):
                raise ValueError(f"cannot resume {str(out)!r}: its {key} is {old.get(key)!r}, this run's is "
                                 f"{settings.get(key)!r}")
        return [], None
    if not force and target.exists and any(out.iterdir()):
        raise ValueError(f"output directory {str(out)!r} exists and is not empty; use --resume to finish a sweep "
                         "there, --force to start a new one beside its files (the files of an earlier sweep there, "
                         "unchanged since written, are removed; every other file is kept), or another --out")
    if force and target.exists:
        target = prepare_output(out, command="sweep", force=True, planned=planned, inputs=inputs)
        for name in target.owned:
            (out / name).unlink(missing_ok=True)
        (out / manifest_name("sweep")).unlink(missing_ok=True)   # its changed files are now the user's
    made = not out.exists()
    out.mkdir(parents=True, exist_ok=True)
    created = [SETTINGS_FILE, SAMPLES_FILE, ENDS_FILE, manifest_name("sweep")]
    return ([""] if made else []) + created, kept_note(target) if target.exists else None


def sweep_listing(out: Path, settings: dict, *files: str):
    """The block of a sweep writing ``out`` (`vibupdate.io.outputs.written_in_place`): its
    files listed in its manifest as they are made, their hashes recorded when it ends."""
    from vibupdate import __version__
    from vibupdate.io.outputs import written_in_place

    return written_in_place(out, "sweep", case=str(settings.get("case", "")), version=__version__, files=files)


def write_settings(out: Path, settings: dict) -> None:
    """``sweep-settings.json``: what a resumed sweep must share."""
    (out / SETTINGS_FILE).write_text(json.dumps(settings, indent=2), encoding="utf-8")


def write_summary(out: Path, case: Case, rows, document: dict, ends, listing, say, plots: bool = True) -> None:
    """``sweep.json``, then the plots (with ``plots``), each listed by ``listing``
    (`sweep_listing`): a plot that fails costs a warning (printed and added to ``sweep.json``
    as ``warnings``), never the sweep."""
    listing.add(SUMMARY_FILE)
    (out / SUMMARY_FILE).write_text(json_text(document), encoding="utf-8")
    if not plots:
        return
    from vibupdate.io.outputs import OutputWarning, collected
    from vibupdate.report.sweep_plots import write_sweep_plots

    with collected(OutputWarning) as notes:
        files = write_sweep_plots(out, case, rows, document, ends)
    listing.add(*(f.name for f in files))
    if notes:
        for note in notes:
            say(f"warning: {note}")
        document["warnings"] = document.get("warnings", []) + notes
        (out / SUMMARY_FILE).write_text(json_text(document), encoding="utf-8")


def write_multistart(out_dir, case: Case, result) -> Path:
    """``multistart.json`` of a sweep (`vibupdate.study.multistart.multistart` of its case),
    listed in the sweep's manifest."""
    out = Path(out_dir)
    path = out / MULTISTART_FILE
    with sweep_listing(out, {"case": case.name}, MULTISTART_FILE):
        path.write_text(json_text(result.as_dict(case.configurations[0].model.parameters)), encoding="utf-8")
    return path
