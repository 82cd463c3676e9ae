"""Human-readable tables of a results document (`RunResult.as_document`): terminal and ``report.md``."""

from __future__ import annotations

__all__ = ["frequency_table_text", "parameter_table_text", "damping_table_text", "summary_text", "markdown_report",
           "ranges_table_text", "sampled_disagreements", "range_notes", "multistart_text"]

#: What the lambda = 0 optimum says (issue 11): the lifted variables absorb every mismatch, so
#: it is ~0 on every example.
LOWER_BOUND_NOTE = "a valid bound of the global minimum, but it certifies nothing unless positive"


def _fmt(value, spec: str) -> str:
    if value is None:
        width = spec.split(".")[0]
        return "-".rjust(int(width) if width.isdigit() else 0)
    return format(value, spec)


def _paper_frequency(document: dict, row: dict, column: str):
    paper = document.get("paper") or {}
    for p in paper.get("frequencies", []):
        if (p["configuration"], p["kind"], int(p["index"])) == (row["configuration"], row["kind"], row["index"]):
            return float(p[column])
    return None


def frequency_table_text(document: dict) -> str:
    """Measured / nominal / updated frequencies with errors, and the paper's updated column
    where the document carries one (Table 5 for the cantilever)."""
    has_paper = bool(document.get("paper"))
    head = (f"{'cfg':>4} {'kind':>13} {'#':>2} {'measured':>9} {'nominal':>9} {'err%':>6} "
            f"{'updated':>9} {'err%':>6}")
    if has_paper:
        head += f" {'paper upd':>9} {'err%':>6}"
    lines = ["Frequencies [Hz]", head]
    for r in document["frequencies"]:
        line = (f"{r['configuration']:>4} {r['kind']:>13} {r['index']:>2} {r['measured_hz']:9.2f} "
                f"{_fmt(r['nominal_hz'], '9.2f')} {_fmt(r['error_nominal_pct'], '6.2f')} "
                f"{_fmt(r['updated_hz'], '9.2f')} {_fmt(r['error_updated_pct'], '6.2f')}")
        if has_paper:
            p = _paper_frequency(document, r, "paper_updated_hz")
            err = None if p is None else 100 * abs(p - r["measured_hz"]) / r["measured_hz"]
            line += f" {_fmt(p, '9.2f')} {_fmt(err, '6.2f')}"
        lines.append(line)
    return "\n".join(lines)


def parameter_table_text(document: dict) -> str:
    """Parameters nominal / bounds / updated, with the paper's updated value if known."""
    paper = {p["name"]: float(p["paper_updated"]) for p in (document.get("paper") or {}).get("parameters", [])}
    head = f"{'name':>8} {'unit':>7} {'nominal':>11} {'lower':>11} {'upper':>11} {'updated':>11}"
    if paper:
        head += f" {'paper':>11}"
    lines = ["Parameters", head]
    for p in document["parameters"]:
        line = (f"{p['name']:>8} {p['unit']:>7} {p['nominal']:11.4g} {p['lower']:11.4g} {p['upper']:11.4g} "
                f"{_fmt(p['updated'], '11.4g')}")
        if paper:
            line += f" {_fmt(paper.get(p['name']), '11.4g')}"
        lines.append(line)
    ident = document.get("identifiability")
    if ident:
        weak = [n for n, v in ident["column_norm"].items() if v < 1e-2 * max(ident["column_norm"].values())]
        lines.append(f"sensitivity rank {ident['rank']} of {len(document['parameters'])}, "
                     f"condition {ident['condition']:.3g}"
                     + (f"; weakly determined by the data: {', '.join(weak)}" if weak else ""))
    return "\n".join(lines)


def _certified(document: dict) -> dict:
    return (document.get("identifiability") or {}).get("certified") or {}


def _sampled(document: dict) -> dict:
    return (document.get("identifiability") or {}).get("sampled") or {}


def _other_ranges(document: dict) -> dict:
    """The ranges beside the certified ones: ``{label: {name: {...}}}``, sampled first."""
    ident = document.get("identifiability") or {}
    others = {}
    if _sampled(document).get("ranges"):
        others["sampled"] = _sampled(document)["ranges"]
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
        if lo is None or hi is None or not lin or lin.get("lower") is None or lin.get("upper") is None:
            continue
        a, b = lin["lower"], lin["upper"]
        tol = 1e-9 * max(abs(a), abs(b), 1e-300)
        if lo < a - tol or hi > b + tol:
            notes.append(f"{name}: the sampled range [{lo:.4g}, {hi:.4g}] reaches outside the linearized range "
                         f"[{a:.4g}, {b:.4g}]: the linearization at the answer misses verified answers of sampled "
                         "data sets")
        elif hi - lo <= 1e-12 * max(abs(lo), abs(hi), 1e-300) and b > a:
            notes.append(f"{name}: every verified sample gave {lo:.4g}, the linearized range is [{a:.4g}, {b:.4g}]: "
                         "the samples did not move it (a bound active in every sample?)")
        elif (b - a) > wider * (hi - lo):
            notes.append(f"{name}: the linearized range [{a:.4g}, {b:.4g}] is {(b - a) / (hi - lo):.3g}x "
                         f"the sampled range [{lo:.4g}, {hi:.4g}]: the samples did not reach all the linearization "
                         "allows")
    return notes


def range_notes(document: dict) -> list[str]:
    """Every disagreement between the certified, sampled and linearized ranges present."""
    from vibupdate.ranges.certify import range_disagreements

    others = _other_ranges(document)
    notes = range_disagreements(_certified(document)["ranges"], others) if _certified(document) else []
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
    spread = (f", objectives {min(objectives):.4g} to {max(objectives):.4g}" if len(objectives) > 1
              else (f", objective {objectives[0]:.4g}" if objectives else ""))
    return (f"multistart of the point estimate: {ms['distinct_minima']} distinct local minima from {converged} "
            f"converged of {ms['starts']} random starts{spread} (answers more than {ms['x_tol']:g} apart in a "
            "normalized parameter count as distinct; many minima with equal objectives are a continuum, not "
            "competing answers)")


def ranges_table_text(document: dict) -> str:
    """Certified outer, sampled and linearized ranges per parameter side by side (those present),
    the disagreements between them and the multistart count; "" when no range was computed."""
    cert = _certified(document)
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
        lines.append(f"Certified outer ranges ({cert['message']}, {cert['seconds']:.1f} s)")
    sampled = _sampled(document)
    if sampled:
        lines.append(f"Sampled ranges: {sampled['verified']} verified, {sampled['unverified']} unverified, "
                     f"{sampled['failed']} failed of {sampled['samples']} samples; {sampled.get('line_ends', 0)} "
                     "line ends along null directions")
    lines.append(head)
    for name in names:
        line = f"{name:>8}"
        if cert:
            c = cert["ranges"].get(name, {})
            line += (f" {_fmt(c.get('lower'), '15.5g')} {_fmt(c.get('upper'), '11.5g')} "
                     f"{'yes' if c.get('certified') else 'no':>5}")
        for ranges in others.values():
            lo, hi = _ends(ranges.get(name, {}))
            line += f" {_fmt(lo, '17.5g')} {_fmt(hi, '11.5g')}"
        lines.append(line)
    lines += [f"disagreement: {n}" for n in range_notes(document)]
    if multistart_text(document):
        lines.append(multistart_text(document))
    return "\n".join(lines)


def damping_table_text(document: dict) -> str:
    """Measured / Rayleigh / Caughey damping ratios with errors, and the paper's Caughey column."""
    if not document.get("damping"):
        return ""
    has_paper = bool((document.get("paper") or {}).get("damping"))
    head = f"{'cfg':>4} {'mode':>4} {'measured':>9} {'Rayleigh':>9} {'err%':>6} {'Caughey':>9} {'err%':>6}"
    head += f" {'paper R.':>9} {'paper C.':>9} {'err%':>6}" if has_paper else ""
    lines = ["Damping ratios [-]", head]
    for d in document["damping"]:
        line = (f"{d['configuration']:>4} {d['mode']:>4} {d['measured']:9.4f} {_fmt(d.get('rayleigh'), '9.4f')} "
                f"{_fmt(d.get('error_rayleigh_pct'), '6.1f')} {d['identified']:9.4f} {d['error_pct']:6.1f}")
        if has_paper:
            pr = _paper_damping(document, d["configuration"], d["mode"], "paper_rayleigh")
            p = _paper_damping(document, d["configuration"], d["mode"], "paper_caughey")
            err = None if p is None else 100 * abs(p - d["measured"]) / d["measured"]
            line += f" {_fmt(pr, '9.4f')} {_fmt(p, '9.4f')} {_fmt(err, '6.1f')}"
        lines.append(line)
    return "\n".join(lines)


def summary_text(document: dict) -> str:
    """Mean errors, solver status and problem size in a few lines."""
    s, solver, size = document["summary"], document.get("solver") or {}, document.get("problem_size") or {}
    paper = (document.get("paper") or {}).get("summary", {})
    lines = [
        f"mean frequency error: nominal {_fmt(s['mean_error_nominal_pct'], '.2f')} %, "
        f"updated {_fmt(s['mean_error_updated_pct'], '.2f')} %"
        + (f" (paper: {paper['mean_error_nominal_pct']} % -> {paper['mean_error_updated_pct']} %)" if paper else ""),
    ]
    if s.get("mean_damping_error_pct") is not None:
        lines.append(
            f"mean damping error: Rayleigh {s['mean_damping_error_rayleigh_pct']:.1f} %, Caughey "
            f"{s['mean_damping_error_pct']:.1f} %"
            + (f" (paper: {paper['mean_damping_error_rayleigh_pct']} %, {paper['mean_damping_error_pct']} %)"
               if "mean_damping_error_pct" in paper else ""))
    if solver:
        lines.append(
            f"solver: {solver['status']}, objective {solver['objective']:.4e}, relaxation lower bound "
            f"{_fmt(solver['relaxation_lower_bound'], '.4e')} ({LOWER_BOUND_NOTE}), {len(solver['steps'])} solves, "
            f"{solver['seconds']:.2f} s"
        )
    for w in solver.get("warnings", []):
        lines.append(f"warning: {w}")
    if size:
        table1 = (document.get("paper") or {}).get("problem_size")
        lines.append(
            f"problem size: {size['n_parameters']} parameters, {size['n_mode_unknowns']} mode unknowns, "
            f"{size['n_adjunct_unknowns']} adjunct unknowns, {size['n_lifted']} lifted scalars"
            + (f" (paper Table 1: {table1['n_mode_unknowns']} / {table1['n_adjunct_unknowns']} / "
               f"{table1['n_lifted']}; here one entry of every vector is fixed for normalization)" if table1 else "")
        )
    return "\n".join(lines)


def verification_markdown(solver: dict) -> list[str]:
    """The verification section: what each stage did and every check with its figures."""
    checks = solver.get("checks") or []
    if not checks and not solver:
        return []
    out = ["## Verification", ""]
    if not checks:
        return out + ["The updated model was not checked: the homotopy did not reach lambda = 1.", ""]
    pol = solver.get("polish")
    stages = "The first stage (homotopy) gave an answer"
    if pol:
        stages += (f"; the polish (bounded least squares of the declared modes' relative frequency errors and the "
                   f"shape-interval penalties) took its objective from {_g(pol['cost_start'], '.4e')} to "
                   f"{_g(pol['cost'], '.4e')} in {pol['evaluations']} evaluations of the full model"
                   + (f" ({pol['rounds']} rounds on a reduced model, {pol.get('reduced_evaluations', 0)} evaluations "
                      "there; each round checked on the full model)" if pol.get("rounds") else "")
                   + " and was " + ("kept" if pol["kept"] else "not kept")
                   + (f" (stopped on its {pol['stopped_on']} limit: {pol['message']})"
                      if pol.get("stopped_on") in ("evaluations", "time") else ""))
    attempts = solver.get("attempts") or []
    if len(attempts) > 1:
        stages += (f"; the vector boxes were widened {len(attempts) - 1} time(s) because the relaxation proved that "
                   "they excluded every fit (lower bounds "
                   + ", ".join(_g(a["relaxation_lower_bound"], ".3g") for a in attempts) + ")")
    verdict = ("**verified**: every check of the returned model against the data passed"
               if solver.get("verified") else "**not verified**: the failed checks below say why")
    out += [stages + ". The answer is " + verdict + ".", ""]
    rows = [[c["name"], "pass" if c["passed"] else ("FAIL" if c["severity"] == "error" else "warning"),
             c["message"].replace("|", "/")] for c in checks]
    return out + _md_table(["check", "result", "finding"], rows) + [""]


def _md_table(header: list[str], rows: list[list]) -> list[str]:
    lines = ["| " + " | ".join(header) + " |", "|" + "|".join("---:" if i else "---" for i in range(len(header))) + "|"]
    lines += ["| " + " | ".join(str(c) for c in row) + " |" for row in rows]
    return lines


def _g(value, spec=".4g") -> str:
    return "-" if value is None else format(value, spec)


def _width(pct) -> str:
    """A range's width in per cent: one decimal from 1 % up, two significant digits below
    (a width of 0.04 % must not print as 0.0)."""
    if pct is None:
        return "-"
    return format(pct, ".1f") if abs(pct) >= 1 else format(pct, ".2g")


def _paper_damping(document, cfg, mode, column):
    for p in (document.get("paper") or {}).get("damping", []):
        if p["configuration"] == cfg and int(p["mode"]) == mode:
            return float(p[column])
    return None


def _ranges_markdown(document: dict) -> list[str]:
    """The paragraphs of ``report.md`` on the sampled and certified ranges, their
    disagreements and the multistart."""
    out = []
    sampled = _sampled(document)
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
    info = _certified(document)
    if info:
        out += ["Certified outer range: min and max of each parameter over a convex (McCormick, linear "
                "programming) relaxation of the consistent set S below, with bound tightening and branching; every point of S "
                "lies inside. Each end is a safe Lagrangian bound evaluated from the LP solver's multipliers with "
                "its rounding accounted for; \"certified\" means the safe bound confirms the solver's optimum, "
                "\"no\" that the reported (still valid) range may be looser. " + info["definition"]
                + f" Outcome: {info['message']}; {info['passes']} tightening pass(es), {info['n_lps']} LPs, "
                f"{info['seconds']:.1f} s (root {info['root_seconds']:.1f} s).", ""]
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


def markdown_report(document: dict, images: list[tuple[str, str]] = (), notes: list[str] = ()) -> str:
    """``report.md``: parameters, frequencies, damping and solver tables, plots, notes."""
    paper = document.get("paper") or {}
    s = document["summary"]
    out = [f"# vibupdate report: {document['case']}", ""]
    status = (document.get("solver") or {}).get("status", "-")
    out += [f"Status: **{status}**. Mean frequency error {_g(s['mean_error_nominal_pct'], '.2f')} % (nominal) -> "
            f"{_g(s['mean_error_updated_pct'], '.2f')} % (updated); mean damping error "
            f"{_g(s['mean_damping_error_rayleigh_pct'], '.1f')} % (Rayleigh) and "
            f"{_g(s['mean_damping_error_pct'], '.1f')} % (Caughey).", ""]
    if paper.get("summary"):
        ps = paper["summary"]
        text = f"The paper reports {ps['mean_error_nominal_pct']} % -> {ps['mean_error_updated_pct']} % for frequencies"
        if "mean_damping_error_pct" in ps:
            text += (f" and {ps['mean_damping_error_rayleigh_pct']} % (Rayleigh) / {ps['mean_damping_error_pct']} % "
                     "(Caughey) for damping")
        out += [text + ".", ""]
    out += verification_markdown(document.get("solver") or {})
    # Parameters
    pp = {p["name"]: float(p["paper_updated"]) for p in paper.get("parameters", [])}
    truth = paper.get("truth") or {}
    ranges = (document.get("identifiability") or {}).get("ranges") or {}
    cert = _certified(document).get("ranges") or {}
    sampled = _sampled(document).get("ranges") or {}
    header = (["parameter", "unit", "nominal", "lower", "upper", "updated"] + (["paper"] if pp else [])
              + (["true", "error %"] if truth else []) + (["consistent range", "width %"] if ranges else [])
              + (["sampled range"] if sampled else []) + (["certified outer range", "certified"] if cert else []))
    rows = []
    for p in document["parameters"]:
        row = [p["name"], p["unit"], _g(p["nominal"]), _g(p["lower"]), _g(p["upper"]), _g(p["updated"])]
        row += [_g(pp.get(p["name"]))] if pp else []
        if truth:
            t = truth.get(p["name"])
            err = None if t in (None, 0) or p["updated"] is None else 100 * abs(p["updated"] - t) / abs(t)
            row += [_g(t), _g(err, ".2f")]
        if ranges:
            rg = ranges.get(p["name"], {})
            row += [f"[{_g(rg.get('lower'))}, {_g(rg.get('upper'))}]", _width(rg.get("width_pct"))]
        if sampled:
            sr = sampled.get(p["name"], {})
            row += [f"[{_g(sr.get('min'))}, {_g(sr.get('max'))}]"]
        if cert:
            c = cert.get(p["name"], {})
            row += [f"[{_g(c.get('lower'))}, {_g(c.get('upper'))}]", "yes" if c.get("certified") else "no"]
        rows.append(row)
    out += ["## Parameters", ""] + _md_table(header, rows) + [""]
    if ranges:
        # a width is None where its linear programs found no finite range (NaN in the results)
        determined = [n for n, rg in ranges.items() if rg["width_pct"] is not None and rg["width_pct"] <= 5.0]
        tol = 100 * (document["identifiability"].get("frequency_tolerance") or 0)
        window = document["identifiability"].get("frequency_windows") or f"{tol:.2g} %"
        out += ["Consistent range (linearized at the verified answer, two linear programs per parameter): the "
                "parameter sets within the bounds whose measured mode-shape entries stay in their intervals and "
                f"whose frequencies move from the answer's by at most {window} plus the answer's own misfit, "
                "to first order in the parameter change. It is not a certified enclosure: far from the answer the "
                "linearization may miss consistent sets (another local minimum, a strongly nonlinear direction). "
                "Its width, in per cent of the nominal (or reference) value, shows what the data determine near "
                "the answer. Within 5 %: " + (", ".join(determined) or "none") + ".", ""]
    out += _ranges_markdown(document)
    ident = document.get("identifiability")
    if ident:
        norms = ident["column_norm"]
        weak = [n for n, v in norms.items() if v < 1e-2 * max(norms.values())]
        out += [f"Sensitivity of the measured data (exact derivatives): rank {ident['rank']} of {len(norms)}, "
                f"condition {ident['condition']:.3g}. "
                + (f"Weakly determined by the data (sensitivity below 1 % of the largest): {', '.join(weak)}."
                   if weak else "Every parameter moves the measured data."), ""]
        combos = ident.get("undetermined_combinations") or []
        if combos:
            out += ["Combinations the data do not determine (exact null directions, normalized parameters): "
                    + "; ".join(f"`{c}`" for c in combos) + ".", ""]
        if ident.get("ranges_note"):
            out += [ident["ranges_note"] + ".", ""]
    # Frequencies
    header = ["cfg", "kind", "#", "measured [Hz]", "nominal [Hz]", "err %", "updated [Hz]", "err %"]
    if paper.get("frequencies"):
        header += ["paper updated [Hz]", "err %"]
    rows = []
    for r in document["frequencies"]:
        row = [r["configuration"], r["kind"], r["index"], _g(r["measured_hz"], ".2f"), _g(r["nominal_hz"], ".2f"),
               _g(r["error_nominal_pct"], ".2f"), _g(r["updated_hz"], ".2f"), _g(r["error_updated_pct"], ".2f")]
        if paper.get("frequencies"):
            p = _paper_frequency(document, r, "paper_updated_hz")
            row += [_g(p, ".2f"), _g(None if p is None else 100 * abs(p - r["measured_hz"]) / r["measured_hz"], ".2f")]
        rows.append(row)
    out += ["## Frequencies", ""] + _md_table(header, rows) + [""]
    # Damping
    if document.get("damping"):
        has_paper = bool(paper.get("damping"))
        header = ["cfg", "mode", "measured", "Rayleigh", "err %", "Caughey", "err %"]
        if has_paper:
            header += ["paper Rayleigh", "paper Caughey"]
        rows = []
        for d in document["damping"]:
            row = [d["configuration"], d["mode"], _g(d["measured"]), _g(d.get("rayleigh")),
                   _g(d.get("error_rayleigh_pct"), ".1f"), _g(d["identified"]), _g(d["error_pct"], ".1f")]
            if has_paper:
                row += [_g(_paper_damping(document, d["configuration"], d["mode"], "paper_rayleigh")),
                        _g(_paper_damping(document, d["configuration"], d["mode"], "paper_caughey"))]
            rows.append(row)
        out += ["## Damping", ""] + _md_table(header, rows) + [""]
        info = document.get("damping_model") or {}
        if info:
            out += [f"Caughey exponents Y = {info.get('exponents')}, coefficients beta = "
                    f"{[float(f'{b:.4g}') for b in info.get('beta', [])]}; Rayleigh baseline Y = [0, 1]. "
                    f"Weights: {info.get('weights_text', 'unweighted')}.", ""]
    # Solver
    solver = document.get("solver") or {}
    if solver:
        rows = [[f"{st['lambda']:.4f}", f"{st['objective']:.4e}", st["iterations"], st["status"],
                 "yes" if st.get("cold") else "no", f"{st['seconds']:.3f}"] for st in solver["steps"]]
        out += ["## Solver", "", f"{solver.get('message', '')}; objective {_g(solver['objective'], '.4e')}, "
                f"lower bound of the global minimum from the lambda = 0 relaxation "
                f"{_g(solver['relaxation_lower_bound'], '.4e')} ({LOWER_BOUND_NOTE}: the lifted variables can "
                f"absorb every mismatch); {solver['seconds']:.2f} s.", ""]
        size = document.get("problem_size") or {}
        if size:
            table1 = paper.get("problem_size")
            out += [f"Problem size: {size['n_parameters']} parameters, {size['n_mode_unknowns']} mode unknowns, "
                    f"{size['n_adjunct_unknowns']} adjunct unknowns, {size['n_lifted']} lifted scalars"
                    + (f" (paper Table 1: {table1['n_mode_unknowns']} / {table1['n_adjunct_unknowns']} / "
                       f"{table1['n_lifted']}; one entry of every vector is fixed here for normalization)"
                       if table1 else "") + ".", ""]
        out += _md_table(["lambda", "objective", "iterations", "status", "cold", "seconds"], rows) + [""]
    if notes:
        out += ["## Notes", ""] + [f"- {n}" for n in notes] + [""]
    if images:
        out += ["## Plots", ""] + [f"![{title}]({name})" for title, name in images] + [""]
    return "\n".join(out)
