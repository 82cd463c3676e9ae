"""Nastran DMIG matrices (a punch file of ``PARAM,EXTOUT,DMIGPCH`` or any bulk data; what the
reader checks: docs/fe/nastran.md, "What the reader checks in a punch").

Read here, not through pyNastran: its current release (1.4.1) requires ``numpy < 2``; the
tests compare this reader with pyNastran 1.3.4, which the ``test`` extra installs.

Small, large (``DMIG*``, ``*`` continuations) and free field cards are read: a header card
``DMIG, NAME, 0, IFO, TIN, TOUT, POLAR, , NCOL`` and one card per column ``DMIG, NAME, GJ, CJ, ,
G1, C1, A1, B1, ...``. ``IFO = 6`` (symmetric) holds one triangle, mirrored; ``IFO = 1``
(square) must be symmetric; complex matrices (``TIN`` 3 or 4) are refused. ``GRID`` cards (basic
system) give the node coordinates. The punch holds the analysis set: the constrained DOFs are
already gone.
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np

from vibupdate.model.fe.export import (FEExport, digit_counts, dof_name, dof_order, existing_file, precision_of_digits,
                                       symmetric_from_entries)


_EXPONENT = re.compile(r"^([+-]?[0-9.]+)([+-][0-9]+)$")


def nastran_float(text: str) -> float:
    """A Nastran real: ``1.5+3``, ``-2.D-4``, ``7.E5``, ``0.25``."""
    t = text.strip().upper().replace("D", "E")
    m = _EXPONENT.match(t)
    if m:
        t = f"{m.group(1)}E{m.group(2)}"
    return float(t)


def _cards(path: Path):
    """``[line number, name, data fields, line of each data field]`` of each card, data fields
    being fields 2-9 of each line."""
    cards = []
    text = path.read_text(errors="replace").splitlines()
    for number, raw in enumerate(text, start=1):
        line = raw.split("$", 1)[0].rstrip()
        if not line.strip() or line.upper().startswith(("BEGIN", "ENDDATA", "CEND", "SOL ", "PARAM")):
            continue
        if "," in line:   # free field: fixed-field DMIG cards hold no commas
            fields = [f.strip() for f in line.split(",")]
            head, data = fields[0], (fields[1:9] + [""] * 8)[:8]
        elif line[:8].rstrip().endswith("*") or line.startswith("*"):
            head = line[:8].strip()
            data = [line[8 + 16 * k:24 + 16 * k].strip() for k in range(4)]
        else:
            head = line[:8].strip()
            data = [line[8 + 8 * k:16 + 8 * k].strip() for k in range(8)]
        if head and not head.startswith(("+", "*")):
            cards.append([number, head.rstrip("*").upper(), data, [number] * len(data)])
        elif cards:
            cards[-1][2] = cards[-1][2] + data
            cards[-1][3] = cards[-1][3] + [number] * len(data)
        else:
            raise ValueError(f"{path}: line {number} continues a card but no card starts before it")
    return cards


def read_dmig_matrices(path, cards=None) -> dict:
    """Every DMIG matrix of a bulk-data file: name -> ``(rows, cols, values, dofs, ifo,
    digits, lines, ncol)`` with the DOF names in the order met, the entries in that numbering
    (0-based), the matrix form, a `collections.Counter` of the significant digits of the values
    as written, the line of each entry and the header's NCOL (None when blank).

    Checked card by card: a column card without a term (a large-field card cut after its first
    line), a term without its value, and more DOFs than the header's NCOL are refused naming the
    line. ``cards``: the file's `_cards` when the caller has them already (the file is then not read
    again)."""
    path = existing_file(path, "Nastran file")
    out, forms, digits, ncols, headers = {}, {}, {}, {}, {}
    for number, head, data, lines in (_cards(path) if cards is None else cards):
        if head != "DMIG":
            continue
        where = f"{path}: line {number}"
        name = data[0].upper()
        try:
            if data[1] == "0":
                ifo, tin = int(data[2]), int(data[3])
                if tin not in (1, 2):
                    raise ValueError(f"{where}: DMIG {name} has TIN = {tin}; only real matrices (1 or 2) are read")
                if ifo not in (1, 6):
                    raise ValueError(f"{where}: DMIG {name} has IFO = {ifo}; a symmetric matrix (6) or a square "
                                     "one (1) is expected")
                if name in out:
                    raise ValueError(f"{where}: a second header card of DMIG {name} (the first at line "
                                     f"{headers[name]})")
                forms[name], headers[name] = ifo, number
                ncols[name] = int(data[7]) if len(data) > 7 and data[7] else None
                digits[name] = []
                out[name] = ([], [], [], {}, [])
                continue
            if name not in out:
                raise ValueError(f"{where}: column of DMIG {name} before its header card")
            rows, cols, values, index, at = out[name]
            col = index.setdefault(dof_name(int(data[1]), int(data[2] or 0)), len(index))
            terms, term_lines = data[4:], lines[4:]
            found = 0
            for k in range(0, len(terms) - 2, 4):
                g, c, a = terms[k:k + 3]
                if not g:
                    continue
                if not a:
                    raise ValueError(f"{path}: line {term_lines[k]}: DMIG {name} term at grid {g} component "
                                     f"{c or 0} has no value; is the card cut short?")
                row = index.setdefault(dof_name(int(g), int(c or 0)), len(index))
                rows.append(row)
                cols.append(col)
                values.append(nastran_float(a))
                at.append(term_lines[k])
                digits[name].append(a)
                found += 1
            if not found:
                raise ValueError(f"{where}: the column card of DMIG {name} at grid {data[1]} component "
                                 f"{data[2] or 0} holds no term (a column card lists at least one); is the file "
                                 "cut short?")
        except (ValueError, IndexError) as exc:
            if str(exc).startswith(str(path)):
                raise
            raise ValueError(f"{where}: cannot read DMIG {name}: {exc}") from None
    if not out:
        raise ValueError(f"Nastran file {str(path)!r} holds no DMIG matrix")
    for name, (_, _, _, index, _) in out.items():
        if ncols[name] is not None and len(index) > ncols[name]:
            raise ValueError(f"{path}: line {headers[name]}: the header of DMIG {name} declares NCOL = {ncols[name]} "
                             f"columns, but its cards name {len(index)} DOFs")
    return {name: (rows, cols, values, tuple(index), forms[name], digit_counts(digits[name]), at, ncols[name])
            for name, (rows, cols, values, index, at) in out.items()}


def read_dmig(path, stiffness: str = "KAAX", mass: str = "MAAX") -> FEExport:
    """Stiffness and mass DMIG matrices of a Nastran file as an `FEExport`; other DMIG
    matrices of the file are left out, said in the export's ``notes``.

    Parameters
    ----------
    path : path
        Punch or bulk-data file.
    stiffness, mass : str
        Names of the two DMIG matrices (default ``KAAX``, ``MAAX``, the punch's names).
    """
    path = existing_file(path, "Nastran file")
    cards = _cards(path)
    found = read_dmig_matrices(path, cards)
    for name in (stiffness, mass):
        if name.upper() not in found:
            raise ValueError(f"{path}: no DMIG matrix {name!r}; the file holds {', '.join(sorted(found))}")
    kr, kc, kv, kdofs, _, kdigits, klines, kncol = found[stiffness.upper()]
    mr, mc, mv, mdofs, _, mdigits, mlines, mncol = found[mass.upper()]
    # a DOF with terms in one matrix only still belongs to both: the union, by grid then direction
    order = sorted(set(kdofs) | set(mdofs), key=dof_order)
    for name, ncol in ((stiffness, kncol), (mass, mncol)):
        if ncol is not None and ncol != len(order):
            raise ValueError(f"{path}: the header of DMIG {name.upper()} declares NCOL = {ncol} columns, but "
                             f"{stiffness.upper()} and {mass.upper()} name {len(order)} DOFs; is the file cut short?")
    pos = {d: k for k, d in enumerate(order)}
    n = len(order)

    def remap(rows, cols, dofs):
        table = np.array([pos[d] for d in dofs], dtype=np.int64)
        return table[np.asarray(rows, dtype=np.int64)], table[np.asarray(cols, dtype=np.int64)]

    K = symmetric_from_entries(*remap(kr, kc, kdofs), kv, n, str(path), f"DMIG {stiffness}", order, klines)
    M = symmetric_from_entries(*remap(mr, mc, mdofs), mv, n, str(path), f"DMIG {mass}", order, mlines)
    others = sorted(set(found) - {stiffness.upper(), mass.upper()})
    notes = (f"{path}: DMIG matrices not read: {', '.join(others)} (only {stiffness.upper()} and {mass.upper()} "
             "are)",) if others else ()
    nodes = _grids(path, cards)
    _check_grids(path, nodes, order)
    return FEExport(K, M, tuple(order), str(path), nodes, precision_of_digits(kdigits + mdigits), notes)


def _check_grids(path: Path, nodes: dict, order) -> None:
    """A file that gives node coordinates (GRID cards) gives them for every grid point of its
    matrices (scalar points have none): else it was cut short, or put together from pieces,
    and a sensor placed by position would be put at another node. A ValueError names the
    file, its length and the grid points without a GRID card."""
    if not nodes:
        return
    grids = {d.split(":")[0] for d in order if not d.endswith(":s")}
    missing = sorted(grids - set(nodes), key=int)
    if missing:
        shown = ", ".join(missing[:6]) + (f" and {len(missing) - 6} more" if len(missing) > 6 else "")
        lines = len(path.read_text(errors="replace").splitlines())
        raise ValueError(f"{path}: its GRID cards give the coordinates of {len(grids) - len(missing)} of the "
                         f"{len(grids)} grid points of its matrices, not of {shown}; the file ends at line {lines}: "
                         "is it cut short? (a file with GRID cards needs one for every grid point of its matrices)")


def _grids(path: Path, cards) -> dict:
    """Coordinates (m) of the GRID cards (the file's `_cards`) in the basic system (``CP`` blank or 0)."""
    nodes = {}
    for number, head, data, _ in cards:
        if head != "GRID":
            continue
        if data[1] not in ("", "0"):
            raise ValueError(f"{path}: line {number}: GRID {data[0]} is in coordinate system {data[1]}; "
                             "only the basic system (CP blank or 0) is read")
        try:
            nodes[str(int(data[0]))] = np.array([nastran_float(v or "0.") for v in data[2:5]])
        except ValueError:
            raise ValueError(f"{path}: line {number}: cannot read GRID {data[:5]}") from None
    return nodes

