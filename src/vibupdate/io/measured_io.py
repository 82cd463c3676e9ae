"""Reading measured modal data from files: CSV tables and Universal File Format dataset 55.

The columns of the frequency and mode-shape tables and the UFF direction names are those of
``docs/case-file.md`` (``frequencies_csv``, ``mode_shapes_csv``, ``mode_shapes_uff``); a
``mode`` or ``index`` left out defaults as `vibupdate.data.pairing` says. UFF is read through
pyuff: each record of dataset 55 (analysis type 2) is one mode, its header giving the
frequency (Hz) and the modal viscous damping ratio.
"""

from __future__ import annotations

import csv
import math
from pathlib import Path

import numpy as np


_UFF_DIRECTIONS = {"r1": "x", "r2": "y", "r3": "z", "r4": "rx", "r5": "ry", "r6": "phi"}


def not_utf8(data: bytes, exc: UnicodeDecodeError) -> str:
    """Where a file stops being UTF-8 text, as ``"line L: ..."``."""
    line = data.count(b"\n", 0, exc.start) + 1
    column = exc.start - (data.rfind(b"\n", 0, exc.start) + 1) + 1
    return f"line {line}: not UTF-8 text (byte 0x{data[exc.start]:02x} at column {column})"


def csv_rows(path: Path) -> list[tuple[int, dict]]:
    """Data rows of a CSV file with their line numbers; blank and ``#`` lines are skipped."""
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8-sig")   # "CSV UTF-8" from a spreadsheet starts with a byte-order mark
    except UnicodeDecodeError as exc:
        raise ValueError(f"{path}: {not_utf8(path.read_bytes(), exc)}") from None
    except OSError as exc:
        raise ValueError(f"CSV file {str(path)!r} could not be read: {exc}") from None
    numbered = [(k, line) for k, line in enumerate(text.splitlines(), start=1)
                if line.strip() and not line.lstrip().startswith("#")]
    if not numbered:
        raise ValueError(f"CSV file {str(path)!r} is empty")
    if "\0" in text:
        raise ValueError(f"CSV file {str(path)!r} holds NUL bytes: not a text table")
    try:
        table = list(csv.reader(line for _, line in numbered))
    except csv.Error as exc:
        raise ValueError(f"CSV file {str(path)!r} could not be read: {exc}") from None
    if len(table) != len(numbered):
        raise ValueError(f"{path}: a quoted field spans several lines; one row per line is expected")
    header = [h.strip() for h in table[0]]
    if len(set(header)) != len(header):
        raise ValueError(f"{path}: line {numbered[0][0]}: repeated column names in {header}")
    rows = []
    for (line, _), fields in zip(numbered[1:], table[1:]):
        if len(fields) > len(header):
            raise ValueError(f"{path}: row {line}: {len(fields)} fields for {len(header)} columns")
        fields = [f.strip() for f in fields] + [""] * (len(header) - len(fields))
        rows.append((line, dict(zip(header, fields))))
    return rows


#: The columns a frequency table may have (module docstring).
FREQUENCY_COLUMNS = ("kind", "hz", "weight", "damping_ratio", "response", "excitation", "mode", "index", "lower_hz",
                     "upper_hz", "damping_lower", "damping_upper")
#: The columns a mode-shape table may have.
SHAPE_COLUMNS = ("mode", "dof", "lower", "upper", "value", "tolerance")


def check_columns(rows, known, path: Path) -> None:
    """A ValueError naming a column that is none of ``known`` (a misspelt one would be ignored),
    with the closest known name."""
    import difflib

    for column in rows[0][1] if rows else ():
        if column not in known:
            close = difflib.get_close_matches(column, known, n=1)
            raise ValueError(f"CSV file {str(path)!r}: unknown column {column!r}"
                             + (f" (did you mean {close[0]!r}?)" if close else "")
                             + f"; expected columns among {', '.join(known)}")


def csv_number(text: str, what: str, path: Path, line: int) -> float:
    """The finite number in a CSV cell; a ValueError naming the file, row and column otherwise."""
    try:
        value = float(text)
    except ValueError:
        raise ValueError(f"{path}: row {line}: {what} must be a number, got {text!r}") from None
    if not math.isfinite(value):
        raise ValueError(f"{path}: row {line}: {what} must be finite, got {text!r}")
    return value


def _count(text: str | None, what: str, path: Path, line: int) -> int | None:
    """An optional 1-based integer column (a declared mode or zero index)."""
    if not text:
        return None
    value = csv_number(text, what, path, line)
    if value != int(value) or value < 1:
        raise ValueError(f"{path}: row {line}: {what} must be an integer >= 1, got {text!r}")
    return int(value)


def read_frequency_csv(path) -> tuple[list[dict], list[dict]]:
    """Natural frequencies and antiresonances from a CSV table (module docstring).

    Returns
    -------
    natural : list of dict
        ``{"hz", "weight", "damping_ratio", "mode", "interval", "damping_interval"}`` in file
        order (None where an optional column is empty; ``interval`` in Hz).
    antiresonances : list of dict
        ``{"hz", "weight", "response", "excitation", "index", "interval"}`` in file order.
    """
    path = Path(path)
    rows = csv_rows(path)
    for column in ("kind", "hz"):
        if rows and column not in rows[0][1]:
            raise ValueError(f"CSV file {str(path)!r} needs a column {column!r}; it has {list(rows[0][1])}")
    check_columns(rows, FREQUENCY_COLUMNS, path)
    natural, zeros = [], []
    seen: dict[tuple, int] = {}
    for i, row in rows:
        same = tuple(sorted(row.items()))
        if same in seen:
            raise ValueError(f"{path}: row {i}: duplicates row {seen[same]}")
        seen[same] = i
        kind = row["kind"].lower()
        hz = csv_number(row["hz"], "hz", path, i)
        weight = csv_number(row["weight"], "weight", path, i) if row.get("weight") else 1.0
        interval = _pair(row, ("lower_hz", "upper_hz"), hz, "hz", path, i)
        if kind == "natural":
            xi = row.get("damping_ratio")
            xi = csv_number(xi, "damping_ratio", path, i) if xi else None
            natural.append({"hz": hz, "weight": weight, "damping_ratio": xi,
                            "mode": _count(row.get("mode"), "mode", path, i), "interval": interval,
                            "damping_interval": _pair(row, ("damping_lower", "damping_upper"), xi, "damping_ratio",
                                                      path, i)})
        elif kind == "antiresonance":
            if not row.get("response") or not row.get("excitation"):
                raise ValueError(f"{path}: row {i}: an antiresonance needs 'response' and 'excitation' DOFs")
            if row.get("damping_lower") or row.get("damping_upper"):
                raise ValueError(f"{path}: row {i}: an antiresonance has no damping ratio; leave damping_lower and "
                                 "damping_upper empty")
            zeros.append({"hz": hz, "weight": weight, "response": row["response"], "excitation": row["excitation"],
                          "index": _count(row.get("index"), "index", path, i), "interval": interval})
        else:
            raise ValueError(f"{path}: row {i}: kind must be 'natural' or 'antiresonance', got {row['kind']!r}")
    return natural, zeros


def _pair(row: dict, columns: tuple[str, str], value, what: str, path: Path, line: int):
    """The interval in ``columns`` of a row, checked to hold ``value``; None when both are empty."""
    lo, hi = (row.get(c) or "" for c in columns)
    if not lo and not hi:
        return None
    if not lo or not hi:
        raise ValueError(f"{path}: row {line}: {columns[0]} and {columns[1]} go together; one of them is empty")
    if value is None:
        raise ValueError(f"{path}: row {line}: {columns[0]}/{columns[1]} given without {what}")
    a, b = csv_number(lo, columns[0], path, line), csv_number(hi, columns[1], path, line)
    if not a <= value <= b:
        raise ValueError(f"{path}: row {line}: the interval [{a:g}, {b:g}] ({columns[0]}, {columns[1]}) does not "
                         f"hold its {what} {value:g}")
    return (a, b)


def read_shape_csv(path, dofs=None) -> dict[int, dict[str, tuple[float, float]]]:
    """Mode-shape intervals from a CSV table: ``{mode (1-based): {dof: (lower, upper)}}``.
    ``dofs``, when given, are the model's DOF and sensor names: a row naming another is an error
    naming the file, the row and the closest names."""
    path = Path(path)
    known = None if dofs is None else set(dofs)
    rows = csv_rows(path)
    check_columns(rows, SHAPE_COLUMNS, path)
    columns = set(rows[0][1]) if rows else set()
    bounds_form = {"lower", "upper"} <= columns
    value_form = {"value", "tolerance"} <= columns
    if not {"mode", "dof"} <= columns or not (bounds_form or value_form):
        raise ValueError(
            f"CSV file {str(path)!r} needs columns mode, dof and lower, upper (or value, tolerance); "
            f"it has {sorted(columns)}"
        )
    shapes: dict[int, dict[str, tuple[float, float]]] = {}
    seen: dict[tuple[int, str], int] = {}
    for i, row in rows:
        mode = csv_number(row["mode"], "mode", path, i)
        if mode != int(mode) or mode < 1:
            raise ValueError(f"{path}: row {i}: mode must be an integer >= 1, got {row['mode']!r}")
        mode = int(mode)
        if not row["dof"]:
            raise ValueError(f"{path}: row {i}: dof is empty")
        if known is not None and row["dof"] not in known:
            import difflib

            near = difflib.get_close_matches(row["dof"], sorted(known), n=3)
            raise ValueError(f"{path}: row {i}: DOF {row['dof']!r} is not in the model"
                             + (f" (closest: {', '.join(near)})" if near else "")
                             + "; shapes name DOFs as the model does, or declared sensors")
        if (mode, row["dof"]) in seen:
            raise ValueError(f"{path}: row {i}: mode {mode}, dof {row['dof']!r} is also given in row "
                             f"{seen[(mode, row['dof'])]}")
        seen[(mode, row["dof"])] = i
        if bounds_form:
            lo, hi = csv_number(row["lower"], "lower", path, i), csv_number(row["upper"], "upper", path, i)
        else:
            v, t = csv_number(row["value"], "value", path, i), csv_number(row["tolerance"], "tolerance", path, i)
            if t < 0:
                raise ValueError(f"{path}: row {i}: tolerance must be >= 0, got {t}")
            lo, hi = v - t, v + t
        if lo > hi:
            raise ValueError(f"{path}: row {i}: mode-shape interval for {row['dof']!r} has lower {lo:g} > upper {hi:g}")
        shapes.setdefault(mode, {})[row["dof"]] = (lo, hi)
    return shapes


class UffMode(dict):
    """One mode of a UFF dataset 55: keys ``hz``, ``damping_ratio`` (or None), ``values``
    (``{dof name: value}``)."""


def read_uff_modes(path) -> list[UffMode]:
    """Normal modes from the dataset-55 records of a UFF file, in file order."""
    from vibupdate.data.frf import uff_records

    modes = []
    for _, record in uff_records(Path(path), 55, "mode shapes"):
        if int(record.get("analysis_type", 0)) != 2:
            continue
        nodes = np.asarray(record["node_nums"]).astype(int)
        values = {}
        for key, prefix in _UFF_DIRECTIONS.items():
            if key in record and record[key] is not None:
                data = np.real(np.asarray(record[key], dtype=complex))
                values.update({f"{prefix}{n}": float(v) for n, v in zip(nodes, data)})
        damping = record.get("modal_damp_vis")
        modes.append(UffMode(hz=float(record["freq"]), values=values,
                             damping_ratio=float(damping) if damping else None))
    if not modes:
        raise ValueError(f"UFF file {str(path)!r} has dataset 55 records but none of normal modes (analysis type 2)")
    return modes
