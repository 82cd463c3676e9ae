"""The files of a sweep's folder besides its rows: the settings a resume checks, the sweep's
manifest (`vibupdate.io.manifests`, command ``sweep``), ``sweep.json`` with the plots (a plot
that fails is a warning there, never the sweep) and ``multistart.json``."""

from __future__ import annotations

import json
from pathlib import Path

from vibupdate.io.case_types import Case
from vibupdate.io.results import json_text
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


def prepare_sweep_folder(out: Path, settings: dict, resume: bool) -> list[str]:
    """A new sweep needs an empty or new, writable folder (settings written, files listed); a
    resumed one the same settings as the folder's. Raises ValueError naming the folder
    otherwise. Returns the files this call created (with the folder itself as ``""`` first
    when it made it)."""
    from vibupdate.io.manifests import manifest_name
    from vibupdate.io.outputs import prepare_output

    prepare_output(out, command="sweep", force=True)   # a folder or a new name, writable: before anything is made
    file = out / SETTINGS_FILE
    if resume:
        if not file.exists():
            raise ValueError(f"nothing to resume in {str(out)!r}: no {SETTINGS_FILE}")
        old = json.loads(file.read_text(encoding="utf-8"))
        for key in ("case_digest", "seed", "sampling", "frequency_tolerance"):
            if old.get(key) != settings.get(key):
                raise ValueError(f"cannot resume {str(out)!r}: its {key} is {old.get(key)!r}, this run's is "
                                 f"{settings.get(key)!r}")
        list_files(out, settings, SETTINGS_FILE, SAMPLES_FILE, ENDS_FILE)
        return []
    if out.is_dir() and any(out.iterdir()):
        raise ValueError(f"output directory {str(out)!r} exists and is not empty; use --resume to finish "
                         "a sweep there, or another --out")
    made = not out.exists()
    out.mkdir(parents=True, exist_ok=True)
    file.write_text(json.dumps(settings, indent=2), encoding="utf-8")
    list_files(out, settings, SETTINGS_FILE, SAMPLES_FILE, ENDS_FILE)
    created = [SETTINGS_FILE, SAMPLES_FILE, ENDS_FILE, manifest_name("sweep")]
    return ([""] if made else []) + created


def list_files(out: Path, settings: dict, *names: str) -> None:
    """List files the sweep wrote into ``out`` in its manifest (`vibupdate.io.manifests`,
    command ``sweep``), so that no other command replaces or removes them."""
    from vibupdate import __version__
    from vibupdate.io.outputs import add_to_manifest

    add_to_manifest(out, "sweep", names, case=str(settings.get("case", "")), version=__version__)


def write_summary(out: Path, case: Case, rows, document: dict, ends, settings: dict, say, plots: bool = True) -> None:
    """``sweep.json``, then the plots (with ``plots``): a plot that fails costs a warning
    (printed and added to ``sweep.json`` as ``warnings``), never the sweep."""
    (out / SUMMARY_FILE).write_text(json_text(document), encoding="utf-8")
    list_files(out, settings, SUMMARY_FILE)
    if not plots:
        return
    import warnings

    from vibupdate.io.outputs import OutputWarning
    from vibupdate.report.sweep_plots import write_sweep_plots

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", OutputWarning)
        files = write_sweep_plots(out, case, rows, document, ends)
    list_files(out, settings, *(f.name for f in files))
    notes = [str(w.message) for w in caught if issubclass(w.category, OutputWarning)]
    for w in caught:
        if not issubclass(w.category, OutputWarning):
            warnings.showwarning(w.message, w.category, w.filename, w.lineno)
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
    path.write_text(json_text(result.as_dict(case.configurations[0].model.parameters)), encoding="utf-8")
    list_files(out, {"case": case.name}, MULTISTART_FILE)
    return path
