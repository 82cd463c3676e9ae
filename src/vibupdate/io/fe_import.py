"""``vibupdate import``: an FE code's export set -> the ``[model]`` of a case file and its files.

The *import file* (TOML) is ``docs/fe-models.md`` ("Import file"). `import_model` reads the
exports (`vibupdate.model.fe`), forms the affine model (`vibupdate.model.fe.perturbed`) and
writes ``model.toml`` (a ``[model]`` of ``type = "matrices"`` and its ``[[parameter]]``
tables) with ``M0.npz``, ``K0.npz``, ``dM_<name>.npz``, ``dK_<name>.npz`` and, when known,
``nodes.csv`` / ``sensors.csv``, into a temporary folder beside the target moved into place
at the end, so a bad export leaves nothing behind.
"""

from __future__ import annotations

import json
import shutil
import tempfile
import tomllib
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np
import scipy.sparse as sp

from vibupdate.io.case_keys import Where, check_table
from vibupdate.model.fe.export import FEExport, without_dofs
from vibupdate.model.fe.perturbed import Perturbation, affine_from_exports
from vibupdate.model.fe.oblique import coordinate_change, congruent, direction_text, translation_masses
from vibupdate.model.fe.sensors import place
from vibupdate.model.parameters import Parameter


FORMATS = ("nastran", "ansys", "abaqus", "opensees")
_TOP = {"format": str, "nominal": None, "builder": str, "fix": list, "stiffness": str, "mass": str,
        "nodes": str, "parameter": list, "sensor": list}
_PARAMETER = {"name": str, "unit": str, "nominal": float, "lower": float, "upper": float, "reference": float,
              "step": float, "export": None, "step2": float, "export2": None}
_SENSOR = {"name": str, "dof": str, "position": list, "direction": list}


@dataclass(frozen=True)
class ImportedModel:
    """What an import file describes, read and checked.

    Attributes
    ----------
    model : AffineModel
        In the coordinates the sensors read: the export's, with an oblique DOF in place of one
        translation per oblique sensor direction.
    nominal : FEExport
        As exported.
    derivatives : tuple of Derivative
        In the model's coordinates.
    sensors : tuple of Sensor
        Where each sensor of the import file measures on the mesh: the DOF it reads, its
        sign, its distance from the position given (`vibupdate.model.fe.sensors.Sensor`).
    obliques : tuple of Oblique
        The model's oblique DOFs.
    """

    model: object
    nominal: FEExport
    derivatives: tuple
    sensors: tuple
    obliques: tuple = ()

    @property
    def directions(self) -> dict:
        """Oblique DOF -> its unit direction (3,)."""
        return {o.dof: o.direction for o in self.obliques}


def _export(fmt: str, where_key: str, item, spec: dict, base: Path, where: Where, values=None) -> FEExport:
    """One export of the set, as an `FEExport` with the ``fix`` DOFs removed."""
    if fmt == "opensees":
        from vibupdate.io.case_model import load_callable
        from vibupdate.model.fe.opensees import export_from_builder, openseespy

        openseespy()   # the optional extra, or MissingExtra naming it
        func = load_callable(spec["builder"], base, Where(where.path))

        def build(p):
            try:
                func(p)
            except Exception as exc:  # the user's OpenSees code: whatever it raises is bad input, named
                raise where.error("builder", f"{spec['builder']} raised {type(exc).__name__}: {exc}") from None

        try:
            export = export_from_builder(build, values, name=spec["builder"])
        except ValueError:
            raise
        except Exception as exc:  # OpenSees refusing to assemble the model the builder made
            raise where.error("builder", f"OpenSees could not assemble the model of {spec['builder']}: "
                                         f"{type(exc).__name__}: {exc}") from None
    elif fmt == "nastran":
        from vibupdate.model.fe.nastran import read_dmig

        if not isinstance(item, str):
            raise where.error(where_key, f"a Nastran export is the punch file's path, got {item!r}")
        export = read_dmig(base / item, spec.get("stiffness", "KAAX"), spec.get("mass", "MAAX"))
    elif fmt == "ansys":
        from vibupdate.model.fe.ansys import read_full, read_hbmat

        if isinstance(item, str) and item.lower().endswith(".full"):
            export = read_full(base / item)
        else:
            files = _files(item, {"K": "K.matrix", "M": "M.matrix", "mapping": "K.mapping"}, base, where_key, where)
            export = read_hbmat(files["K"], files["M"], files["mapping"])
    else:
        from vibupdate.model.fe.abaqus import read_abaqus

        files = _files(item, {"K": "*_STIF*.mtx", "M": "*_MASS*.mtx"}, base, where_key, where)
        export = read_abaqus(files["K"], files["M"])
    return without_dofs(export, spec.get("fix", [])) if spec.get("fix") else export


def _files(item, defaults: dict, base: Path, key: str, where: Where) -> dict:
    """Files of an export given as a folder (default names) or a table of paths."""
    if isinstance(item, dict):
        check_table(item, {k: str for k in defaults}, key, where, required=tuple(defaults))
        return {k: base / v for k, v in item.items()}
    if not isinstance(item, str):
        raise where.error(key, f"an export is a folder or a table of files ({', '.join(defaults)}), got {item!r}")
    folder = base / item
    if not folder.is_dir():
        raise where.error(key, f"export folder {str(folder)!r} does not exist")
    out = {}
    for k, pattern in defaults.items():
        found = sorted(folder.glob(pattern))
        if len(found) != 1:
            raise where.error(key, f"folder {str(folder)!r} must hold one file {pattern}, found {len(found)}")
        out[k] = found[0]
    return out


def check_import(spec: dict, where: Where) -> list[tuple[Parameter, dict]]:
    """Check the tables of an import file (not its exports); returns each parameter with its table."""
    check_table(spec, _TOP, "import", where, required=("format", "parameter"))
    fmt = spec["format"]
    if fmt not in FORMATS:
        raise where.error("format", f"must be one of {', '.join(FORMATS)}, got {fmt!r}")
    if fmt == "opensees" and "builder" not in spec:
        raise where.error("builder", "an OpenSees import needs builder = 'file.py:function'")
    if fmt != "opensees" and "nominal" not in spec:
        raise where.error("nominal", "the nominal export is required")
    out = []
    for i, item in enumerate(spec["parameter"], start=1):
        key = f"parameter[{i}]"
        check_table(item, _PARAMETER, key, where, required=("name", "nominal", "lower", "upper", "step")
                    + (() if fmt == "opensees" else ("export",)))
        if fmt != "opensees" and ("step2" in item) != ("export2" in item):
            raise where.error(key, "a second perturbation needs both step2 and export2")
        try:
            p = Parameter(item["name"], item["nominal"], item["lower"], item["upper"], item.get("unit", ""),
                          item.get("reference"))
        except ValueError as exc:
            raise where.error(key, str(exc)) from None
        out.append((p, item))
    for i, item in enumerate(spec.get("sensor", []), start=1):
        check_table(item, _SENSOR, f"sensor[{i}]", where, required=("name",))
    return out


def read_import(path) -> ImportedModel:
    """Read and check the import file ``path`` and every export it names."""
    path = Path(path)
    where = Where(path)
    if not path.is_file():
        raise ValueError(f"import file {str(path)!r} does not exist")
    try:
        spec = tomllib.loads(path.read_text())
    except tomllib.TOMLDecodeError as exc:
        raise ValueError(f"{path}: not valid TOML: {exc}") from None
    checked = check_import(spec, where)
    params, rows = [p for p, _ in checked], [item for _, item in checked]
    fmt, base = spec["format"], path.parent
    nominal_values = {p.name: p.nominal for p in params}
    nominal = _export(fmt, "nominal", spec.get("nominal"), spec, base, where, nominal_values)
    perts = []
    for i, (p, item) in enumerate(zip(params, rows), start=1):
        exports = []
        for step_key, export_key in (("step", "export"), ("step2", "export2")):
            if step_key not in item:
                exports.append(None)
                continue
            values = {**nominal_values, p.name: p.nominal + item[step_key]}
            exports.append(_export(fmt, f"parameter[{i}].{export_key}", item.get(export_key), spec, base, where,
                                   values))
        perts.append(Perturbation(p, item["step"], exports[0], item.get("step2"), exports[1]))
    model, ders = affine_from_exports(nominal, perts)
    if "nodes" in spec:
        nominal = replace(nominal, nodes={**nominal.nodes, **_read_nodes(base / spec["nodes"], where)})
    sensors, obliques = place(spec.get("sensor", []), nominal.dofs, nominal.nodes, where.error)
    if obliques:
        model, ders = _in_coordinates(model, ders, obliques)
    return ImportedModel(model, nominal, ders, sensors, obliques)


def _in_coordinates(model, ders, obliques):
    """The affine model and its derivatives with the oblique DOFs (`vibupdate.model.fe.oblique`)."""
    T, dofs = coordinate_change(model.dofs, obliques)
    model = replace(model, dofs=dofs, M0=congruent(model.M0, T), K0=congruent(model.K0, T),
                    M_par=tuple(congruent(A, T) for A in model.M_par),
                    K_par=tuple(congruent(A, T) for A in model.K_par))
    return model, tuple(d.in_coordinates(T, dofs) for d in ders)


def _read_nodes(path: Path, where: Where) -> dict:
    """Node label -> coordinates (m) from a CSV file with columns ``node, x, y, z``."""
    import csv

    if not path.is_file():
        raise where.error("nodes", f"node file {str(path)!r} does not exist")
    nodes = {}
    with path.open(newline="") as handle:
        for number, row in enumerate(csv.DictReader(handle), start=2):
            try:
                nodes[str(int(row["node"]))] = np.array([float(row[k]) for k in ("x", "y", "z")])
            except (KeyError, TypeError, ValueError):
                raise where.error("nodes", f"{path}: line {number}: expected columns node, x, y, z (numbers), got "
                                           f"{row}") from None
    return nodes


def _model_toml(imported: ImportedModel, source: str) -> str:
    m = imported.model
    lines = [f"# [model] and [[parameter]] written by `vibupdate import {source}`; add `case = ...` above and the",
             "# [[configuration]] tables below (docs/case-file.md)", "[model]", 'type = "matrices"',
             'M0 = "M0.npz"', 'K0 = "K0.npz"'] + (['sensors = "sensors.csv"'] if imported.sensors else []) + (
             [f"matrix_precision = {m.matrix_precision!r}   # relative precision of the numbers the exports wrote"]
             if m.matrix_precision is not None else []) + [
             f"dofs = {json.dumps(list(m.dofs))}", "", "[model.dM]"]
    lines += [f'{d.name} = "dM_{d.name}.npz"' for d in imported.derivatives if d.dM.nnz]
    lines += ["", "[model.dK]"] + [f'{d.name} = "dK_{d.name}.npz"' for d in imported.derivatives if d.dK.nnz]
    for p, d in zip(m.parameters, imported.derivatives):
        note = "" if d.departure is None else f"   # departure from affine {d.departure:.3g} ({d.scheme})"
        lines += ["", "[[parameter]]" + note, f'name = "{p.name}"', f'unit = "{p.unit}"', f"nominal = {p.nominal!r}",
                  f"lower = {p.lower!r}", f"upper = {p.upper!r}"]
        if p.reference != p.nominal:
            lines.append(f"reference = {p.reference!r}")
    return "\n".join(lines) + "\n"


def import_model(path, out) -> ImportedModel:
    """Read an import file and write the model files into a new folder (docs/fe-models.md).

    A failed import leaves no partial folder.

    Parameters
    ----------
    path : str or Path
        The import file (TOML) naming the FE exports and the parameters.
    out : str or Path
        The new folder: it must not exist or be empty. It receives ``M0.npz``, ``K0.npz``,
        the ``dM_*.npz``/``dK_*.npz`` parameter matrices, ``model.toml`` and, when the exports
        have them, ``nodes.csv`` and ``sensors.csv``.

    Returns
    -------
    ImportedModel
        The model, the nominal export, the parameter derivatives and the sensors, as read.

    Raises
    ------
    ValueError
        ``out`` exists and is not an empty folder, or the import file or an export cannot be
        read or fails its checks.
    """
    out = Path(out)
    if out.exists() and (not out.is_dir() or any(out.iterdir())):
        raise ValueError(f"output folder {str(out)!r} exists and is not empty; name a new folder")
    imported = read_import(path)
    out.parent.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(prefix=".vibupdate-import-", dir=out.parent))
    try:
        m = imported.model
        sp.save_npz(tmp / "M0.npz", sp.csr_matrix(m.M0))
        sp.save_npz(tmp / "K0.npz", sp.csr_matrix(m.K0))
        for d in imported.derivatives:
            if d.dM.nnz:
                sp.save_npz(tmp / f"dM_{d.name}.npz", d.dM)
            if d.dK.nnz:
                sp.save_npz(tmp / f"dK_{d.name}.npz", d.dK)
        (tmp / "model.toml").write_text(_model_toml(imported, Path(path).name))
        if imported.nominal.nodes:
            rows = ["node,x,y,z"] + [f"{k}," + ",".join(repr(float(c)) for c in np.resize(v, 3))
                                     for k, v in imported.nominal.nodes.items()]
            (tmp / "nodes.csv").write_text("\n".join(rows) + "\n")
        if imported.sensors:
            (tmp / "sensors.csv").write_text(sensors_csv(imported.sensors))
        if out.exists():
            out.rmdir()
        tmp.rename(out)
    finally:
        if tmp.exists():
            shutil.rmtree(tmp)
    return imported


def sensors_csv(sensors) -> str:
    """``sensors.csv``: one row per sensor, its direction to full precision (the oblique DOFs'
    directions are read back from it)."""
    import csv
    import io

    out = io.StringIO()
    table = csv.writer(out, lineterminator="\n")   # a name with a comma or a quote is quoted
    table.writerow(["sensor", "dof", "sign", "distance_m", "nx", "ny", "nz"])
    for s in sensors:
        along = ["", "", ""] if s.direction is None else [repr(float(c) + 0.0) for c in s.direction]
        table.writerow([s.name, s.dof, f"{s.sign:g}", f"{s.distance:.6g}", *along])
    return out.getvalue()


#: A sensor placed farther from its node than this fraction of the mesh's extent (the diagonal
#: of the nodes' bounding box) is warned about: on a mesh it should sit on the structure, and a
#: position in millimetres or in another coordinate system lands far from every node.
FAR_SENSOR = 0.1


def _mesh_span(nodes) -> float:
    """Diagonal of the bounding box of the nodes' coordinates, m (0 without nodes)."""
    if not nodes:
        return 0.0
    xyz = np.array([np.resize(np.asarray(v, dtype=float), 3) for v in nodes.values()])
    return float(np.linalg.norm(xyz.max(axis=0) - xyz.min(axis=0)))


def summary_lines(imported: ImportedModel, n_modes: int = 6) -> list[str]:
    """Model size, total mass, rigid-body modes, first frequencies and each parameter's group and
    departure from affine: what to compare with the FE code's own output."""
    from vibupdate.modal.analysis import massless_dofs, modes
    from vibupdate.model.physical import definiteness

    m = imported.model
    M, K = sp.csr_matrix(m.M0), sp.csr_matrix(m.K0)
    lines = [f"model: {m.n_dofs} DOFs, {len(massless_dofs(M))} without mass; {len(m.parameters)} parameter(s)"]
    lines += [f"note: {note}" for note in imported.nominal.notes]
    for axis, mass in translation_masses(M, m.dofs, imported.directions).items():
        lines.append(f"mass moving with a unit {axis} translation: {mass or 0.0:.6g} kg")
    if m.matrix_precision is not None:
        lines.append(f"matrix precision: {m.matrix_precision:.3g} (relative; the digits the exports were written with)")
    state = definiteness(M, K, m.matrix_precision)
    lines.append(f"rigid-body modes: {state.rigid_body_modes}" + (f" ({state.problem})" if state.problem else ""))
    omega = modes(M, K, min(n_modes + state.rigid_body_modes, m.n_dofs - len(massless_dofs(M))),
                  precision=m.matrix_precision)[0]
    lines.append("first frequencies (Hz): " + ", ".join(f"{w / (2 * np.pi):.6g}" for w in omega))
    for d in imported.derivatives:
        how = "one step, affinity not checked" if d.departure is None else \
            f"departure from affine {d.departure:.3g} ({'affine' if d.affine else 'NOT affine: linearized'} " \
            f"at the nominal, {d.scheme} difference)"
        shown = ", ".join(d.nodes[:8]) + (" ..." if len(d.nodes) > 8 else "")
        lines.append(f"parameter {d.name}: moves {len(d.dofs)} DOFs at {len(d.nodes)} node(s) [{shown}]; {how}")
    span = _mesh_span(imported.nominal.nodes)
    for s in imported.sensors:
        lines.append(f"sensor {s.name}: {'-' if s.sign < 0 else ''}{s.dof} ({s.distance:.3g} m from the position)")
        if span > 0 and s.distance > FAR_SENSOR * span:
            lines.append(f"warning: sensor {s.name} is {s.distance:.3g} m from its node, {s.distance / span:.2g} times "
                         f"the mesh's extent ({span:.3g} m): is its position in the model's units and coordinate "
                         "system?")
    for o in imported.obliques:
        lines.append(f"oblique DOF {o.dof} in place of {o.replaces}: the node's translation along "
                     f"{direction_text(o.direction)}")
    return lines
