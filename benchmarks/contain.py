"""Benchmark: what holding every reported answer costs the certified ranges.

Run:  PYTHONPATH=src python benchmarks/contain.py [--examples chain cantilever] [--samples 10]
      [--seconds 60] [--seed 6]

For each example, one process: the run's update and a sweep of ``--samples`` data sets (as
``vibupdate run --samples N`` does; ``starts = 0``), then the certified enclosure twice under
the same time budget:

* *answer only*: S widened to hold the run's answer alone (the set certified before the
  fix, with today's widening rule for the answer);
* *every answer*: S widened to hold the answer, every verified sampled answer and every line
  end (what ``run --certify`` does now).

Printed per parameter: the sampled range, both certified ranges, their width ratio to the
sampled width, whether each end is flagged certified, and how many sampled answers each
certified range misses; the widening's summary (`vibupdate.ranges.inclusion.Inclusion`); the
load average before and after (the machine is shared).

The chain is the one of the sweep tests (``tests/sweep_cases.py``: 5 masses, k1, k3, m2, m5 free,
+-0.5 % tolerance, exact data of the truth). The cantilever is its case file with a +-0.5 %
frequency tolerance (it states none, and the sampler needs one).
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time
from dataclasses import replace
from pathlib import Path

os.environ.setdefault("OMP_NUM_THREADS", "1")

import numpy as np  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]


def load(example: str, tolerance: float):
    from vibupdate.io.case import load_case

    if example == "chain":
        sys.path.insert(0, str(ROOT / "tests"))
        from sweep_cases import write_chain_case

        return load_case(write_chain_case(Path(tempfile.mkdtemp()) / "chain.toml", tolerance=tolerance))
    return replace(load_case(ROOT / "examples" / example / "case.toml"), frequency_tolerance=tolerance)


def measure(example: str, samples: int, seconds: float, seed: int, tolerance: float) -> None:
    from vibupdate.inverse.update import update
    from vibupdate.ranges.certify import certified_ranges
    from vibupdate.study.sampled_ranges import SampledRanges

    case = load(example, tolerance)
    model = case.configurations[0].model
    t0 = time.perf_counter()
    verification = replace(case.verification, frequency_tolerance=case.frequency_tolerance)
    result = update(case.configurations, formulation=case.formulation, solver=case.solver, polish=case.polish,
                    verification=verification)
    sections, _, answers = SampledRanges(samples, starts=0, seed=seed, workers=1)(case, result, lambda m: None)
    print(f"\n## {example}: update ({result.status.value}) and {samples} samples in {time.perf_counter() - t0:.1f} s; "
          f"{len(answers)} reported answers besides the run's (verified samples and line ends)")
    last = result.attempts[-1] if result.attempts else None   # the vector boxes the first stage ended with
    boxes = replace(case.formulation, **{k: getattr(last, k) for k in ("shape_margin", "adjunct_margin") if last is not None})
    xbar = np.asarray(result.xbar)
    found = {}
    for label, include in (("answer only", ()), ("every answer", answers)):
        load0 = os.getloadavg()[0]
        cert = certified_ranges(case.configurations, xbar, include=include,
                                frequency_tolerance=case.frequency_tolerance, seconds=seconds, options=boxes)
        found[label] = cert
        print(f"{label}: {cert.message}; {cert.seconds:.1f} s, {cert.passes} passes, {cert.splits} splits, "
              f"{cert.n_lps} LPs; load {load0:.1f} -> {os.getloadavg()[0]:.1f}")
        if include:
            print("  " + cert.definition[cert.definition.index("S is widened"):])
    sampled = sections["sampled"]["ranges"]
    points = np.array([model.physical(p) for _, p in answers] + [model.physical(xbar)])
    print("\n| parameter | sampled | answer only | ratio | misses | every answer | ratio | misses | certified |")
    print("|---|---|---|---:|---:|---|---:|---:|---|")
    for i, name in enumerate(model.parameter_names):
        s = sampled[name]
        width = s["max"] - s["min"]
        cells = [name, f"[{s['min']:.5g}, {s['max']:.5g}]"]
        for label in ("answer only", "every answer"):
            c = found[label]
            miss = int(np.count_nonzero((points[:, i] < c.lower[i]) | (points[:, i] > c.upper[i])))
            cells += [f"[{c.lower[i]:.5g}, {c.upper[i]:.5g}]",
                      f"{(c.upper[i] - c.lower[i]) / width:.3g}" if width > 0 else "-", str(miss)]
        cells.append(f"{'yes' if found['answer only'].certified[i] else 'no'} / "
                     f"{'yes' if found['every answer'].certified[i] else 'no'}")
        print("| " + " | ".join(cells) + " |")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--examples", nargs="+", default=["chain", "cantilever"])
    parser.add_argument("--samples", type=int, default=10)
    parser.add_argument("--seconds", type=float, default=60.0)
    parser.add_argument("--seed", type=int, default=6)
    parser.add_argument("--tolerance", type=float, default=0.005)
    args = parser.parse_args()
    print(f"load average at start: {os.getloadavg()}")
    for example in args.examples:
        measure(example, args.samples, args.seconds, args.seed, args.tolerance)
    print(f"\nload average at end: {os.getloadavg()}")


if __name__ == "__main__":
    main()
