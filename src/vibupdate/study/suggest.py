"""``vibupdate suggest``: which of a case's candidates to update (`vibupdate.ranges.candidates`)
on a case file, with the optional ``suggestion.json`` and ``suggestion.md`` written through
the results-folder protocol of `vibupdate.io.outputs` (checked before any work, staged, moved
into place at the end, listed in the folder's manifest)."""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path

from vibupdate.io.case_types import Case
from vibupdate.io.outputs import prepare_output, write_published
from vibupdate.io.validation import validate_case
from vibupdate.ranges.candidates import CHECKED, Suggestion, suggest_sets
from vibupdate.io.records import SuggestionRecord, plain
from vibupdate.report.suggestion import suggestion_markdown


#: The files ``--out`` receives.
FILES = ("suggestion.json", "suggestion.md")


def _write(folder: Path, case: Case, suggestion: Suggestion) -> None:
    from vibupdate import __version__

    record = {"version": __version__, "case": case.name, **plain(suggestion.record())}
    (folder / FILES[0]).write_text(json.dumps(record, indent=1, allow_nan=False) + "\n", encoding="utf-8")
    (folder / FILES[1]).write_text(suggestion_markdown(SuggestionRecord.from_dict(record), case.name),
                                   encoding="utf-8")


def suggest_case(case: Case, out_dir=None, *, max_size: int = 3, checked: int = CHECKED, force: bool = False,
                 progress: Callable[[str], None] | None = None) -> Suggestion:
    """Screen, rank and check the sets of ``case``'s candidates (`vibupdate.ranges.candidates`).

    Parameters
    ----------
    case : Case
        A case with ``[[candidate]]`` tables.
    out_dir : str or Path, optional
        Folder for ``suggestion.json`` and ``suggestion.md``; checked before any work as a run's
        results folder is (`vibupdate.io.outputs.prepare_output`). None writes nothing.
    max_size : int
        Largest set of candidates tried.
    checked : int
        Top sets updated in full.
    force : bool
        Write into a folder that holds other files (they are kept).
    progress : callable, optional
        Receives the progress lines.

    Returns
    -------
    Suggestion
        Every set of candidates screened, ranked (sets that pass verification first, then
        smaller sets, then by misfit), the top ``checked`` sets updated in full; a set is
        suggested only when its full update is verified.

    Raises
    ------
    ValueError
        No candidates, a bad ``max_size`` or ``checked``, an invalid case (`validate_case` on
        the model with every candidate free) or an output folder that cannot take the files.
    """
    from vibupdate import __version__

    say = progress or (lambda message: None)
    if not case.candidates:
        raise ValueError(f"{case.path}: the case declares no [[candidate]]: add [[candidate]] tables (as "
                         "[[parameter]] ones) for what the model might be missing (docs/case-file.md)")
    if isinstance(max_size, bool) or not isinstance(max_size, int) or max_size < 1:
        raise ValueError(f"--max-size must be an integer >= 1, got {max_size!r}")
    if isinstance(checked, bool) or not isinstance(checked, int) or checked < 0:
        raise ValueError(f"--checked must be an integer >= 0, got {checked!r}")
    names = [p.name for p in case.candidates]
    target = None if out_dir is None else prepare_output(out_dir, force=force, planned=FILES, command="suggest",
                                                         inputs=case.inputs, case=case.name)
    # every candidate free: the bounds are checked (and narrowed where they reach models that are
    # not physical) once, for every set
    full = validate_case(case.with_candidates(names))
    for warning in full.warnings:
        say(f"warning: {warning}")
    pool = (full.case or case.with_candidates(names)).configurations
    own = list(case.configurations[0].model.parameter_names)
    suggestion = suggest_sets(pool, own, names, max_size=max_size, checked=checked, formulation=case.formulation,
                              solver=case.solver, polish=case.polish, verification=case.verify_options(),
                              frequency_tolerance=case.frequency_tolerance, progress=say)
    if target is not None:
        write_published(target, lambda staged: _write(staged, case, suggestion), case=case.name, version=__version__)
        say(f"wrote {target.path}/ ({', '.join(FILES)})")
    return suggestion
