"""Known-truth problems the acceptance engine does not cover: 3-D frames through the FE import
route, with the variations users bring, and the case-file mistakes they make.

Each *run* problem (seeded) builds a `vibupdate.examples.frame3d` frame, writes its nominal and
perturbed exports with the project's own writers (Nastran DMIG free/large field, ANSYS HBMAT,
Abaqus mtx), imports them with ``vibupdate import``, synthesizes measured data from the frame at
a truth drawn in the parameter box, and runs ``vibupdate run`` (all in-process through
`vibupdate.cli.main`). Variations (the problem's class): random truths, fewer modes than
parameters, two or three sensors, oblique sensors placed by position and direction, noisy
frequencies with a stated ``frequency_tolerance``, noisy shapes as intervals, free-free frames
(six rigid-body modes), a parameter the measured modes hardly see (a vertical spring on a roof
corner under the first sway modes), a square frame (repeated modes), a section depth (not
affine, imported with a second perturbation), the 1,020-DOF frame.

The judge follows ``tests/acceptance/runner.py``, on an independent truth model (the frame's
own matrices, its massless rotations condensed, dense eigen-solves; for a section depth the
linearization the import makes, from the same difference quotients):

* ``crash``: exit 3 or an exception out of ``main``; ``refused``: exit 2 on a valid problem;
* ``exit_code``: exit code and status disagree;
* ``outside``: ``success`` with a datum outside its band (exact data: 1e-6 relative for
  frequencies, 1e-6 absolute on shapes normalized to a largest entry of 1; noisy data: the
  stated tolerance); a shape counts as inside when some combination of the model modes of its
  frequency (one, or the cluster of a repeated frequency) fits its intervals;
* ``determined_miss``: ``success`` with a parameter the data determine (consistent range at the
  truth under 5 %) outside that range plus 10 % of its width (the truth among the reported
  ``alternatives`` excuses it);
* ``truth_outside_reported``: the truth outside the range ``results.json`` reports;
* ``report``: a reported updated frequency that differs from the recomputed one;
* ``not_verified_exact``: ``not_verified`` on exact data from an affine family (to investigate).

Each *mistake* problem spoils a valid case (a shape at a DOF the model lacks, rad/s written as
Hz, a bound equal to the nominal, a parameter with nominal 0, a repeated mode, a mode beyond the
model's, ...) and checks that ``check`` / ``run`` / ``import`` end with exit 2 and a message that
names the value or the file, no traceback, no internal error, nothing written (or, for the valid
but unusual inputs, a run without a crash).

Usage::

    PYTHONPATH=src:tests python benchmarks/explore_fe.py --cases 60 [--seed 0] [--json out.json]
"""

from __future__ import annotations

import argparse
import contextlib
import io
import json
import sys
import tempfile
import time
import traceback
import warnings
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp

from vibupdate.examples import frame3d as F
from vibupdate.examples.fe_writers import write_abaqus, write_dmig, write_hbmat

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))   # before this folder's acceptance.py
from acceptance.emit import EXACT_SLACK  # noqa: E402  the acceptance judge's own slack, margins and range test
from acceptance.runner import DETERMINED_PCT, FLOOR, _outside_ranges  # noqa: E402

TWO_PI = 2.0 * np.pi
DEFECTS = ("crash", "refused", "exit_code", "outside", "determined_miss", "truth_outside_reported", "report",
           "not_verified_exact")
UNITS = {"E_col": "Pa", "E_beam": "Pa", "rho_col": "kg/m^3", "m_floor": "kg/m^2", "k_base": "N m/rad",
         "d_beam": "m", "k_roof": "N/m"}
K_ROOF = 1e6      # nominal vertical spring on a roof corner (N/m): the parameter the sway modes hardly see
CLASSES = ("base", "few_modes", "few_sensors", "oblique", "noisy_freq", "noisy_shapes", "free_free",
           "invisible", "symmetric", "nonaffine", "freq_only", "large")
ROUTES = ("nastran", "nastran-large", "ansys", "abaqus")
SIZES = ((1, 1, 1), (2, 1, 1), (1, 1, 2), (2, 1, 2), (1, 2, 2))


# -- the truth model -----------------------------------------------------------------------------


def square_frame(bx: int, by: int, stories: int):
    """The frame with square bays (4 m x 4 m): x and y sway modes repeated exactly."""
    saved = F.BAY
    try:
        F.BAY = (4.0, 4.0)
        return F.frame3d.__wrapped__(bx, by, stories)
    finally:
        F.BAY = saved


@dataclass
class Family:
    """The frame's model family: exact matrices, the import's linearization, the DOF names."""

    frame: object
    free: bool = False
    roof: str | None = None                  # DOF of the k_roof spring, when it is a parameter
    steps: dict = field(default_factory=dict)   # name -> (step, step2 or None)

    @property
    def dofs(self):
        return self.frame.all_dofs if self.free else self.frame.dofs

    def exact(self, values: dict):
        v = {k: x for k, x in values.items() if k != "k_roof"}
        if self.free:
            v["k_base"] = 0.0
        K, M = self.frame.matrices(v, constrained=self.free)
        if self.roof is not None:
            e = np.zeros(K.shape[0])
            e[self.dofs.index(self.roof)] = 1.0
            K = K + values.get("k_roof", K_ROOF) * sp.csr_matrix(np.outer(e, e))
        return sp.csr_matrix(K), sp.csr_matrix(M)

    def nominal(self, names):
        out = {n: (K_ROOF if n == "k_roof" else F.NOMINAL[n]) for n in names}
        return out

    def linear(self, values: dict):
        """The import's affine form at ``values``: nominal plus difference quotients."""
        names = list(self.steps)
        nom = self.nominal(names)
        K0, M0 = self.exact(nom)
        K, M = K0.copy(), M0.copy()
        for n in names:
            h, h2 = self.steps[n]
            Kp, Mp = self.exact({**nom, n: nom[n] + h})
            if h2 is None:
                dK, dM = (Kp - K0) / h, (Mp - M0) / h
            else:
                Km, Mm = self.exact({**nom, n: nom[n] + h2})
                dK, dM = (Kp - Km) / (h - h2), (Mp - Mm) / (h - h2)
            K = K + (values[n] - nom[n]) * dK
            M = M + (values[n] - nom[n]) * dM
        return K, M


def modes(K, M, dofs, n_rigid: int, n_refine: int = 12):
    """Flexible modes (Hz) and shapes (rows: ``dofs`` with mass) of (K, M), massless DOFs
    condensed for a dense eigen-solve, then the first ``n_refine`` flexible modes refined by two
    steps of inverse iteration on the full system (block-wise on a cluster of close modes, with
    a Rayleigh-Ritz step): the condensed solve alone leaves errors of ~1e-10 on small shape
    ratios of close modes, more than the verification's rounding allowance."""
    K, M = K.toarray(), M.toarray()
    mass = np.abs(M).sum(axis=1) > 0
    a, b = np.flatnonzero(mass), np.flatnonzero(~mass)
    if b.size:
        Kab = K[np.ix_(a, b)]
        Kc = K[np.ix_(a, a)] - Kab @ np.linalg.solve(K[np.ix_(b, b)], Kab.T)
    else:
        Kc = K
    Kc = 0.5 * (Kc + Kc.T)
    w2, Phi = sla.eigh(Kc, M[np.ix_(a, a)])
    full = np.zeros((K.shape[0], Phi.shape[1]))
    full[a] = Phi
    if b.size:
        full[b] = -np.linalg.solve(K[np.ix_(b, b)], K[np.ix_(b, a)] @ Phi)
    last = min(n_rigid + n_refine, w2.size)
    j = n_rigid
    while j < last:
        block = [j]
        while block[-1] + 1 < w2.size and w2[block[-1] + 1] - w2[j] <= 1e-3 * abs(w2[j]):
            block.append(block[-1] + 1)
        X = full[:, block]
        lu = sla.lu_factor(K - w2[j] * (1 - 1e-9) * M)
        for _ in range(2):
            X = sla.lu_solve(lu, M @ X)
            lam, Y = sla.eigh(X.T @ K @ X, X.T @ M @ X)
            X = X @ Y
        full[:, block], w2[block] = X, lam
        j = block[-1] + 1
    w = np.sqrt(np.maximum(w2, 0.0))
    kept = [dofs[i] for i in a]
    return w[n_rigid:] / TWO_PI, full[a][:, n_rigid:], kept


# -- the problem ---------------------------------------------------------------------------------


@dataclass
class Problem:
    seed: int
    klass: str
    route: str
    size: tuple
    names: list
    truth: dict
    bounds: dict
    measured: list          # model modes (1-based, flexible)
    sensors: list           # (name, node, direction unit vector or None, dof or None)
    freq_noise: float = 0.0
    shape_noise: float = 0.0
    declare: bool = False
    family: Family | None = None

    @property
    def case_id(self):
        return f"{self.klass}-{self.seed}"

    @property
    def exact_family(self):
        # a large-field DMIG keeps 10 digits: point shapes of the exact frame are not exactly
        # those of the imported model (its difference quotients lose about 9 digits)
        return (self.freq_noise == 0 and self.shape_noise == 0 and "d_beam" not in self.names
                and self.route != "nastran-large")


def _corner_nodes(frame, level):
    return sorted(n for n in frame.nodes if n // 1000 == level and n % 1000 <= len(
        [m for m in frame.nodes if m // 1000 == 0]))


def generate(seed: int, klass: str | None = None) -> Problem:
    rng = np.random.default_rng(seed)
    klass = klass or CLASSES[seed % len(CLASSES)]
    route = ROUTES[rng.integers(len(ROUTES))]
    size = SIZES[rng.integers(len(SIZES))]
    if klass == "large":
        size = (3, 2, 4)
    frame = square_frame(*size[:1] * 2, size[2]) if klass == "symmetric" else F.frame3d(*size)
    if klass == "symmetric":
        size = (size[0], size[0], size[2])
    family = Family(frame, free=klass == "free_free")
    pool = ["E_col", "E_beam", "rho_col", "m_floor"] + ([] if family.free else ["k_base"])
    n_par = int(rng.integers(2, len(pool) + 1))
    names = sorted(rng.choice(pool, n_par, replace=False).tolist(), key=pool.index)
    if klass == "nonaffine":
        names = [n for n in names if n != "E_beam"][:3] + ["d_beam"]
    stories = size[2]
    top = _corner_nodes(frame, stories)
    if klass == "invisible":
        names = names + ["k_roof"]
        family.roof = f"{top[0]}:z"
    truth, bounds = {}, {}
    for n in names:
        p0 = K_ROOF if n == "k_roof" else F.NOMINAL[n]
        if n == "d_beam":
            bounds[n] = (0.75 * p0, 1.25 * p0)
            truth[n] = p0 * (1 + rng.uniform(-0.06, 0.06))
        else:
            bounds[n] = (0.5 * p0, 1.5 * p0)
            truth[n] = p0 * rng.uniform(0.7, 1.3)
    for n in names:
        p0 = K_ROOF if n == "k_roof" else F.NOMINAL[n]
        rel = 0.05 if n == "d_beam" else 0.1
        family.steps[n] = (rel * p0, -rel * p0 if n == "d_beam" else None)
    # measured modes
    if klass == "few_modes":
        n_modes = int(rng.integers(max(1, len(names) - 2), len(names)))
    elif klass == "invisible":
        n_modes = 3
    else:
        n_modes = int(rng.integers(len(names) + 1, len(names) + 5))
    measured = list(range(1, n_modes + 1))
    declare = False
    if klass not in ("invisible", "symmetric") and n_modes >= 4 and rng.random() < 0.3:
        measured.pop(int(rng.integers(1, n_modes - 1)))   # a mode skipped: declared numbers
        declare = True
    # sensors
    sensors = []
    if klass == "few_sensors":
        cand = [(n, d) for n in top for d in "xyz"]
        for k in rng.choice(len(cand), int(rng.integers(2, 4)), replace=False):
            n, d = cand[k]
            sensors.append((f"s{len(sensors)}", n, None, f"{n}:{d}"))
    elif klass == "oblique":
        levels = sorted({n // 1000 for n in frame.nodes if n // 1000 > 0})
        for k in range(int(rng.integers(2, 5))):
            node = int(rng.choice(_corner_nodes(frame, levels[-1 - (k % len(levels))])))
            v = rng.normal(size=3)
            v /= np.linalg.norm(v)
            sensors.append((f"o{k}", node, v, None))
        sensors.append(("ax", top[-1], None, f"{top[-1]}:x"))
    elif klass != "freq_only":
        for n in top[:4]:
            sensors += [(f"c{n}x", n, None, f"{n}:x"), (f"c{n}y", n, None, f"{n}:y")]
        sensors += [(f"c{top[0]}z", top[0], None, f"{top[0]}:z"), (f"c{top[-1]}z", top[-1], None, f"{top[-1]}:z")]
    freq_noise = float(rng.choice([0.001, 0.003, 0.01])) if klass == "noisy_freq" else 0.0
    shape_noise = float(rng.choice([0.01, 0.03, 0.05])) if klass == "noisy_shapes" else 0.0
    if klass == "nonaffine":
        freq_noise = 0.003
    if klass == "noisy_shapes":
        freq_noise = 0.002
    return Problem(seed, klass, route, tuple(size), names, truth, bounds, measured, sensors, freq_noise,
                   shape_noise, declare, family)


# -- writing the exports, the import file and the case -------------------------------------------


def write_export(problem, folder: Path, values) -> str:
    fam = problem.family
    K, M = fam.exact(values)
    dofs = fam.dofs
    if problem.route == "abaqus":
        if fam.free:
            write_abaqus(folder, K, M, dofs)
        else:   # Abaqus writes the matrices before the boundary conditions: the fixed DOFs stay
            v = {k: x for k, x in values.items() if k != "k_roof"}
            Ka, Ma = fam.frame.matrices(v, constrained=True)
            if fam.roof is not None:
                e = np.zeros(Ka.shape[0])
                e[fam.frame.all_dofs.index(fam.roof)] = 1.0
                Ka = Ka + values.get("k_roof", K_ROOF) * sp.csr_matrix(np.outer(e, e))
            write_abaqus(folder, Ka, Ma, fam.frame.all_dofs)
        return folder.name
    if problem.route.startswith("nastran"):
        field_ = "large" if problem.route == "nastran-large" else "free"
        write_dmig(folder.with_suffix(".pch"), K, M, dofs, field_)
        return folder.with_suffix(".pch").name
    write_hbmat(folder, K, M, dofs)
    return folder.name


def write_import(problem, root: Path) -> Path:
    fam = problem.family
    root.mkdir(parents=True, exist_ok=True)
    nom = fam.nominal(problem.names)
    lines = [f'format = "{problem.route.split("-")[0]}"', f'nominal = "{write_export(problem, root / "nominal", nom)}"']
    if problem.route == "abaqus" and not fam.free:
        fixed = sorted(set(fam.frame.all_dofs) - set(fam.frame.dofs))
        lines.append("fix = [" + ", ".join(f'"{d}"' for d in fixed) + "]")
    if any(s[2] is not None for s in problem.sensors):
        rows = ["node,x,y,z"] + [f"{k}," + ",".join(repr(float(c)) for c in v) for k, v in fam.frame.nodes.items()]
        (root / "nodes.csv").write_text("\n".join(rows) + "\n")
        lines.append('nodes = "nodes.csv"')
    for name, node, direction, dof in problem.sensors:
        lines += ["[[sensor]]", f'name = "{name}"']
        if dof:
            lines.append(f'dof = "{dof}"')
        else:
            lines += [f"position = {fam.frame.nodes[node].tolist()}", f"direction = {direction.tolist()}"]
    for n in problem.names:
        h, h2 = fam.steps[n]
        lo, hi = problem.bounds[n]
        export = write_export(problem, root / f"{n}_plus", {**nom, n: nom[n] + h})
        lines += ["[[parameter]]", f'name = "{n}"', f'unit = "{UNITS[n]}"', f"nominal = {nom[n]!r}",
                  f"lower = {lo!r}", f"upper = {hi!r}", f"step = {h!r}", f'export = "{export}"']
        if h2 is not None:
            export2 = write_export(problem, root / f"{n}_minus", {**nom, n: nom[n] + h2})
            lines += [f"step2 = {h2!r}", f'export2 = "{export2}"']
    (root / "import.toml").write_text("\n".join(lines) + "\n")
    return root / "import.toml"


def sensor_readings(problem, Phi, kept, sensors_csv: Path | None):
    """Measured DOF name -> row of readings (modes in columns) as the sensors read the frame."""
    index = {d: k for k, d in enumerate(kept)}
    out = {}
    if sensors_csv is not None and sensors_csv.is_file():
        import csv

        given = {s[0]: s for s in problem.sensors}
        with sensors_csv.open(newline="") as handle:
            for row in csv.DictReader(handle):
                _, node, direction, dof = given[row["sensor"]]
                if direction is None:
                    direction = np.eye(3)["xyz".index(dof.split(":")[1])]
                u = Phi[[index[f"{node}:{a}"] for a in "xyz"]]
                out.setdefault(row["dof"], float(row["sign"]) * (direction @ u))
        return out
    for _, node, direction, dof in problem.sensors:
        out[dof] = Phi[index[dof]]
    return out


def write_case(problem, model_dir: Path, rng) -> dict:
    """case.toml (what the user runs) and judge.toml (exact data widened to EXACT_SLACK) beside
    the imported model.toml; returns the synthesized data."""
    fam = problem.family
    hz, Phi, kept = modes(*fam.exact(problem.truth), fam.dofs, 6 if fam.free else 0)
    idx = [m - 1 for m in problem.measured]
    f = hz[idx].copy()
    if problem.freq_noise:
        f = f * (1 + 0.9 * problem.freq_noise * rng.uniform(-1, 1, f.size))
        f = np.sort(f)
    reads = sensor_readings(problem, Phi, kept, model_dir / "sensors.csv" if problem.sensors else None)
    shapes = {}
    for j, m in zip(idx, problem.measured):
        vals = {d: r[j] for d, r in reads.items()}
        if not vals:
            continue
        scale = max(abs(v) for v in vals.values())
        sign = -1.0 if rng.random() < 0.5 else 1.0
        vals = {d: float(sign * v / scale) for d, v in vals.items()}
        if problem.shape_noise:
            half = problem.shape_noise
            vals = {d: (float(v + 0.8 * half * rng.uniform(-1, 1)), half) for d, v in vals.items()}
        else:
            vals = {d: (v, 0.0) for d, v in vals.items()}
        shapes[m] = vals
    data = {"hz": f, "shapes": shapes}
    model_text = (model_dir / "model.toml").read_text()
    for label, widen in (("case", 0.0), ("judge", EXACT_SLACK)):
        tol = problem.freq_noise if problem.freq_noise else (EXACT_SLACK if label == "judge" else 0.0)
        head = [f'case = "{problem.case_id}"']
        if tol:
            head.append(f"frequency_tolerance = {tol!r}")
        cfg = ["[[configuration]]", 'name = "test"', f"natural_hz = [{', '.join(repr(float(x)) for x in f)}]"]
        if problem.declare or label == "judge":
            cfg.append(f"natural_modes = {problem.measured}")
        if shapes:
            rows = ["mode,dof,lower,upper"]
            for m, vals in shapes.items():
                for d, (v, h) in vals.items():
                    h = h + (widen if problem.shape_noise == 0 else 0.0)
                    rows.append(f"{m},{d},{float(v - h)!r},{float(v + h)!r}")
            (model_dir / f"shapes_{label}.csv").write_text("\n".join(rows) + "\n")
            cfg.append(f'mode_shapes_csv = "shapes_{label}.csv"')
        verification = ["[verification]", "shape_tolerance = 0.0"]
        if problem.freq_noise:
            verification.append("natural_tolerance = 0.0")
        text = "\n".join(head) + "\n\n" + model_text + "\n" + "\n".join(cfg) + "\n\n" + "\n".join(verification) + "\n"
        (model_dir / f"{label}.toml").write_text(text)
    return data


# -- running the CLI -----------------------------------------------------------------------------


def cli(argv) -> tuple[int, str, str, str | None]:
    """``vibupdate`` in-process: exit code, stdout, stderr, and an escaped exception."""
    from vibupdate.cli import main

    out, err = io.StringIO(), io.StringIO()
    escaped = None
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err), warnings.catch_warnings():
        warnings.simplefilter("ignore")
        try:
            code = main(argv)
        except SystemExit as exc:
            code = exc.code if isinstance(exc.code, int) else 3
        except Exception as exc:   # an escape from main is the finding
            code, escaped = 3, "".join(traceback.format_exception(exc))[-1500:]
    return code, out.getvalue(), err.getvalue(), escaped


# -- judging -------------------------------------------------------------------------------------


def _scale_miss(phi: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> float:
    """Distance (half-widths) of the best combination of the columns of ``phi`` from the
    intervals [lo, hi] (an LP: as the acceptance judge's, with a cluster of repeated modes)."""
    from scipy.optimize import linprog

    phi = phi.reshape(len(lo), -1)
    k = phi.shape[1]
    half = np.maximum(0.5 * (hi - lo), 1e-12)
    A = np.vstack([np.column_stack([phi, -half]), np.column_stack([-phi, -half])])
    b = np.concatenate([hi, -lo])
    c = np.zeros(k + 1)
    c[-1] = 1.0
    sol = linprog(c, A_ub=A, b_ub=b, bounds=[(None, None)] * k + [(0.0, None)], method="highs")
    return float(sol.x[-1]) if sol.status == 0 else np.inf


def misses(problem, data, values: dict, model_dir: Path):
    fam = problem.family
    hz, Phi, kept = modes(*fam.linear(values), fam.dofs, 6 if fam.free else 0)
    reads = sensor_readings(problem, Phi, kept, model_dir / "sensors.csv" if problem.sensors else None)
    tol = problem.freq_noise or EXACT_SLACK
    if "d_beam" in problem.names and not problem.freq_noise:
        tol = 0.02
    out = []
    for m, f in zip(problem.measured, data["hz"]):
        got = hz[m - 1]
        if abs(got - f) > tol * f * (1 + FLOOR):
            out.append(f"mode {m}: {got:.7g} Hz vs {f:.7g} Hz +- {100 * tol:.3g} % ({100 * (got - f) / f:+.3g} %)")
        if m in data["shapes"]:
            names = list(data["shapes"][m])
            cluster = np.flatnonzero(np.abs(hz - hz[m - 1]) <= 1e-7 * hz[m - 1])
            phi = np.array([[reads[d][c] for c in cluster] for d in names])
            v = np.array([data["shapes"][m][d][0] for d in names])
            h = np.array([data["shapes"][m][d][1] for d in names]) + (EXACT_SLACK if not problem.shape_noise else 0.0)
            miss = _scale_miss(phi, v - h, v + h)
            if miss > FLOOR:
                out.append(f"mode {m}: shape outside its intervals ({miss:.3g} half-widths, cluster of {cluster.size})")
    return out, hz


def reference(problem, model_dir: Path):
    """Consistent ranges at the truth on the judge's case (the library's linearized ranges)."""
    from vibupdate.io.case import load_case
    from vibupdate.ranges.identifiability import parameter_ranges

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        case = load_case(model_dir / "judge.toml")
        model = case.configurations[0].model
        xbar = model.normalized([problem.truth[p.name] for p in model.parameters])
        r = parameter_ranges(case.configurations, xbar, frequency_tolerance=case.frequency_tolerance)
    widths = np.asarray(r.width_pct, dtype=float)
    determined = [n for n, w in zip(model.parameter_names, widths) if np.isfinite(w) and w <= DETERMINED_PCT]
    return (np.asarray(r.lower), np.asarray(r.upper)), widths, determined, list(model.parameter_names)


def run_problem(problem, workdir: Path) -> dict:
    rng = np.random.default_rng(10_000 + problem.seed)
    start = time.perf_counter()
    verdict = {"case": problem.case_id, "class": problem.klass, "route": problem.route, "size": problem.size,
               "params": problem.names, "modes": problem.measured, "sensors": len(problem.sensors),
               "failures": [], "details": []}
    spec = write_import(problem, workdir / "exports")
    code, out, err, escaped = cli(["import", str(spec), "--out", str(workdir / "model")])
    if code != 0:
        verdict.update(status="import_failed", exit_code=code, seconds=time.perf_counter() - start)
        verdict["failures"].append("crash" if code == 3 else "refused")
        verdict["details"].append(f"import: exit {code}: {(escaped or err).strip()[-400:]}")
        return verdict
    data = write_case(problem, workdir / "model", rng)
    code, out, err, escaped = cli(["run", str(workdir / "model" / "case.toml"), "--out", str(workdir / "out")])
    verdict["seconds"] = time.perf_counter() - start
    verdict["exit_code"] = code
    doc_path = workdir / "out" / "results.json"
    doc = json.loads(doc_path.read_text()) if doc_path.is_file() else None
    status = doc["solver"]["status"] if doc else ("refused" if code == 2 else "crash")
    verdict["status"] = status
    success = status in ("success", "acceptable")
    if status == "crash" or code == 3:
        verdict["failures"].append("crash")
        verdict["details"].append("crash: " + (escaped or err).strip()[-600:])
    elif status == "refused":
        verdict["failures"].append("refused")
        verdict["details"].append("refused: " + err.strip()[-600:])
    elif not success:
        verdict["failures"].append("not_verified_exact" if status == "not_verified" and problem.exact_family
                                   else status)
    if code not in (2, 3) and code != (0 if success else 1):
        verdict["failures"].append("exit_code")
    if doc is None:
        return verdict
    values = {p["name"]: p["updated"] for p in doc["parameters"]}
    verdict["error_pct"] = {n: round(100 * (values[n] / problem.truth[n] - 1), 4) for n in problem.names}
    miss, hz = misses(problem, data, values, workdir / "model")
    if success and miss:
        verdict["failures"].append("outside")
    verdict["details"] += ["miss: " + m for m in miss[:4]]
    try:
        (lo, hi), widths, determined, names = reference(problem, workdir / "model")
    except Exception as exc:   # the reference is the judge's; its failure is noted, not judged
        verdict["details"].append(f"reference failed: {type(exc).__name__}: {exc}")
        return verdict
    verdict["determined"] = determined
    refs = [p.get("reference", p["nominal"]) or 1.0 for p in doc["parameters"]]
    alts = ((doc.get("identifiability") or {}).get("alternatives") or [])

    def outside(x, lo_, hi_, only=None):
        return _outside_ranges(names, x, (lo_, hi_), refs, only)

    named = [a for a in alts if not outside([a["values"][n] for n in names], lo, hi, determined)]
    if success and not named:
        bad = outside([values[n] for n in names], lo, hi, determined)
        if bad:
            verdict["failures"].append("determined_miss")
            verdict["details"] += [f"determined_miss: {n} = {x:.6g} outside [{a:.6g}, {b:.6g}] at the truth"
                                   for n, x, a, b in bad]
    reported = (doc.get("identifiability") or {}).get("ranges")
    if reported and not named:
        rr = (np.array([reported[n]["lower"] for n in names]), np.array([reported[n]["upper"] for n in names]))
        bad = outside([problem.truth[n] for n in names], *rr)
        if bad:
            verdict["failures"].append("truth_outside_reported")
            verdict["details"] += [f"truth_outside_reported: true {n} = {x:.6g} outside [{a:.6g}, {b:.6g}]"
                                   for n, x, a, b in bad]
    for row in doc.get("frequencies") or []:
        if row.get("kind") != "natural" or row.get("updated_hz") is None:
            continue
        m = row.get("model_index", row.get("index"))
        if isinstance(m, int) and 1 <= m <= hz.size and abs(row["updated_hz"] - hz[m - 1]) > 1e-6 * hz[m - 1]:
            verdict["failures"].append("report")
            verdict["details"].append(f"report: mode {m} reported {row['updated_hz']:.7g} Hz, recomputed {hz[m - 1]:.7g}")
            break
    return verdict


# -- case-file mistakes --------------------------------------------------------------------------


def _base_case(root: Path, route="nastran", names=("E_col", "m_floor"), n_modes=4):
    """A valid imported case on the smallest frame, exact data at a truth: the mistakes' seed."""
    p = Problem(0, "base", route, (1, 1, 1), list(names), {n: F.NOMINAL[n] * 1.1 for n in names},
                {n: (0.5 * F.NOMINAL[n], 1.5 * F.NOMINAL[n]) for n in names}, list(range(1, n_modes + 1)),
                [], family=Family(F.frame3d(1, 1, 1)))
    top = _corner_nodes(p.family.frame, 1)
    p.sensors = [(f"c{n}{d}", n, None, f"{n}:{d}") for n in top[:2] for d in "xy"]
    for n in names:
        p.family.steps[n] = (0.1 * F.NOMINAL[n], None)
    spec = write_import(p, root / "exports")
    code, _, err, _ = cli(["import", str(spec), "--out", str(root / "model")])
    assert code == 0, err
    write_case(p, root / "model", np.random.default_rng(0))
    return p, spec, root / "model" / "case.toml"


def _edit(path: Path, old: str, new: str, count=1):
    text = path.read_text()
    assert old in text, (old, path)
    path.write_text(text.replace(old, new, count))


def _edit_shapes(case: Path, edit) -> None:
    """Rewrite the case's ``shapes_case.csv`` with ``edit(lines)`` applied to its lines (header
    first) in place."""
    csv = case.parent / "shapes_case.csv"
    lines = csv.read_text().splitlines()
    edit(lines)
    csv.write_text("\n".join(lines) + "\n")


def mistakes():
    """(name, kind, spoil(root, case, spec) -> (command args, expected substrings)). ``kind``:
    ``bad`` must exit 2; ``valid`` must not crash (exit 0 or 1, or 2 with a named reason)."""
    def shape_dof(root, case, spec):
        _edit_shapes(case, lambda lines: lines.append(lines[1].split(",")[0] + ",9999:x,0.1,0.2"))
        return ["run", str(case)], ["9999:x"]

    def rad_s(root, case, spec):
        text = case.read_text()
        import re

        hz = re.search(r"natural_hz = \[(.*)\]", text).group(1)
        new = ", ".join(repr(float(x) * TWO_PI) for x in hz.split(","))
        case.write_text(text.replace(hz, new))
        return ["run", str(case)], ["rad/s"]

    def bound_equal_lower(root, case, spec):
        _edit(case, "lower = 105000000000.0", "lower = 210000000000.0")
        return ["run", str(case)], []

    def bound_degenerate(root, case, spec):
        _edit(case, "lower = 105000000000.0", "lower = 210000000000.0")
        _edit(case, "upper = 315000000000.0", "upper = 210000000000.0")
        return ["run", str(case)], ["E_col"]

    def nominal_zero_import(root, case, spec):
        _edit(spec, "nominal = 400.0", "nominal = 0.0")
        return ["import", str(spec), "--out", str(root / "model2")], ["m_floor", "nominal 0"]

    def nominal_zero_case(root, case, spec):
        _edit(case, "nominal = 400.0", "nominal = 0.0")
        return ["run", str(case)], ["m_floor", "nominal 0"]

    def duplicated_mode(root, case, spec):
        text = case.read_text()
        case.write_text(text.replace('mode_shapes_csv', 'natural_modes = [1, 1, 2, 3]\nmode_shapes_csv'))
        return ["run", str(case)], ["[1, 1, 2, 3]"]

    def duplicated_frequency(root, case, spec):
        import re

        text = case.read_text()
        hz = re.search(r"natural_hz = \[(.*)\]", text).group(1)
        first = hz.split(",")[0]
        case.write_text(text.replace(hz, first + "," + hz))
        return ["run", str(case)], ["given twice"]   # equal frequencies are a repeated pair: warned, run

    def mode_beyond(root, case, spec):
        text = case.read_text()
        case.write_text(text.replace('mode_shapes_csv', 'natural_modes = [1, 2, 3, 5000]\nmode_shapes_csv'))
        csv = case.parent / "shapes_case.csv"
        csv.write_text(csv.read_text().replace("\n4,", "\n5000,"))
        return ["run", str(case)], ["5000"]

    def modes_without_shapes(case, modes) -> None:
        """The case's shapes file replaced by declared ``natural_modes``."""
        case.write_text(case.read_text().replace('mode_shapes_csv = "shapes_case.csv"', f"natural_modes = {modes}"))

    def mode_beyond_no_shapes(root, case, spec):
        modes_without_shapes(case, [1, 2, 3, 5000])
        return ["run", str(case)], ["5000"]

    def shape_mode_undeclared(root, case, spec):
        csv = case.parent / "shapes_case.csv"
        csv.write_text(csv.read_text().replace("\n4,", "\n7,"))
        return ["run", str(case)], ["7", "shapes_case.csv"]

    def shape_at_massless(root, case, spec):
        massless = F.frame3d(1, 1, 1).massless[0]
        _edit_shapes(case, lambda lines: lines.append(f"1,{massless},-0.5,0.5"))
        return ["run", str(case)], []

    def first_row_bounds(lower: str, upper: str):
        def edit(lines):
            lines[1] = ",".join(lines[1].split(",")[:2] + [lower, upper])
        return edit

    def shape_nan(root, case, spec):
        _edit_shapes(case, first_row_bounds("nan", "nan"))
        return ["run", str(case)], ["shapes_case.csv"]

    def shape_lower_above_upper(root, case, spec):
        _edit_shapes(case, first_row_bounds("0.5", "0.1"))
        return ["run", str(case)], ["shapes_case.csv"]

    def negative_frequency(root, case, spec):
        import re

        text = case.read_text()
        hz = re.search(r"natural_hz = \[(.*)\]", text).group(1)
        case.write_text(text.replace("natural_hz = [", "natural_hz = [-1.0, ").replace(
            'mode_shapes_csv = "shapes_case.csv"', "") if hz else text)
        return ["run", str(case)], ["-1.0"]

    def import_sensor_fixed_dof(root, case, spec):
        text = spec.read_text()
        spec.write_text(text.replace("[[sensor]]", '[[sensor]]\nname = "base"\ndof = "1:x"\n\n[[sensor]]', 1))
        return ["import", str(spec), "--out", str(root / "model2")], ["1:x"]

    def import_step_zero(root, case, spec):
        _edit(spec, "step = 40.0", "step = 0.0")
        return ["import", str(spec), "--out", str(root / "model2")], ["step"]

    def with_sensor_by_position(spec, name: str, position, direction) -> None:
        """The import file given the mesh's nodes and, first, a sensor placed by position."""
        text = spec.read_text()
        (spec.parent / "nodes.csv").write_text("node,x,y,z\n" + "".join(
            f"{k},{float(v[0])!r},{float(v[1])!r},{float(v[2])!r}\n" for k, v in F.frame3d(1, 1, 1).nodes.items()))
        spec.write_text('nodes = "nodes.csv"\n' + text.replace(
            "[[sensor]]", f'[[sensor]]\nname = "{name}"\nposition = {position}\ndirection = {direction}\n\n[[sensor]]', 1))

    def import_sensor_far(root, case, spec):
        with_sensor_by_position(spec, "far", [100.0, 100.0, 100.0], [1.0, 0.0, 0.0])
        return ["import", str(spec), "--out", str(root / "model2")], []

    def import_direction_zero(root, case, spec):
        with_sensor_by_position(spec, "zero", [0.0, 0.0, 3.5], [0.0, 0.0, 0.0])
        return ["import", str(spec), "--out", str(root / "model2")], ["zero"]

    def more_modes_than_dofs(root, case, spec):
        import re

        text = case.read_text()
        hz = re.search(r"natural_hz = \[(.*)\]", text).group(1)
        many = ", ".join(repr(10.0 * (k + 1)) for k in range(400))
        case.write_text(text.replace(hz, many).replace('mode_shapes_csv = "shapes_case.csv"', ""))
        return ["run", str(case)], ["400"]

    def mode_among_massless(root, case, spec):
        modes_without_shapes(case, [1, 2, 3, 80])
        return ["run", str(case)], ["80"]

    return [("shape at a DOF the model lacks", "bad", shape_dof),
            ("rad/s written as Hz", "wrong_units", rad_s),
            ("lower bound equal to the nominal", "valid", bound_equal_lower),
            ("lower = nominal = upper (a fixed parameter)", "valid", bound_degenerate),
            ("nominal 0 in the import file, no reference", "bad", nominal_zero_import),
            ("nominal 0 in the case file, no reference", "bad", nominal_zero_case),
            ("a mode declared twice", "bad", duplicated_mode),
            ("a frequency given twice (a repeated pair)", "warned", duplicated_frequency),
            ("a mode beyond the model's (with a shape)", "bad", mode_beyond),
            ("a mode beyond the model's (frequency only)", "bad", mode_beyond_no_shapes),
            ("a shape for an undeclared mode", "bad", shape_mode_undeclared),
            ("a shape entry at a massless rotation", "valid", shape_at_massless),
            ("a shape entry NaN", "bad", shape_nan),
            ("a shape interval with lower > upper", "bad", shape_lower_above_upper),
            ("a negative frequency", "bad", negative_frequency),
            ("an import sensor on a fixed DOF", "bad", import_sensor_fixed_dof),
            ("an import step of 0", "bad", import_step_zero),
            ("an import sensor far from every node", "valid", import_sensor_far),
            ("an import sensor of direction 0", "bad", import_direction_zero),
            ("more frequencies than the model has modes", "bad", more_modes_than_dofs),
            ("a mode beyond the finite modes (80 of 72; 84 DOFs)", "bad", mode_among_massless)]


def run_mistake(name, kind, spoil, workdir: Path) -> dict:
    _, spec, case = _base_case(workdir)
    argv, expected = spoil(workdir, case, spec)
    out_dir = workdir / "out"
    if argv[0] == "run":
        argv = argv + ["--out", str(out_dir)]
    code, out, err, escaped = cli(argv)
    written = (out_dir.exists() and any(out_dir.iterdir())) or (workdir / "model2").exists()
    failures = []
    if escaped or code == 3 or "Traceback" in err or "internal error" in err:
        failures.append("crash")
    elif kind == "bad":
        if code != 2:
            failures.append(f"exit_{code}")
        if written:
            failures.append("written")
        missing = [s for s in expected if s.lower() not in err.lower()]
        if code == 2 and missing:
            failures.append("unnamed")
    elif kind in ("wrong_units", "warned"):
        if code == 0:
            failures.append(f"success_on_{kind}")
        if not any(s in (err + out) for s in expected):
            failures.append("no_warning")
    elif kind == "valid" and code == 2:
        failures.append("refused")
    last = (escaped or err).strip().splitlines()
    return {"case": name, "class": "mistake", "kind": kind, "exit_code": code, "failures": failures,
            "message": (last[-1] if last else "")[:400]}


# -- the table -----------------------------------------------------------------------------------


def table(verdicts) -> str:
    rows = {}
    for v in verdicts:
        r = rows.setdefault(v["class"], {"n": 0, "ok": 0, "defects": {}, "other": {}, "s": []})
        r["n"] += 1
        defects = [f for f in v["failures"] if f in DEFECTS or v["class"] == "mistake"]
        other = [f for f in v["failures"] if f not in defects]
        r["ok"] += v.get("status") in ("success", "acceptable") or (v["class"] == "mistake" and not defects)
        for f in defects:
            r["defects"][f] = r["defects"].get(f, 0) + 1
        for f in other:
            r["other"][f] = r["other"].get(f, 0) + 1
        if "seconds" in v:
            r["s"].append(v["seconds"])
    lines = ["| class | problems | success / passed | defects | other outcomes | median s |", "|---|---|---|---|---|---|"]
    for k, r in rows.items():
        d = ", ".join(f"{a} {b}" for a, b in sorted(r["defects"].items())) or "-"
        o = ", ".join(f"{a} {b}" for a, b in sorted(r["other"].items())) or "-"
        s = f"{np.median(r['s']):.1f}" if r["s"] else "-"
        lines.append(f"| {k} | {r['n']} | {r['ok']} | {d} | {o} | {s} |")
    return "\n".join(lines)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cases", type=int, default=60, help="run problems (default 60)")
    ap.add_argument("--seed", type=int, default=0, help="first seed")
    ap.add_argument("--only", default="", help="comma-separated classes (default: all, in turn)")
    ap.add_argument("--no-mistakes", action="store_true")
    ap.add_argument("--json", default="", help="write the verdicts here")
    ap.add_argument("--keep", default="", help="keep each problem's folder under this one")
    args = ap.parse_args(argv)
    only = [c for c in args.only.split(",") if c]
    verdicts = []
    for k in range(args.cases):
        seed = args.seed + k
        klass = only[k % len(only)] if only else None
        problem = generate(seed, klass)
        with tempfile.TemporaryDirectory(prefix="vibupdate-explore-") as tmp:
            if args.keep:
                tmp = Path(args.keep) / problem.case_id
                tmp.mkdir(parents=True, exist_ok=True)
            try:
                v = run_problem(problem, Path(tmp))
            except Exception as exc:   # the harness's own failure: shown, not hidden
                v = {"case": problem.case_id, "class": problem.klass, "failures": ["harness"],
                     "details": ["".join(traceback.format_exception(exc))[-800:]]}
        verdicts.append(v)
        print(f"{v['case']:>16s} {problem.route:13s} {str(problem.size):10s} {v.get('status', '?'):13s} "
              f"{','.join(v['failures']) or 'ok':30s} {v.get('seconds', 0):6.1f}s "
              f"{json.dumps(v.get('error_pct', {}))[:120]}", flush=True)
        for d in v["details"]:
            if not d.startswith("miss:") or v["failures"]:
                print("      " + d[:300], flush=True)
    if not args.no_mistakes:
        for name, kind, spoil in mistakes():
            with tempfile.TemporaryDirectory(prefix="vibupdate-mistake-") as tmp:
                try:
                    v = run_mistake(name, kind, spoil, Path(tmp))
                except Exception as exc:
                    v = {"case": name, "class": "mistake", "failures": ["harness"],
                         "message": f"{type(exc).__name__}: {exc}"}
            verdicts.append(v)
            print(f"  mistake: {name:45s} exit {v.get('exit_code')} {','.join(v['failures']) or 'ok':20s} "
                  f"{v['message'][:200]}", flush=True)
    print()
    print(table(verdicts))
    if args.json:
        Path(args.json).write_text(json.dumps(verdicts, indent=1, default=str))
    return 0


if __name__ == "__main__":
    sys.exit(main())
