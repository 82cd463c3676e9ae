"""Human-readable tables of a results document (terminal and Markdown)."""

from __future__ import annotations

__all__ = ["frequency_table_text"]


def _fmt(value, spec: str) -> str:
    if value is None:
        width = spec.split(".")[0]
        return "-".rjust(int(width) if width.isdigit() else 0)
    return format(value, spec)


def frequency_table_text(document: dict) -> str:
    """Measured / nominal / updated frequencies with errors, as fixed-width text."""
    head = f"{'cfg':>4} {'kind':>13} {'#':>2} {'measured':>9} {'nominal':>9} {'err%':>6} {'updated':>9} {'err%':>6}"
    lines = ["Frequencies [Hz]", head]
    for r in document["frequencies"]:
        lines.append(
            f"{r['configuration']:>4} {r['kind']:>13} {r['index']:>2} {r['measured_hz']:9.2f} "
            f"{_fmt(r['nominal_hz'], '9.2f')} {_fmt(r['error_nominal_pct'], '6.2f')} "
            f"{_fmt(r['updated_hz'], '9.2f')} {_fmt(r['error_updated_pct'], '6.2f')}"
        )
    s = document["summary"]
    lines.append(
        f"mean error: nominal {_fmt(s['mean_error_nominal_pct'], '.2f')} %, "
        f"updated {_fmt(s['mean_error_updated_pct'], '.2f')} %"
    )
    return "\n".join(lines)
