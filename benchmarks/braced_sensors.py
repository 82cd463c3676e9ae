"""Sixteen floor sensors and sixteen brace groups on the braced frame (`braced_frame.py`).

Run:  python benchmarks/braced_sensors.py [--suggest]

Writes the case files of ``tests/io/test_case_sensors.py`` (the frame element by element on
its rigid-floor DOFs, the four accelerometers per floor as ``[[sensor]]`` tables, exact data:
8 frequencies and the shapes at the 16 sensors; three damaged brace groups) for the 12-DOF and
the 120-DOF model, runs ``vibupdate run`` on each and prints the largest error of a group
factor and the wall seconds; with ``--suggest``, also ``vibupdate suggest`` on the 12-DOF case
with the 16 groups as candidates, and what it names. The figures of `RESULTS.md`, "Sixteen
sensors on the braced frame's rigid floors".
"""

from __future__ import annotations

import contextlib
import importlib.util
import io
import json
import sys
import tempfile
import time
from pathlib import Path

TESTS = Path(__file__).resolve().parents[1] / "tests"


def _load(name: str, path: Path):
    spec = importlib.util.spec_from_file_location(name, path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def main(suggest: bool) -> None:
    from vibupdate.cli import main as cli

    sys.path.insert(0, str(TESTS))      # the case writer's own import of the frame's elements
    cases = _load("test_case_sensors", TESTS / "io" / "test_case_sensors.py")
    print("model     command  largest error  wall s")
    for full in (False, True):
        with tempfile.TemporaryDirectory() as folder:
            path = cases.write_case(Path(folder), full=full)
            t0 = time.perf_counter()
            with contextlib.redirect_stdout(io.StringIO()):
                code = cli(["run", path, "--out", str(Path(folder) / "out")])
            wall = time.perf_counter() - t0
            doc = json.loads((Path(folder) / "out" / "results.json").read_text())
            error = max(abs(p["updated"] - cases.TRUTH.get(p["name"], 1.0)) for p in doc["parameters"])
            print(f"{120 if full else 12:>3} DOFs  run      {error:13.2g}  {wall:6.1f}  (exit {code})")
    if suggest:
        with tempfile.TemporaryDirectory() as folder:
            path = cases.write_case(Path(folder), table="candidate")
            t0 = time.perf_counter()
            out = io.StringIO()
            with contextlib.redirect_stdout(out):
                code = cli(["suggest", path, "--out", str(Path(folder) / "out")])
            wall = time.perf_counter() - t0
            named = next((line for line in out.getvalue().splitlines() if line.startswith("suggested:")), "(none)")
            print(f" 12 DOFs  suggest  {named}  {wall:.1f} s  (exit {code})")


if __name__ == "__main__":
    main("--suggest" in sys.argv[1:])
