"""Manifests: which files of a folder each vibupdate command wrote (``docs/outputs.md``, "One
manifest per command").

Each command of `COMMANDS` lists its files, with the SHA-256 of each, in its own
``vibupdate-manifest-COMMAND.json`` (`manifest_name`) and owns those unchanged since
(`changed_files`; a file listed without a hash counts as unchanged). The shared manifest of
earlier versions (`LEGACY_MANIFEST`) is read as the docs page says.
"""

from __future__ import annotations

import hashlib
import json
import os
from collections.abc import Iterable
from pathlib import Path


#: The commands that write folders, each with its own manifest (``example`` writes as ``run``).
COMMANDS = ("run", "extract", "sweep", "batch", "suggest")
#: The manifest shared by every command before the manifests were per command.
LEGACY_MANIFEST = "vibupdate-manifest.json"
_MANIFEST_PREFIX = "vibupdate-manifest"


def manifest_name(command: str) -> str:
    """File name of the manifest of ``command`` (one of `COMMANDS`)."""
    if command not in COMMANDS:
        raise ValueError(f"unknown command {command!r} of an output folder; expected one of {', '.join(COMMANDS)}")
    return f"{_MANIFEST_PREFIX}-{command}.json"


def is_manifest(name: str) -> bool:
    """Whether ``name`` is a manifest of some command (or one being written)."""
    names = {LEGACY_MANIFEST, *(manifest_name(c) for c in COMMANDS)}
    return name in names or (name.endswith(".tmp") and name[:-4] in names)


def manifest_files(path: Path) -> tuple[list[str], dict] | None:
    """The plain file names listed in a manifest file and its whole content; None when it
    cannot be read."""
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    files = data.get("files") if isinstance(data, dict) else None
    if not isinstance(files, list) or not all(isinstance(f, str) for f in files):
        return None
    # Only plain names in the folder itself: a manifest never reaches outside it.
    return [f for f in files if f == Path(f).name and f not in ("", ".", "..") and not is_manifest(f)], data


def legacy_owner(files: list[str], data: dict) -> str | None:
    """The command that wrote a legacy shared manifest, when it or its files say so."""
    if data.get("command") in COMMANDS:
        return data["command"]
    names = set(files)
    if "extraction.json" in names and "results.json" not in names:
        return "extract"
    if "results.json" in names and "extraction.json" not in names:
        return "run"
    return None


def read_manifests(folder) -> dict[str, list[str]]:
    """Files of every command's manifest in ``folder``: ``{command: [names]}``; the files
    of a legacy manifest under the command that wrote it, or under ``""`` when unknown."""
    folder = Path(folder)
    out: dict[str, list[str]] = {}
    for command in COMMANDS:
        read = manifest_files(folder / manifest_name(command))
        if read is not None:
            out[command] = read[0]
    legacy = manifest_files(folder / LEGACY_MANIFEST)
    if legacy is not None:
        owner = legacy_owner(*legacy) or ""
        out[owner] = sorted(set(out.get(owner, [])) | set(legacy[0]))
    return out


def read_manifest(folder, command: str = "run") -> list[str] | None:
    """Files that ``command`` wrote in ``folder`` (its manifest, and a legacy manifest it
    wrote); None when there is no readable manifest of it."""
    files = read_manifests(folder).get(command)
    return None if files is None else sorted(files)


def ownership(folder: Path, command: str) -> tuple[set[str], dict[str, str]]:
    """The files ``command`` owns in ``folder``, and every file another command wrote with
    that command's name (``""``: a legacy manifest of an unknown command). A file listed by
    two commands belongs to neither: it is kept."""
    manifests = read_manifests(folder)
    others = {f: c for c, files in manifests.items() if c != command for f in files}
    owned = set(manifests.get(command, [])) - set(others)
    return owned, others


def file_hash(path: Path) -> str | None:
    """SHA-256 of the content of the file ``path`` (hex); None when it is not a readable file."""
    digest = hashlib.sha256()
    try:
        with open(path, "rb") as f:
            for block in iter(lambda: f.read(1 << 20), b""):
                digest.update(block)
    except OSError:
        return None
    return digest.hexdigest()


def recorded_hashes(data: dict) -> dict[str, str]:
    """The SHA-256 of each file recorded in a manifest's content ``data`` (`manifest_files`)."""
    hashes = data.get("sha256")
    return {k: v for k, v in hashes.items() if isinstance(v, str)} if isinstance(hashes, dict) else {}


def changed_files(folder, command: str, files) -> set[str]:
    """Those of ``files`` (listed by ``command``'s manifest in ``folder``) whose content is not
    what the command wrote: another hash than the recorded one, or no longer a plain file.
    A file without a recorded hash (an earlier version's manifest) counts as unchanged."""
    folder = Path(folder)
    read = manifest_files(folder / manifest_name(command))
    hashes = recorded_hashes(read[1]) if read is not None else {}
    changed = set()
    for f in files:
        path = folder / f
        if path.is_symlink() or (path.exists() and not path.is_file()):
            changed.add(f)
        elif f in hashes and path.exists() and file_hash(path) != hashes[f]:
            changed.add(f)
    return changed


def manifest_case(folder, command: str) -> str | None:
    """The case recorded in ``command``'s manifest in ``folder``; None without one."""
    read = manifest_files(Path(folder) / manifest_name(command))
    case = read[1].get("case") if read is not None else None
    return case if isinstance(case, str) else None


def write_manifest(folder: Path, command: str, files: list[str], case: str, version: str,
                   hashes: dict[str, str] | None = None) -> None:
    """Write ``command``'s manifest in ``folder``: ``files`` with their SHA-256 (``hashes``,
    or read from the files in ``folder`` when not given)."""
    if hashes is None:
        hashes = {f: file_hash(folder / f) for f in files}
    hashes = {f: hashes[f] for f in sorted(files) if hashes.get(f) is not None}
    text = json.dumps({"vibupdate": version, "command": command, "case": case, "files": sorted(files),
                       "sha256": hashes}, indent=2) + "\n"
    name = manifest_name(command)
    tmp = folder / f"{name}.tmp"
    tmp.write_text(text, encoding="utf-8")
    os.replace(tmp, folder / name)


def add_to_manifest(folder, command: str, files: Iterable[str], *, case: str, version: str) -> None:
    """List ``files`` (written into ``folder`` by ``command`` outside `publish`) in the
    command's manifest, beside those already listed, with the hash of their content now (none
    for a file not written yet). Commands call it through `vibupdate.io.outputs.written_in_place`,
    which records the final hashes when the command ends."""
    folder = Path(folder)
    listed = read_manifests(folder).get(command, [])
    read = manifest_files(folder / manifest_name(command))
    hashes = recorded_hashes(read[1]) if read is not None else {}
    hashes.update({f: file_hash(folder / f) for f in files})
    write_manifest(folder, command, sorted(set(listed) | set(files)), case, version, hashes)
