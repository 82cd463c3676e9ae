"""Export sets of the space frame for each FE route and the exact-data case around an import:
shared by the tests of `vibupdate import`."""

from __future__ import annotations

from pathlib import Path

import numpy as np

import fe_writers
from vibupdate.examples.frame3d import NOMINAL, frame3d

#: Parameters of the known-truth runs: (name, unit, lower, upper factor), step = 10 % of nominal.
AFFINE = ("E_col", "E_beam", "rho_col", "m_floor", "k_base")
TRUTH = {"E_col": 1.08, "E_beam": 0.93, "rho_col": 1.05, "m_floor": 0.96, "k_base": 1.2, "d_beam": 1.04}
UNITS = {"E_col": "Pa", "E_beam": "Pa", "rho_col": "kg/m^3", "m_floor": "kg/m^2", "k_base": "N m/rad", "d_beam": "m"}


#: The HBMAT layouts of the ``ansys-*`` routes: MAPDL's own (one number a line, D exponents), with a
#: right-hand side, and with repeat counts, E exponents and the upper triangle.
MAPDL_LAYOUTS = {"ansys-mapdl": {}, "ansys-mapdl-rhs": {"rhs": True},
                 "ansys-mapdl-e4": {"exponent": "E", "per_line": 4, "triangle": "upper"}}


#: The *MATRIX INPUT layouts of the ``abaqus-*`` routes (``abaqus``: the lower triangle, no zeros).
ABAQUS_LAYOUTS = {"abaqus-square-zeros": {"layout": "square", "zeros": True},
                  "abaqus-upper-zeros": {"layout": "upper", "zeros": True}}


def write_export(route: str, folder: Path, frame, values) -> str:
    """One export of ``frame`` at ``values`` as ``route`` writes it; returns its path in the import file."""
    if route == "abaqus":
        K, M = frame.matrices(values, constrained=True)
        fe_writers.write_abaqus(folder, K, M, frame.all_dofs)
        return folder.name
    if route in ABAQUS_LAYOUTS:
        K, M = frame.matrices(values, constrained=True)
        fe_writers.write_abaqus_layout(folder, K, M, frame.all_dofs, **ABAQUS_LAYOUTS[route])
        return folder.name
    K, M = frame.matrices(values)
    if route.startswith("nastran"):
        field = route.split("-")[1] if "-" in route else "free"
        fe_writers.write_dmig(folder.with_suffix(".pch"), K, M, frame.dofs, field)
        return folder.with_suffix(".pch").name
    if route in MAPDL_LAYOUTS:
        fe_writers.write_mapdl_hbmat(folder, K, M, frame.dofs, **MAPDL_LAYOUTS[route])
        return folder.name
    fe_writers.write_hbmat(folder, K, M, frame.dofs)
    return folder.name


def write_export_set(route: str, root: Path, frame, names=AFFINE, two_steps=(), sensors: str = "") -> Path:
    """Nominal export, one per parameter (+10 %, 5 % for ``d_beam``; a second step of the opposite
    sign for ``two_steps``) and the import file."""
    root.mkdir(parents=True, exist_ok=True)
    nominal = write_export(route, root / "nominal", frame, {})
    fmt = route.split("-")[0]
    lines = [f'format = "{fmt}"', f'nominal = "{nominal}"']
    if fmt == "abaqus":
        fixed = sorted(set(frame.all_dofs) - set(frame.dofs))
        lines.append("fix = [" + ", ".join(f'"{d}"' for d in fixed) + "]")
    lines.append(sensors)
    for name in names:
        p0, rel = NOMINAL[name], 0.05 if name == "d_beam" else 0.1
        export = write_export(route, root / f"{name}_plus", frame, {name: p0 + rel * p0})
        lines += ["[[parameter]]", f'name = "{name}"', f'unit = "{UNITS[name]}"', f"nominal = {p0!r}",
                  f"lower = {0.5 * p0!r}", f"upper = {1.5 * p0!r}", f"step = {rel * p0!r}", f'export = "{export}"']
        if name in two_steps:
            export2 = write_export(route, root / f"{name}_minus", frame, {name: p0 - rel * p0})
            lines += [f"step2 = {-rel * p0!r}", f'export2 = "{export2}"']
    (root / "import.toml").write_text("\n".join(lines) + "\n")
    return root / "import.toml"


def measured_dofs(frame, stories: int):
    """x and y at every roof corner node and z at two of them: the sensors of the runs."""
    top = [n for n in frame.nodes if n // 1000 == stories and frame.nodes[n][2] == stories * 3.5]
    corners = sorted(top)[:4]
    return [f"{n}:{d}" for n in corners for d in ("x", "y")] + [f"{corners[0]}:z", f"{corners[-1]}:z"]


def run_inputs(model_dir: Path) -> dict[str, bytes]:
    """Every file of an imported model's folder (the model, its matrices, the case and data
    `exact_case` writes), as bytes: all that a run on the folder reads. Two folders with the same
    bytes give the same run (one process thread, no randomness), so a test checking several
    routes runs the update once per distinct folder."""
    return {p.name: p.read_bytes() for p in sorted(model_dir.iterdir()) if p.is_file()}


def exact_case(model_dir: Path, K, M, dofs, measured, n_modes=6) -> Path:
    """Case file: the imported ``model.toml`` plus one configuration of exact data from (K, M)."""
    from vibupdate.modal.analysis import modes

    omega, phi = modes(M, K, n_modes)[:2]
    index = {d: k for k, d in enumerate(dofs)}
    rows = ["mode,dof,value,tolerance"] + [f"{k + 1},{d},{float(phi[index[d], k])!r},0"
                                           for k in range(n_modes) for d in measured]
    (model_dir / "shapes.csv").write_text("\n".join(rows) + "\n")
    hz = ", ".join(repr(float(w / (2 * np.pi))) for w in omega)
    text = (f'case = "frame3d"\n' + (model_dir / "model.toml").read_text()
            + f'\n[[configuration]]\nname = "test"\nnatural_hz = [{hz}]\nmode_shapes_csv = "shapes.csv"\n')
    (model_dir / "case.toml").write_text(text)
    return model_dir / "case.toml"
