"""How often the uniqueness search finds the truth among several exact fits, with and without
following each new answer along its own weakest direction (`Search.follow`), and what that costs.

Run:  python benchmarks/search_folds.py [--seeds 0 500]

Problems: the random 5-mass chains of the test suite (`tests/inverse/test_update.py`,
``random_chain_problem``: k1, k3, m2 and m5 drawn in their boxes, the 4 lowest natural
frequencies exact, with and without the zeros of h_y1,y3 below the fourth). Each problem is
updated with ``Search(follow=0)`` and with the default search, alternately first, in one process
(CPU time, one BLAS thread). Printed: the runs whose truth is among the answers (the returned one
or an alternative, every parameter within 1e-6), the verdicts, the runs where the search followed
a second answer, and the CPU time of each setting. Figures: benchmarks/RESULTS.md, "Answers
across a second fold".
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from collections import Counter
from pathlib import Path

os.environ.setdefault("OMP_NUM_THREADS", "1")
TESTS = Path(__file__).resolve().parent.parent / "tests"
sys.path[:0] = [str(TESTS), str(TESTS / "inverse")]

import numpy as np  # noqa: E402
from test_update import random_chain_problem  # noqa: E402

from vibupdate import update  # noqa: E402
from vibupdate.inverse.search import Search  # noqa: E402


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", nargs=2, type=int, default=[0, 500], metavar=("FIRST", "END"))
    args = parser.parse_args()
    settings = {"follow=0": Search(follow=0), "default": Search()}
    found, verdicts, cpu = Counter(), {k: Counter() for k in settings}, Counter()
    followed, missed = 0, {k: [] for k in settings}
    runs = 0
    for seed in range(*args.seeds):
        for zeros in (False, True):
            cfg, truth = random_chain_problem(seed, 0.0, zeros)
            runs += 1
            for name in (list(settings) if seed % 2 else list(settings)[::-1]):
                t0 = time.process_time()
                result = update([cfg], search=settings[name])
                cpu[name] += time.process_time() - t0
                verdicts[name][result.verdict.value] += 1
                answers = [result.values] + [[a.values[p.name] for p in result.parameters] for a in result.alternatives]
                if min(np.max(np.abs(np.asarray(a) / truth - 1)) for a in answers) <= 1e-6:
                    found[name] += 1
                else:
                    missed[name].append((seed, "zeros" if zeros else "frequencies"))
                if name == "default":
                    followed += any("from answer" in s.start for s in result.sought.starts)
    for name in settings:
        print(f"{name}: truth among the answers in {found[name]} of {runs} runs; verdicts {dict(verdicts[name])}; "
              f"CPU {cpu[name]:.1f} s; truth missed: {missed[name]}")
    print(f"the default search followed a second answer in {followed} runs; CPU ratio "
          f"{cpu['default'] / cpu['follow=0']:.3f}")


if __name__ == "__main__":
    main()
