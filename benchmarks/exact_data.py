"""Shared by the exact-data benchmarks (`scaling.py`, `large_structure.py`): timing, peak
memory, and `update` beside the two peers on the same configurations in one process."""

from __future__ import annotations

import time

PEER_TOL = 1e-12


def peak_mb() -> float:
    """Peak resident memory of this process so far, MB."""
    import resource

    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024


def timed(fn):
    """``(seconds, fn())``."""
    t0 = time.perf_counter()
    out = fn()
    return time.perf_counter() - t0, out


def update_and_peers(case, parameter_error) -> dict:
    """`update` of ``case`` (its formulation and solver options, verification at its frequency
    tolerance), then the classical frequency fit and the eigenvector-difference fit from the
    nominal model (exact Jacobians, ``ftol = xtol = gtol = PEER_TOL``), each with
    ``parameter_error(values)`` of its physical parameter values."""
    from vibupdate import update
    from vibupdate.inverse.baseline import eigenvector_fit, frequency_fit
    from vibupdate.inverse.verify import VerifyOptions

    configurations = case.configurations
    model = configurations[0].model
    seconds, result = timed(lambda: update(configurations, formulation=case.formulation, solver=case.solver,
                                           verification=VerifyOptions(frequency_tolerance=case.frequency_tolerance)))
    row = {"update": {"seconds": seconds, "status": result.status.value,
                      "parameter_error": parameter_error(result.values),
                      "first_stage_error": parameter_error(model.physical(result.first_stage_xbar)),
                      "polish": result.polish.as_dict() if result.polish else None,
                      "failed_checks": [c.message[:300] for c in result.checks
                                        if c.severity == "error" and not c.passed]}}
    for name, fn in (("frequency_fit", frequency_fit), ("eigenvector_fit", eigenvector_fit)):
        fit = fn(configurations, tol=PEER_TOL)
        row[name] = {"seconds": fit.seconds, "evaluations": fit.n_evaluations, "message": fit.message,
                     "parameter_error": parameter_error(fit.values),
                     "mean_frequency_error_pct": fit.mean_error_pct}
    return row


def sizes_main(script: str, doc: str, points: dict, option: str, key: str, default, choices=None,
               error_chars: int = 300) -> None:
    """The command line of a size sweep: ``script WHAT [--OPTION N ...] [--timeout S]`` runs
    `run_sizes` over the sizes (``default(WHAT)`` when none are given); the hidden ``--point N``
    runs ``points[WHAT](N)`` in this process and prints its JSON row."""
    import argparse
    import json

    parser = argparse.ArgumentParser(description=doc.splitlines()[0])
    parser.add_argument("what", choices=sorted(points))
    parser.add_argument(f"--{option}", type=int, nargs="+", choices=choices)
    parser.add_argument("--timeout", type=float, default=1800.0, help="seconds per size")
    parser.add_argument("--point", type=int, help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.point is not None:
        print(json.dumps(points[args.what](args.point)))
        return
    run_sizes(script, args.what, getattr(args, option) or default(args.what), key, args.timeout, error_chars)


def run_sizes(script: str, what: str, sizes, key: str, timeout: float, error_chars: int = 300) -> None:
    """Run ``script what --point SIZE`` for each size in its own process (so that its peak
    memory is its own) and print one JSON row per size, with the load average before and
    after it; a failed or over-time size is a row with ``error``."""
    import json
    import os
    import subprocess
    import sys

    for size in sizes:
        load_before = os.getloadavg()[0]
        try:
            proc = subprocess.run([sys.executable, script, what, "--point", str(size)],
                                  capture_output=True, text=True, timeout=timeout)
            row = json.loads(proc.stdout.strip().splitlines()[-1]) if proc.returncode == 0 else \
                {key: size, "error": (proc.stderr.strip().splitlines() or ["?"])[-1][:error_chars]}
        except subprocess.TimeoutExpired:
            row = {key: size, "error": f"over {timeout:.0f} s"}
        row["load_average"] = [round(load_before, 2), round(os.getloadavg()[0], 2)]
        print(json.dumps(row), flush=True)
