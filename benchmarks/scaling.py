"""Scaling benchmark: the frame example refined from ~30 to ~30,000 DOFs.

Run:  python benchmarks/scaling.py kernels [--subdivisions 8 77 770]
      python benchmarks/scaling.py update  [--subdivisions 1 8 77]
      python benchmarks/scaling.py run     [--subdivisions 8]

Every element of the frame example is split into ``s`` equal elements (s = 8, 77, 770 give
305, 2,996 and 30,023 DOFs); the 29 parameters, the 7 measured modes and the measured DOFs (x,
y of the 10 original free nodes) stay the same. Each size runs in its own process, so that
its peak memory (max RSS, which includes the ~100 MB of the imported libraries) is its own.

* ``kernels``: seconds of the model build (29 complex-step builder calls plus the affine
  check), of the 7 lowest modes, of one receptance over 400 frequency lines (0 to 1.2 times
  the 7th natural frequency) and of the 7 lowest antiresonances of a driving-point and of a
  transfer receptance, with the largest backward error of the modes.
* ``update``: Problem 1 with *exact* data (no noise; shape intervals +-1e-4): seconds of
  `update` and the largest relative parameter error.
* ``run``: the whole pipeline of ``vibupdate run`` (`pipeline.run_case`: update, damping,
  identifiability, results, report, plots, matrices) on exact data, in a temporary
  directory, with the largest relative parameter error and the peak memory.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
from pathlib import Path

os.environ.setdefault("OMP_NUM_THREADS", "1")

DEFAULTS = {"kernels": (8, 77, 770), "update": (1, 8, 77), "run": (8,)}
SHAPE_TOLERANCE = 1e-4
N_LINES = 400


def _peak_mb() -> float:
    import resource

    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024


def kernels(subdivisions: int) -> dict:
    """Build, modes, receptance and antiresonances of the true refined frame."""
    import numpy as np

    from vibupdate.modal.analysis import antiresonances, mode_residuals, modes, receptance
    from vibupdate.examples import frame

    t0 = time.perf_counter()
    model = frame.model(subdivisions)
    build_s = time.perf_counter() - t0
    truth = frame.truth()
    M, K = model.matrices_at([truth[p.name] for p in model.parameters])
    t0 = time.perf_counter()
    omega, Phi = modes(M, K, frame.N_MODES)
    modes_s = time.perf_counter() - t0
    r, c = model.dof("x6"), model.dof("y10")
    lines = np.linspace(0.0, 1.2 * omega[-1], N_LINES)
    t0 = time.perf_counter()
    h = receptance(M, K, r, c, lines)
    receptance_s = time.perf_counter() - t0
    t0 = time.perf_counter()
    z_rr = antiresonances(M, K, r, r, n_zeros=7)
    zeros_rr_s = time.perf_counter() - t0
    t0 = time.perf_counter()
    z_rc = antiresonances(M, K, r, c, n_zeros=7, with_vectors=True)[0]
    zeros_rc_s = time.perf_counter() - t0
    return {"subdivisions": subdivisions, "dofs": model.n_dofs, "build_s": build_s, "modes_s": modes_s,
            "receptance_s": receptance_s, "zeros_rr_s": zeros_rr_s, "zeros_rc_s": zeros_rc_s,
            "backward_error": float(mode_residuals(M, K, omega, Phi).max()),
            "f1_hz": float(omega[0] / (2 * np.pi)), "n_zeros": [int(z_rr.size), int(z_rc.size)],
            "h_finite": bool(np.all(np.isfinite(h))), "peak_mb": _peak_mb()}


def exact_case(subdivisions: int):
    """The frame case on the refined model with exact data (shape intervals +-1e-4)."""
    from dataclasses import replace

    from vibupdate.examples import frame

    frequencies, shapes = frame.generate(frequency_error=0.0, shape_error=0.0, subdivisions=subdivisions)
    shapes = [{**s, "tolerance": SHAPE_TOLERANCE} for s in shapes]
    configurations = frame.configurations(frequencies, shapes, subdivisions)
    return replace(frame.case(), configurations=tuple(configurations), frequency_tolerance=1e-4)


def _parameter_error(parameters, values) -> dict:
    """Largest error relative to the true value (to the bound range where the truth is 0),
    the parameter it occurs at and the median over all parameters."""
    import numpy as np

    from vibupdate.examples import frame

    truth = frame.truth()
    true = np.array([truth[p.name] for p in parameters])
    scale = np.where(true != 0, np.abs(true), np.array([p.upper - p.lower for p in parameters]))
    err = np.abs(np.asarray(values, dtype=float) - true) / scale
    k = int(np.argmax(err))
    return {"max": float(err[k]), "at": parameters[k].name, "median": float(np.median(err))}


def update_point(subdivisions: int) -> dict:
    from vibupdate import update
    from vibupdate.inverse.verify import VerifyOptions

    t0 = time.perf_counter()
    case = exact_case(subdivisions)
    setup_s = time.perf_counter() - t0
    t0 = time.perf_counter()
    result = update(case.configurations, formulation=case.formulation, solver=case.solver,
                    verification=VerifyOptions(frequency_tolerance=case.frequency_tolerance))
    return {"subdivisions": subdivisions, "dofs": case.configurations[0].model.n_dofs, "setup_s": setup_s,
            "update_s": time.perf_counter() - t0, "status": result.status.value,
            "parameter_error": _parameter_error(result.parameters, result.values),
            "mean_frequency_error_pct": result.mean_error(),
            "peak_mb": _peak_mb()}


def run_point(subdivisions: int) -> dict:
    import tempfile

    from vibupdate.pipeline import run_case

    t0 = time.perf_counter()
    case = exact_case(subdivisions)
    with tempfile.TemporaryDirectory() as tmp:
        run = run_case(case, Path(tmp) / "out")
        plots = sorted(p.name for p in (Path(tmp) / "out").rglob("*.png"))
    parameters = case.configurations[0].model.parameters
    updated = {row.name: row.updated for row in run.parameters}
    return {"subdivisions": subdivisions, "dofs": case.configurations[0].model.n_dofs,
            "total_s": time.perf_counter() - t0, "success": run.success,
            "parameter_error": _parameter_error(parameters, [updated[p.name] for p in parameters]),
            "plots": len(plots), "peak_mb": _peak_mb()}


POINTS = {"kernels": kernels, "update": update_point, "run": run_point}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("what", choices=sorted(POINTS))
    parser.add_argument("--subdivisions", type=int, nargs="+")
    parser.add_argument("--timeout", type=float, default=1800.0, help="seconds per size")
    parser.add_argument("--point", type=int, help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.point is not None:
        print(json.dumps(POINTS[args.what](args.point)))
        return
    for s in args.subdivisions or DEFAULTS[args.what]:
        try:
            proc = subprocess.run([sys.executable, __file__, args.what, "--point", str(s)],
                                  capture_output=True, text=True, timeout=args.timeout)
            row = json.loads(proc.stdout.strip().splitlines()[-1]) if proc.returncode == 0 else \
                {"subdivisions": s, "error": (proc.stderr.strip().splitlines() or ["?"])[-1][:160]}
        except subprocess.TimeoutExpired:
            row = {"subdivisions": s, "error": f"over {args.timeout:.0f} s"}
        print(json.dumps(row), flush=True)


if __name__ == "__main__":
    main()
