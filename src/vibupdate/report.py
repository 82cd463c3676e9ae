"""Human-readable tables of a results document (terminal)."""

from __future__ import annotations

__all__ = ["frequency_table_text", "parameter_table_text", "summary_text"]


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


def summary_text(document: dict) -> str:
    """Mean errors, solver status and problem size in a few lines."""
    s, solver, size = document["summary"], document.get("solver") or {}, document.get("problem_size") or {}
    paper = (document.get("paper") or {}).get("summary", {})
    lines = [
        f"mean frequency error: nominal {_fmt(s['mean_error_nominal_pct'], '.2f')} %, "
        f"updated {_fmt(s['mean_error_updated_pct'], '.2f')} %"
        + (f" (paper: {paper['mean_error_nominal_pct']} % -> {paper['mean_error_updated_pct']} %)" if paper else ""),
    ]
    if solver:
        lines.append(
            f"solver: {solver['status']}, objective {solver['objective']:.4e}, relaxation lower bound "
            f"{_fmt(solver['relaxation_lower_bound'], '.4e')}, {len(solver['steps'])} solves, {solver['seconds']:.2f} s"
        )
    if size:
        lines.append(
            f"problem size: {size['n_parameters']} parameters, {size['n_mode_unknowns']} mode unknowns, "
            f"{size['n_adjunct_unknowns']} adjunct unknowns, {size['n_lifted']} lifted scalars"
        )
    return "\n".join(lines)
