"""A known-truth `Problem` as a case folder and as Python `Configuration` objects.

* `write_case`: ``case.toml`` with the ``[model]`` table of the structure (elements, or matrix
  files in Matrix Market or ``.npz``), the parameters, one ``[[configuration]]`` per data set
  (frequencies typed in the TOML or in a CSV table with the columns of
  `vibupdate.io.measured_io.read_frequency_csv`, shapes in a CSV table ``mode,dof,lower,upper``),
  ``frequency_tolerance`` = the problem's 3-sigma half-width for noisy data, the model-form
  tolerances of a model family that holds the truth (`model_form`), and the measured damping
  ratios with a ``[damping]`` table of the true series' exponents where the problem has them
  (damped frequencies with ``frequency_type = "damped"`` where it gives those).
* `configurations`: the same data for `vibupdate.update`; a noisy frequency carries its
  interval. ``judge=True`` gives the judge's configurations: modes and zeros always declared,
  and exact data widened into intervals of relative half-width `EXACT_SLACK` (frequencies) and
  absolute `EXACT_SLACK` (shape ratios), the numerical meaning of "exact".
"""

from __future__ import annotations

import json
import math
from pathlib import Path

from acceptance import structures as S
from vibupdate import Antiresonance, Configuration, NaturalFrequency, ShapeInterval

__all__ = ["write_case", "write_frfs", "configurations", "toml_value", "flexible_mode", "model_form",
           "EXACT_SLACK"]

#: Half-width the judge gives exact data: relative for frequencies, absolute for shape ratios
#: (well above the 1e-8 of a dense eigen-solve, far below any measurement).
EXACT_SLACK = 1e-6

TWO_PI = 2.0 * math.pi


def toml_value(value) -> str:
    """A TOML value (inline tables and arrays)."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, (int,)) and not isinstance(value, bool):
        return str(value)
    if isinstance(value, float):
        return repr(value)
    if isinstance(value, str):
        return json.dumps(value)
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(toml_value(v) for v in value) + "]"
    if isinstance(value, dict):
        return "{ " + ", ".join(f"{k} = {toml_value(v)}" for k, v in value.items()) + " }"
    raise TypeError(f"cannot write {value!r} as TOML")


def _table(lines: list[str], header: str, items: dict) -> None:
    lines.append(header)
    lines += [f"{k} = {toml_value(v)}" for k, v in items.items()]
    lines.append("")


def write_frfs(problem, folder: Path) -> list[str]:
    """The receptances of ``problem.frf`` (`acceptance.problem.Problem`), synthesized at the truth
    from its mass, stiffness and Rayleigh damping, one table file per repeat (column 0 the
    frequency in Hz, then ``re+imj`` per response, comma separated) with complex Gaussian noise
    of ``noise`` times ``|H|`` plus a floor constant in acceleration, ``floor`` times the largest
    ``|w^2 H|`` of each FRF over ``w^2``; returns the file names."""
    import numpy as np

    f = problem.frf
    M, K, dofs = S.matrices_at(problem.structure, problem.truth)
    C = f["rayleigh"][0] * M + f["rayleigh"][1] * K
    hz = np.linspace(*f["span_hz"], f["lines"])
    w = TWO_PI * hz
    force = np.zeros(len(dofs))
    force[dofs.index(f["exciter"])] = 1.0
    H = np.linalg.solve(K[None] - w[:, None, None] ** 2 * M[None] + 1j * w[:, None, None] * C[None],
                        np.broadcast_to(force[:, None], (w.size, len(dofs), 1)))[:, :, 0]
    H = H[:, [dofs.index(r) for r in f["responses"]]]
    # the floor is constant in acceleration, as an accelerometer's: of the largest |w^2 H| over w^2
    sigma = f["noise"] * np.abs(H) + f["floor"] * np.abs(w[:, None] ** 2 * H).max(axis=0)[None] / w[:, None] ** 2
    rng = np.random.default_rng(f["seed"])
    names = []
    for k in range(f["repeats"]):
        noisy = H + sigma * (rng.standard_normal(H.shape) + 1j * rng.standard_normal(H.shape))
        rows = [f"{float(x)!r}," + ",".join(f"{z.real:.12e}{z.imag:+.12e}j" for z in line)
                for x, line in zip(hz, noisy)]
        names.append(f"frf_{k + 1}.csv")
        (folder / names[-1]).write_text("\n".join(rows) + "\n", encoding="utf-8")
    return names


def _configuration_table(problem, cfg, folder: Path) -> dict:
    table: dict = {"name": cfg.name}
    if cfg.extra_mass:
        table["mass"] = [{"dof": cfg.extra_mass[0], "value": float(cfg.extra_mass[1])}]
    if problem.frf is not None:
        files = write_frfs(problem, folder)
        table["frf"] = {"files": files, "responses": list(problem.frf["responses"]),
                        "excitations": [problem.frf["exciter"]] * len(files), "kind": "receptance",
                        "band_hz": [float(b) for b in problem.frf["band_hz"]]}
        return table
    damped = any(n.damping is not None for n in cfg.natural)
    if problem.damped:
        table["frequency_type"] = "damped"
    if problem.csv and (cfg.natural or cfg.zeros):
        rows = ["kind,hz,response,excitation,mode,index" + (",damping_ratio" if damped else "")]
        rows += [f"natural,{_written_hz(problem, n)!r},,,{flexible_mode(problem, n) if cfg.declare else ''},"
                 + (f",{n.damping!r}" if damped else "") for n in cfg.natural]
        rows += [f"antiresonance,{z.hz!r},{z.response},{z.excitation},,{z.index if cfg.declare is True else ''}"
                 + ("," if damped else "") for z in cfg.zeros]
        (folder / f"frequencies_{cfg.name}.csv").write_text("\n".join(rows) + "\n", encoding="utf-8")
        table["frequencies_csv"] = f"frequencies_{cfg.name}.csv"
    else:
        if cfg.natural:
            table["natural_hz"] = [_written_hz(problem, n) for n in cfg.natural]
            if cfg.declare:
                table["natural_modes"] = [flexible_mode(problem, n) for n in cfg.natural]
            if damped:
                table["damping_ratios"] = [float(n.damping) for n in cfg.natural]
        if cfg.zeros:
            table["antiresonances"] = [{"hz": float(z.hz), "response": z.response, "excitation": z.excitation,
                                        **({"index": z.index} if cfg.declare is True else {})} for z in cfg.zeros]
    shaped = [n for n in cfg.natural if n.shape]
    if shaped:
        rows = ["mode,dof,lower,upper"]
        rows += [f"{flexible_mode(problem, n)},{dof},{lo!r},{hi!r}" for n in shaped for dof, (lo, hi) in n.shape.items()]
        (folder / f"shapes_{cfg.name}.csv").write_text("\n".join(rows) + "\n", encoding="utf-8")
        table["mode_shapes_csv"] = f"shapes_{cfg.name}.csv"
        if problem.mass_normalized:
            table["mass_normalized_shapes"] = True
    if not cfg.interlacing:
        table["interlacing"] = False
    return table


def _written_hz(problem, natural) -> float:
    """The frequency the case file gives: the natural one, or the damped one of a problem that
    gives damped frequencies (``Problem.damped``)."""
    hz = float(natural.hz)
    return hz * math.sqrt(1.0 - natural.damping ** 2) if problem.damped else hz


def write_case(problem, folder) -> Path:
    """Write ``problem`` as a case folder (module docstring); returns the path of ``case.toml``."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    lines = [f"# known-truth problem {problem.case_id} (tests/acceptance/generator.py); truth: "
             + ", ".join(f"{k} = {v:.6g}" for k, v in problem.truth.items()),
             f"case = {toml_value(problem.case_id)}"]
    if problem.tolerance > 0:
        lines.append(f"frequency_tolerance = {problem.tolerance!r}")
    lines.append("")
    _table(lines, "[verification]", model_form(problem))
    _table(lines, "[model]", S.model_table(problem.structure, problem.parameters, folder))
    for p in problem.parameters:
        _table(lines, "[[parameter]]", {"name": p.name, "unit": p.unit, "nominal": p.nominal, "lower": p.lower,
                                        "upper": p.upper})
    for cfg in problem.data:
        _table(lines, "[[configuration]]", _configuration_table(problem, cfg, folder))
    if problem.damping is not None:
        _table(lines, "[damping]", {"exponents": [float(y) for y in problem.damping[0]]})
    path = folder / "case.toml"
    path.write_text("\n".join(lines), encoding="utf-8")
    return path


def model_form(problem) -> dict:
    """The model-form tolerances a known-truth case states: the model family holds the truth,
    so shapes are held to their intervals alone, and noisy frequencies to theirs; exact
    frequencies keep the default (a wrong answer within it is what the judge's
    ``outside`` and ``determined_miss`` classes find)."""
    tolerances = {"shape_tolerance": 0.0}
    if problem.mass_normalized:
        tolerances["modal_mass_tolerance"] = 0.0
    if problem.tolerance > 0:
        tolerances.update(natural_tolerance=0.0, antiresonance_tolerance=0.0)
    return tolerances


def flexible_mode(problem, natural) -> int:
    """The mode number vibupdate reads: rigid-body modes are not counted (docs/vocabulary.md)."""
    return natural.mode - problem.structure.rigid_modes


def _interval(value: float, half: float):
    return (value - half, value + half) if half > 0 else None


def configurations(problem, judge: bool = False) -> tuple:
    """The Python route's configurations, or the judge's (module docstring)."""
    rel = problem.tolerance if problem.tolerance > 0 else (EXACT_SLACK if judge else 0.0)
    models: dict = {}
    out = []
    for cfg in problem.data:
        key = cfg.extra_mass
        if key not in models:
            models[key] = S.affine_model(problem.structure, problem.parameters, extra_mass=cfg.extra_mass)
        declare = cfg.declare or judge
        natural = []
        for n in cfg.natural:
            shape = None
            if n.shape:
                widen = EXACT_SLACK if judge and problem.shape_noise == 0 else 0.0
                shape = ShapeInterval({d: (lo - widen, hi + widen) for d, (lo, hi) in n.shape.items()},
                                      mass_normalized=problem.mass_normalized)
            w = TWO_PI * n.hz
            natural.append(NaturalFrequency(w, shape=shape, mode=flexible_mode(problem, n) if declare else None,
                                            interval=_interval(w, rel * w), damping_ratio=n.damping))
        zeros = [Antiresonance(TWO_PI * z.hz, z.response, z.excitation,
                               index=z.index if cfg.declare is True or judge else None,
                               interval=_interval(TWO_PI * z.hz, rel * TWO_PI * z.hz)) for z in cfg.zeros]
        out.append(Configuration(cfg.name, models[key], tuple(natural), tuple(zeros), interlacing=cfg.interlacing))
    return tuple(out)
