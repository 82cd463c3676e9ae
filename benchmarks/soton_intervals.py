"""The Southampton frame's extracted intervals: frequencies, damping ratios and the
ten listed antiresonances with their 95 % intervals, against the reference values.

Run:  python benchmarks/soton_intervals.py [DATA_DIR] [--json FILE]

Reads the three tests (real data, not in the repository; default
``../shared/realdata/soton3storey`` next to the repository) through one extraction, as
``vibupdate extract ... --band 3 28 --modes 3`` does, and prints each value, its interval,
the interval's half-width (relative) and whether the reference lies inside it.
"""

from __future__ import annotations

import json
import os
import sys
from pathlib import Path

os.environ.setdefault("OMP_NUM_THREADS", "1")

import numpy as np  # noqa: E402

from vibupdate.data.extraction import extract  # noqa: E402
from vibupdate.data.frf import read_frfs  # noqa: E402

FILES = ("Experimental.csv", "test_2.csv", "test_3.csv")  # force at floor 1, 2, 3
MODES_HZ = (6.5126, 17.4608, 26.5003)
DAMPING = (0.0017, 0.0025, 0.0022)
ZEROS_HZ = {("x1", "x1"): (8.80, 23.94), ("x2", "x2"): (14.99, 19.85), ("x3", "x3"): (14.18, 25.24),
            ("x2", "x1"): (14.39,), ("x1", "x2"): (14.48,), ("x3", "x2"): (19.43,), ("x2", "x3"): (19.45,)}
TWO_PI = 2 * np.pi


def main(folder: Path, out: str | None) -> None:
    frfs = read_frfs([folder / f for f in FILES], responses=["x1", "x2", "x3"], excitations=["x1", "x2", "x3"],
                     kind="accelerance")
    result = extract(frfs, band=(TWO_PI * 3, TWO_PI * 28), n_modes=3)
    rows = []
    for m, ref, xi in zip(result.modes, MODES_HZ, DAMPING):
        lo, hi = (w / TWO_PI for w in m.omega_interval)
        rows.append(("mode", f"{ref}", m.omega / TWO_PI, lo, hi, ref))
        rows.append(("damping", f"{ref}", m.damping_ratio, *m.damping_interval, xi))
    for z in result.zeros:
        refs = ZEROS_HZ.get((z.response, z.excitation), ())
        if refs:
            ref = min(refs, key=lambda r: abs(r - z.omega / TWO_PI))
            rows.append((f"h{z.response[1:]}{z.excitation[1:]}", f"{ref}", z.omega / TWO_PI,
                         z.interval[0] / TWO_PI, z.interval[1] / TWO_PI, ref))
    print(f"{'what':8} {'ref':>8} {'value':>10} {'interval':>22} {'hw %':>7} {'ref in':>7}")
    for what, label, v, lo, hi, ref in rows:
        print(f"{what:8} {label:>8} {v:>10.5g} {lo:>10.5g}-{hi:<10.5g} {100 * (hi - lo) / 2 / v:>7.3f} "
              f"{str(lo <= ref <= hi):>7}")
    if out:
        Path(out).write_text(json.dumps(rows))


if __name__ == "__main__":
    args = [a for a in sys.argv[1:] if not a.startswith("--json")]
    out = next((sys.argv[i + 1] for i, a in enumerate(sys.argv) if a == "--json"), None)
    args = [a for a in args if a != out]
    default = Path(__file__).resolve().parents[1].parent / "shared" / "realdata" / "soton3storey"
    main(Path(args[0]) if args else default, out)
