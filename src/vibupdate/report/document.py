"""Human-readable tables of a results document (`RunResult.as_document`): terminal and ``report.md``.

Every figure goes through `vibupdate.report.numbers.fmt`, so that no value (missing, NaN,
infinite, huge) can stop a table or the report."""

from __future__ import annotations

from vibupdate.report.numbers import finite, fmt
from vibupdate.report.ranges_text import (
    certified_info,
    multistart_text,
    range_notes,
    ranges_markdown,
    ranges_table_text,
    sampled_disagreements,
    sampled_info,
)

__all__ = ["failed_report", "diagnosis_text", "diagnosis_markdown", "matrix_files_markdown", "frequency_table_text", "parameter_table_text", "damping_table_text", "summary_text", "markdown_report",
           "ranges_table_text", "sampled_disagreements", "range_notes", "multistart_text"]

#: What the lambda = 0 optimum says: the lifted variables absorb every mismatch, so
#: it is ~0 on every example.
LOWER_BOUND_NOTE = "a valid bound of the global minimum, but it certifies nothing unless positive"


def _weak(norms: dict) -> list[str]:
    """Parameters whose sensitivity column norm is below 1 % of the largest finite one
    (a norm that is not finite is neither weak nor the largest)."""
    values = [v for v in norms.values() if finite(v)]
    if not values:
        return []
    top = max(values)
    return [n for n, v in norms.items() if finite(v) and v < 1e-2 * top]


def _condition(ident: dict, n_parameters: int) -> str:
    """The condition number of the sensitivity as text: ``inf`` where it is not finite
    (``null`` in ``results.json``) and the rank is below the number of parameters."""
    value = ident.get("condition")
    rank = ident.get("rank")
    if value is None and isinstance(rank, int) and rank < n_parameters:
        return "inf (rank deficient)"
    return fmt(value, ".3g", missing="not computed")


def _paper_frequency(document: dict, row: dict, column: str):
    paper = document.get("paper") or {}
    for p in paper.get("frequencies", []):
        if (p["configuration"], p["kind"], int(p["index"])) == (row["configuration"], row["kind"], row["index"]):
            return _number(p.get(column))
    return None


def _number(value):
    """A published value as a float; None where it is missing or not a number."""
    try:
        return None if value is None else float(value)
    except (TypeError, ValueError):
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
        line = (f"{r['configuration']:>4} {r['kind']:>13} {fmt(r['index'], '>2')} {fmt(r['measured_hz'], '9.2f')} "
                f"{fmt(r['nominal_hz'], '9.2f')} {fmt(r['error_nominal_pct'], '6.2f')} "
                f"{fmt(r['updated_hz'], '9.2f')} {fmt(r['error_updated_pct'], '6.2f')}")
        if has_paper:
            p = _paper_frequency(document, r, "paper_updated_hz")
            line += f" {fmt(p, '9.2f')} {fmt(_error_pct(p, r['measured_hz']), '6.2f')}"
        lines.append(line)
    return "\n".join(lines)


def parameter_table_text(document: dict) -> str:
    """Parameters nominal / bounds / updated, with the paper's updated value if known."""
    paper = {p["name"]: _number(p.get("paper_updated")) for p in (document.get("paper") or {}).get("parameters", [])}
    head = f"{'name':>8} {'unit':>7} {'nominal':>11} {'lower':>11} {'upper':>11} {'updated':>11}"
    if paper:
        head += f" {'paper':>11}"
    lines = ["Parameters", head]
    for p in document["parameters"]:
        line = (f"{p['name']:>8} {p['unit']:>7} {fmt(p['nominal'], '11.4g')} {fmt(p['lower'], '11.4g')} "
                f"{fmt(p['upper'], '11.4g')} "
                f"{fmt(p['updated'], '11.4g')}")
        if paper:
            line += f" {fmt(paper.get(p['name']), '11.4g')}"
        lines.append(line)
    ident = document.get("identifiability")
    if ident:
        weak = _weak(ident.get("column_norm") or {})
        lines.append(f"sensitivity rank {ident.get('rank')} of {len(document['parameters'])}, "
                     f"condition {_condition(ident, len(document['parameters']))}"
                     + (f"; weakly determined by the data: {', '.join(weak)}" if weak else ""))
        lines += [f"not determined by the data (exact null direction, normalized parameters): {c}"
                  for c in ident.get("undetermined_combinations") or []]
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
        line = (f"{d['configuration']:>4} {fmt(d['mode'], '>4')} {fmt(d['measured'], '9.4f')} "
                f"{fmt(d.get('rayleigh'), '9.4f')} {fmt(d.get('error_rayleigh_pct'), '6.1f')} "
                f"{fmt(d['identified'], '9.4f')} {fmt(d['error_pct'], '6.1f')}")
        if has_paper:
            pr = _paper_damping(document, d["configuration"], d["mode"], "paper_rayleigh")
            p = _paper_damping(document, d["configuration"], d["mode"], "paper_caughey")
            line += f" {fmt(pr, '9.4f')} {fmt(p, '9.4f')} {fmt(_error_pct(p, d['measured']), '6.1f')}"
        lines.append(line)
    return "\n".join(lines)


def summary_text(document: dict) -> str:
    """Mean errors, solver status and problem size in a few lines."""
    s, solver, size = document["summary"], document.get("solver") or {}, document.get("problem_size") or {}
    paper = (document.get("paper") or {}).get("summary", {})
    lines = [
        f"mean frequency error: nominal {fmt(s['mean_error_nominal_pct'], '.2f')} %, "
        f"updated {fmt(s['mean_error_updated_pct'], '.2f')} %"
        + (f" (paper: {fmt(paper.get('mean_error_nominal_pct'), 'g')} % -> "
           f"{fmt(paper.get('mean_error_updated_pct'), 'g')} %)" if paper else ""),
    ]
    if s.get("mean_damping_error_pct") is not None:
        lines.append(
            f"mean damping error: Rayleigh {fmt(s.get('mean_damping_error_rayleigh_pct'), '.1f')} %, Caughey "
            f"{fmt(s['mean_damping_error_pct'], '.1f')} %"
            + (f" (paper: {fmt(paper.get('mean_damping_error_rayleigh_pct'), 'g')} %, "
               f"{fmt(paper.get('mean_damping_error_pct'), 'g')} %)"
               if "mean_damping_error_pct" in paper else ""))
    if solver:
        lines.append(
            f"solver: {solver.get('status')}, objective {fmt(solver.get('objective'), '.4e')}, relaxation lower "
            f"bound {fmt(solver.get('relaxation_lower_bound'), '.4e')} ({LOWER_BOUND_NOTE}), "
            f"{len(solver.get('steps') or [])} solves, {fmt(solver.get('seconds'), '.2f')} s"
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
                   f"shape-interval penalties) took its objective from {fmt(pol['cost_start'], '.4e')} to "
                   f"{fmt(pol['cost'], '.4e')} in {pol['evaluations']} evaluations of the full model"
                   + (f" ({pol['rounds']} rounds on a reduced model, {pol.get('reduced_evaluations', 0)} evaluations "
                      "there; each round checked on the full model)" if pol.get("rounds") else "")
                   + " and was " + ("kept" if pol["kept"] else "not kept")
                   + (f" (stopped on its {pol['stopped_on']} limit: {pol['message']})"
                      if pol.get("stopped_on") in ("evaluations", "time") else ""))
    attempts = solver.get("attempts") or []
    if len(attempts) > 1:
        stages += (f"; the vector boxes were widened {len(attempts) - 1} time(s) because the relaxation proved that "
                   "they excluded every fit (lower bounds "
                   + ", ".join(fmt(a["relaxation_lower_bound"], ".3g") for a in attempts) + ")")
    verdict = ("**verified**: every check of the returned model against the data passed"
               + limited_text(checks) if solver.get("verified") else "**not verified**: the failed checks below say why")
    out += [stages + ". The answer is " + verdict + ".", ""]
    rows = [[c["name"], "pass" if c["passed"] else ("FAIL" if c["severity"] == "error" else "warning"),
             c["message"].replace("|", "/")] for c in checks]
    return out + _md_table(["check", "result", "finding"], rows) + [""]


def limited_text(checks) -> str:
    """What limited a verified answer, from the checks' ``limited_by``: ``""`` when no check
    says, else the clause the report and the terminal add to the verdict."""
    limits = [c.get("limited_by") for c in checks if c.get("limited_by")]
    if not limits:
        return ""
    if "model_form" in limits:
        names = ", ".join(c["name"] for c in checks if c.get("limited_by") == "model_form")
        return (f"; the model's form limits it: some data lie outside their measurement intervals and within the "
                f"model-form tolerances (check {names})")
    return "; the measurements limit it: every datum lies in its measurement interval"


#: Groups of the ranking shown in the terminal and the report (every one is in results.json).
RANKED_SHOWN = 5


def _trial_cells(t: dict) -> list[str]:
    """A screened group's figures: objective, frequency errors on the data kept, shape misses,
    the screened checks."""
    return [fmt(t.get("share"), ".2f"), fmt(t.get("objective"), ".3g"), fmt(t.get("mean_error_pct"), ".3g"),
            fmt(t.get("max_error_pct"), ".3g"), fmt(t.get("shape_misses"), "d"),
            "pass" if t.get("passed") else "fail: " + ", ".join(t.get("failed") or [])]


def diagnosis_text(document: dict) -> str:
    """The diagnosis for the terminal: the top groups and the best model without the top one
    beside the full one; empty without a diagnosis."""
    d = document.get("diagnosis")
    if not d:
        return ""
    lines = [f"Which data conflict (the answer failed {', '.join(d.get('failed') or [])}; {d.get('groups')} groups "
             f"of the data, each left out in turn; {fmt(d.get('seconds'), '.1f')} s)",
             f"full data: objective {fmt(d.get('objective'), '.3g')}, frequency error mean "
             f"{fmt(d.get('mean_error_pct'), '.3g')} % max {fmt(d.get('max_error_pct'), '.3g')} %"]
    for rank, t in enumerate((d.get("trials") or [])[:RANKED_SHOWN], start=1):
        share, obj, mean, top, misses, verdict = _trial_cells(t)
        lines.append(f"{rank}. without the {t['label']}: objective {obj}, frequency error mean {mean} % max {top} %, "
                     f"{misses} shape-interval misses, {verdict}")
    best = d.get("best")
    if best:
        lines.append(f"updated again without the {best['without_label']}: {best['status']}")
        full = {p["name"]: p.get("updated") for p in document["parameters"]}
        lines.append(f"{'name':>8} {'all data':>11} {'without':>11}")
        lines += [f"{n:>8} {fmt(full.get(n), '11.5g')} {fmt(v, '11.5g')}" for n, v in best["values"].items()]
    return "\n".join(lines)


def diagnosis_markdown(document: dict) -> list[str]:
    """The report's section "Which data conflict"; empty without a diagnosis."""
    d = document.get("diagnosis")
    if not d:
        return []
    trials = d.get("trials") or []
    out = ["## Which data conflict", "",
           f"The answer failed {', '.join(d.get('failed') or [])}: the model does not fit all the data. Each group "
           "of the data (each natural frequency with its shape, each antiresonance, each mode's shape, each shape "
           "DOF across all modes: a biased sensor or driving point corrupts that DOF in every mode) was left out "
           "in turn, the rest refitted from the answer (polish, the same options) and verified on the data kept "
           f"(the consistency check aside). {len(trials)} of {d.get('groups')} groups screened"
           + (f", {d.get('untried')} left untried on the limits" if d.get("untried") else "")
           + f", {fmt(d.get('seconds'), '.1f')} s in all. With all the data: objective {fmt(d.get('objective'), '.3g')}, "
           f"frequency error mean {fmt(d.get('mean_error_pct'), '.3g')} %, max {fmt(d.get('max_error_pct'), '.3g')} %. "
           "Ranked by the fit without the group (passing first, then the objective):", ""]
    rows = [[str(rank), t["label"]] + _trial_cells(t) for rank, t in enumerate(trials[:RANKED_SHOWN], start=1)]
    out += _md_table(["rank", "left out", "share of the misfit", "objective", "freq. err. mean %",
                      "freq. err. max %", "shape misses", "checks"], rows) + [""]
    if len(trials) > RANKED_SHOWN:
        out += [f"The other {len(trials) - RANKED_SHOWN} groups fit worse without them (all in `results.json`, "
                "`diagnosis.trials`).", ""]
    best = d.get("best")
    if best:
        failed = [c["name"] for c in best.get("checks") or [] if c.get("severity") == "error" and not c.get("passed")]
        out += [f"Updated again in full (the same options) without the {best['without_label']}: **{best['status']}**"
                + (f" (failed {', '.join(failed)})" if failed else ", every check passed on the data kept")
                + f"; frequency error on the data kept mean {fmt(best.get('mean_error_pct'), '.3g')} %, max "
                f"{fmt(best.get('max_error_pct'), '.3g')} %; {fmt(best.get('seconds'), '.2f')} s.", ""]
        full = {p["name"]: p for p in document["parameters"]}
        rows = [[n, full.get(n, {}).get("unit", ""), fmt(full.get(n, {}).get("updated")), fmt(v),
                 fmt(_error_pct(v, full.get(n, {}).get("updated")), ".3g")] for n, v in best["values"].items()]
        out += _md_table(["parameter", "unit", "all data (not verified)", "without the group", "differ %"], rows)
        out += [""]
    return out


def matrix_files_markdown(document: dict) -> list[str]:
    """One line naming the matrix files, when a model written is not verified."""
    files = document.get("matrix_files") or {}
    names = [f for per in files.values() for f in per.values()]
    if document.get("success") or not names:
        return []
    return ["Matrices written: " + ", ".join(f"`{n}`" for n in names) + ". The run's model is not verified, and its "
            "files say so (`not_verified_`); `without_worst_` files hold the model updated without the group of "
            "data that conflicts most (prefixed `not_verified_` too when that one is not verified either).", ""]


def _md_table(header: list[str], rows: list[list]) -> list[str]:
    lines = ["| " + " | ".join(header) + " |", "|" + "|".join("---:" if i else "---" for i in range(len(header))) + "|"]
    lines += ["| " + " | ".join(str(c) for c in row) + " |" for row in rows]
    return lines


def _error_pct(value, reference):
    """``100 |value - reference| / |reference|``; None where either is missing or not
    finite, or the reference is 0."""
    if not (finite(value) and finite(reference)) or reference == 0:
        return None
    return 100 * abs(value - reference) / abs(reference)


def _width(pct) -> str:
    """A range's width in per cent: one decimal from 1 % up, two significant digits below
    (a width of 0.04 % must not print as 0.0)."""
    if not finite(pct):
        return fmt(pct)
    return fmt(pct, ".1f") if abs(pct) >= 1 else fmt(pct, ".2g")


def _paper_damping(document, cfg, mode, column):
    for p in (document.get("paper") or {}).get("damping", []):
        if p["configuration"] == cfg and int(p["mode"]) == mode:
            return _number(p.get(column))
    return None


def markdown_report(document: dict, images: list[tuple[str, str]] = (), notes: list[str] = ()) -> str:
    """``report.md``: parameters, frequencies, damping and solver tables, plots, notes."""
    paper = document.get("paper") or {}
    s = document["summary"]
    out = [f"# vibupdate report: {document['case']}", ""]
    status = (document.get("solver") or {}).get("status", "-")
    out += [f"Status: **{status}**. Mean frequency error {fmt(s['mean_error_nominal_pct'], '.2f')} % (nominal) -> "
            f"{fmt(s['mean_error_updated_pct'], '.2f')} % (updated); mean damping error "
            f"{fmt(s['mean_damping_error_rayleigh_pct'], '.1f')} % (Rayleigh) and "
            f"{fmt(s['mean_damping_error_pct'], '.1f')} % (Caughey).", ""]
    if paper.get("summary"):
        ps = paper["summary"]
        text = (f"The paper reports {fmt(ps.get('mean_error_nominal_pct'), 'g')} % -> "
                f"{fmt(ps.get('mean_error_updated_pct'), 'g')} % for frequencies")
        if "mean_damping_error_pct" in ps:
            text += (f" and {fmt(ps.get('mean_damping_error_rayleigh_pct'), 'g')} % (Rayleigh) / "
                     f"{fmt(ps.get('mean_damping_error_pct'), 'g')} % "
                     "(Caughey) for damping")
        out += [text + ".", ""]
    out += verification_markdown(document.get("solver") or {})
    out += matrix_files_markdown(document)
    out += diagnosis_markdown(document)
    from vibupdate.report.suggestion import run_section_markdown

    out += run_section_markdown(document)
    # Parameters
    pp = {p["name"]: _number(p.get("paper_updated")) for p in paper.get("parameters", [])}
    truth = paper.get("truth") or {}
    ranges = (document.get("identifiability") or {}).get("ranges") or {}
    cert = certified_info(document).get("ranges") or {}
    sampled = sampled_info(document).get("ranges") or {}
    header = (["parameter", "unit", "nominal", "lower", "upper", "updated"] + (["paper"] if pp else [])
              + (["true", "error %"] if truth else []) + (["consistent range", "width %"] if ranges else [])
              + (["sampled range"] if sampled else []) + (["certified outer range", "certified"] if cert else []))
    rows = []
    for p in document["parameters"]:
        row = [p["name"], p["unit"], fmt(p["nominal"]), fmt(p["lower"]), fmt(p["upper"]), fmt(p["updated"])]
        row += [fmt(pp.get(p["name"]))] if pp else []
        if truth:
            t = truth.get(p["name"])
            err = None if t in (None, 0) or p["updated"] is None else 100 * abs(p["updated"] - t) / abs(t)
            row += [fmt(t), fmt(err, ".2f")]
        if ranges:
            rg = ranges.get(p["name"], {})
            row += [f"[{fmt(rg.get('lower'))}, {fmt(rg.get('upper'))}]", _width(rg.get("width_pct"))]
        if sampled:
            sr = sampled.get(p["name"], {})
            row += [f"[{fmt(sr.get('min'))}, {fmt(sr.get('max'))}]"]
        if cert:
            c = cert.get(p["name"], {})
            row += [f"[{fmt(c.get('lower'))}, {fmt(c.get('upper'))}]", "yes" if c.get("certified") else "no"]
        rows.append(row)
    out += ["## Parameters", ""] + _md_table(header, rows) + [""]
    if ranges:
        # a width is None where its linear programs found no finite range (NaN in the results)
        determined = [n for n, rg in ranges.items() if finite(rg.get("width_pct")) and rg["width_pct"] <= 5.0]
        tol = 100 * (document["identifiability"].get("frequency_tolerance") or 0)
        window = document["identifiability"].get("frequency_windows") or f"{fmt(tol, '.2g')} %"
        out += ["Consistent range (linearized at the verified answer, two linear programs per parameter): the "
                "parameter sets within the bounds whose measured mode-shape entries stay in their intervals and "
                f"whose frequencies move from the answer's by at most {window} plus the answer's own misfit, "
                "to first order in the parameter change. It is not a certified enclosure: far from the answer the "
                "linearization may miss consistent sets (another local minimum, a strongly nonlinear direction). "
                "Its width, in per cent of the nominal (or reference) value, shows what the data determine near "
                "the answer. Within 5 %: " + (", ".join(determined) or "none") + ".", ""]
    out += ranges_markdown(document)
    ident = document.get("identifiability")
    if ident:
        norms = ident.get("column_norm") or {}
        weak = _weak(norms)
        n_parameters = len(document["parameters"])
        out += [f"Sensitivity of the measured data (exact derivatives): rank {ident.get('rank')} of {n_parameters}, "
                f"condition {_condition(ident, n_parameters)}. "
                + (f"Weakly determined by the data (sensitivity below 1 % of the largest): {', '.join(weak)}."
                   if weak else "Every parameter moves the measured data."), ""]
        combos = ident.get("undetermined_combinations") or []
        if combos:
            out += ["Combinations the data do not determine (exact null directions, normalized parameters): "
                    + "; ".join(f"`{c}`" for c in combos) + ".", ""]
        if ident.get("minimum_change"):
            out += ["Minimum change: " + ident["minimum_change"] + ".", ""]
        others = ident.get("alternatives") or []
        if others:
            units = {p["name"]: p.get("unit", "") for p in document["parameters"]}
            out += [f"Not unique: {len(others)} other answer(s) fit the data about as well and pass every check; "
                    "the data do not single out the parameters in which they differ:", ""]
            for a in others:
                out += [f"- from the {a['start']} (objective {fmt(a['objective'], '.3g')}): "
                        + ", ".join(f"{n} = {fmt(a['values'][n], '.5g')} {units.get(n, '')}".rstrip()
                                    for n in a.get("differs", a["values"]))]
            out += [""]
        if ident.get("ranges_note"):
            out += [ident["ranges_note"] + ".", ""]
    # Frequencies
    header = ["cfg", "kind", "#", "measured [Hz]", "nominal [Hz]", "err %", "updated [Hz]", "err %"]
    if paper.get("frequencies"):
        header += ["paper updated [Hz]", "err %"]
    rows = []
    for r in document["frequencies"]:
        row = [r["configuration"], r["kind"], r["index"], fmt(r["measured_hz"], ".2f"), fmt(r["nominal_hz"], ".2f"),
               fmt(r["error_nominal_pct"], ".2f"), fmt(r["updated_hz"], ".2f"), fmt(r["error_updated_pct"], ".2f")]
        if paper.get("frequencies"):
            p = _paper_frequency(document, r, "paper_updated_hz")
            row += [fmt(p, ".2f"), fmt(_error_pct(p, r["measured_hz"]), ".2f")]
        rows.append(row)
    out += ["## Frequencies", ""] + _md_table(header, rows) + [""]
    # Where the measured points sit on an imported FE mesh
    if document.get("sensors"):
        rows = [[s["sensor"], s["dof"], "+" if s["sign"] > 0 else "-", fmt(s["distance_m"], ".3g")]
                for s in document["sensors"]]
        out += ["## Measured points on the mesh", "",
                "Each sensor measures one DOF of the model (node:direction); a sensor pointing along the "
                "negative axis reads the DOF with sign -; distance from the sensor's given position to the node, m.",
                ""] + _md_table(["sensor", "DOF", "sign", "distance (m)"], rows) + [""]
    # Damping
    if document.get("damping"):
        has_paper = bool(paper.get("damping"))
        header = ["cfg", "mode", "measured", "Rayleigh", "err %", "Caughey", "err %"]
        if has_paper:
            header += ["paper Rayleigh", "paper Caughey"]
        rows = []
        for d in document["damping"]:
            row = [d["configuration"], d["mode"], fmt(d["measured"]), fmt(d.get("rayleigh")),
                   fmt(d.get("error_rayleigh_pct"), ".1f"), fmt(d["identified"]), fmt(d["error_pct"], ".1f")]
            if has_paper:
                row += [fmt(_paper_damping(document, d["configuration"], d["mode"], "paper_rayleigh")),
                        fmt(_paper_damping(document, d["configuration"], d["mode"], "paper_caughey"))]
            rows.append(row)
        out += ["## Damping", ""] + _md_table(header, rows) + [""]
        info = document.get("damping_model") or {}
        if info:
            out += [f"Caughey exponents Y = [{', '.join(fmt(y, 'g') for y in info.get('exponents') or [])}], coefficients beta = "
                    f"[{', '.join(fmt(b) for b in info.get('beta') or [])}]; Rayleigh baseline Y = [0, 1]. "
                    f"Weights: {info.get('weights_text', 'unweighted')}.", ""]
    # Solver
    solver = document.get("solver") or {}
    if solver:
        rows = [[fmt(st.get("lambda"), ".4f"), fmt(st.get("objective"), ".4e"), fmt(st.get("iterations"), "d"),
                 st.get("status"), "yes" if st.get("cold") else "no", fmt(st.get("seconds"), ".3f")]
                for st in solver.get("steps") or []]
        out += ["## Solver", "", f"{solver.get('message', '')}; objective {fmt(solver.get('objective'), '.4e')}, "
                f"lower bound of the global minimum from the lambda = 0 relaxation "
                f"{fmt(solver.get('relaxation_lower_bound'), '.4e')} ({LOWER_BOUND_NOTE}: the lifted variables can "
                f"absorb every mismatch); {fmt(solver.get('seconds'), '.2f')} s.", ""]
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


def failed_report(case, status, reason: str, notes=()) -> str:
    """The short ``report.md`` written when the full report could not be: what failed and
    where the figures are. Plain text of its arguments only, so that it cannot fail itself."""
    lines = [f"# vibupdate report: {case}", "", f"Status: **{status}**.", "",
             f"The full report could not be written ({reason}). Every figure of the run is in `results.json` "
             "(and the updated matrices in the `.mtx` files); `vibupdate.io.results.load_results` reads it.", ""]
    if notes:
        lines += ["## Notes", ""] + [f"- {n}" for n in notes] + [""]
    return "\n".join(lines)
