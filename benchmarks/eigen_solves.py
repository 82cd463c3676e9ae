"""Count the eigen-solves of one whole ``vibupdate run`` (no repeated eigen-solves of
the same matrices within a run), per stage, on a bundled example.

Run:  python benchmarks/eigen_solves.py [cantilever|frame]

Counts calls of the kernels' entry points (`tests/solve_log.py`: the dense and sparse
eigen-solves of a pencil ``(K, M)`` and of an adjunct pencil), groups them by the matrices solved (a hash of ``M``
and ``K``) and by the stage in whose call stack they ran, and prints the total, the solves of
each configuration's updated matrices per stage, and how many solves repeated a pencil that
had already been solved in the run. A count, not a timing: the machine's load does not enter.
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
from collections import Counter
from pathlib import Path

os.environ.setdefault("OMP_NUM_THREADS", "1")
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))

from solve_log import counting_solves, matrices_key  # noqa: E402
from vibupdate.pipeline import run_example  # noqa: E402

#: The stage of a solve: the first of these source files found in its call stack.
STAGES = (("polish", "inverse/polish.py"), ("ranges", "ranges/identifiability.py"),
          ("formulation", "inverse/formulation/"), ("validation", "io/validation.py"),
          ("data", "data/"), ("model build", "model/"), ("results", "io/results.py"), ("report", "report/"),
          ("damping", "vibupdate/damping/"), ("update", "inverse/update.py"))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("example", nargs="?", default="cantilever")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp, counting_solves(STAGES) as solves:
        run = run_example(args.example, os.path.join(tmp, "out"))
    log = [(s.kind, s.key, s.pair, s.stage) for s in solves]
    updated = {matrices_key(m.M, m.K): name for name, m in run.matrices.items()}
    seen, repeats = set(), Counter()
    for kind, key, pair, stage in log:
        if (kind, key, pair) in seen:
            repeats[stage] += 1
        seen.add((kind, key, pair))
    print(f"example {args.example}: {run.status.value}, {len(run.matrices)} configuration(s)")
    print(f"eigen-solves in the whole run: {len(log)} ({sum(k == 'modes' for k, *_ in log)} of a pencil, "
          f"{sum(k == 'zeros' for k, *_ in log)} of an adjunct pencil)")
    print(f"solves of a pencil already solved in the run: {sum(repeats.values())}, by stage: {dict(repeats)}")
    at = Counter((kind, stage) for kind, key, _, stage in log if key in updated)
    print(f"solves of the updated matrices, summed over the configurations, by stage: "
          f"{ {f'{k} {s}': v for (k, s), v in sorted(at.items())} }")


if __name__ == "__main__":
    main()
