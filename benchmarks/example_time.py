"""Where the wall time of ``vibupdate example cantilever`` goes: interpreter and imports,
`update` (the solve), plots, and the rest (loading, damping, ranges, results, report).

Run:  python benchmarks/example_time.py [--repeats 5] [--in-process]

Each repeat is a fresh child process (``python -c``) that runs the CLI's ``main()`` with the
command's ``sys.argv`` in an empty temporary folder, as the console script does (the program's
own imports), records the time until the command starts (the imports) and wraps `vibupdate.update` and the plot writer in timers; the child's wall time is
measured by the parent from spawn to exit. The median over the repeats of each share is
printed, with the load average (other work on the machine inflates every stage alike).
``--command``: the console script itself, uninstrumented (``vibupdate example cantilever``
beside the interpreter, else ``python -m vibupdate``), its wall time against the seconds of
the ``solver:`` line it prints (the update's own clock). The start against an earlier
version of the code: benchmarks/start_time.py.
"""

from __future__ import annotations

import argparse
import json
import os
import re
import subprocess
import sys
import tempfile
import time

os.environ.setdefault("OMP_NUM_THREADS", "1")

CHILD = r"""
import atexit, contextlib, io, json, sys, time
t0 = time.perf_counter()
import vibupdate.cli as cli
times = {"plots": 0.0, "update": 0.0, "exit": None}

def timed(key, fn):
    def wrapper(*args, **kwargs):
        t = time.perf_counter()
        try:
            return fn(*args, **kwargs)
        finally:
            times[key] += time.perf_counter() - t
    return wrapper

command = cli._command

def instrumented(args):   # entered before the command's imports
    import vibupdate.io.outputs as outputs
    import vibupdate.pipeline as pipeline
    times["imports"] = time.perf_counter() - t0
    outputs.drawn = timed("plots", outputs.drawn)
    pipeline.update = timed("update", pipeline.update)
    t = time.perf_counter()
    try:
        times["exit"] = command(args)
        return times["exit"]
    finally:
        times["main"] = time.perf_counter() - t

def report():
    times["in_process"] = time.perf_counter() - t0
    sys.__stdout__.write(json.dumps(times) + "\n")
    sys.__stdout__.flush()

cli._command = instrumented
atexit.register(report)
sys.argv = ["vibupdate", "example", "cantilever"]   # main() as the console script calls it
with contextlib.redirect_stdout(io.StringIO()):
    cli.main()
"""


def one() -> dict:
    with tempfile.TemporaryDirectory() as folder:
        t0 = time.perf_counter()
        done = subprocess.run([sys.executable, "-c", CHILD], capture_output=True,
                              text=True, cwd=folder)
        wall = time.perf_counter() - t0
    if done.returncode != 0:
        raise RuntimeError(done.stderr[-2000:])
    row = json.loads(done.stdout.strip().splitlines()[-1])
    row["wall"] = wall
    row["interpreter"] = wall - row["in_process"]
    row["rest"] = row["main"] - row["update"] - row["plots"]
    return row


def command() -> dict:
    """One uninstrumented run of the console script: wall time and the update's seconds."""
    script = os.path.join(os.path.dirname(sys.executable), "vibupdate")
    argv = [script] if os.path.exists(script) else [sys.executable, "-m", "vibupdate"]
    with tempfile.TemporaryDirectory() as folder:
        t0 = time.perf_counter()
        done = subprocess.run(argv + ["example", "cantilever"], capture_output=True, text=True, cwd=folder)
        wall = time.perf_counter() - t0
    found = re.search(r"^solver: .*, ([0-9.]+) s$", done.stdout, re.M)
    if done.returncode != 0 or not found:
        raise RuntimeError(done.stdout[-1000:] + done.stderr[-2000:])
    return {"wall": wall, "update": float(found.group(1)), "exit": done.returncode}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--command", action="store_true",
                        help="time the console script itself: wall and the seconds of its solver line")
    args = parser.parse_args()
    rows = [command() if args.command else one() for _ in range(args.repeats)]
    keys = ("wall", "update") if args.command else ("wall", "interpreter", "imports", "update", "plots", "rest")
    median = {k: sorted(r[k] for r in rows)[len(rows) // 2] for k in keys}
    share = {k: median[k] / median["wall"] for k in keys[1:]}
    print(json.dumps({"median_s": median, "share_of_wall": share,
                      "update_share_per_run": [r["update"] / r["wall"] for r in rows],
                      "exit_codes": [r["exit"] for r in rows], "load_average": os.getloadavg()}, indent=1))


if __name__ == "__main__":
    main()
