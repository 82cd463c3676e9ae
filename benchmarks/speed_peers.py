"""vibupdate's update against the classical fit a user would write, on problems it was not
built around, in one process: time ratios and accuracy, medians over seeds.

Run:  python benchmarks/speed_peers.py [--seeds 5] [--repeat 1] [--problems cantilever frame12 frame120 run120]

Problems:

* ``cantilever``: paper test case 2 (`vibupdate.examples.cantilever`, measured frequencies and
  antiresonances of 4 configurations, 7 parameters); its data do not depend on the seed, so
  the seeds are repetitions of the same timing.
* ``frame12`` / ``frame120``: the braced frame of the IASC-ASCE benchmark class
  (`benchmarks/braced_frame.py`: 12- and 120-DOF models, 8 stiffness factors, the 6 lowest
  modes with noisy frequencies and shapes at the 12 floor DOFs; truth and noise drawn per seed).
* ``run120``: ``vibupdate run`` (in process, `vibupdate.cli.main`, its output discarded) on
  a case folder of the acceptance engine's shear-building family (`tests/acceptance`, the
  frame's 6 lowest modes with 0.5-1 % noise at a drawn truth) with the 120-DOF model itself:
  the whole run (loading, update, ranges, report, plots, matrices), against the classical fit
  on the same data (the configurations the engine's Python route reads).

Peer (the classical fit, as a user with scipy writes it): `scipy.optimize.least_squares`
(``trf``, the default tolerances, forward-difference Jacobian) from the nominal parameters,
scaled by their nominal values, inside their bounds; each evaluation solves the model's modes
(`vibupdate.modes`) and, for the cantilever, the antiresonances (`vibupdate.antiresonances`).
Residuals: relative errors of the natural frequencies (and antiresonances), each measured
mode paired with the model mode of largest MAC at the measured DOFs when shapes are measured
(in order otherwise), and the measured shapes' misfits (the model's shape scaled to the
measured one by least squares).

vibupdate: ``update([configuration])`` with its defaults (the whole update: first stage,
polish, verification and the uniqueness probe); "first stage": building the problem and the
homotopy path alone (`prepare_first_stage`, `solve_homotopy`); "one evaluation": the CPU time
of one evaluation of every configuration's data and Jacobian (`evaluation_cpu`). Accuracy: the
largest relative parameter error against the truth (frames), the mean frequency error in per
cent (cantilever). Each time is wall and CPU (process) time: on a shared machine the CPU ratio
is the steadier one (one thread, ``OMP_NUM_THREADS=1``); ``--repeat R`` times each run and each
fit R times, alternating, and keeps the least of each (what the other load on the machine added
the least).
"""

from __future__ import annotations

import argparse
import os
import platform
import sys
import time
from pathlib import Path

os.environ.setdefault("OMP_NUM_THREADS", "1")

import numpy as np  # noqa: E402
from scipy.optimize import least_squares  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))

import braced_frame  # noqa: E402

import vibupdate as vu  # noqa: E402
from vibupdate.inverse.homotopy import solve_homotopy  # noqa: E402
from vibupdate.inverse.update import prepare_first_stage  # noqa: E402


def _mac(a, b):
    return float(np.dot(a, b) ** 2 / (np.dot(a, a) * np.dot(b, b)))


def classical_fit(configurations):
    """The peer (module docstring); returns (physical values, (wall, CPU) seconds, evaluations)."""
    model = configurations[0].model
    nominal = np.array([p.nominal for p in model.parameters])
    lower = np.array([p.lower for p in model.parameters]) / nominal
    upper = np.array([p.upper for p in model.parameters]) / nominal
    measured = []
    for cfg in configurations:
        # each mode's measured DOFs and the midpoints of its intervals (None: no shape)
        shapes = [None if n.shape is None else ([cfg.model.dof(d) for d in n.shape.bounds],
                                                np.array([np.mean(b) for b in n.shape.bounds.values()]))
                  for n in cfg.natural]
        zeros = {}
        for a in cfg.antiresonances:
            zeros.setdefault(a.receptance, []).append(a.omega)
        measured.append((cfg, shapes, zeros))

    def residual(scaled):
        values = scaled * nominal
        out = []
        for cfg, shapes, zeros in measured:
            M, K = cfg.model.matrices_at(values)
            n = len(cfg.natural)
            w, Phi = vu.modes(M, K, n + 2 if any(shapes) else n)
            for k, f in enumerate(cfg.natural):
                if shapes[k] is not None:
                    idx, phi = shapes[k]
                    j = int(np.argmax([_mac(Phi[idx, q], phi) for q in range(w.size)]))
                    model_shape = Phi[idx, j]
                    scale = np.dot(model_shape, phi) / np.dot(model_shape, model_shape)
                    out.append((w[j] - f.omega) / f.omega)
                    out.extend(scale * model_shape - phi)
                else:
                    out.append((w[k] - f.omega) / f.omega)
            for (r, c), measured_zeros in zeros.items():
                z = vu.antiresonances(M, K, cfg.model.dof(r), cfg.model.dof(c))
                for zm in measured_zeros:
                    out.append((z[np.argmin(np.abs(z - zm))] - zm) / zm)
        return np.asarray(out)

    t0, c0 = time.perf_counter(), time.process_time()
    fit = least_squares(residual, np.ones(nominal.size), bounds=(lower, upper), method="trf")
    return fit.x * nominal, (time.perf_counter() - t0, time.process_time() - c0), fit.nfev


def evaluation_cpu(configurations, repetitions=100):
    """CPU seconds of one evaluation of the admissible-data contract with its Jacobian (every
    configuration's data map, `vibupdate.inverse.admissible.evaluate`) at the nominal point:
    the unit the polish and the uniqueness search pay per step. Process time over
    ``repetitions``, the least of 3 blocks (the machine is shared)."""
    from vibupdate.inverse.admissible import Admissible, evaluate

    contract = Admissible.of(configurations)
    xbar = np.zeros(configurations[0].model.n_parameters)
    evaluate(configurations, contract, xbar)
    blocks = []
    for _ in range(3):
        t0 = time.process_time()
        for _ in range(repetitions):
            evaluate(configurations, contract, xbar)
        blocks.append((time.process_time() - t0) / repetitions)
    return min(blocks)


def problems(names, seeds):
    """(problem name, seed, configurations, truth or None) of every run."""
    from vibupdate.examples import cantilever

    for name in names:
        if name == "run120":
            for seed in seeds:
                problem = _run120(seed)
                yield name, seed, problem, np.array([problem.truth[p.name] for p in problem.parameters])
            continue
        if name == "cantilever":
            cfgs = cantilever.configurations()
            for seed in seeds:
                yield name, seed, cfgs, None
            continue
        model = braced_frame.model(12 if name == "frame12" else 120)
        for seed in seeds:
            truth = braced_frame.truth(seed)
            yield name, seed, [braced_frame.configuration(model, truth, seed)], truth


def _run120(seed: int):
    """The acceptance engine's shear-building problem of ``seed`` with the frame's 120-DOF
    model (``run120``, module docstring)."""
    import dataclasses

    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
    from acceptance import families, structures

    frame = families._braced_frame()
    problem = families.shear_building(seed)
    M, K_fixed, groups, names = frame.matrices(120)
    spec = structures.given_matrices("frame-120", M, K_fixed, dict(zip(frame.parameter_names(), groups)), names,
                                     frame.MEASURED_DOFS)
    return dataclasses.replace(problem, structure=spec, in_family=True, case_id=f"frame120_{seed}",
                               family="frame120")


def vibupdate_run(problem):
    """``vibupdate run`` in process on ``problem`` written as a case folder; returns the
    physical values, (wall, CPU) seconds of the run and its status."""
    import contextlib
    import io
    import json
    import shutil
    import tempfile

    from vibupdate.cli import main as cli

    folder = Path(tempfile.mkdtemp(prefix="speed_peers_"))
    case = problem.write_case(folder / "case")
    t0, c0 = time.perf_counter(), time.process_time()
    with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()):
        try:
            cli(["run", str(case), "--out", str(folder / "out")])
        except SystemExit:
            pass
    seconds = (time.perf_counter() - t0, time.process_time() - c0)
    doc = json.loads((folder / "out" / "results.json").read_text())
    shutil.rmtree(folder)
    updated = {p["name"]: p["updated"] for p in doc["parameters"]}
    return np.array([updated[p.name] for p in problem.parameters]), seconds, doc["solver"]["status"]


def accuracy(configurations, values, truth):
    if truth is not None:
        return float(np.max(np.abs(values / truth - 1)))
    errors = []
    for cfg in configurations:
        M, K = cfg.model.matrices_at(values)
        w = vu.modes(M, K, len(cfg.natural))[0]
        errors += [abs(wk / f.omega - 1) for wk, f in zip(w, cfg.natural)]
    return 100 * float(np.mean(errors))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=5)
    parser.add_argument("--problems", nargs="+", default=["cantilever", "frame12", "frame120"])
    parser.add_argument("--repeat", type=int, default=1,
                        help="time each run and fit this many times and keep the least (a shared machine)")
    args = parser.parse_args()
    print(f"machine: {platform.machine()}, {os.cpu_count()} cores, Python {platform.python_version()}, "
          f"OMP_NUM_THREADS={os.environ['OMP_NUM_THREADS']}")
    vu.update(__import__("vibupdate.examples.cantilever", fromlist=["x"]).configurations())  # warm-up: imports, builds
    if "run120" in args.problems:   # warm-up of the run: its imports (matplotlib) and the report's fonts
        vibupdate_run(_run120(1000))
    rows = {}
    print("problem    seed  update_s (cpu)  first_stage_s  classical_s (cpu)  ratio_update (cpu)  ratio_first  "
          "status         acc_update  acc_classical")
    for name, seed, cfgs, truth in problems(args.problems, range(args.seeds)):
        problem, run_times, fit_times = cfgs, [], []
        if name == "run120":
            cfgs = problem.configurations()
        for _ in range(args.repeat):   # the vibupdate run or update, then the classical fit
            if name == "run120":
                values_run, seconds, status = vibupdate_run(problem)
                t_first, path_status = float("nan"), "-"
            else:
                t0, c0 = time.perf_counter(), time.process_time()
                result = vu.update(cfgs)
                seconds = (time.perf_counter() - t0, time.process_time() - c0)
                values_run, status = np.asarray(result.values), result.status.value
                t0 = time.perf_counter()
                path = solve_homotopy(prepare_first_stage(cfgs).problem)
                t_first, path_status = time.perf_counter() - t0, path.status.value
            run_times.append(seconds)
            values, fit_seconds, nfev = classical_fit(cfgs)
            fit_times.append(fit_seconds)
        (t_update, c_update), (t_classical, c_classical) = np.min(run_times, axis=0), np.min(fit_times, axis=0)
        row = (t_update, t_first, t_classical, t_update / t_classical, t_first / t_classical,
               accuracy(cfgs, values_run, truth), accuracy(cfgs, values, truth), c_update, c_classical,
               c_update / c_classical)
        rows.setdefault(name, []).append(row)
        print(f"{name:10s} {seed:4d}  {t_update:6.2f} ({c_update:5.2f})  {t_first:13.2f}  {t_classical:7.2f} "
              f"({c_classical:5.2f})  {row[3]:9.2f} ({row[9]:5.2f})  {row[4]:11.2f}  {status:13s}  {row[5]:10.3g}  "
              f"{row[6]:13.3g}  (path {path_status}, {nfev} fit evaluations)", flush=True)
    print("\nmedians (accuracy: largest relative parameter error for the frames, mean frequency error % for the "
          "cantilever)")
    done = set()
    for name, _, cfgs, _ in problems(args.problems, range(1)):
        if name not in done and name != "run120":
            done.add(name)
            print(f"{name:10s} one evaluation of the data with its Jacobian: "
                  f"{1e3 * evaluation_cpu(cfgs):.2f} ms CPU")
    for name, rs in rows.items():
        med = np.median(np.array(rs), axis=0)
        what = "vibupdate run" if name == "run120" else "update"
        print(f"{name:10s} {what} {med[0]:.2f} s ({med[7]:.2f} s CPU), first stage {med[1]:.2f} s, classical "
              f"{med[2]:.2f} s ({med[8]:.2f} s CPU); ratio {what}/classical {med[3]:.2f}x wall, {med[9]:.2f}x CPU "
              f"(range {min(r[9] for r in rs):.2f}-{max(r[9] for r in rs):.2f}x), first stage/classical "
              f"{med[4]:.2f}x; accuracy {what} {med[5]:.3g}, classical {med[6]:.3g}")


if __name__ == "__main__":
    main()
