"""Which parameters to update, in words: the terminal table and the markdown of a suggestion
(`vibupdate.io.records.SuggestionRecord`, the record of `vibupdate.ranges.candidates.Suggestion`),
for ``vibupdate suggest`` and the section of a run's report."""

from __future__ import annotations

from vibupdate.io.outputs import first_of
from vibupdate.io.records import SuggestionRecord
from vibupdate.report.numbers import fmt
from vibupdate.report.table import Column, Table, markdown, text


#: Sets shown in the tables (every set is in the record).
SHOWN = 10


def _verdict(t) -> str:
    """The screening's and the full update's verdicts of one set (a `SetTrialRow`)."""
    text = "passes" if t.passed else "fails " + ", ".join(t.failed)
    if not t.determined:
        text += ", undetermined combination"
    if t.update:
        text += f"; update: {t.update.status.value}"
    return text


def _cells(rank: int, t) -> list[str]:
    natural = t.update.natural_max_pct if t.update else t.natural_max_pct
    return [str(rank), " + ".join(t.candidates), fmt(t.objective, ".3g"), fmt(natural, ".3g"),
            fmt(t.antiresonance_max_pct, ".3g"), f"{t.rank}/{t.free}", fmt(t.condition, ".3g"),
            _verdict(t), ", ".join(" + ".join(s) for s in t.tied_with) or "-"]


HEADER = ["rank", "added", "objective", "natural max %", "antires. max %", "rank/free", "condition", "verdict",
          "ties with"]


def _table(trials, title: str = "") -> Table:
    """The ranked sets ``trials`` as a table (`vibupdate.report.table`), the first ranked 1."""
    return Table(title, tuple(Column(h) for h in HEADER), tuple(_cells(k, t) for k, t in enumerate(trials, start=1)))


def _values_lines(t) -> list[str]:
    """The values of a checked set's full update, one line each."""
    units, ranges = t.update.units, t.update.range_pct or {}
    return [f"{name} = {fmt(v, '.6g')} {units.get(name, '')}".rstrip()
            + (f" (linearized range width {fmt(ranges[name], '.3g')} %)" if name in ranges else "")
            for name, v in t.update.values.items()]


def _best(record):
    """The first set whose full update succeeded; None without one."""
    return next((t for t in record.trials if t.update and t.update.success), None)


def suggestion_text(record: SuggestionRecord) -> str:
    """The terminal table of a suggestion."""
    trials = record.trials
    own = ", ".join(record.own) or "none"
    lines = [text(_table(trials[:SHOWN], f"Which parameters to update ({len(record.candidates)} candidates, the "
                                         f"case's own: {own}; {len(trials)} sets screened, sizes "
                                         f"{', '.join(map(str, record.sizes))}; {fmt(record.seconds, '.1f')} s)")),
             record.message]
    best = _best(record)
    if best is not None:
        lines += ["  " + line for line in _values_lines(best)]
    return "\n".join(lines)


def suggestion_markdown(record: SuggestionRecord, case: str) -> str:
    """``suggestion.md``: the ranking and the suggested set's update."""
    trials, nominal = record.trials, record.nominal
    out = [f"# vibupdate suggest: {case}", "",
           f"Candidates: {', '.join(record.candidates)}; the case's own parameters, free in every set: "
           f"{', '.join(record.own) or 'none'}. Every set of {', '.join(map(str, record.sizes))}"
           " candidates was fitted from the nominal point (polish, the case's options) and verified against the data "
           "(the consistency check aside); the search stops after the smallest size at which a set passes. Ranked: "
           "passing first, then smaller sets, then sets the data determine, then the objective (objectives within "
           f"{fmt(100 * record.limits.get('tie_rtol', 0.01), 'g')} % are ties, ordered as the candidates "
           "are declared); the top sets were updated in full. "
           f"{len(trials)} sets screened" + (f", {record.untried} left untried on the limits" if record.untried
                                             else "") + _untried(record) + f", {fmt(record.seconds, '.1f')} s.", ""]
    if nominal:
        out += [f"The case's own parameters alone: objective {fmt(nominal.get('objective'), '.3g')}, natural "
                f"frequencies within {fmt(nominal.get('natural_max_pct'), '.3g')} %, "
                + ("passes." if nominal.get("passed") else f"fails {', '.join(nominal.get('failed') or [])}."), ""]
    out += markdown(_table(trials[:SHOWN]))
    if len(trials) > SHOWN:
        out += [f"The other {len(trials) - SHOWN} sets rank lower (all in `suggestion.json`).", ""]
    out += [f"**{record.message}**", ""]
    best = _best(record)
    if best is not None:
        out += [f"The update with {' + '.join(best.candidates)}:", ""] + [f"* {line}" for line in
                                                                         _values_lines(best)] + [""]
        out += ["To run it, move these `[[candidate]]` tables to `[[parameter]]` in the case file.", ""]
    return "\n".join(out)


def run_section_markdown(record: SuggestionRecord | None) -> list[str]:
    """The run report's section "Which parameters might be missing": the screening of single
    candidates after a run that did not verify; empty without it."""
    if not record:
        return []
    trials = record.trials
    out = ["## Which parameters might be missing", "",
           f"The answer is not verified and the case declares candidates: each set of "
           f"{', '.join(map(str, record.sizes))} candidate(s) was added to the parameters, fitted from "
           "the answer (polish) and verified (the consistency check aside); screened only, not updated in full "
           f"({fmt(record.seconds, '.1f')} s).", ""]
    out += markdown(_table(trials[:5]))
    passing = [t for t in trials if t.passed]
    if passing:
        out += [f"Adding {' + '.join(passing[0].candidates)} lets the data fit within their tolerances in the "
                "screening. `vibupdate suggest CASE.toml` checks the sets by a full update and tries larger ones.", ""]
    else:
        out += ["No single candidate lets the data fit; `vibupdate suggest CASE.toml --max-size 2` tries pairs.", ""]
    return out


def _untried(record: SuggestionRecord) -> str:
    """The sets left untried, named (the first 8), in brackets; empty when none is listed."""
    return f" ({first_of(('+'.join(s) for s in record.untried_sets), 8)})" if record.untried_sets else ""
