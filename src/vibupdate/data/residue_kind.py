"""Is the FRF kind declared right? The phase of the fitted modal constants says.

A receptance's modal constants ``2 j w_d A`` (`vibupdate.data.extraction`) are real, and positive
at a driving point; a kind one order off turns every one by +-90 degrees, two orders off (or a
flipped driving point) a driving point's by 180. The rule, on the doubled angle that folds
transfer FRFs' signs together: docs/frf-extraction.md, "Input" ("A kind one order off");
`KIND_TURN` from the turns in benchmarks/RESULTS.md, "A kind one order off". It adds to the
check of the raw FRFs (`vibupdate.data.frf.check_kind`).
"""

from __future__ import annotations

import math

import numpy as np


#: Degrees by which the weighted modal constants may turn from real before the declared kind
#: is refused: halfway between right (0) and one order off (90).
KIND_TURN = 45.0


def check_fitted_kind(result, kinds, sources) -> None:
    """Raise ValueError naming the files when the fitted modal constants of ``result`` (an
    `Extraction`) turn by more than `KIND_TURN` from real (the kind declared is one order off),
    or when a driving point's turn by more than ``180 - KIND_TURN`` (two orders off, or its sign
    flipped). Nothing is said of data of mixed kinds.

    The turn, in [0, 90] degrees, is half the angle of the mean of ``exp(2 j theta)`` over every
    FRF and fitted mode, each FRF's constants weighted by their magnitude relative to its largest
    (so every FRF counts alike); the driving points' angle, in (-180, 180], their weighted mean."""
    if result.measured not in kinds:
        return
    n = result.fitted_poles.shape[0]
    wd = result.fitted_poles[:, 0] * np.sqrt(1.0 - result.fitted_poles[:, 1] ** 2)
    coefficients = result.coefficients   # per mode r, Re and Im of its residue in columns 2 r and 2 r + 1
    constants = wd * (-coefficients[:, 1:2 * n:2] + 1j * coefficients[:, 0:2 * n:2])   # 2 j w_d A, up to a scale
    size = np.abs(constants)
    weight = size / np.maximum(size.max(axis=1, keepdims=True), 1e-300)
    folded = np.sum(weight * np.exp(2j * np.angle(constants)))
    turn = 0.5 * math.degrees(abs(math.atan2(folded.imag, folded.real)))
    drives = [k for k, (r, c) in enumerate(result.pairs) if r == c]
    at = np.sum(weight[drives] * np.exp(1j * np.angle(constants[drives])))
    drive = math.degrees(math.atan2(at.imag, at.real)) if drives else None
    where = f"FRF file {', '.join(sources)}" if sources else "FRFs"
    order = kinds.index(result.measured)
    if turn <= KIND_TURN and drive is not None and abs(drive) >= 180.0 - KIND_TURN:
        two = [kinds[order + k] for k in (2, -2) if 0 <= order + k < len(kinds)]
        raise ValueError(f"{where}: declared {result.measured}, but the driving point's fitted modal constants are "
                         f"negative (at {drive:+.0f} degrees; a driving point's are phi^2 > 0): the data are two "
                         f"orders off the kind declared ({' or '.join(two)}?) or the driving point's sign is flipped "
                         "(the response measured against the force's direction). Is the kind (--kind, kind =) or the "
                         "sign right?")
    if turn <= KIND_TURN:
        return
    steps = [1] if drive is not None and drive > 0 else [-1] if drive is not None else [1, -1]
    likely = [kinds[order + k] for k in steps if 0 <= order + k < len(kinds)]
    which = " or ".join(likely) if likely else "a kind one order off"
    raise ValueError(f"{where}: declared {result.measured}, but the fitted modal constants turn by "
                     f"{turn:.0f} degrees from real (a receptance's are real; the weighted mean over every FRF and "
                     f"mode" + (f", the driving point's at {drive:+.0f} degrees" if drive is not None else "")
                     + f"): the data look like {which}, one order off the kind declared. Is the kind "
                     "(--kind, kind =) right?")
