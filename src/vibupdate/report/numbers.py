"""Numbers as text for reports, tables and plot titles: one formatter, `fmt`, that never
raises, so that no figure (missing, not finite, huge, not a number) can stop a report.
"""

from __future__ import annotations

import math
import numbers
import re


#: Text of a figure that was not computed (``None``).
MISSING = "-"
#: Text of a figure that is NaN.
NOT_A_NUMBER = "n/a"
#: A fixed-point figure at or above this magnitude is written in exponent form.
FIXED_LIMIT = 1e12

_SPEC = re.compile(r"^(?P<head>[^0-9.]*)(?P<width>\d+)?(?:,)?(?:\.(?P<precision>\d+))?(?P<kind>[a-zA-Z%]?)$")


def _pad(text: str, spec: str) -> str:
    """``text`` padded to the field width of ``spec``, aligned as it says (``>`` unless ``<`` or ``^``)."""
    match = _SPEC.match(spec)
    if not match or not match.group("width"):
        return text
    align = next((c for c in match.group("head") if c in "<>^="), ">")
    return format(text, f"{align if align in '<^' else '>'}{int(match.group('width'))}")


def fmt(value, spec: str = ".4g", missing: str = MISSING) -> str:
    """``value`` formatted with ``spec``, never raising.

    Parameters
    ----------
    value : object
        A number (Python, numpy), None, or anything else.
    spec : str
        A format specification such as ``"9.2f"`` or ``".3g"``.
    missing : str
        Text of None.

    Returns
    -------
    str
        ``format(value, spec)`` for a finite number that fits its field; ``missing`` for
        None, ``"n/a"`` for NaN, ``"inf"`` / ``"-inf"``, a fixed-point figure of magnitude
        `FIXED_LIMIT` or more in exponent form, an integer format of a non-integer in ``g``
        form, and ``str(value)`` for anything that is not a number; each padded to the width
        of ``spec``.
    """
    if value is None:
        return _pad(missing, spec)
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        return _pad(str(value), spec)
    try:
        number = float(value)
    except (TypeError, ValueError, OverflowError):
        return _pad(str(value), spec)
    if math.isnan(number):
        return _pad(NOT_A_NUMBER, spec)
    if math.isinf(number):
        return _pad("inf" if number > 0 else "-inf", spec)
    match = _SPEC.match(spec)
    kind = match.group("kind") if match else ""
    if kind in ("f", "F", "%") and abs(number) * (100 if kind == "%" else 1) >= FIXED_LIMIT:
        precision = match.group("precision")
        return _pad(format(number, f".{precision or 6}e") + ("%" if kind == "%" else ""), spec)
    if kind in ("d", "n", "x", "X", "o", "b", "c"):
        if number != int(number) or not isinstance(value, numbers.Integral):
            return _pad(format(number, "g"), spec)
        value = int(value)
    try:
        return format(value, spec)
    except (TypeError, ValueError):
        try:
            return _pad(format(number, "g"), spec)
        except (TypeError, ValueError):
            return _pad(str(value), spec)
