"""Scaling benchmark: Problem 1 on the frame example refined from ~30 to ~3000 DOFs.

Run:  python benchmarks/scaling.py [--subdivisions 1 3 8 26 77] [--write benchmarks/RESULTS.md]

Every element of the frame example is split into ``s`` equal elements; the 29 parameters,
the 7 measured modes and the measured DOFs (x, y of the 10 original free nodes) stay the same,
with the seeded data regenerated from the true refined model. Each size runs in its own
process, so that its peak memory (max RSS) is its own. Reported per size: DOFs, unknowns
(parameters + vector entries + lifted + residuals), lifted scalars, constraints (residual
equalities + 4 McCormick rows per lifted scalar), seconds of the model build, of the
lambda = 0 solve, of the whole homotopy (solver build included), status, frequency error,
minimum MAC and peak memory.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import subprocess
import sys
import time
from pathlib import Path

os.environ.setdefault("OMP_NUM_THREADS", "1")

DEFAULT_SUBDIVISIONS = (1, 3, 8, 26, 77)


def one_point(subdivisions: int, reduction: str = "auto") -> dict:
    """Run one size in this process and return its figures."""
    import resource

    from vibupdate import FormulationOptions, update
    from vibupdate.examples import frame

    t0 = time.perf_counter()
    model = frame.model(subdivisions)
    build_seconds = time.perf_counter() - t0
    frequencies, shapes = frame.generate(subdivisions=subdivisions)
    configurations = frame.configurations(frequencies, shapes, subdivisions)
    t0 = time.perf_counter()
    result = update(configurations, formulation=FormulationOptions(reduction=reduction))
    update_seconds = time.perf_counter() - t0
    size = result.problem_size
    n_unknowns = size["n_parameters"] + size["n_mode_unknowns"] + size["n_adjunct_unknowns"] + size["n_lifted"] \
        + size["n_residuals"]
    return {
        "subdivisions": subdivisions,
        "dofs": model.n_dofs,
        "solved_dofs": size.get("reduced_dofs", model.n_dofs),
        "unknowns": n_unknowns,
        "lifted": size["n_lifted"],
        "constraints": size["n_residuals"] + 4 * size["n_lifted"],
        "build_s": build_seconds,
        "lambda0_s": result.steps[0].seconds,
        "homotopy_s": result.seconds,
        "update_s": update_seconds,
        "iterations": sum(s.iterations for s in result.steps),
        "status": result.status.value,
        "mean_error_pct": result.mean_error(),
        "mac_min": float(min(result.mac["frame"])),
        "peak_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024,
    }


def table(rows: list[dict]) -> str:
    head = ("| DOFs | solved DOFs | unknowns | lifted | constraints | model build s | lambda=0 s | homotopy s "
            "| IPOPT iter. | status | freq. error % | min MAC | peak MB |")
    lines = [head, "|" + "---:|" * 13]
    for r in rows:
        if "error" in r:
            lines.append(f"| s = {r.get('subdivisions', '?')} | failed: {r['error']} |" + " |" * 11)
            continue
        lines.append(
            f"| {r['dofs']} | {r['solved_dofs']} | {r['unknowns']} | {r['lifted']} | {r['constraints']} | {r['build_s']:.2f} | "
            f"{r['lambda0_s']:.2f} | {r['homotopy_s']:.2f} | {r['iterations']} | {r['status']} | "
            f"{r['mean_error_pct']:.3f} | {r['mac_min']:.3f} | {r['peak_mb']:.0f} |")
    return "\n".join(lines)


def machine() -> str:
    import numpy
    import scipy

    try:
        import casadi

        cas = casadi.__version__
    except ImportError:
        cas = "?"
    cpu = platform.processor() or platform.machine()
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    mem = ""
    try:
        kb = int(Path("/proc/meminfo").read_text().split()[1])
        mem = f", {kb / 1024**2:.0f} GiB"
    except (OSError, ValueError, IndexError):
        pass
    return (f"{cpu}, {os.cpu_count()} cores{mem}; Python {platform.python_version()}, numpy {numpy.__version__}, "
            f"scipy {scipy.__version__}, CasADi {cas} (IPOPT + MUMPS); OMP_NUM_THREADS=1")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--subdivisions", type=int, nargs="+", default=list(DEFAULT_SUBDIVISIONS))
    parser.add_argument("--write", default=None, help="write the table into this Markdown file")
    parser.add_argument("--timeout", type=float, default=540.0, help="seconds per size")
    parser.add_argument("--reduction", default="auto", choices=["auto", "none", "craig-bampton"],
                        help="formulation option 'reduction' (default auto)")
    parser.add_argument("--point", type=int, help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.point is not None:
        print(json.dumps(one_point(args.point, args.reduction)))
        return
    rows = []
    for s in args.subdivisions:
        try:
            proc = subprocess.run([sys.executable, __file__, "--point", str(s), "--reduction", args.reduction],
                                  capture_output=True, text=True, timeout=args.timeout)
            row = json.loads(proc.stdout.strip().splitlines()[-1]) if proc.returncode == 0 else \
                {"subdivisions": s, "error": (proc.stderr.strip().splitlines() or ["?"])[-1][:120]}
        except subprocess.TimeoutExpired:
            row = {"subdivisions": s, "error": f"over {args.timeout:.0f} s"}
        rows.append(row)
        print(json.dumps(row), flush=True)
    text = table(rows)
    print(text)
    if args.write:
        Path(args.write).write_text(f"Machine: {machine()}\nReduction: {args.reduction}\n\n{text}\n",
                                    encoding="utf-8")


if __name__ == "__main__":
    main()
