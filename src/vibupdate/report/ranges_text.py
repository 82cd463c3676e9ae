"""The parameter ranges of a results document as text: the certified outer, sampled and
linearized ranges side by side, where they disagree, and the multistart count (terminal and
``report.md``; `vibupdate.report.document` joins them to the other tables)."""

from __future__ import annotations

from vibupdate.report.numbers import finite, fmt

__all__ = ["ranges_table_text", "ranges_markdown", "sampled_disagreements", "range_notes", "multistart_text",
           "certified_info", "sampled_info"]


def certified_info(document: dict) -> dict:
    """``identifiability.certified`` of a document ({} when not computed)."""
    return (document.get("identifiability") or {}).get("certified") or {}


def sampled_info(document: dict) -> dict:
    """``identifiability.sampled`` of a document ({} when not computed)."""
    return (document.get("identifiability") or {}).get("sampled") or {}


def _other_ranges(document: dict) -> dict:
    """The ranges beside the certified ones: ``{label: {name: {...}}}``, sampled first."""
    ident = document.get("identifiability") or {}
    others = {}
    if sampled_info(document).get("ranges"):
        others["sampled"] = sampled_info(document)["ranges"]
    if ident.get("ranges"):
        others["linearized"] = ident["ranges"]
    return others


def _ends(r: dict) -> tuple:
    return r.get("lower", r.get("min")), r.get("upper", r.get("max"))


def sampled_disagreements(sampled: dict, linearized: dict, wider: float = 2.0) -> list[str]:
    """Where the linearized ranges disagree with the sampled ones.

    Parameters
    ----------
    sampled : dict
        ``{name: {"min", "max", ...}}`` (``identifiability.sampled.ranges``).
    linearized : dict
        ``{name: {"lower", "upper", ...}}`` (``identifiability.ranges``).
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
        lo, hi = _ends(s)
        lin = linearized.get(name)
        if not lin or not all(finite(v) for v in (lo, hi, lin.get("lower"), lin.get("upper"))):
            continue
        a, b = lin["lower"], lin["upper"]
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


def range_notes(document: dict) -> list[str]:
    """Every disagreement between the certified, sampled and linearized ranges present."""
    from vibupdate.ranges.certify import range_disagreements

    others = _other_ranges(document)
    notes = range_disagreements(certified_info(document)["ranges"], others) if certified_info(document) else []
    if "sampled" in others and "linearized" in others:
        notes += sampled_disagreements(others["sampled"], others["linearized"])
    return notes


def multistart_text(document: dict) -> str:
    """One sentence on the multistart of the point estimate, or "" without one."""
    ms = (document.get("identifiability") or {}).get("multistart")
    if not ms:
        return ""
    converged = ms["starts"] - ms["failed"]
    objectives = [m["objective"] for m in ms["minima"] if m.get("objective") is not None]
    objectives = [v for v in objectives if finite(v)]
    spread = (f", objectives {fmt(min(objectives))} to {fmt(max(objectives))}" if len(objectives) > 1
              else (f", objective {fmt(objectives[0])}" if objectives else ""))
    return (f"multistart of the point estimate: {ms['distinct_minima']} distinct local minima from {converged} "
            f"converged of {ms['starts']} random starts{spread} (answers more than {fmt(ms['x_tol'], 'g')} apart in a "
            "normalized parameter count as distinct; many minima with equal objectives are a continuum, not "
            "competing answers)")


def ranges_table_text(document: dict) -> str:
    """Certified outer, sampled and linearized ranges per parameter side by side (those present),
    the disagreements between them and the multistart count; "" when no range was computed."""
    cert = certified_info(document)
    others = _other_ranges(document)
    if not cert and not others:
        return multistart_text(document)
    names = [p["name"] for p in document["parameters"]]
    head = f"{'name':>8}"
    if cert:
        head += f" {'certified lower':>15} {'upper':>11} {'cert.':>5}"
    head += "".join(f" {label + ' lower':>17} {'upper':>11}" for label in others)
    kinds = (["certified outer"] if cert else []) + [
        {"sampled": "sampled", "linearized": "linearized at the answer"}[label] for label in others]
    lines = ["Parameter ranges: " + ", ".join(kinds)]
    if cert:
        lines.append(f"Certified outer ranges ({cert['message']}, {fmt(cert.get('seconds'), '.1f')} s)")
    sampled = sampled_info(document)
    if sampled:
        lines.append(f"Sampled ranges: {sampled['verified']} verified, {sampled['unverified']} unverified, "
                     f"{sampled['failed']} failed of {sampled['samples']} samples; {sampled.get('line_ends', 0)} "
                     "line ends along null directions")
    lines.append(head)
    for name in names:
        line = f"{name:>8}"
        if cert:
            c = cert["ranges"].get(name, {})
            line += (f" {fmt(c.get('lower'), '15.5g')} {fmt(c.get('upper'), '11.5g')} "
                     f"{'yes' if c.get('certified') else 'no':>5}")
        for ranges in others.values():
            lo, hi = _ends(ranges.get(name, {}))
            line += f" {fmt(lo, '17.5g')} {fmt(hi, '11.5g')}"
        lines.append(line)
    lines += [f"disagreement: {n}" for n in range_notes(document)]
    if multistart_text(document):
        lines.append(multistart_text(document))
    return "\n".join(lines)


def ranges_markdown(document: dict) -> list[str]:
    """The paragraphs of ``report.md`` on the sampled and certified ranges, their
    disagreements and the multistart."""
    out = []
    sampled = sampled_info(document)
    if sampled:
        out += [f"Sampled range: {sampled['samples']} data sets drawn inside the measured intervals "
                f"({sampled.get('distribution', 'uniform')}, seed {sampled.get('seed')}), each updated and verified "
                "as this run was "
                f"({sampled['verified']} verified, {sampled['unverified']} not verified, "
                f"{sampled['failed']} failed; the last two are counted, not used). Where the data leave a "
                "combination undetermined (an exact null direction at a verified answer) the answer was walked "
                "along it to the farthest point still verified against the same data "
                f"({sampled.get('line_ends', 0)} such ends). The range is the min and max over the verified "
                "answers and these ends: an inner estimate of what the data allow (every value in it is a verified "
                "answer of some data set inside the intervals; values outside may still be consistent).", ""]
    info = certified_info(document)
    if info:
        out += ["Certified outer range: min and max of each parameter over a convex (McCormick, linear "
                "programming) relaxation of the consistent set S below, with bound tightening and branching; every point of S "
                "lies inside. Each end is a safe Lagrangian bound evaluated from the LP solver's multipliers with "
                "its rounding accounted for; \"certified\" means the safe bound confirms the solver's optimum, "
                "\"no\" that the reported (still valid) range may be looser. " + info["definition"]
                + f" Outcome: {info['message']}; {info['passes']} tightening pass(es), {info['n_lps']} LPs, "
                f"{fmt(info.get('seconds'), '.1f')} s (root {fmt(info.get('root_seconds'), '.1f')} s).", ""]
    if len(_other_ranges(document)) + bool(info) >= 2:
        notes = range_notes(document)
        out += (["Where the ranges disagree:", ""] + [f"- {n}" for n in notes] + [""] if notes
                else ["The ranges agree: "
                      + ("the other ranges lie inside the certified ones and none is less than half as wide"
                         if info else "the sampled ranges lie inside the linearized ones and are at least half as "
                         "wide") + ".", ""])
    if multistart_text(document):
        text = multistart_text(document)
        out += [text[0].upper() + text[1:] + ".", ""]
    return out
