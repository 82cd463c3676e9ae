"""Worked examples of the FE-code route: ``vibupdate example fe-<code> --out DIR`` (one page per
code under docs/fe/).

Each writes what a user would have after exporting a model from the code and measuring the
structure: ``DIR/exports/``, the export set of the space frame of `vibupdate.examples.frame3d`
(`SIZE`) in the code's own format (`vibupdate.examples.fe_writers`, no FE code is run; for
OpenSees the builder file ``frame_ops.py``) with ``import.toml``; ``DIR/measured/``, the
`N_MODES` frequencies and shapes of the frame at the known `truth`, rounded as a test report
gives them (`FREQUENCY_DIGITS`, `SHAPE_DECIMALS`). `commands` gives the ``vibupdate import``
and ``vibupdate run`` command lines that update it (`write_case` makes the case file between
them, as docs/fe-models.md says to).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from vibupdate.examples import new_folder
from vibupdate.examples.frame3d import NOMINAL, STOREY, frame3d


#: Example name -> the import file's ``format``.
CODES = {"fe-nastran": "nastran", "fe-ansys": "ansys", "fe-abaqus": "abaqus", "fe-opensees": "opensees"}
#: Bays in x, in y, storeys: coarser than the 1,020-DOF fixture so each example runs in seconds.
SIZE = (2, 1, 2)
#: Updating parameters and their units (the affine ones of `frame3d`).
PARAMETERS = {"E_col": "Pa", "E_beam": "Pa", "rho_col": "kg/m^3", "m_floor": "kg/m^2", "k_base": "N m/rad"}
#: True value / nominal value of each parameter: what the "measured" structure is.
TRUTH_FACTOR = {"E_col": 1.08, "E_beam": 0.93, "rho_col": 1.05, "m_floor": 0.96, "k_base": 1.2}
#: Measured modes.
N_MODES = 8
#: Significant digits of the measured frequencies and decimals of the shapes (scaled to 1 at
#: their largest reading), each tolerance one unit of the last digit written; model-form
#: tolerances of 0, the data being made from the model family itself (docs/fe-models.md).
FREQUENCY_DIGITS = 6
FREQUENCY_TOLERANCE = 10.0 ** (1 - FREQUENCY_DIGITS)
SHAPE_DECIMALS = 4
SHAPE_TOLERANCE = 10.0 ** -SHAPE_DECIMALS
MODEL_FORM = {"natural_tolerance": 0.0, "shape_tolerance": 0.0}
#: Relative step of every export; ``E_col`` gets a second export at minus this step.
STEP = 0.1
TWO_STEPS = ("E_col",)


def truth() -> dict[str, float]:
    """The true parameter values (SI units of `PARAMETERS`)."""
    return {name: NOMINAL[name] * TRUTH_FACTOR[name] for name in PARAMETERS}


def sensors(frame=None) -> list[str]:
    """The measured DOFs: x and y at the first four roof nodes over columns (2001-2004 at the default
    size), z at the first and last of them."""
    frame = frame or frame3d(*SIZE)
    roof = SIZE[2] * STOREY
    corners = sorted(n for n in frame.nodes if n // 1000 == SIZE[2] and frame.nodes[n][2] == roof)[:4]
    return [f"{n}:{d}" for n in corners for d in ("x", "y")] + [f"{corners[0]}:z", f"{corners[-1]}:z"]


def _export(code: str, folder: Path, values: dict) -> str:
    """One export of the frame at ``values`` as ``code`` writes it; its path in the import file."""
    from vibupdate.examples import fe_writers

    frame = frame3d(*SIZE)
    if code == "abaqus":
        # *MATRIX GENERATE writes the matrices before the boundary conditions: the base too
        K, M = frame.matrices(values, constrained=True)
        fe_writers.write_abaqus(folder, K, M, frame.all_dofs, job="frame")
        return folder.name
    K, M = frame.matrices(values)
    if code == "nastran":
        nodes = {label: tuple(map(float, xyz)) for label, xyz in frame.nodes.items()}
        fe_writers.write_dmig(folder.with_suffix(".pch"), K, M, frame.dofs, "large", nodes)
        return folder.with_suffix(".pch").name
    fe_writers.write_hbmat(folder, K, M, frame.dofs)
    return folder.name


def _sensor_lines(code: str) -> list[str]:
    """The ``sensor`` array of the import file (before the ``[[parameter]]`` tables, as TOML needs)."""
    frame = frame3d(*SIZE)
    lines = ["sensor = ["]
    for dof in sensors(frame):
        node, direction = dof.split(":")
        where = f'dof = "{dof}"'
        if code == "nastran" and direction == "z":
            # placed by position: the GRID cards of the punch give the nearest node
            x, y, z = (float(c) for c in frame.nodes[int(node)])
            where = f"position = [{x!r}, {y!r}, {z!r}], direction = [0.0, 0.0, 1.0]"
        lines.append(f'  {{ name = "roof-{node}-{direction}", {where} }},')
    return lines + ["]"]


def _write_import(code: str, folder: Path) -> Path:
    """The exports (or the builder file) and ``import.toml``."""
    frame = frame3d(*SIZE)
    lines = [f"# import file of `vibupdate example fe-{code}`: the {SIZE[0]} x {SIZE[1]} bay, {SIZE[2]}-storey "
             "frame of vibupdate.examples.frame3d", f'format = "{code}"']
    if code == "opensees":
        (folder / "frame_ops.py").write_text(
            '"""Builder of the frame in OpenSees (vibupdate.examples.frame3d_opensees)."""\n\n'
            "from vibupdate.examples.frame3d_opensees import build_frame\n\n\n"
            f"def build(p):\n    build_frame(p, {SIZE!r})\n")
        lines.append('builder = "frame_ops.py:build"')
    else:
        lines.append(f'nominal = "{_export(code, folder / "nominal", {})}"')
    if code == "abaqus":
        fixed = [d for d in frame.all_dofs if d not in set(frame.dofs)]
        lines.append("fix = [" + ", ".join(f'"{d}"' for d in fixed) + "]   # the base translations")
    lines += _sensor_lines(code)
    for name, unit in PARAMETERS.items():
        p0 = NOMINAL[name]
        lines += ["", "[[parameter]]", f'name = "{name}"', f'unit = "{unit}"', f"nominal = {p0!r}",
                  f"lower = {0.5 * p0!r}", f"upper = {1.5 * p0!r}", f"step = {STEP * p0!r}"]
        if code != "opensees":
            lines.append(f'export = "{_export(code, folder / f"{name}_plus", {name: p0 * (1 + STEP)})}"')
        if name in TWO_STEPS:
            lines.append(f"step2 = {-STEP * p0!r}")
            if code != "opensees":
                lines.append(f'export2 = "{_export(code, folder / f"{name}_minus", {name: p0 * (1 - STEP)})}"')
    (folder / "import.toml").write_text("\n".join(lines) + "\n")
    return folder / "import.toml"


def _true_matrices(code: str):
    """K, M and DOF names of the "measured" structure."""
    frame = frame3d(*SIZE)
    if code != "opensees":
        K, M = frame.matrices(truth())
        return K, M, frame.dofs
    from vibupdate.examples.frame3d_opensees import build_frame
    from vibupdate.model.fe.opensees import export_from_builder

    # OpenSees lumps the column mass: the structure is what OpenSees itself forms at the truth
    export = export_from_builder(lambda p: build_frame(p, SIZE), truth())
    return export.K, export.M, export.dofs


def _write_measured(code: str, folder: Path) -> None:
    """``frequencies.csv`` (Hz, `FREQUENCY_DIGITS` significant digits) and ``shapes.csv`` (each mode
    scaled to 1 at its largest sensor reading, `SHAPE_DECIMALS` decimals, +- `SHAPE_TOLERANCE`)
    of the true structure at the sensors: rounded as a test report gives them."""
    from vibupdate.modal.analysis import modes

    K, M, dofs = _true_matrices(code)
    omega, phi = modes(M, K, N_MODES)[:2]
    rows = ["kind,hz"] + [f"natural,{float(w / (2 * np.pi)):.{FREQUENCY_DIGITS}g}" for w in omega]
    (folder / "frequencies.csv").write_text("\n".join(rows) + "\n")
    at = phi[[dofs.index(d) for d in sensors()]]
    at = at / at[np.argmax(np.abs(at), axis=0), np.arange(N_MODES)]
    rows = ["mode,dof,value,tolerance"] + [f"{k + 1},{d},{at[i, k]:.{SHAPE_DECIMALS}f},{SHAPE_TOLERANCE}"
                                           for k in range(N_MODES) for i, d in enumerate(sensors())]
    (folder / "shapes.csv").write_text("\n".join(rows) + "\n")


def write_inputs(name: str, out) -> Path:
    """Write ``out/exports`` and ``out/measured`` of example ``name`` into the new folder ``out``;
    returns the import file. Raises ValueError for an unknown name or a folder in use, and
    `MissingExtra` for ``fe-opensees`` without the ``[fe]`` extra."""
    if name not in CODES:
        raise ValueError(f"unknown FE example {name!r}; expected one of {', '.join(CODES)}")
    code = CODES[name]
    if code == "opensees":
        from vibupdate.model.fe.opensees import openseespy

        openseespy()   # before any file is written
    out = Path(out)
    new_folder(out)
    for sub in ("exports", "measured"):
        (out / sub).mkdir()
    spec = _write_import(code, out / "exports")
    _write_measured(code, out / "measured")
    return spec


def write_case(name: str, out) -> Path:
    """``out/model/case.toml``: the imported ``model.toml`` made a case file with the measured data."""
    model = Path(out) / "model"
    text = (f'case = "{name}"\nfrequency_tolerance = {FREQUENCY_TOLERANCE!r}\n\n' + (model / "model.toml").read_text()
            + '\n[[configuration]]\nname = "measured"\nfrequencies_csv = "../measured/frequencies.csv"\n'
              'mode_shapes_csv = "../measured/shapes.csv"\n\n[verification]\n'
            + "".join(f"{key} = {value!r}\n" for key, value in MODEL_FORM.items()))
    (model / "case.toml").write_text(text)
    return model / "case.toml"


def commands(out) -> tuple[list[str], list[str]]:
    """The ``vibupdate import`` and ``vibupdate run`` command lines of the example in ``out``."""
    out = Path(out)
    return (["import", str(out / "exports" / "import.toml"), "--out", str(out / "model")],
            ["run", str(out / "model" / "case.toml"), "--out", str(out / "results")])


def truth_lines(out) -> list[str]:
    """Each parameter's updated value against its truth, from ``out/results/results.json``."""
    import json

    document = json.loads((Path(out) / "results" / "results.json").read_text())
    true = truth()
    lines = [f"{'parameter':<10} {'unit':<8} {'truth':>12} {'updated':>18} {'relative error':>15}"]
    for p in document["parameters"]:
        value, target = p["updated"], true[p["name"]]
        lines.append(f"{p['name']:<10} {p['unit']:<8} {target:>12.6g} {value:>18.12g} "
                     f"{abs(value / target - 1):>15.2e}")
    return lines
