"""The one place where the acceptance engine reads vibupdate's answers.

The judge sees only what a user sees: the status, the parameter values, the consistent ranges
the run reports, the other answers it reports as fitting the data as well, the frequency rows
of ``results.json`` and the group the diagnosis ranks first. `from_results_json` reads them from
``results.json`` (the CLI route), `from_update_result` from a `vibupdate.UpdateResult` and the
ranges the user computed at its answer (the Python route). Whatever the library calls its
statuses, they are mapped here to the judge's words (`status_word`), so a renamed status
touches this file alone.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

__all__ = ["Outcome", "status_word", "from_results_json", "from_update_result", "failed_outcome", "ANSWERED"]

#: The judge's words for a status: an answer that claims to fit every datum, an answer that does
#: not, a valid input refused, an internal error; other statuses (a failed path) pass as they are.
_WORDS = {"success": "success", "acceptable": "success", "verified": "success",
          "not_unique": "not_unique", "not_verified": "not_verified", "refused": "refused", "crash": "crash"}
#: Statuses whose answer claims to fit every datum (the tool's ``not_unique`` says so, and names
#: the other answers).
ANSWERED = ("success", "not_unique")


def status_word(status) -> str:
    """The judge's word for a status given as a string or an enum (its value, else its name)."""
    raw = getattr(status, "value", status)
    raw = raw if isinstance(raw, str) else getattr(status, "name", str(status))
    raw = raw.lower()
    return _WORDS.get(raw, raw)


@dataclass
class Outcome:
    """What one run returned, in the judge's terms (module docstring).

    Attributes
    ----------
    status : str
        `status_word` of the run's status.
    exit_code : int or None
        The CLI's exit code (None on the Python route).
    seconds : float
    values : ndarray or None
        Physical parameter values of the answer, in the problem's parameter order.
    ranges : dict of str to (float, float), or None
        Consistent ranges the run reports.
    alternatives : list of ndarray
        Other answers the run reports as fitting the data as well.
    rows : list of dict
        Frequency rows (``configuration``, ``kind``, ``receptance``, ``index``, ``model_index``,
        ``updated_hz``) for the check that the report shows the answer's own frequencies.
    diagnosis : tuple of str
        Keys of the data groups the diagnosis ranked, first the one whose removal fits best.
    error : str
    damping : list of dict
        The damping rows (``configuration``, ``mode``, ``measured`` and ``identified`` ratios).
    damping_model : dict or None
        The fitted Caughey series, ``exponents`` and ``beta``.
    warnings : tuple of str
        Every warning the run gave.
    """

    status: str
    exit_code: int | None
    seconds: float
    values: np.ndarray | None = None
    ranges: dict | None = None
    alternatives: list = field(default_factory=list)
    rows: list = field(default_factory=list)
    diagnosis: tuple = ()
    error: str = ""
    damping: list = field(default_factory=list)
    damping_model: dict | None = None
    warnings: tuple = ()

    @property
    def answered(self) -> bool:
        return self.status in ANSWERED


def failed_outcome(status: str, seconds: float, error: str, exit_code: int | None = None) -> Outcome:
    """A run that returned no answer (refused or crashed)."""
    return Outcome(status, exit_code, seconds, error=error[:300])


def from_results_json(doc: dict | None, exit_code: int, seconds: float, error: str) -> Outcome:
    """The outcome of ``vibupdate run`` from its ``results.json`` (None: not written)."""
    if doc is None:
        return failed_outcome("refused" if exit_code == 2 else "crash", seconds, error, exit_code)
    names = [p["name"] for p in doc["parameters"]]
    ident = doc.get("identifiability") or {}
    ranges = _ranges(ident.get("ranges"))
    alternatives = [np.array([a["values"][n] for n in names], dtype=float) for a in ident.get("alternatives") or []]
    diagnosis = tuple(t["key"] for t in ((doc.get("diagnosis") or {}).get("trials") or []))
    model = doc.get("damping_model")
    return Outcome(status_word(doc["solver"]["status"]), exit_code, seconds,
                   np.array([p["updated"] for p in doc["parameters"]], dtype=float), ranges, alternatives,
                   list(doc.get("frequencies") or []), diagnosis, error, list(doc.get("damping") or []),
                   None if not model else {"exponents": model["exponents"], "beta": model["beta"]},
                   tuple(doc.get("warnings") or ()))


def _ranges(ranges: dict | None) -> dict | None:
    """``{name: (lower, upper)}`` from ranges as ``results.json`` writes them (``{name: {"lower",
    "upper", ...}}``)."""
    return {n: (r["lower"], r["upper"]) for n, r in ranges.items()} if ranges else None


def from_update_result(result, seconds: float, ranges: dict | None = None, damping=None) -> Outcome:
    """The outcome of `vibupdate.update`; ``ranges`` the consistent ranges the user computed at
    its answer, as ``results.json`` writes them (`acceptance.runner.api_ranges`); ``damping``
    the `vibupdate.DampingStage` the user identified on it (None: none)."""
    from vibupdate.io.results import frequencies_of

    alternatives = [np.array(list(a["values"].values()), dtype=float) for a in getattr(result, "alternatives", ())]
    rows, model, warned = [], None, tuple(result.warnings)
    if damping is not None:
        rows = damping.rows()
        model = {"exponents": [float(y) for y in damping.caughey.exponents],
                 "beta": [float(b) for b in damping.caughey.beta]}
        warned += tuple(damping.warnings)
    return Outcome(status_word(result.status), None, seconds, np.asarray(result.values, dtype=float),
                   _ranges(ranges), alternatives, [r.as_dict() for r in frequencies_of(result.correlation)],
                   damping=rows, damping_model=model, warnings=warned)
