"""The sensors of a case file: ``[[sensor]]`` tables and a ``sensors`` CSV file, each sensor a
name and DOF weights, or a point of a rigid body (its reference DOFs, the sensor's offset and
direction), read into `vibupdate.model.measurement.Sensor` s (``docs/sensors.md``). Errors
name the file and the key (`vibupdate.io.case_keys`); the DOFs are checked against the model
where the sensors are attached to it (`vibupdate.model.affine.with_sensors`).
"""

from __future__ import annotations

from pathlib import Path

from vibupdate.io.case_keys import Where, check_table
from vibupdate.model.measurement import RIGID_DOFS, Sensor, rigid_weights


SENSOR_KEYS = {"name": str, "dofs": dict, "rigid": dict, "offset": list, "direction": None}

#: A direction given by its axis name, as a layout sheet writes it.
_AXES = {"x": (1.0, 0.0, 0.0), "y": (0.0, 1.0, 0.0), "z": (0.0, 0.0, 1.0)}


def case_sensors(data: dict, base: Path, where: Where) -> tuple[Sensor, ...]:
    """The sensors of a case file: its ``[[sensor]]`` tables, then the rows of its ``sensors``
    CSV file; a name given twice (in either or across both) is an error."""
    tables = data.get("sensor", [])
    if not isinstance(tables, list):
        raise where.error("sensor", f"must be an array of tables ([[sensor]]), got {tables!r}")
    out = [_table(item, i, where) for i, item in enumerate(tables, start=1)]
    if "sensors" in data:
        try:
            out += read_sensor_csv(base / data["sensors"])
        except ValueError as exc:
            raise where.error("sensors", str(exc)) from None
    seen = set()
    for s in out:
        if s.name in seen:
            raise where.error("sensor", f"sensor {s.name!r} is declared twice; give each sensor one name")
        seen.add(s.name)
    return tuple(out)


def _table(item, i: int, where: Where) -> Sensor:
    key = f"sensor[{i}]"
    if not isinstance(item, dict):
        raise where.error(key, f"must be a table, got {item!r}")
    check_table(item, SENSOR_KEYS, key, where, required=("name",))
    given = [k for k in ("dofs", "rigid") if k in item]
    if len(given) != 1:
        raise where.error(key, "needs either dofs = {\"<dof>\" = <weight>, ...} or rigid = {x = \"<dof>\", ...} "
                               "with offset and direction" + (" (not both)" if given else ""))
    try:
        if "dofs" in item:
            extra = [k for k in ("offset", "direction") if k in item]
            if extra:
                raise ValueError(f"{', '.join(extra)} belong to a rigid-body sensor (rigid = {{...}}), not to one "
                                 "given by DOF weights")
            return Sensor(item["name"], tuple(item["dofs"].items()))
        missing = [k for k in ("offset", "direction") if k not in item]
        if missing:
            raise ValueError(f"a rigid-body sensor needs offset (m from the reference point) and direction; "
                             f"missing {', '.join(missing)}")
        bad = [v for v in item["rigid"].values() if not isinstance(v, str)]
        if bad:
            raise ValueError(f"rigid maps {', '.join(RIGID_DOFS)} to DOF names, got {bad[0]!r}")
        return Sensor(item["name"], tuple(rigid_weights(item["rigid"], item["offset"],
                                                        _direction(item["direction"])).items()))
    except ValueError as exc:
        raise where.error(f"{key} ({item['name']!r})", str(exc)) from None


def _direction(value):
    """A direction: 2 or 3 numbers, or an axis name with an optional sign (``"x"``, ``"-y"``)."""
    if isinstance(value, str):
        axis = value.strip().lower()
        sign = -1.0 if axis.startswith("-") else 1.0
        axis = axis.lstrip("+-")
        if axis not in _AXES:
            raise ValueError(f"direction is an axis (x, y, z, -x, -y, -z) or 2 or 3 numbers, got {value!r}")
        return [sign * c for c in _AXES[axis]]
    return value


#: The columns of a sensors CSV of rigid-body sensors: the body's reference DOFs by kind, the
#: offset (m) and the direction (an axis name, or nx, ny and optionally nz).
RIGID_COLUMNS = ("sensor", *RIGID_DOFS, "offset_x", "offset_y", "offset_z", "direction", "nx", "ny", "nz")
WEIGHT_COLUMNS = ("sensor", "dof", "weight")


def read_sensor_csv(path: Path) -> list[Sensor]:
    """Sensors from a CSV file in one of two layouts (``docs/sensors.md``): rows ``sensor,
    dof, weight``, one per DOF a sensor reads, a sensor's rows together; or one row per
    rigid-body sensor, columns `RIGID_COLUMNS` (the reference DOFs it needs, ``offset_x``,
    ``offset_y``, and ``direction`` or ``nx``, ``ny``), as a layout sheet lists them."""
    from vibupdate.io.measured_io import check_columns, csv_rows

    rows = csv_rows(path)
    rigid = bool(rows) and "offset_x" in rows[0][1]
    check_columns(rows, RIGID_COLUMNS if rigid else WEIGHT_COLUMNS, path)
    return _rigid_rows(rows, path) if rigid else _weight_rows(rows, path)


def _weight_rows(rows, path: Path) -> list[Sensor]:
    from vibupdate.io.measured_io import csv_number

    weights: dict[str, list] = {}
    last = None
    for line, row in rows:
        missing = [c for c in WEIGHT_COLUMNS if not row.get(c)]
        if missing:
            raise ValueError(f"{path}: row {line}: needs columns sensor, dof, weight (or a rigid body's, with "
                             f"offset_x); missing or empty {', '.join(missing)}")
        name = row["sensor"]
        if name in weights and name != last:
            raise ValueError(f"{path}: row {line}: sensor {name!r} is declared twice (its rows are not together); "
                             "give each sensor one name")
        weights.setdefault(name, []).append((row["dof"], csv_number(row["weight"], "weight", path, line)))
        last = name
    return [Sensor(name, tuple(pairs)) for name, pairs in weights.items()]


def _rigid_rows(rows, path: Path) -> list[Sensor]:
    from vibupdate.io.measured_io import csv_number

    out = []
    for line, row in rows:
        missing = [c for c in ("sensor", "offset_x", "offset_y") if not row.get(c)]
        if missing:
            raise ValueError(f"{path}: row {line}: a rigid-body sensor needs sensor, offset_x, offset_y; missing or "
                             f"empty {', '.join(missing)}")
        offset = [csv_number(row[c], c, path, line) for c in ("offset_x", "offset_y", "offset_z") if row.get(c)]
        if row.get("direction"):
            direction = _direction(row["direction"])
        elif row.get("nx") and row.get("ny"):
            direction = [csv_number(row[c], c, path, line) for c in ("nx", "ny", "nz") if row.get(c)]
        else:
            raise ValueError(f"{path}: row {line}: sensor {row['sensor']!r} needs its direction (column direction, "
                             "or nx, ny and optionally nz)")
        reference = {k: row[k] for k in RIGID_DOFS if row.get(k)}
        try:
            out.append(Sensor(row["sensor"], tuple(rigid_weights(reference, offset, direction).items())))
        except ValueError as exc:
            raise ValueError(f"{path}: row {line}: sensor {row['sensor']!r}: {exc}") from None
    return out
