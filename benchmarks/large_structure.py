"""Exact data at ~300, ~3,000 and ~30,000 DOFs on a structure that is large, not over-refined.

Run:  python benchmarks/large_structure.py check  [--sizes 300 3000 30000]
      python benchmarks/large_structure.py update [--sizes 300 3000 30000]
      python benchmarks/large_structure.py run    [--sizes 300 3000 30000]

The structure is `tests/building.py`: a planar steel building frame of ``storeys`` x
``bays`` with 0.75 m frame elements on 0.3-0.36 m deep sections, 12 parameters (column and
beam stiffness factors and superimposed floor mass, per group of storeys), the 8 lowest modes
with shapes at 20-30 translational DOFs. The sizes grow by storeys and bays:

    ~300 DOFs: 7 x 1 (315 DOFs); ~3,000: 14 x 6 (2,940); ~30,000: 43 x 21 (30,315).

**Exact data** are the true model's frequencies and its shapes at the measured DOFs as points
(intervals of zero width), frequency tolerance 1e-4, as `benchmarks/scaling.py` uses.

* ``check``: what the data determine (exact sensitivity at the truth: rank, smallest singular
  value, condition, the first-order amplification of data errors per parameter) and the
  rounding floor of the mesh: every stored entry of ``K`` changed by one rounding unit
  (relative 2.2e-16, random sign, symmetric), the largest relative change of the 8 frequencies
  and of the measured shape ratios.
* ``update``: `update` and, in the same process, the two peers (`vibupdate.inverse.baseline`:
  classical frequency fit and eigenvector-difference fit from the nominal model, exact
  Jacobians, tolerances 1e-12).
* ``run``: `pipeline.run_case` (what ``vibupdate run`` does: update, damping,
  identifiability, results, report, plots, matrices) in a temporary directory, with the time
  of each stage (from its progress messages), the parameter errors and the peak memory.

Each size runs in its own process so that its peak memory (max RSS, including ~100 MB of
imported libraries) is its own. Parameter error: ``|updated - true| / |true|``.
"""

from __future__ import annotations

import os
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))   # the building frame

from exact_data import peak_mb as _peak_mb, timed as _timed, sizes_main, update_and_peers

os.environ.setdefault("OMP_NUM_THREADS", "1")

SIZES = {300: (7, 1), 3000: (14, 6), 30000: (43, 21)}
FREQUENCY_TOLERANCE = 1e-4
TARGET = 1e-4




def _parameter_error(parameters, values) -> dict:
    import numpy as np

    import building

    truth = building.truth()
    true = np.array([truth[p.name] for p in parameters])
    err = np.abs(np.asarray(values, dtype=float) - true) / np.abs(true)
    k = int(np.argmax(err))
    return {"max": float(err[k]), "at": parameters[k].name, "median": float(np.median(err)),
            "above_target": [p.name for p, e in zip(parameters, err) if e > TARGET]}


def _ratios(Phi, idx, ref=None):
    """Shape ratios at the measured DOFs: each mode scaled to its entry ``ref`` (default: its
    largest measured entry), and the reference entries, shape (n_modes,)."""
    import numpy as np

    shapes = Phi[idx]
    ref = np.argmax(np.abs(shapes), axis=0) if ref is None else ref
    return shapes / shapes[ref, np.arange(shapes.shape[1])], ref


def rounding_floor(M, K, idx, n_modes: int, seed: int = 0) -> dict:
    """Largest relative change of the frequencies and of the shape ratios when every stored
    entry of ``K`` (upper triangle, mirrored) moves by one relative rounding unit."""
    import numpy as np
    import scipy.sparse as sp

    from vibupdate.modal.analysis import modes

    rng = np.random.default_rng(seed)
    upper = sp.triu(K, format="coo")
    signs = rng.choice([-1.0, 1.0], size=upper.nnz)
    D = sp.coo_matrix((upper.data * signs * np.finfo(float).eps, (upper.row, upper.col)), shape=K.shape)
    D = (D + sp.triu(D, k=1, format="coo").T).tocsr()
    w0, P0 = modes(M, K, n_modes)
    w1, P1 = modes(M, (K + D).tocsr(), n_modes)
    r0, ref = _ratios(P0, idx)
    r1, _ = _ratios(P1, idx, ref)
    return {"frequency": float(np.max(np.abs(w1 - w0) / w0)), "shape_ratio": float(np.max(np.abs(r1 - r0))),
            "perturbation_norm": float(abs(D).max())}


def check_point(size: int) -> dict:
    """Determinacy of the data and the rounding floor of the model at the truth."""
    import numpy as np

    import building
    from vibupdate.inverse.data_map import sensitivity

    storeys, bays = SIZES[size]
    build_s, configurations = _timed(lambda: building.configurations(storeys, bays))
    model = configurations[0].model
    truth = building.truth()
    values = np.array([truth[p.name] for p in model.parameters])
    sens_s, found = _timed(lambda: sensitivity(configurations, model.normalized(values)))
    sv = found.singular_values
    amplification = np.abs(np.linalg.pinv(found.matrix)).sum(axis=1)
    names = [p.name for p in model.parameters]
    M, K = model.matrices_at(values)
    idx = [model.dof(d) for d in building.measured_dofs(storeys, bays)]
    floor_s, floor = _timed(lambda: rounding_floor(M, K, idx, building.N_MODES))
    omega = building.exact_data(storeys, bays)[0]
    return {"size": size, "storeys": storeys, "bays": bays, "dofs": model.n_dofs, "parameters": len(names),
            "measured_dofs": len(idx), "data_rows": int(found.matrix.shape[0]),
            "frequencies_hz": [round(float(x), 4) for x in omega / (2 * np.pi)],
            "rank": found.rank, "singular_values": [float(sv[0]), float(sv[-1])],
            "condition": float(found.condition),
            "weakest": names[int(np.argmax(amplification))],
            "amplification_max": float(amplification.max()),
            "rounding": floor, "build_s": build_s, "sensitivity_s": sens_s, "rounding_s": floor_s,
            "peak_mb": _peak_mb()}


def exact_case(size: int):
    import building
    from vibupdate.inverse.formulation.options import FormulationOptions
    from vibupdate.inverse.homotopy import SolverOptions
    from vibupdate.io.case_types import Case, DampingOptions

    storeys, bays = SIZES[size]
    configurations = building.configurations(storeys, bays)
    damping = DampingOptions(exponents=building.DAMPING_LAW[0], rationale="the law that generated the data")
    return Case("building", None, tuple(configurations), SolverOptions(), FormulationOptions(), damping,
                frequency_tolerance=FREQUENCY_TOLERANCE)


def update_point(size: int) -> dict:
    """`update` and both peers on exact data, same process (`exact_data.update_and_peers`)."""
    setup_s, case = _timed(lambda: exact_case(size))
    configurations = case.configurations
    parameters = configurations[0].model.parameters
    row = {"size": size, "dofs": configurations[0].model.n_dofs, "setup_s": setup_s,
           **update_and_peers(case, lambda values: _parameter_error(parameters, values))}
    row["peak_mb"] = _peak_mb()
    return row


def run_point(size: int) -> dict:
    """`run_case` end to end, with the seconds between its progress messages."""
    import tempfile

    from vibupdate.pipeline import run_case

    t0 = time.perf_counter()
    stages = []

    def progress(message: str) -> None:
        stages.append((round(time.perf_counter() - t0, 2), message[:80]))

    case = exact_case(size)
    setup_s = time.perf_counter() - t0
    with tempfile.TemporaryDirectory() as tmp:
        run = run_case(case, Path(tmp) / "out", progress=progress)
        plots = sorted(p.name for p in (Path(tmp) / "out").rglob("*.png"))
    parameters = case.configurations[0].model.parameters
    updated = {row.name: row.updated for row in run.parameters}
    return {"size": size, "dofs": case.configurations[0].model.n_dofs, "setup_s": setup_s,
            "total_s": time.perf_counter() - t0, "success": run.success,
            "parameter_error": _parameter_error(parameters, [updated[p.name] for p in parameters]),
            "warnings": [w[:300] for w in run.warnings], "plots": len(plots), "stages": stages,
            "peak_mb": _peak_mb()}


POINTS = {"check": check_point, "update": update_point, "run": run_point}


def main() -> None:
    sizes_main(__file__, __doc__, POINTS, "sizes", "size", lambda what: sorted(SIZES), sorted(SIZES))


if __name__ == "__main__":
    main()
