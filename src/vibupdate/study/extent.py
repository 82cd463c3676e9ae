"""How far the consistent set of one sample extends along its exact null directions.

Where the data leave a parameter combination undetermined (an exact symmetry: every stiffness
and every mass scaled together leaves every frequency unchanged), the verified answers of a
sweep lie on a line, but each answer is one point of it: the random starts of
`vibupdate.study.multistart.random_start_solve` are pulled to the point of the line nearest
a random point of the box, and that point is the mean of the start's coordinates along the
line, so it is rarely near the ends. The sampled range then stops short of what the data allow.

Here, at a verified answer ``xbar`` of a sample, the exact sensitivity of the measured data
(`vibupdate.inverse.data_map.sensitivity`) gives its null directions ``v`` (right singular
vectors of singular values below ``1e-8`` of the largest). Along each, in both senses, the
point ``xbar + t v`` is tried at the box boundary ``t = t_max`` first; when that point is
not acceptable, the largest acceptable ``t`` is found by bisection on ``[0, t_max]``
(``BISECTIONS`` halvings: the end is within ``t_max / 2^12`` of the last acceptable point,
assuming the acceptable points of the line form one interval through ``xbar``).

A point is acceptable when it passes the same test as a random-start answer of the sample
(`vibupdate.study.sweep`): each measured frequency of the sample's drawn data is matched no
worse than by the verified answer, up to a twentieth of that datum's interval half-width, and
every error check of the verification (`vibupdate.inverse.verify.verify`) passes. So an end
point is a verified answer of the sample's data set, as every reported point of a sweep is;
for an exact symmetry it fits the data exactly as well as the answer does.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np


#: Halvings of the bisection for the last acceptable point of a direction.
BISECTIONS = 12
#: A point other than the homotopy answer of a sample is accepted when each of its frequency
#: errors is at most the homotopy answer's plus this fraction of the datum's interval half-width.
#: A choice, not a measurement: a twentieth of the half-width is far below what the intervals
#: resolve, and large enough that the exact symmetry of `tests/study/test_sweep.py` (misfit
#: unchanged to rounding along the line) is walked to its bounds.
ACCEPT_FRACTION = 0.05


def misfit(configurations, frequencies) -> np.ndarray:
    """Relative error of the model frequencies (`model_frequencies`, one per configuration)
    for every measured frequency of ``configurations``, shape (n_data,); NaN (a declared zero
    the model lacks) becomes inf."""
    errors = []
    for cfg, freqs in zip(configurations, frequencies):
        errors += [abs(w - f.omega) / f.omega for w, f in zip(freqs.natural, cfg.natural)]
        errors += [abs(w - a.omega) / a.omega for w, a in zip(freqs.antiresonances, cfg.antiresonances)]
    return np.nan_to_num(np.array(errors), nan=np.inf)


class Acceptance:
    """Is a point other than the verified homotopy answer of a sample an answer of its data?

    Yes when every measured frequency's relative error is at most the homotopy answer's plus
    ``ACCEPT_FRACTION`` times that datum's relative interval half-width, and every error check
    of the same verification passes (`vibupdate.inverse.verify.verify`). The nominal and the
    answer's modal data are computed once, at construction.

    Parameters
    ----------
    configurations : sequence of Configuration
        The sample's configurations (drawn data).
    result : UpdateResult
        The verified homotopy answer of those data.
    half : ndarray, shape (n_data,)
        Relative half-width of each measured frequency's interval, in the order of `misfit`.
    verification : VerifyOptions
    """

    def __init__(self, configurations, result, half, verification):
        from vibupdate.inverse.correlation import model_frequencies

        self.configurations, self.result, self.verification = configurations, result, verification
        self.nominal = [model_frequencies(c) for c in configurations]
        self.answer = [model_frequencies(c, result.xbar) for c in configurations]
        self.limit = misfit(configurations, self.answer) + ACCEPT_FRACTION * np.asarray(half, dtype=float)

    def frequencies(self, xbar):
        """The paired model data at ``xbar`` (one `ModelFrequencies` per configuration) when
        it is acceptable, else None."""
        from vibupdate.inverse.correlation import model_frequencies
        from vibupdate.inverse.verify import verify

        updated = [model_frequencies(c, xbar) for c in self.configurations]
        if not np.all(misfit(self.configurations, updated) <= self.limit):
            return None
        checks = verify(self.configurations, xbar, nominal=self.nominal, updated=updated,
                        lower_bound=self.result.relaxation_lower_bound, n_blocks=len(self.result.vectors),
                        options=self.verification)
        if any(c.severity == "error" and not c.passed for c in checks):
            return None
        return updated

    def __call__(self, xbar) -> bool:
        return self.frequencies(xbar) is not None


@dataclass(frozen=True)
class LineEnd:
    """One end of the walk along a null direction.

    Attributes
    ----------
    direction : int
        1-based index of the null direction at the answer.
    side : int
        +1 or -1: the sense along the direction.
    distance : float
        Step ``t`` from the answer, in normalized parameters (Eq. 12) (-).
    xbar : ndarray, shape (n_x,)
        The end point, normalized.
    stop : {"bound", "verification"}
        Why the walk ended: it reached the parameter box, or the next point was not acceptable.
    """

    direction: int
    side: int
    distance: float
    xbar: np.ndarray
    stop: str


def _step_to_box(x: np.ndarray, d: np.ndarray, lower: np.ndarray, upper: np.ndarray) -> float:
    """Largest ``t >= 0`` with ``lower <= x + t d <= upper``."""
    up, down = d > 1e-12, d < -1e-12
    steps = np.concatenate([(upper[up] - x[up]) / d[up], (lower[down] - x[down]) / d[down]])
    return float(max(0.0, steps.min())) if steps.size else 0.0


def walk_null_directions(configurations, xbar, acceptable: Callable[[np.ndarray], bool], *,
                         rtol: float = 1e-8, freqs=None) -> list[LineEnd]:
    """Walk from the verified answer ``xbar`` along each exact null direction to the farthest
    acceptable point in both senses (module docstring).

    Parameters
    ----------
    configurations : sequence of Configuration
        The sample's configurations (its drawn data).
    xbar : ndarray, shape (n_x,)
        A verified answer of those data, normalized.
    acceptable : callable
        ``acceptable(xbar) -> bool`` for a point of shape (n_x,).
    rtol : float
        Singular values below ``rtol`` times the largest count as zero
        (`vibupdate.inverse.data_map.sensitivity`).
    freqs : sequence of ModelFrequencies, optional
        `model_frequencies` of each configuration at ``xbar``, when already computed.

    Returns
    -------
    list of LineEnd
        The ends that lie beyond the answer (``distance > 0``); none when the sensitivity has
        full rank.
    """
    from vibupdate.inverse.data_map import sensitivity

    x = np.asarray(xbar, dtype=float)
    lower, upper = configurations[0].model.bounds()
    null = sensitivity(configurations, x, rtol=rtol, freqs=freqs).null_directions
    ends = []
    for j, v in enumerate(null, start=1):
        for side in (1, -1):
            d = side * np.asarray(v, dtype=float)
            t_max = _step_to_box(x, d, lower, upper)
            if t_max <= 0.0:
                continue
            if acceptable(np.clip(x + t_max * d, lower, upper)):
                t, stop = t_max, "bound"
            else:
                good, bad = 0.0, t_max
                for _ in range(BISECTIONS):
                    mid = 0.5 * (good + bad)
                    if acceptable(np.clip(x + mid * d, lower, upper)):
                        good = mid
                    else:
                        bad = mid
                t, stop = good, "verification"
            if t > 0.0:
                ends.append(LineEnd(j, side, t, np.clip(x + t * d, lower, upper), stop))
    return ends
