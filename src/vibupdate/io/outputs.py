"""Output folders: which files each command owns, and how they are put in place.

The protocol is ``docs/outputs.md`` ("The results folder and its manifest"): `prepare_output`
checks the folder before any work, the writers fill a `staging_folder`, and `publish` moves
the new files into place with SIGINT held back, removes the command's stale unchanged files
and writes its manifest last (`vibupdate.io.manifests`); a command never replaces or removes
a file it did not write, one changed since, or one it reads. A command that writes straight
into its folder (a sweep's rows) lists its files as it makes them (`written_in_place`).
Names derived from user text go through `safe_name`.
"""

from __future__ import annotations

import hashlib
import os
import re
import shutil
import signal
import tempfile
import threading
from collections import Counter
from collections.abc import Callable, Iterable, Sequence
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import TypeVar

from vibupdate.extras import MissingExtra
from vibupdate.io.interrupted import Interrupted
from vibupdate.io.manifests import (
    COMMANDS,
    LEGACY_MANIFEST,
    add_to_manifest,
    changed_files,
    file_hash,
    is_manifest,
    legacy_owner,
    manifest_case,
    manifest_files,
    manifest_name,
    ownership,
    recorded_hashes,
    write_manifest,
)

_T = TypeVar("_T")


#: Name of the manifest of a run's results folder.
MANIFEST = manifest_name("run")
#: Longest name derived from user text (characters).
MAX_NAME = 64
_PARTIAL = ".vibupdate-partial-"


def is_partial(name: str) -> bool:
    """Whether ``name`` is a staging folder's (`staging_folder`), in a folder or beside it."""
    return _PARTIAL in name and name.startswith(".")


class OutputWarning(UserWarning):
    """A file of the results (a plot, the report) that could not be written; the results
    themselves are kept and the warning says which file and why."""


@contextmanager
def collected(category):
    """The messages of the warnings of ``category`` raised inside, in the list it yields (filled
    on exit); warnings of other categories are shown as usual."""
    import warnings

    messages = []
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", category)
        yield messages
    for w in caught:
        if issubclass(w.category, category):
            messages.append(str(w.message))
        else:
            warnings.showwarning(w.message, w.category, w.filename, w.lineno)


def drawn(path, plot, *args, **kwargs) -> bool:
    """Call ``plot(path, *args, **kwargs)``; a plot (or another optional file) that fails costs
    a warning, not the run.

    Returns True when the file was written. On any exception of ``plot`` (a degenerate
    figure, a font or backend problem, matplotlib not installed: `vibupdate.extras`) the
    partial file is removed, an `OutputWarning` naming the file and the error is issued, and
    False is returned (the plots' figures are held by no register: `vibupdate.report.plots.figure`).
    KeyboardInterrupt is not caught.
    """
    import warnings

    path = Path(path)
    try:
        plot(path, *args, **kwargs)
        return True
    except Exception as exc:  # an optional file is never worth the run: any failure is a note
        if path.is_file():
            path.unlink()
        why = str(exc) if isinstance(exc, MissingExtra) else f"{type(exc).__name__}: {exc}"
        warnings.warn(OutputWarning(f"{path.name} was not drawn: {why}"), stacklevel=2)
        return False


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
    counts = Counter(first.values())
    return {n: _hashed(part, n) if counts[part] > 1 else part for n, part in first.items()}


#: Prefix of the matrix files of a model that is not verified.
NOT_VERIFIED = "not_verified_"
#: Matrix-file variants besides the run's own model: the best model of the diagnosis, updated
#: without the group of data that conflicts most (`vibupdate.inverse.diagnosis`).
VARIANTS = ("", "without_worst")


def matrix_file(matrix: str, part: str, *, verified: bool = True, variant: str = "") -> str:
    """The file of matrix ``matrix`` (``M``, ``K``, ``C``) of configuration ``part`` (a
    `file_names` part): ``M_A.mtx`` for a verified model, ``not_verified_M_A.mtx`` for one
    that is not, ``without_worst_M_A.mtx`` (or ``not_verified_without_worst_M_A.mtx``) for the
    diagnosis's model. A prefix, so that no configuration name can make one name another's."""
    if variant not in VARIANTS:
        raise ValueError(f"matrix-file variant must be one of {VARIANTS}, got {variant!r}")
    return ("" if verified else NOT_VERIFIED) + (f"{variant}_" if variant else "") + f"{matrix}_{part}.mtx"


def matrix_files_planned(part: str) -> list[str]:
    """Every name `matrix_file` may give configuration ``part`` (before the run says which)."""
    return [matrix_file(m, part, verified=v, variant=variant) for variant in VARIANTS for v in (True, False)
            for m in ("M", "K", "C") if not (variant and m == "C")]


def _umask() -> int:
    mask = os.umask(0o022)
    os.umask(mask)
    return mask


@dataclass(frozen=True)
class OutputTarget:
    """A folder checked by `prepare_output`.

    Attributes
    ----------
    path : Path
        The folder.
    exists : bool
        Whether it existed when checked.
    owned : tuple of str
        Files of this command's previous run (from its manifest).
    foreign : tuple of str
        Entries this command did not write (another command's, or the user's); kept, never
        replaced.
    command : str
        The command writing the folder (`COMMANDS`).
    protected : tuple of str
        Files in the folder that the command reads (its ``inputs``); kept, never replaced.
    changed : tuple of str
        Files of this command's manifest whose content changed since it wrote them; kept,
        never replaced.
    other_case : str or None
        The case of the results of this command already in the folder, when another than
        the one being written.
    """

    path: Path
    exists: bool
    owned: tuple[str, ...]
    foreign: tuple[str, ...]
    command: str = "run"
    protected: tuple[str, ...] = ()
    changed: tuple[str, ...] = ()
    other_case: str | None = None


def kept_note(target: OutputTarget) -> str | None:
    """One line naming the files of the folder the command kept (not its own, or changed
    since it wrote them); None when there are none."""
    parts = []
    if target.foreign:
        parts.append(f"{len(target.foreign)} file(s) `vibupdate {target.command}` did not write "
                     f"({_shown(target.foreign)})")
    if target.changed:
        parts.append(f"{len(target.changed)} file(s) changed since it wrote them ({_shown(target.changed)})")
    return f"kept in {target.path}/: " + "; ".join(parts) if parts else None


def _inputs_in(folder: Path, inputs: Iterable) -> set[str]:
    """Names of the files of ``inputs`` that live in ``folder`` itself."""
    try:
        here = folder.resolve()
    except OSError:
        return set()
    names = set()
    for item in inputs:
        try:
            path = Path(item).resolve()
        except (OSError, TypeError, ValueError):
            continue
        if path.parent == here:
            names.add(path.name)
    return names


def first_of(items, n: int = 5, sep: str = ", ") -> str:
    """The first ``n`` of ``items`` joined by ``sep``, and how many more there are."""
    items = list(items)
    return sep.join(items[:n]) + (f" and {len(items) - n} more" if len(items) > n else "")


def _shown(names) -> str:
    return first_of(sorted(names))


def _described(names, others: dict[str, str]) -> str:
    """``names`` for a message, those of other commands grouped with the command that wrote
    them: ``"notes.txt; extraction.json, shapes.csv written by `vibupdate extract`"``."""
    by: dict[str, list[str]] = {}
    for n in names:
        by.setdefault(others.get(n, "-"), []).append(n)
    parts = [_shown(by.pop("-"))] if "-" in by else []
    parts += [f"{_shown(files)} written by " + (f"`vibupdate {c}`" if c in COMMANDS else "an earlier vibupdate")
              for c, files in by.items()]
    return "; ".join(parts)


def _check_name_lengths(path: Path) -> None:
    """A ValueError naming a part of ``path`` longer than its file system allows (255 bytes on
    most), before any call that would fail on it."""
    limit = 255
    try:
        limit = os.pathconf(next((p for p in (path, *path.parents) if p.exists()), Path(".")), "PC_NAME_MAX")
    except (OSError, ValueError):
        pass
    for part in path.parts:
        if len(os.fsencode(part)) > limit:
            raise ValueError(f"output path: the name {part[:40]!r}... is {len(os.fsencode(part))} bytes long; the "
                             f"file system allows at most {limit}")


def _check_writable(folder: Path) -> None:
    try:
        fd, name = tempfile.mkstemp(prefix=".vibupdate-write-test-", dir=folder)
        os.close(fd)
        os.unlink(name)
    except OSError as exc:
        raise ValueError(f"output folder {str(folder)!r} is not writable ({exc.strerror or exc})") from None


def prepare_output(path, *, force: bool = False, planned: Iterable[str] = (), command: str = "run",
                   inputs: Iterable = (), case: str | None = None) -> OutputTarget:
    """Check the output folder before any work; nothing is created or changed.

    Parameters
    ----------
    path : str or Path
        The folder.
    force : bool
        Accept a folder that holds files other than this command's unchanged results of
        ``case`` (they are kept).
    planned : iterable of str
        Names of the files the command will write, to refuse overwriting a file it did not
        write or that changed since it wrote it.
    command : str
        The command writing the folder (`COMMANDS`): its manifest says which files it owns.
    inputs : iterable of str or Path
        Files the command reads (the case file and its data); those in the folder are never
        replaced or removed.
    case : str, optional
        The case being written: results of the same command for another case need ``force``.

    Raises
    ------
    ValueError
        The path is not a folder, the folder (or the parent that would hold it) is not
        writable, it holds anything but this command's unchanged results of ``case`` and
        ``force`` is false, a planned file would overwrite a file kept, or the command would
        replace or remove a file it reads.
    """
    manifest_name(command)  # a known command
    path = Path(path)
    _check_name_lengths(path)
    if path.is_symlink() and not path.exists():
        raise ValueError(f"output path {str(path)!r} is a symbolic link to {os.readlink(path)!r}, which does not "
                         "exist; expected a folder or a new name")
    if path.exists() and not path.is_dir():
        raise ValueError(f"output path {str(path)!r} exists and is not a folder")
    if not path.exists():
        parent = path.parent
        while not parent.exists() and not parent.is_symlink():
            parent = parent.parent
        if not parent.is_dir():
            raise ValueError(f"output path {str(path)!r} cannot be created: {str(parent)!r} is not a folder")
        _check_writable(parent)
        return OutputTarget(path, False, (), (), command)
    _check_writable(path)
    owned, others = ownership(path, command)
    owned = {f for f in owned if (path / f).exists() or (path / f).is_symlink()}
    changed = changed_files(path, command, owned)
    owned -= changed
    previous = manifest_case(path, command)
    other_case = previous if case is not None and owned and previous is not None and previous != case else None
    protected = _inputs_in(path, inputs)
    planned = set(planned)
    touched = sorted(protected & (owned | planned))
    if touched:
        raise ValueError(f"output folder {str(path)!r} holds {', '.join(touched)}, which this case reads and "
                         f"`vibupdate {command}` would replace or remove; choose another --out")
    foreign = sorted(e.name for e in path.iterdir()
                     if not is_manifest(e.name) and e.name not in owned and e.name not in changed
                     and not e.name.startswith(_PARTIAL))
    if not force and (foreign or changed or other_case):
        held = []
        if other_case:
            held.append(f"the results of case {other_case!r} written by `vibupdate {command}` ({_shown(owned)})")
        if changed:
            held.append(f"files changed since `vibupdate {command}` wrote them ({_shown(changed)})")
        if foreign:
            held.append(f"files `vibupdate {command}` did not write ({_described(foreign, others)})")
        raise ValueError(f"output folder {str(path)!r} holds " + "; and ".join(held) + "; choose a new or empty "
                         "folder with --out, or pass --force to write beside them (files this command wrote and "
                         "that are unchanged are then replaced or removed; every other file is kept)")
    clash = sorted(planned & set(foreign))
    if clash:
        raise ValueError(f"output folder {str(path)!r} holds {', '.join(clash)}, which `vibupdate {command}` did not "
                         f"write and would overwrite ({_described(clash, others)}); move it or choose another --out")
    clash = sorted(planned & changed)
    if clash:
        raise ValueError(f"output folder {str(path)!r} holds {', '.join(clash)}, changed since `vibupdate {command}` "
                         "wrote it, which this command would overwrite; move it or choose another --out")
    return OutputTarget(path, True, tuple(sorted(owned)), tuple(foreign), command, tuple(sorted(protected)),
                        tuple(sorted(changed)), other_case)


def staging_folder(target: OutputTarget) -> Path:
    """A new empty folder to write the results into (removed by `publish` or by the caller):
    hidden, inside the folder or beside a new one, so on its file system and the moves renames."""
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


def publish(staged: Path, target: OutputTarget, *, case: str, version: str) -> list[str]:
    """Move the files of ``staged`` into the folder; returns their names.

    The files of the command's earlier manifest that this run did not write are removed when
    their content is what the command wrote (their hash); a file changed since is kept.
    Raises ValueError, before anything is moved, when a staged file would replace a file
    this command did not write, one changed since, or one it reads (the folder changed since
    `prepare_output`).
    """
    files = sorted(p.name for p in staged.iterdir() if p.is_file() and not is_manifest(p.name))
    hashes = {f: file_hash(staged / f) for f in files}
    moved = False
    try:
        with _sigint_held():
            _move_into_place(staged, target, files, hashes, case, version)
            moved = True
    except KeyboardInterrupt:
        if not moved:
            raise
        # Ctrl-C held back while the files moved: delivered now, with the results in place
        raise Interrupted(f"the results were written to {target.path}/ before it") from None
    return files


def _move_into_place(staged: Path, target: OutputTarget, files: list[str], hashes: dict, case: str,
                     version: str) -> None:
    """`publish`'s moves, with SIGINT held back."""
    final, command = target.path, target.command
    if not target.exists:
        if final.exists() or final.is_symlink():
            raise ValueError(f"output folder {str(final)!r} appeared while vibupdate was running; "
                             "nothing was written, run again")
        write_manifest(staged, command, files, case, version, hashes)
        os.rename(staged, final)
        return
    owned, others = ownership(final, command)
    owned -= set(target.protected)
    owned -= changed_files(final, command, owned)
    clash = [f for f in files if ((final / f).exists() or (final / f).is_symlink())
             and (f not in owned or f in target.protected)]
    if clash:
        raise ValueError(f"output folder {str(final)!r} now holds {', '.join(clash)}, which `vibupdate {command}` "
                         f"did not write or which changed since ({_described(clash, others)}); nothing was "
                         "replaced")
    for f in files:
        os.replace(staged / f, final / f)
    for f in sorted(owned - set(files)):
        stale = final / f
        if stale.is_file() or stale.is_symlink():
            stale.unlink()
    write_manifest(final, command, files, case, version, hashes)
    legacy = manifest_files(final / LEGACY_MANIFEST)
    if legacy is not None and legacy_owner(*legacy) == command:
        (final / LEGACY_MANIFEST).unlink()   # its files are now in this command's manifest, or removed
    shutil.rmtree(staged, ignore_errors=True)


class InPlace:
    """The files a command writes straight into its folder rather than through `publish` (a
    sweep's rows, appended as its samples finish), listed in the command's manifest as they
    are made. Made by `written_in_place`, which hashes their final content when the command
    ends."""

    def __init__(self, folder: Path, command: str, case: str, version: str):
        manifest_name(command)  # a known command
        self.folder, self.command, self.case, self.version = Path(folder), command, case, version
        self.names: list[str] = []

    def add(self, *names: str) -> None:
        """List ``names`` (files of the folder, existing or about to be written) in the
        manifest now, so that no other command replaces or removes them while this one runs."""
        add_to_manifest(self.folder, self.command, names, case=self.case, version=self.version)
        self.names += [n for n in names if n not in self.names]

    def seal(self) -> None:
        """Record the hash of the content of every file listed through `add`; a listed file
        that no longer exists leaves the manifest. Nothing when the manifest is gone."""
        read = manifest_files(self.folder / manifest_name(self.command))
        if read is None:
            return
        listed, data = read
        hashes = recorded_hashes(data)
        files = set(listed)
        for name in self.names:
            digest = file_hash(self.folder / name)
            if digest is None:
                files.discard(name)
                hashes.pop(name, None)
            else:
                hashes[name] = digest
        write_manifest(self.folder, self.command, sorted(files), self.case, self.version, hashes)


@contextmanager
def written_in_place(folder, command: str, *, case: str, version: str, files: Iterable[str] = ()):
    """The block of a command that writes files straight into ``folder`` (checked by
    `prepare_output`): yields an `InPlace` that lists them (``files`` at once, the others by
    its ``add``). When the block ends, normally or by an exception or Ctrl-C, the manifest gets
    the hash of the final content of every file listed in it, with SIGINT held back: a file
    the user edits afterwards is then recognised as changed, and kept, by every command."""
    listing = InPlace(Path(folder), command, case, version)
    try:
        listing.add(*files)
        yield listing
    finally:
        with _sigint_held():
            listing.seal()


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
