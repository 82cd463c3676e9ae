"""The results folder: which files vibupdate owns, and how they are put in place.

A results folder holds a manifest, ``vibupdate-manifest.json``, listing the files vibupdate
wrote there. Only those files are ever replaced or removed; anything else in the folder is
the user's and is kept. The protocol of a run:

1. `prepare_output` (before solving): the folder is a directory or does not exist yet, it is
   writable, and it holds no file vibupdate did not write, unless ``force`` is given (then
   those files are kept, and a run that would overwrite one of them is refused).
2. The writers fill a staging folder (`staging_folder`): a hidden sibling when the results
   folder does not exist yet, a hidden folder inside it otherwise (same file system, so the
   final moves are renames).
3. `publish` moves the new files into place with SIGINT held back, removes the files of the
   previous run that this run did not write, and writes the new manifest last. A run that
   fails or is interrupted before `publish` leaves the earlier results as they were.

Files and folders get the permissions of the user's umask (``tempfile`` would make them
private). Names derived from user text (the case name, configuration names) go through
`safe_name`: no path separators, no ``..``, bounded length.
"""

from __future__ import annotations

import hashlib
import json
import os
import re
import shutil
import signal
import tempfile
import threading
from collections.abc import Callable, Iterable, Sequence
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import TypeVar

_T = TypeVar("_T")

__all__ = ["MANIFEST", "OutputTarget", "safe_name", "file_names", "prepare_output", "staging_folder", "publish",
           "write_published", "read_manifest"]

#: Name of the manifest file in every results folder.
MANIFEST = "vibupdate-manifest.json"
#: Longest name derived from user text (characters).
MAX_NAME = 64
_PARTIAL = ".vibupdate-partial-"


def safe_name(text: str, *, default: str = "case") -> str:
    """A file-name-safe form of ``text``.

    Characters other than letters, digits, ``.``, ``_`` and ``-`` become ``_``; leading dots
    are dropped (no hidden files, no ``..``); a name longer than `MAX_NAME` is cut and gets a
    short hash of the full text, so that different long names stay different. An empty
    result is ``default``.
    """
    name = re.sub(r"[^A-Za-z0-9._-]", "_", str(text)).lstrip(".")
    name = re.sub(r"\.{2,}", ".", name)
    if len(name) > MAX_NAME:
        name = _hashed(name, text)
    return name or default


def _hashed(name: str, text: str) -> str:
    """``name`` cut to fit `MAX_NAME` with a short hash of the full ``text`` appended."""
    return f"{name[:MAX_NAME - 9]}-{hashlib.sha1(str(text).encode('utf-8')).hexdigest()[:8]}"


def file_names(names: Sequence[str]) -> dict[str, str]:
    """Map configuration names to distinct file-name parts (`safe_name`, made unique).

    Two names that sanitize to the same text (``"a/b"`` and ``"a_b"``) both get a short hash
    of their full text appended.
    """
    first = {n: safe_name(n, default="configuration") for n in names}
    counts: dict[str, int] = {}
    for part in first.values():
        counts[part] = counts.get(part, 0) + 1
    out = {}
    for n, part in first.items():
        if counts[part] > 1:
            part = _hashed(part, n)
        out[n] = part
    return out


def _umask() -> int:
    mask = os.umask(0o022)
    os.umask(mask)
    return mask


def read_manifest(folder) -> list[str] | None:
    """Files listed in the manifest of ``folder``; None when there is no readable manifest."""
    path = Path(folder) / MANIFEST
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    files = data.get("files") if isinstance(data, dict) else None
    if not isinstance(files, list) or not all(isinstance(f, str) for f in files):
        return None
    # Only plain names in the folder itself: a manifest never reaches outside it.
    return [f for f in files if f == Path(f).name and f not in ("", ".", "..", MANIFEST)]


@dataclass(frozen=True)
class OutputTarget:
    """A results folder checked by `prepare_output`.

    Attributes
    ----------
    path : Path
        The results folder.
    exists : bool
        Whether it existed when checked.
    owned : tuple of str
        Files of the previous run (from its manifest).
    foreign : tuple of str
        Entries vibupdate did not write; kept, never replaced.
    """

    path: Path
    exists: bool
    owned: tuple[str, ...]
    foreign: tuple[str, ...]


def _check_writable(folder: Path) -> None:
    try:
        fd, name = tempfile.mkstemp(prefix=".vibupdate-write-test-", dir=folder)
        os.close(fd)
        os.unlink(name)
    except OSError as exc:
        raise ValueError(f"output folder {str(folder)!r} is not writable ({exc.strerror or exc})") from None


def prepare_output(path, *, force: bool = False, planned: Iterable[str] = ()) -> OutputTarget:
    """Check the results folder before any solve; nothing is created or changed.

    Parameters
    ----------
    path : str or Path
        The results folder.
    force : bool
        Accept a folder that holds files vibupdate did not write (they are kept).
    planned : iterable of str
        Names of the files the run will write, to refuse overwriting a foreign file.

    Raises
    ------
    ValueError
        The path is not a folder, the folder (or the parent that would hold it) is not
        writable, it holds foreign files and ``force`` is false, or a planned file would
        overwrite a foreign one.
    """
    path = Path(path)
    if path.exists() and not path.is_dir():
        raise ValueError(f"output path {str(path)!r} exists and is not a folder")
    if not path.exists():
        parent = path.parent
        while not parent.exists():
            parent = parent.parent
        if not parent.is_dir():
            raise ValueError(f"output path {str(path)!r} cannot be created: {str(parent)!r} is not a folder")
        _check_writable(parent)
        return OutputTarget(path, False, (), ())
    _check_writable(path)
    owned = read_manifest(path) or []
    foreign = sorted(e.name for e in path.iterdir()
                     if e.name != MANIFEST and e.name not in owned and not e.name.startswith(_PARTIAL))
    if foreign and not force:
        shown = ", ".join(foreign[:5]) + (f" and {len(foreign) - 5} more" if len(foreign) > 5 else "")
        raise ValueError(f"output folder {str(path)!r} holds files vibupdate did not write ({shown}); "
                         "choose a new or empty folder with --out, or pass --force to write beside them "
                         "(only vibupdate's own files are then replaced)")
    clash = sorted(set(planned) & set(foreign))
    if clash:
        raise ValueError(f"output folder {str(path)!r} holds {', '.join(clash)}, which vibupdate did not write "
                         "and would overwrite; move it or choose another --out")
    return OutputTarget(path, True, tuple(owned), tuple(foreign))


def staging_folder(target: OutputTarget) -> Path:
    """A new empty folder to write the results into (removed by `publish` or by the caller)."""
    if target.exists:
        where, prefix = target.path, _PARTIAL
    else:
        target.path.parent.mkdir(parents=True, exist_ok=True)
        where, prefix = target.path.parent, f".{safe_name(target.path.name)}{_PARTIAL}"
    tmp = Path(tempfile.mkdtemp(prefix=prefix, dir=where))
    tmp.chmod(0o777 & ~_umask())
    return tmp


@contextmanager
def _sigint_held():
    """Hold SIGINT back (main thread only) so that moving files into place is not cut short."""
    if threading.current_thread() is not threading.main_thread() or not hasattr(signal, "pthread_sigmask"):
        yield
        return
    old = signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT})
    try:
        yield
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, old)


def _write_manifest(folder: Path, files: list[str], case: str, version: str) -> None:
    text = json.dumps({"vibupdate": version, "case": case, "files": sorted(files)}, indent=2) + "\n"
    tmp = folder / f"{MANIFEST}.tmp"
    tmp.write_text(text, encoding="utf-8")
    os.replace(tmp, folder / MANIFEST)


def publish(staged: Path, target: OutputTarget, *, case: str, version: str) -> list[str]:
    """Move the files of ``staged`` into the results folder; returns their names.

    Raises ValueError, before anything is moved, when a staged file would replace a file
    vibupdate did not write (the folder changed since `prepare_output`).
    """
    files = sorted(p.name for p in staged.iterdir() if p.is_file() and p.name != MANIFEST)
    final = target.path
    with _sigint_held():
        if not target.exists:
            if final.exists():
                raise ValueError(f"output folder {str(final)!r} appeared while vibupdate was running; "
                                 "nothing was written, run again")
            _write_manifest(staged, files, case, version)
            os.rename(staged, final)
            return files
        owned = set(read_manifest(final) or [])
        clash = [f for f in files if (final / f).exists() and f not in owned]
        if clash:
            raise ValueError(f"output folder {str(final)!r} now holds {', '.join(clash)}, which vibupdate did not "
                             "write; nothing was replaced")
        for f in files:
            os.replace(staged / f, final / f)
        for f in sorted(owned - set(files)):
            stale = final / f
            if stale.is_file() or stale.is_symlink():
                stale.unlink()
        _write_manifest(final, files, case, version)
        shutil.rmtree(staged, ignore_errors=True)
    return files


def write_published(target: OutputTarget, write: Callable[[Path], _T], *, case: str, version: str) -> _T:
    """Steps 2 and 3 of the protocol in one call: ``write`` fills a staging folder, `publish`
    moves its files into ``target``; the staging folder is removed whatever happens.

    Parameters
    ----------
    target : OutputTarget
        The checked results folder (`prepare_output`).
    write : callable
        Receives the staging folder (a `Path`) and writes every file into it.
    case, version : str
        Recorded in the manifest.

    Returns
    -------
    What ``write`` returned. An exception of ``write`` or `publish` propagates with the results
    folder as it was before.
    """
    staged = staging_folder(target)
    try:
        out = write(staged)
        publish(staged, target, case=case, version=version)
    finally:
        shutil.rmtree(staged, ignore_errors=True)
    return out
