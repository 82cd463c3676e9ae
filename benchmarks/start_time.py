"""Wall time of ``vibupdate example cantilever`` against an earlier version of the code.

Run:  python benchmarks/start_time.py [--against REF] [--repeats 7]

The source tree of git revision ``REF`` (default ``main``) is unpacked into a temporary folder
(``git archive``); each repeat runs ``python -m vibupdate example cantilever`` once with this
checkout's ``src`` and once with ``REF``'s on ``PYTHONPATH``, in that order and then swapped
on the next repeat, each in a fresh empty folder. Printed: the median wall time of each, the
median of the per-repeat ratios (this checkout / ``REF``: the figure to quote, as both runs
of a repeat meet about the same load), each version's wall time over the seconds its
``solver:`` line reports (the update's own clock: a ratio within one process), and the load
average. Timings vary with the load of the machine; quote them with it.
"""

from __future__ import annotations

import argparse
import json
import os
import re
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

os.environ.setdefault("OMP_NUM_THREADS", "1")
ROOT = Path(__file__).resolve().parents[1]


def unpack(ref: str, folder: Path) -> Path:
    """The ``src`` tree of git revision ``ref`` in ``folder``."""
    archive = subprocess.run(["git", "-C", str(ROOT), "archive", ref, "src"], capture_output=True, check=True)
    subprocess.run(["tar", "-x", "-C", str(folder)], input=archive.stdout, check=True)
    return folder / "src"


def one(src: Path) -> dict:
    """One run of the example with ``src`` first on the path: wall seconds, solver seconds."""
    env = dict(os.environ, PYTHONPATH=str(src))
    with tempfile.TemporaryDirectory() as folder:
        t0 = time.perf_counter()
        done = subprocess.run([sys.executable, "-m", "vibupdate", "example", "cantilever"], capture_output=True,
                              text=True, cwd=folder, env=env)
        wall = time.perf_counter() - t0
    found = re.search(r"^solver: .*, ([0-9.]+) s$", done.stdout, re.M)
    if done.returncode != 0 or not found:
        raise RuntimeError(done.stdout[-1000:] + done.stderr[-2000:])
    return {"wall": wall, "solver": float(found.group(1))}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--against", default="main", help="git revision to compare with (default main)")
    parser.add_argument("--repeats", type=int, default=7)
    args = parser.parse_args()
    load_before = os.getloadavg()
    with tempfile.TemporaryDirectory() as folder:
        versions = {"this": ROOT / "src", args.against: unpack(args.against, Path(folder))}
        rows = []
        for k in range(args.repeats):
            order = list(versions) if k % 2 == 0 else list(versions)[::-1]
            rows.append({name: one(versions[name]) for name in order})
    this, ref = "this", args.against
    median = {name: statistics.median(r[name]["wall"] for r in rows) for name in versions}
    print(json.dumps({
        "median_wall_s": median,
        "ratio_this_over_ref_median": statistics.median(r[this]["wall"] / r[ref]["wall"] for r in rows),
        "ratios_per_repeat": [round(r[this]["wall"] / r[ref]["wall"], 3) for r in rows],
        "wall_over_solver_median": {name: statistics.median(r[name]["wall"] / r[name]["solver"] for r in rows)
                                    for name in versions},
        "load_average_before_after": [load_before, os.getloadavg()],
    }, indent=1))


if __name__ == "__main__":
    main()
