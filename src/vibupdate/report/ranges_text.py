"""The parameter ranges of a run as one table (certified outer, sampled and linearized ranges
side by side, where they disagree, the multistart count) and the report's paragraphs on how
each was computed; `vibupdate.report.document` joins them to the other tables. Each function
reads ``identifiability`` of the results (`vibupdate.io.results.Identifiability`)."""

from __future__ import annotations

from vibupdate.options import finite
from vibupdate.report.numbers import fmt
from vibupdate.report.table import Column, Table


def _other_ranges(ident) -> dict:
    """The ranges beside the certified ones: ``{label: {name: range}}``, sampled first (each
    range with ``lower`` and ``upper``: `LinearRange`, `SampledRange`)."""
    others = {}
    if ident.sampled is not None and ident.sampled.ranges:
        others["sampled"] = ident.sampled.ranges
    if ident.ranges:
        others["linearized"] = ident.ranges
    return others


def sampled_disagreements(sampled: dict, linearized: dict, wider: float = 2.0) -> list[str]:
    """Where the linearized ranges disagree with the sampled ones.

    Parameters
    ----------
    sampled : dict of str to SampledRange
        ``identifiability.sampled.ranges``.
    linearized : dict of str to LinearRange
        ``identifiability.ranges``.
    wider : float
        A linearized range wider than ``wider`` times the sampled one is reported.

    Returns
    -------
    list of str
        One sentence per parameter: sampled verified answers outside the linearized range
        (the linearization misses values the data allow), or a linearized range much wider
        than the sampled one (the samples did not reach what the linearization allows).
    """
    notes = []
    for name, s in sampled.items():
        lo, hi = s.lower, s.upper
        lin = linearized.get(name)
        if not lin or not all(finite(v) for v in (lo, hi, lin.lower, lin.upper)):
            continue
        a, b = lin.lower, lin.upper
        tol = 1e-9 * max(abs(a), abs(b), 1e-300)
        if lo < a - tol or hi > b + tol:
            notes.append(f"{name}: the sampled range [{fmt(lo)}, {fmt(hi)}] reaches outside the linearized range "
                         f"[{fmt(a)}, {fmt(b)}]: the linearization at the answer misses verified answers of sampled "
                         "data sets")
        elif hi - lo <= 1e-12 * max(abs(lo), abs(hi), 1e-300) and b > a:
            notes.append(f"{name}: every verified sample gave {fmt(lo)}, the linearized range is [{fmt(a)}, {fmt(b)}]: "
                         "the samples did not move it (a bound active in every sample?)")
        elif (b - a) > wider * (hi - lo):
            notes.append(f"{name}: the linearized range [{fmt(a)}, {fmt(b)}] is {fmt((b - a) / (hi - lo), '.3g')}x "
                         f"the sampled range [{fmt(lo)}, {fmt(hi)}]: the samples did not reach all the linearization "
                         "allows")
    return notes


def range_disagreements(certified: dict, others: dict, wider: float = 2.0) -> list[str]:
    """Where other ranges disagree with the certified outer ranges.

    Parameters
    ----------
    certified : dict of str to CertifiedRange
        ``identifiability.certified.ranges``.
    others : dict
        ``{label: {name: range}}``, the linearized and the sampled ranges (`_other_ranges`).
    wider : float
        A certified range wider than ``wider`` times another is reported.

    Returns
    -------
    list of str
        One sentence per disagreement: another range reaching outside the certified one (its
        values are not consistent with the data as S states them), or a certified range much
        wider than another (the other misses what the data allow).
    """
    notes = []
    for label, ranges in others.items():
        for name, c in certified.items():
            o = ranges.get(name)
            if not o or not all(finite(v) for v in (o.lower, o.upper, c.lower, c.upper)):
                continue   # a range end that is missing or not finite is no disagreement
            lo, hi = o.lower, o.upper
            tol = 1e-9 * max(abs(c.lower), abs(c.upper), 1e-300)
            if lo < c.lower - tol or hi > c.upper + tol:
                notes.append(f"{name}: the {label} range [{lo:.4g}, {hi:.4g}] reaches outside the certified range "
                             f"[{c.lower:.4g}, {c.upper:.4g}]")
            elif (c.upper - c.lower) > wider * (hi - lo):
                notes.append(f"{name}: the certified range [{c.lower:.4g}, {c.upper:.4g}] is "
                             f"{(c.upper - c.lower) / max(hi - lo, 1e-300):.3g}x the {label} range "
                             f"[{lo:.4g}, {hi:.4g}]")
    return notes


def range_notes(ident) -> list[str]:
    """Every disagreement between the certified, sampled and linearized ranges present."""
    others, cert = _other_ranges(ident), ident.certified
    notes = range_disagreements(cert.ranges, others) if cert else []
    if "sampled" in others and "linearized" in others:
        notes += sampled_disagreements(others["sampled"], others["linearized"])
    return notes


def multistart_text(ident) -> str:
    """One sentence on the multistart of the point estimate, or "" without one."""
    ms = ident.multistart
    if not ms:
        return ""
    converged = ms.starts - ms.failed
    objectives = [m.objective for m in ms.minima if finite(m.objective)]
    spread = (f", objectives {fmt(min(objectives))} to {fmt(max(objectives))}" if len(objectives) > 1
              else (f", objective {fmt(objectives[0])}" if objectives else ""))
    return (f"multistart of the point estimate: {ms.distinct_minima} distinct local minima from {converged} "
            f"converged of {ms.starts} random starts{spread} (answers more than {fmt(ms.x_tol, 'g')} apart in a "
            "normalized parameter count as distinct; many minima with equal objectives are a continuum, not "
            "competing answers)")


def _width(pct) -> str:
    """A range's width in per cent: one decimal from 1 % up, two significant digits below
    (a width of 0.04 % must not print as 0.0)."""
    return fmt(pct, ".1f") if finite(pct) and abs(pct) >= 1 else fmt(pct, ".2g")


def _range(r) -> str:
    lo, hi = (None, None) if r is None else (r.lower, r.upper)
    return f"[{fmt(lo)}, {fmt(hi)}]"


def _range_notes(ident) -> tuple[str, ...]:
    """Below the table: how the certified and sampled ranges ended, where the ranges
    disagree (or that they agree), the multistart."""
    cert, sampled = ident.certified, ident.sampled
    notes = [f"Certified outer ranges ({cert.message}, {fmt(cert.seconds, '.1f')} s)"] if cert else []
    if sampled:
        notes.append(f"Sampled ranges: {sampled.verified} verified, {sampled.unverified} unverified, "
                     f"{sampled.failed} failed of {sampled.samples} samples; {sampled.line_ends} "
                     "line ends along null directions")
    if len(_other_ranges(ident)) + bool(cert) >= 2:
        notes += [f"Disagreement: {n}" for n in range_notes(ident)] or [
            "The ranges agree: " + ("the other ranges lie inside the certified ones and none is less than half as wide"
                                    if cert else "the sampled ranges lie inside the linearized ones and are at least "
                                    "half as wide")]
    return tuple(notes) + ((f"The {multistart_text(ident)}.",) if ident.multistart else ())


def ranges_table(ident, names: list[str]) -> Table | None:
    """Certified outer, sampled and linearized (consistent) ranges per parameter side by side
    (those computed), with `_range_notes`; None without ``ident`` (an `Identifiability`) or
    when no range was computed."""
    if ident is None:
        return None
    cert, others = ident.certified.ranges if ident.certified else None, _other_ranges(ident)
    if not cert and not others:
        return None
    columns, cells = [Column("parameter")], [[n] for n in names]
    if cert:
        columns += [Column("certified outer range"), Column("certified")]
        for row in cells:
            c = cert.get(row[0])
            row += [_range(c), "yes" if c is not None and c.certified else "no"]
    if "sampled" in others:
        columns.append(Column("sampled range"))
        for row in cells:
            row.append(_range(others["sampled"].get(row[0])))
    if "linearized" in others:
        columns += [Column("consistent range"), Column("width %")]
        for row in cells:
            r = others["linearized"].get(row[0])
            row += [_range(r), _width(r.width_pct if r is not None else None)]
    kinds = (["certified outer"] if cert else []) + [
        {"sampled": "sampled", "linearized": "linearized at the answer"}[label] for label in others]
    return Table("Parameter ranges: " + ", ".join(kinds), tuple(columns), tuple(tuple(r) for r in cells),
                 notes=_range_notes(ident))


def ranges_markdown(ident) -> list[str]:
    """The paragraphs of ``report.md`` on how the linearized, sampled and certified ranges
    were computed (none without ``ident``, an `Identifiability`)."""
    if ident is None:
        return []
    out = []
    if ident.ranges:
        # a width is None where its linear programs found no finite range (NaN in the results)
        determined = [n for n, rg in ident.ranges.items() if finite(rg.width_pct) and rg.width_pct <= 5.0]
        window = ident.frequency_windows or f"{fmt(100 * (ident.frequency_tolerance or 0), '.2g')} %"
        out += ["Consistent range (linearized at the verified answer, two linear programs per parameter): the "
                "parameter sets within the bounds whose measured mode-shape entries stay in their intervals and "
                f"whose frequencies move from the answer's by at most {window} plus the answer's own misfit, "
                "to first order in the parameter change. It is not a certified enclosure: far from the answer the "
                "linearization may miss consistent sets (another local minimum, a strongly nonlinear direction). "
                "Its width, in per cent of the nominal (or reference) value, shows what the data determine near "
                "the answer. Within 5 %: " + (", ".join(determined) or "none") + ".", ""]
    sampled = ident.sampled
    if sampled:
        out += [f"Sampled range: {sampled.samples} data sets drawn inside the measured intervals "
                f"({sampled.distribution}, seed {sampled.seed}), each updated and verified "
                "as this run was "
                f"({sampled.verified} verified, {sampled.unverified} not verified, "
                f"{sampled.failed} failed; the last two are counted, not used). Where the data leave a "
                "combination undetermined (an exact null direction at a verified answer) the answer was walked "
                "along it to the farthest point still verified against the same data "
                f"({sampled.line_ends} such ends). The range is the min and max over the verified "
                "answers and these ends: an inner estimate of what the data allow (every value in it is a verified "
                "answer of some data set inside the intervals; values outside may still be consistent).", ""]
    info = ident.certified
    if info:
        out += ["Certified outer range: min and max of each parameter over a convex (McCormick, linear "
                "programming) relaxation of the consistent set S below, with bound tightening and branching; every "
                "point of S lies inside. Each end is a safe Lagrangian bound evaluated from the LP solver's "
                "multipliers with its rounding accounted for; \"certified\" means the safe bound confirms the "
                "solver's optimum, \"no\" that the reported (still valid) range may be looser. " + info.definition
                + f" Outcome: {info.message}; {info.passes} tightening pass(es), {info.n_lps} LPs, "
                f"{fmt(info.seconds, '.1f')} s (root {fmt(info.root_seconds, '.1f')} s).", ""]
    return out
