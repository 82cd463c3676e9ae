"""Local signal-to-noise ratio of the antiresonances found, true zeros against spurious ones.

Known truth (``tests/frf_synthetic.py``): the cantilever (5 repeats, 3 % noise) and the
Southampton-like frame (one record) with their noise floors raised until zeros sink into
them; every zero the extraction finds (``keep_noisy_zeros=True``) is true when a zero of the
undamped receptance lies within 1 % of it, else spurious. Prints the SNR ranges of both and
the counts on each side of candidate thresholds; then the Southampton data's zeros.

    OMP_NUM_THREADS=1 PYTHONPATH=src:tests python benchmarks/noisy_zeros.py [seeds]
"""

import math
import sys

import numpy as np

from frf_synthetic import FRAME_PAIRS, PAIRS, frame_measured, measured, true_zeros
from vibupdate.data.extraction import extract


def classify(result, M, K, dofs):
    out = []
    lo, hi = result.band
    for z in result.zeros:
        truth = true_zeros(M, K, dofs.index(z.response), dofs.index(z.excitation))
        truth = truth[(truth > lo) & (truth < hi)]
        ok = truth.size > 0 and np.min(np.abs(truth / z.omega - 1)) < 0.01
        hit = ok and bool(np.any((truth >= z.interval[0]) & (truth <= z.interval[1])))
        out.append((z.snr, bool(ok), hit))
    return out


def main(seeds=10):
    pooled = []
    for label, make, kwargs in (
            ("cantilever floor 1e-3", lambda s: measured(s), {}),
            ("cantilever floor 1e-2", lambda s: measured(s, floor=1e-2), {}),
            ("cantilever floor 3e-2", lambda s: measured(s, floor=3e-2), {}),
            ("frame floor 4e-3", lambda s: frame_measured(s), {"band": (2 * math.pi * 3, 2 * math.pi * 28), "n_modes": 3}),
            ("frame floor 2e-2", lambda s: frame_measured(s, floor=2e-2),
             {"band": (2 * math.pi * 3, 2 * math.pi * 28), "n_modes": 3}),
            ("frame floor 5e-2", lambda s: frame_measured(s, floor=5e-2),
             {"band": (2 * math.pi * 3, 2 * math.pi * 28), "n_modes": 3})):
        rows = []
        for seed in range(seeds):
            frfs, M, K, C, dofs = make(seed)
            try:
                result = extract(frfs, keep_noisy_zeros=True, **kwargs)
            except ValueError as exc:
                print(f"  {label} seed {seed}: {exc}")
                continue
            rows += classify(result, M, K, dofs)
        rows = np.array(rows, dtype=float).reshape(-1, 3)
        true, false = rows[rows[:, 1] == 1, 0], rows[rows[:, 1] == 0, 0]
        low = (rows[:, 1] == 1) & (rows[:, 0] < 0.25)
        print(f"  true zeros under SNR 0.25: {int(low.sum())}, of which inside their intervals "
              f"{int(np.sum(rows[low, 2]))}")
        pooled.append(rows)
        print(f"{label:24s} true {true.size:4d}: SNR {np.min(true) if true.size else np.nan:7.2f} .. "
              f"{np.max(true) if true.size else np.nan:9.1f}   spurious {false.size:3d}: SNR "
              f"{np.min(false) if false.size else np.nan:6.2f} .. {np.max(false) if false.size else np.nan:6.2f}",
              flush=True)
    rows = np.vstack(pooled)
    for threshold in (0.1, 0.15, 0.2, 0.25, 0.5, 1.0, 2.0):
        kept_true = np.sum((rows[:, 1] == 1) & (rows[:, 0] >= threshold))
        dropped_false = np.sum((rows[:, 1] == 0) & (rows[:, 0] < threshold))
        print(f"threshold {threshold:4.2f}: true kept {kept_true}/{int(np.sum(rows[:, 1]))}, spurious dropped "
              f"{dropped_false}/{int(np.sum(rows[:, 1] == 0))}")


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 10)
