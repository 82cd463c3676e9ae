"""Where the wall time of ``vibupdate example cantilever`` goes: interpreter and imports,
`update` (the solve), plots, and the rest (loading, damping, ranges, results, report).

Run:  python benchmarks/example_time.py [--repeats 5] [--in-process]

Each repeat is a fresh child process (``python -c``) that records the time of its imports and
wraps `vibupdate.update` and the plot writer in timers, then runs the CLI's ``main(["example",
"cantilever"])`` in an empty temporary folder; the child's wall time is measured by the parent
from spawn to exit. The median over the repeats of each share is printed, with the load average
(other work on the machine inflates every stage alike). ``--in-process``: the plots drawn by
the run's own process, as before the plotting process (`vibupdate.io.plot_process`); without
it, ``plots`` is the time the run waits for the child's drawings.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time

os.environ.setdefault("OMP_NUM_THREADS", "1")

CHILD = r"""
import contextlib, io, json, sys, time
t0 = time.perf_counter()
import vibupdate.io.outputs as outputs
import vibupdate.pipeline as pipeline
from vibupdate.cli import main
times = {"imports": time.perf_counter() - t0, "plots": 0.0, "update": 0.0}
drawn, update = outputs.drawn, pipeline.update

def timed(key, fn):
    def wrapper(*args, **kwargs):
        t = time.perf_counter()
        try:
            return fn(*args, **kwargs)
        finally:
            times[key] += time.perf_counter() - t
    return wrapper

if IN_PROCESS:   # the plots drawn by the run's own process, as before the plotting process
    import vibupdate.io.plot_process as plot_process
    plot_process.plot_process = lambda wanted=True: contextlib.nullcontext()
outputs.drawn = timed("plots", drawn)
pipeline.update = timed("update", update)
t = time.perf_counter()
with contextlib.redirect_stdout(io.StringIO()):
    code = main(["example", "cantilever"])
times["main"] = time.perf_counter() - t
times["in_process"] = time.perf_counter() - t0
times["exit"] = code
print(json.dumps(times))
"""


def one(in_process: bool) -> dict:
    with tempfile.TemporaryDirectory() as folder:
        t0 = time.perf_counter()
        done = subprocess.run([sys.executable, "-c", f"IN_PROCESS = {in_process}\n" + CHILD], capture_output=True,
                              text=True, cwd=folder)
        wall = time.perf_counter() - t0
    if done.returncode != 0:
        raise RuntimeError(done.stderr[-2000:])
    row = json.loads(done.stdout.strip().splitlines()[-1])
    row["wall"] = wall
    row["interpreter"] = wall - row["in_process"]
    row["rest"] = row["main"] - row["update"] - row["plots"]
    return row


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--in-process", action="store_true",
                        help="draw the plots in the run's own process (no plotting process), for comparison")
    args = parser.parse_args()
    rows = [one(args.in_process) for _ in range(args.repeats)]
    keys = ("wall", "interpreter", "imports", "update", "plots", "rest")
    median = {k: sorted(r[k] for r in rows)[len(rows) // 2] for k in keys}
    share = {k: median[k] / median["wall"] for k in keys[1:]}
    print(json.dumps({"median_s": median, "share_of_wall": share,
                      "update_share_per_run": [r["update"] / r["wall"] for r in rows],
                      "exit_codes": [r["exit"] for r in rows], "load_average": os.getloadavg()}, indent=1))


if __name__ == "__main__":
    main()
