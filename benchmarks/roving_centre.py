"""A roving-hammer test with an accelerometer next to the centre of a free-free bar: do the
antiresonances run, and do they agree with the natural frequencies?

Run: ``PYTHONPATH=src python benchmarks/roving_centre.py [--seeds 10] [--noise 0.01]
[--accelerometer 10]`` (``--accelerometer 9``: on the centre itself).

The truth is the Timoshenko bar of `vibupdate.examples.bar` (shear-flexible elements, rotary
inertia, a mesh three times finer than the model's, the two suspension springs), with the
accelerometer's 5 g at node 10, next to the centre node 9; the centre is a node of every mode
antisymmetric about it, so the FRFs of the points near it have zeros on or next to poles and
sign patterns that a nominal model reads differently. The hammer hits the nine odd nodes 1-17
(the centre among them) and node 10 (the driving point); three hits each, complex Gaussian
noise of ``noise * |H|`` plus 1e-4 of the largest ``|H|`` per line, 0.6 % modal damping.

The model is the Euler-Bernoulli bar of the example's case file with E its one parameter and the
accelerometer at node 10. Per seed:

* ``vibupdate run`` on the case with ``[configuration.frf]`` (frequencies, shapes and every
  antiresonance the extraction keeps): its exit code, status, E, and the warnings that name a
  receptance whose interlacing signs were dropped ("interlacing signs of h_...");
* `vibupdate.update` on the same case's configuration with its antiresonances removed
  (frequencies and shapes alone): E;
* the two E's relative difference (the aim: within 0.5 %).
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

from vibupdate.data.frf import write_uff58
from vibupdate.examples import bar as B

ACCELEROMETER = 10


def hammer(accelerometer: int) -> tuple:
    """The points hit: the odd nodes and the accelerometer's (the driving point)."""
    return tuple(sorted({*range(1, 18, 2), accelerometer}))


def case_text(accelerometer: int) -> str:
    """The example's case with E its parameter, the accelerometer at node ``accelerometer``,
    its FRFs and the default verification (model-form tolerances 2 %: the example's 0.1 % on
    frequencies asks more than an Euler-Bernoulli model of a Timoshenko bar can give)."""
    text = B.case_text(parameters=("E",))
    text = text.replace(f'dof = "y{B.ACCELEROMETER}"\nvalue = "macc"', f'dof = "y{accelerometer}"\nvalue = "macc"')
    return text[:text.index("[verification]")]


def one(seed: int, noise: float, accelerometer: int, folder: Path) -> dict:
    from vibupdate.cli import main as cli
    import vibupdate as vu

    folder.mkdir(parents=True, exist_ok=True)
    write_uff58(folder / "hammer.uff", B.measured(seed, noise=noise, accelerometer=accelerometer,
                                                  hammer=hammer(accelerometer)))
    (folder / "case.toml").write_text(case_text(accelerometer))
    start = time.perf_counter()
    code = cli(["run", str(folder / "case.toml"), "--out", str(folder / "results")])
    seconds = time.perf_counter() - start
    row = {"seed": seed, "exit": code, "seconds": seconds}
    path = folder / "results" / "results.json"
    if path.is_file():
        doc = json.loads(path.read_text())
        row["status"] = doc["solver"]["status"]
        row["E_zeros"] = next(p["updated"] for p in doc["parameters"] if p["name"] == "E")
        row["dropped"] = [w for w in doc.get("warnings", []) if w.startswith("interlacing signs of h_")]
    case = vu.load_case(folder / "case.toml")
    row["zeros"] = sum(len(c.antiresonances) for c in case.configurations)
    alone = [replace(c, antiresonances=()) for c in case.configurations]
    result = vu.update(alone, formulation=case.formulation, solver=case.solver, polish=case.polish,
                       verification=case.verify_options())
    row["E_frequencies"] = float(result.values[0])
    row["status_frequencies"] = str(result.status)
    if "E_zeros" in row:
        row["difference"] = abs(row["E_zeros"] / row["E_frequencies"] - 1)
    return row


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=10)
    parser.add_argument("--noise", type=float, default=0.01)
    parser.add_argument("--accelerometer", type=int, default=ACCELEROMETER, help="its node (9: the centre)")
    args = parser.parse_args(argv)
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for seed in range(args.seeds):
            row = one(seed, args.noise, args.accelerometer, Path(tmp) / f"seed{seed}")
            rows.append(row)
            print(f"seed {seed}: exit {row['exit']}, {row.get('status')}, {row['zeros']} zeros, "
                  f"E {row.get('E_zeros', float('nan')):.6g} (frequencies and shapes alone "
                  f"{row['E_frequencies']:.6g}, {row['status_frequencies']}), difference "
                  f"{100 * row.get('difference', float('nan')):.3f} %, {len(row.get('dropped', []))} sign "
                  f"relations dropped, {row['seconds']:.1f} s", flush=True)
            for line in row.get("dropped", []):
                print("   ", line[:200])
    ran = [r for r in rows if r["exit"] != 2]
    diff = [r["difference"] for r in rows if "difference" in r]
    print(f"\naccelerometer at y{args.accelerometer}, noise {args.noise:g}: {len(ran)} of {len(rows)} seeds ran "
          f"(exit 0 or 1); difference median "
          f"{100 * np.median(diff):.3f} %, max {100 * max(diff):.3f} %; within 0.5 %: "
          f"{sum(d <= 5e-3 for d in diff)} of {len(diff)}; seeds with a dropped sign relation: "
          f"{sum(bool(r.get('dropped')) for r in rows)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
