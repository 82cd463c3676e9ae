"""The whole `vibupdate run` against a classical fit a user would write, on the building frame
at ~3,000, ~30,000 and ~300,000 DOFs, exact data, in one benchmark run.

Run:  python benchmarks/run_speed.py [--sizes 3000 30000 300000] [--damping] [--profile] [--no-classical]

The structure is `tests/building.py` (a planar steel frame of ``storeys`` x ``bays``,
12 parameters: column and beam stiffness factors and a superimposed floor mass per group of
storeys). Its exact data (the 8 lowest natural frequencies, the shapes at 20-30 translational
DOFs as points) and its affine model are written as a user exporting from an FE package would
write them: ``M0``, ``K0`` and one ``dM/dp``, ``dK/dp`` per parameter as ``.npz`` files, a case
file of ``type = "matrices"`` and the shapes as CSV. No damping data unless ``--damping``.

* **classical fit**: `scipy.optimize.least_squares` (``trf``, forward-difference Jacobian,
  ``xtol = ftol = gtol = 1e-12``) from the nominal parameters on the relative frequency errors
  and the shape misfits (the model's shape at the measured DOFs scaled to the measured one by
  least squares), each evaluation one sparse shift-invert `scipy.sparse.linalg.eigsh` about 0
  of the full model: the peer a user with scipy writes.
* **vibupdate run**: ``python -m vibupdate run case.toml --out DIR`` in a child process, wall
  time from spawn to exit (imports, loading, update, damping, identifiability, writing, report,
  plots), its stages from its own progress messages, its peak memory (max RSS of the child).

Each size runs in its own process. Parameter error: ``|updated - true| / |true|``.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))   # the building frame

os.environ.setdefault("OMP_NUM_THREADS", "1")

SIZES = {3000: (14, 6), 30000: (43, 21), 300000: (135, 67)}


def write_case(folder: Path, storeys: int, bays: int, damping: bool, exact_family: bool = False) -> Path:
    """The building's nominal model, its parameter derivatives and its exact data as files;
    with ``exact_family`` the case states model-form tolerances of 0 (the model family holds
    the truth), else it keeps the defaults (2 %)."""
    import numpy as np
    import scipy.sparse as sp

    import building

    model = building.model(storeys, bays)
    omega, ratios, shapes = building.exact_data(storeys, bays)
    dofs = building.measured_dofs(storeys, bays)
    sp.save_npz(folder / "M0.npz", sp.csr_matrix(model.M0))
    sp.save_npz(folder / "K0.npz", sp.csr_matrix(model.K0))
    dM, dK = [], []
    for p, Mi, Ki in zip(model.parameters, model.M_par, model.K_par):
        r = p.reference if p.reference else p.nominal   # the affine model holds d/d xbar = p_ref d/dp
        sp.save_npz(folder / f"dM_{p.name}.npz", sp.csr_matrix(Mi) / r)
        sp.save_npz(folder / f"dK_{p.name}.npz", sp.csr_matrix(Ki) / r)
        dM.append(f'{p.name} = "dM_{p.name}.npz"')
        dK.append(f'{p.name} = "dK_{p.name}.npz"')
    rows = ["mode,dof,value,tolerance"] + [f"{k + 1},{d},{float(shapes[i, k])!r},0"
                                           for k in range(omega.size) for i, d in enumerate(dofs)]
    (folder / "shapes.csv").write_text("\n".join(rows) + "\n")
    (folder / "dofs.json").write_text(json.dumps(list(model.dofs)))
    params = "\n".join(f'[[parameter]]\nname = "{p.name}"\nnominal = {p.nominal!r}\nlower = {p.lower!r}\n'
                       f'upper = {p.upper!r}\n' for p in model.parameters)
    hz = ", ".join(repr(float(w / (2 * np.pi))) for w in omega)
    extra = (f"damping_ratios = {[float(z) for z in ratios]}\n" if damping else "")
    case = (f'case = "building-{model.n_dofs}"\n\n[model]\ntype = "matrices"\nM0 = "M0.npz"\nK0 = "K0.npz"\n'
            f'dofs = {json.dumps(list(model.dofs))}\n\n[model.dM]\n' + "\n".join(dM) + "\n\n[model.dK]\n"
            + "\n".join(dK) + f"\n\n{params}\n[[configuration]]\nname = \"building\"\nnatural_hz = [{hz}]\n"
            'mode_shapes_csv = "shapes.csv"\n' + extra
            + ("\n[verification]\nnatural_tolerance = 0.0\nshape_tolerance = 0.0\n" if exact_family else ""))
    (folder / "case.toml").write_text(case)
    return folder / "case.toml"


def classical_fit(storeys: int, bays: int) -> dict:
    """`scipy.optimize.least_squares` with a forward-difference Jacobian and a sparse
    shift-invert eigen-solve per evaluation (module docstring)."""
    import numpy as np
    import scipy.optimize
    import scipy.sparse as sp
    import scipy.sparse.linalg as sla

    import building

    model = building.model(storeys, bays)
    omega_m, _, shapes_m = building.exact_data(storeys, bays)
    idx = np.array([model.dof(d) for d in building.measured_dofs(storeys, bays)])
    n = omega_m.size
    M0, K0 = sp.csc_matrix(model.M0), sp.csc_matrix(model.K0)
    Mi = [sp.csc_matrix(m) for m in model.M_par]
    Ki = [sp.csc_matrix(k) for k in model.K_par]
    counter = [0]

    def residuals(xbar):
        counter[0] += 1
        M = M0 + sum(x * m for x, m in zip(xbar, Mi))
        K = K0 + sum(x * k for x, k in zip(xbar, Ki))
        lam, Phi = sla.eigsh(K, k=n, M=M, sigma=0.0, which="LM", v0=np.ones(K.shape[0]))
        order = np.argsort(lam)
        omega, shapes = np.sqrt(lam[order]), Phi[idx][:, order]
        scale = np.sum(shapes * shapes_m, axis=0) / np.sum(shapes * shapes, axis=0)
        return np.concatenate([omega / omega_m - 1.0, (shapes * scale - shapes_m).ravel()])

    truth = building.truth()
    true = np.array([truth[p.name] for p in model.parameters])
    t0 = time.perf_counter()
    fit = scipy.optimize.least_squares(residuals, np.zeros(model.n_parameters), jac="2-point",
                                       bounds=model.bounds(), xtol=1e-12, ftol=1e-12, gtol=1e-12)
    seconds = time.perf_counter() - t0
    values = model.physical(fit.x)
    err = np.abs(values - true) / np.abs(true)
    return {"seconds": seconds, "evaluations": counter[0], "message": fit.message,
            "max_parameter_error": float(err.max())}


def vibupdate_run(case: Path, out: Path, profile: bool) -> dict:
    """``vibupdate run`` in a child process (module docstring)."""
    import numpy as np

    import building

    cmd = [sys.executable, "-m", "vibupdate", "run", str(case), "--out", str(out)]
    if profile:
        cmd = [sys.executable, "-m", "cProfile", "-o", str(out.parent / "run.prof"), "-m", "vibupdate", "run",
               str(case), "--out", str(out)]
    t0 = time.perf_counter()
    done = subprocess.run(cmd, capture_output=True, text=True)
    seconds = time.perf_counter() - t0
    peak = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024
    row = {"seconds": seconds, "exit": done.returncode, "peak_mb": peak,
           "stdout_tail": done.stdout.splitlines()[-40:], "stderr_tail": done.stderr.splitlines()[-10:]}
    results = out / "results.json"
    if results.is_file():
        doc = json.loads(results.read_text())
        truth = building.truth()
        err = [abs(p["updated"] / truth[p["name"]] - 1) for p in doc["parameters"]]
        sought = doc["solver"].get("sought") or {}
        row.update(status=doc["solver"]["status"], verdict=doc["solver"].get("verdict"),
                   uniqueness_searched=sought.get("uniqueness_searched"), uniqueness=sought.get("reason"),
                   max_parameter_error=float(np.max(err)))
    if profile:
        import pstats
        import io
        buf = io.StringIO()
        pstats.Stats(str(out.parent / "run.prof"), stream=buf).sort_stats("cumulative").print_stats(40)
        row["profile"] = buf.getvalue().splitlines()[:80]
    return row


def point(size: int, damping: bool, profile: bool, classical: bool = True, exact_family: bool = False) -> dict:
    import building

    storeys, bays = SIZES[size]
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        t0 = time.perf_counter()
        case = write_case(folder, storeys, bays, damping, exact_family)
        setup = time.perf_counter() - t0
        run = vibupdate_run(case, folder / "out", profile)
        peer = classical_fit(storeys, bays) if classical else None
    return {"size": size, "dofs": building.n_dofs(storeys, bays), "setup_s": setup, "classical": peer,
            "run": run, "ratio_run_classical": run["seconds"] / peer["seconds"] if peer else None,
            "load_average": os.getloadavg()}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", type=int, nargs="*", default=[3000, 30000])
    parser.add_argument("--damping", action="store_true", help="give the case damping ratios")
    parser.add_argument("--profile", action="store_true", help="cProfile the child run")
    parser.add_argument("--no-classical", action="store_true", help="vibupdate run only (the classical fit "
                        "at 300,000 DOFs takes about 145 sparse eigen-solves of the full model)")
    parser.add_argument("--exact-family", action="store_true", help="the case states model-form tolerances of 0 "
                        "(the model family holds the truth; default: the 2 %% defaults)")
    parser.add_argument("--point", type=int, help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.point:
        print(json.dumps(point(args.point, args.damping, args.profile, not args.no_classical, args.exact_family)))
        return
    for size in args.sizes:
        cmd = [sys.executable, __file__, "--point", str(size)] + (["--damping"] if args.damping else []) \
            + (["--profile"] if args.profile else []) + (["--no-classical"] if args.no_classical else []) \
            + (["--exact-family"] if args.exact_family else [])
        done = subprocess.run(cmd, capture_output=True, text=True)
        print(done.stdout.strip() or done.stderr[-3000:], flush=True)


if __name__ == "__main__":
    main()
