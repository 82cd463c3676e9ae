"""Mode numbers of FRF data that skip a mode, on generated structures: how often the extracted
modes are numbered right by the rule of a case file's `[configuration.frf]` without `first_mode`
(the MAC of their shapes with the nominal model's modes where unambiguous,
`vibupdate.data.pairing.modes_by_shape`), against the consecutive numbers it replaced.

Run:  python benchmarks/frf_mode_numbers.py [--seeds 0 40] [--floor 1e-3]

Problems: the acceptance family `hidden_mode` (`tests/acceptance/families.py`: a chain or clamped
beam whose exciter sits near a node of one of its lowest modes, the truth drawn per seed). Its
receptances from the exciter to every measurable DOF are synthesized at the truth with Rayleigh
damping (1 % at mode 1 and at the highest measured mode), three repeats with complex Gaussian
noise of 0.5 % of |H| plus ``floor`` times the FRF's largest |H| per line (``--floor 1e-3``: the
-60 dB floor of `tests/frf_synthetic.py`), over 0.3-1.15 times the measured span; `extract`
keeps the modes it finds in 0.5-1.1 times that span. Each extracted mode's true number is the
truth's mode nearest in frequency; the count says how many extractions skip a mode and how
the rule numbers them: right, left consecutive (no unambiguous pairing: the run's
correspondence warning then names the modes), or wrong.
"""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path

os.environ.setdefault("OMP_NUM_THREADS", "1")
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))

import numpy as np  # noqa: E402

from acceptance import emit, families as F, structures as S, truth as T  # noqa: E402
from vibupdate.data.extraction import extract  # noqa: E402
from vibupdate.data.frf import FRFSet  # noqa: E402
from vibupdate.data.pairing import modes_by_shape  # noqa: E402


def numbered(seed: int, floor: float):
    """(true numbers of the extracted modes, the rule's numbers or None), or None when nothing
    was extracted."""
    problem = F.hidden_mode(seed)
    cfg = emit.configurations(problem)[0]
    M, K, dofs = S.matrices_at(problem.structure, problem.truth)
    w = T.modes(M, K)[0]
    flex = w[w > 0]
    w1, w2 = flex[0], flex[min(len(cfg.natural), flex.size) - 1]
    a, b = np.linalg.solve([[1 / (2 * w1), w1 / 2], [1 / (2 * w2), w2 / 2]], [0.01, 0.01])
    C = a * M + b * K
    exciter = problem.data[0].zeros[0].excitation
    responses = list(problem.structure.measurable)
    top = flex[min(len(cfg.natural) + 1, flex.size) - 1]
    omega = np.linspace(0.3 * w1, 1.15 * top, 4000)
    H = np.linalg.inv(K[None] - omega[:, None, None] ** 2 * M[None] + 1j * omega[:, None, None] * C[None])
    rng = np.random.default_rng(seed)
    blocks = []
    for r in responses:
        h = H[:, dofs.index(r), dofs.index(exciter)]
        e = rng.standard_normal((3, h.size)) + 1j * rng.standard_normal((3, h.size))
        blocks.append(h[None] + (0.005 * np.abs(h) + floor * np.abs(h).max())[None] * e)
    frfs = FRFSet(omega, tuple((r, exciter) for r in responses), tuple(blocks))
    modes = extract(frfs, band=(0.5 * w1, 1.1 * top)).modes
    if not modes:
        return None
    true = [1 + int(np.argmin(np.abs(flex - m.omega) / flex)) for m in modes]
    return true, modes_by_shape([dict(m.shape_interval) for m in modes], cfg.model)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--seeds", type=int, nargs=2, default=(0, 40), metavar=("FIRST", "STOP"))
    ap.add_argument("--floor", type=float, default=1e-3)
    args = ap.parse_args()
    found = [numbered(s, args.floor) for s in range(*args.seeds)]
    found = [f for f in found if f is not None]
    skip = [(t, p) for t, p in found if t != list(range(1, len(t) + 1))]
    rest = [(t, p) for t, p in found if t == list(range(1, len(t) + 1))]
    print(f"seeds {args.seeds[0]}-{args.seeds[1] - 1}, floor {args.floor:g}: {len(found)} extractions, "
          f"{len(skip)} skip a mode: numbered right {sum(p == t for t, p in skip)}, left consecutive "
          f"{sum(p is None for t, p in skip)}, wrong {sum(p is not None and p != t for t, p in skip)} "
          f"(consecutive numbers: all {len(skip)} wrong); no mode skipped: numbered right "
          f"{sum(p in (t, None) for t, p in rest)} of {len(rest)}")


if __name__ == "__main__":
    main()
