"""Scaling benchmark: the frame example refined from ~30 to ~30,000 DOFs, with exact data.

Run:  python benchmarks/scaling.py kernels [--subdivisions 8 77 770]
      python benchmarks/scaling.py update  [--subdivisions 8 77 770]
      python benchmarks/scaling.py run     [--subdivisions 8 77 770]
      python benchmarks/scaling.py examples

Every element of the frame example is split into ``s`` equal elements (s = 8, 77, 770 give
305, 2,996 and 30,023 DOFs); the 29 parameters, the 7 measured modes and the measured DOFs (x,
y of the 10 original free nodes) stay the same. Each size runs in its own process, so that
its peak memory (max RSS, which includes the ~100 MB of the imported libraries) is its own.

**Exact data** are the true model's 7 natural frequencies and its mode shapes at the 20
measured DOFs *as points* (intervals of zero width), with a frequency tolerance of 1e-4 for
the consistency check. Points, because these data determine the 29 parameters only weakly:
the exact sensitivity of the data to the normalized parameters at the truth (`determinacy`)
has full rank but a condition number of 7e5, and its smallest singular values (2e-5) belong
to the rotary inertias J3, J5, J7, J9, J11 and to the difference of the two balancing
springs kbs - kbs2. Shape intervals of +-1e-4, as an earlier version of this benchmark used,
let J5 move by up to 28 units of its normalized range (1e-4 times the largest row sum of the
pseudo-inverse, 2.8e5): every point inside the intervals fits, and "the exact answer" is
not defined for those parameters. ``determinacy`` lists, per parameter, the data accuracy
needed to fix it to 1e-4 and which parameters +-1e-4 intervals leave undetermined.

* ``kernels``: seconds of the model build (29 complex-step builder calls plus the affine
  check), of the 7 lowest modes, of one receptance over 400 frequency lines (0 to 1.2 times
  the 7th natural frequency) and of the 7 lowest antiresonances of a driving-point and of a
  transfer receptance, with the largest backward error of the modes.
* ``update``: Problem 1 with exact data: seconds, status and parameter errors of `update`
  and, in the same process, of the two peers a competent user would write
  (`vibupdate.inverse.baseline`: the classical frequency fit and the eigenvector-difference
  fit, both from the nominal model with exact Jacobians), with the determinacy report.
* ``run``: the whole pipeline of ``vibupdate run`` (`pipeline.run_case`: update, damping,
  identifiability, results, report, plots, matrices) on exact data, in a temporary
  directory, with the parameter errors and the peak memory.
* ``examples``: `update` and both peers on the cantilever (paper test case 2) and on the
  frame example with its bundled (noisy) data.
"""

from __future__ import annotations

import os
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))   # the frame data generator

from exact_data import peak_mb as _peak_mb, timed as _timed, sizes_main, update_and_peers

os.environ.setdefault("OMP_NUM_THREADS", "1")

DEFAULTS = {"kernels": (8, 77, 770), "update": (8, 77, 770), "run": (8, 77, 770), "examples": (0,)}
#: Half-width of the exact shape data (points) and the frequency tolerance of the checks.
SHAPE_TOLERANCE = 0.0
FREQUENCY_TOLERANCE = 1e-4
#: Target for the parameter errors on exact data.
TARGET = 1e-4
#: Tolerances of the peers on exact data, the polish's (scipy's default 1e-8 would stop them
#: short of an exact answer); `examples` leaves them at scipy's defaults.
N_LINES = 400



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
    z_rc = antiresonances(M, K, r, c, n_zeros=7)
    zeros_rc_s = time.perf_counter() - t0
    return {"subdivisions": subdivisions, "dofs": model.n_dofs, "build_s": build_s, "modes_s": modes_s,
            "receptance_s": receptance_s, "zeros_rr_s": zeros_rr_s, "zeros_rc_s": zeros_rc_s,
            "backward_error": float(mode_residuals(M, K, omega, Phi).max()),
            "f1_hz": float(omega[0] / (2 * np.pi)), "n_zeros": [int(z_rr.size), int(z_rc.size)],
            "h_finite": bool(np.all(np.isfinite(h))), "peak_mb": _peak_mb()}


def exact_case(subdivisions: int):
    """The frame case on the refined model with exact data (module docstring)."""
    from dataclasses import replace

    import frame_data
    from vibupdate.examples import frame

    frequencies, shapes = frame_data.generate(frequency_error=0.0, shape_error=0.0, subdivisions=subdivisions)
    shapes = [{**s, "tolerance": SHAPE_TOLERANCE} for s in shapes]
    configurations = frame.configurations(frequencies, shapes, subdivisions)
    return replace(frame.case(), configurations=tuple(configurations), frequency_tolerance=FREQUENCY_TOLERANCE)


def _scale(parameters):
    """Per parameter, what its error is relative to: the true value, or the bound range where
    the truth is 0."""
    import numpy as np

    from vibupdate.examples import frame

    truth = frame.truth()
    true = np.array([truth[p.name] for p in parameters])
    return true, np.where(true != 0, np.abs(true), np.array([p.upper - p.lower for p in parameters]))


def _parameter_error(parameters, values) -> dict:
    """Largest error relative to the true value (to the bound range where the truth is 0),
    the parameter it occurs at, the median over all parameters and the parameters above
    `TARGET`."""
    import numpy as np

    true, scale = _scale(parameters)
    err = np.abs(np.asarray(values, dtype=float) - true) / scale
    k = int(np.argmax(err))
    return {"max": float(err[k]), "at": parameters[k].name, "median": float(np.median(err)),
            "above_target": [p.name for p, e in zip(parameters, err) if e > TARGET]}


def determinacy(configurations) -> dict:
    """What the data determine, from the exact sensitivity ``S`` (relative frequencies and
    shape ratios per normalized parameter) at the truth.

    ``amplification[i]`` is the row sum of ``|pinv(S)|``: the largest change of parameter
    ``i`` (normalized) that data errors of at most 1 can cause to first order. A parameter is
    fixed to `TARGET` of its scale by data accurate to ``needed[i] = TARGET * scale_i /
    (p_ref_i * amplification[i])``; data within +-1e-4 leave it uncertain by up to
    ``1e-4 p_ref_i amplification[i] / scale_i`` of its scale (undetermined above 1)."""
    import numpy as np

    from vibupdate.inverse.data_map import sensitivity

    model = configurations[0].model
    true, scale = _scale(model.parameters)
    found = sensitivity(configurations, model.normalized(true))
    amplification = np.abs(np.linalg.pinv(found.matrix)).sum(axis=1)
    p_ref = np.array([p.reference if p.reference else abs(p.nominal) for p in model.parameters])
    needed = TARGET * scale / (p_ref * amplification)
    names = [p.name for p in model.parameters]
    order = np.argsort(needed)
    sv = found.singular_values
    with_intervals = 1e-4 * p_ref * amplification / scale   # worst first-order error, +-1e-4 data
    return {"rank": found.rank, "singular_values": [float(sv[0]), float(sv[-1])], "condition": found.condition,
            "data_accuracy_needed": {names[i]: float(needed[i]) for i in order[:8]},
            "error_with_1e-4_intervals": {names[i]: float(with_intervals[i]) for i in order[:8]},
            "undetermined_by_1e-4_intervals": [names[i] for i in order if with_intervals[i] > 1.0]}



def update_point(subdivisions: int) -> dict:
    """`update` and both peers on exact data, same process (`exact_data.update_and_peers`)."""
    setup_s, case = _timed(lambda: exact_case(subdivisions))
    configurations = case.configurations
    parameters = configurations[0].model.parameters
    row = {"subdivisions": subdivisions, "dofs": configurations[0].model.n_dofs, "setup_s": setup_s,
           **update_and_peers(case, lambda values: _parameter_error(parameters, values))}
    row["determinacy"] = determinacy(configurations)
    row["peak_mb"] = _peak_mb()
    return row


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
            "warnings": [w[:300] for w in run.warnings], "plots": len(plots), "peak_mb": _peak_mb()}


def examples_point(_: int = 0) -> dict:
    """`update` and both peers on the cantilever and on the frame example (bundled data)."""
    from vibupdate import update
    from vibupdate.examples import cantilever, frame
    from vibupdate.inverse.baseline import eigenvector_fit, frequency_fit

    rows = {}
    for name, configurations, truth in (("cantilever", cantilever.configurations(), None),
                                        ("frame", frame.case().configurations, frame.truth())):
        parameters = configurations[0].model.parameters
        update(configurations)   # warm-up (imports, CasADi)
        t, result = _timed(lambda: update(configurations))
        row = {"update": {"seconds": t, "status": result.status.value, "mean_frequency_error_pct": result.mean_error()}}
        if truth:
            row["update"]["parameter_error"] = _parameter_error(parameters, result.values)
        for label, fn in (("frequency_fit", frequency_fit), ("eigenvector_fit", eigenvector_fit)):
            fit = fn(configurations)
            row[label] = {"seconds": fit.seconds, "evaluations": fit.n_evaluations,
                          "mean_frequency_error_pct": fit.mean_error_pct}
            if truth:
                row[label]["parameter_error"] = _parameter_error(parameters, fit.values)
        rows[name] = row
    return rows


POINTS = {"kernels": kernels, "update": update_point, "run": run_point, "examples": examples_point}


def main() -> None:
    sizes_main(__file__, __doc__, POINTS, "subdivisions", "subdivisions", DEFAULTS.__getitem__, error_chars=160)


if __name__ == "__main__":
    main()
