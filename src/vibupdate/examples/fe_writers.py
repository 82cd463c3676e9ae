"""Writers of the FE codes' native export formats from known matrices: what Nastran (a DMIG
punch), ANSYS (``HBMAT`` files and their ``.mapping``) and Abaqus (``*MATRIX OUTPUT`` ``.mtx``
files) write for a model whose matrices are known exactly. The worked examples of
``vibupdate example fe-<code>`` write their export sets with them (no FE code is run), and the
tests of the readers in `vibupdate.model.fe` use them as fixtures."""

from __future__ import annotations

from pathlib import Path

import scipy.sparse as sp


#: vibupdate direction -> ANSYS DOF label, Nastran/Abaqus component.
ANSYS = {"x": "UX", "y": "UY", "z": "UZ", "rx": "ROTX", "ry": "ROTY", "rz": "ROTZ"}
COMPONENT = {"x": 1, "y": 2, "z": 3, "rx": 4, "ry": 5, "rz": 6}


def _split(name):
    node, d = name.split(":")
    return int(node), COMPONENT[d]


def _nastran_small(v: float) -> str:
    """A real in 8 characters, Nastran's implied exponent (``-1.2345+5``)."""
    if v == 0:
        return "0."
    for digits in range(7, -1, -1):
        mantissa, exp = f"{v:.{digits}E}".split("E")
        text = f"{mantissa.rstrip('0') if '.' in mantissa else mantissa}{int(exp):+d}"
        if len(text) <= 8:
            return text
    raise ValueError(f"{v!r} does not fit an 8-character Nastran field")


def _nastran_large(v: float) -> str:
    """A double in 16 characters with a D exponent (``-1.234567890D+05``)."""
    for digits in range(12, 0, -1):
        text = f"{v:.{digits}E}".replace("E", "D")
        if len(text) <= 16:
            return text
    raise ValueError(f"{v!r} does not fit a 16-character Nastran field")


def _columns(A, dofs):
    """(column DOF, [(row DOF, value)]) of the lower triangle, column by column."""
    L = sp.tril(sp.csc_matrix(A)).tocsc()
    for j in range(L.shape[1]):
        lo, hi = L.indptr[j], L.indptr[j + 1]
        terms = [(dofs[i], v) for i, v in zip(L.indices[lo:hi], L.data[lo:hi]) if v != 0]
        if terms:
            yield dofs[j], terms


def dmig_text(name: str, A, dofs, field: str = "free") -> str:
    """One symmetric DMIG matrix (``IFO = 6``, lower triangle) in ``small``, ``large`` or ``free`` field."""
    lines = []
    # fields per line, field width, continuation marker of the first and later lines
    per_line, width, marks, fmt = {"small": (8, 8, ("", ""), _nastran_small),
                                   "large": (4, 16, ("*", "*"), _nastran_large)}.get(field, (8, 0, None, repr))

    def card(first, data):
        out = []
        for k in range(0, max(len(data), 1), per_line):
            chunk = data[k:k + per_line]
            if marks is None:    # free field: comma separated
                out.append(",".join([first if k == 0 else ""] + chunk))
            else:
                head = first + marks[0] if k == 0 else marks[1]
                out.append(f"{head:<8}" + "".join(f"{c:>{width}}" for c in chunk))
        return out

    lines += card("DMIG", [name, "0", "6", "2", "0", "", "", ""])
    for col, terms in _columns(A, dofs):
        g, c = _split(col)
        data = [name, str(g), str(c), ""]
        for row, v in terms:
            gr, cr = _split(row)
            data += [str(gr), str(cr), fmt(float(v)), ""]
        lines += card("DMIG", data)
    return "\n".join(lines) + "\n"


def grid_text(nodes) -> str:
    """Free-field GRID cards (basic system) of ``nodes``: label -> (x, y, z), m."""
    return "".join(f"GRID,{label},,{x!r},{y!r},{z!r}\n" for label, (x, y, z) in nodes.items())


def write_dmig(path, K, M, dofs, field="free", nodes=None):
    """A punch file with ``KAAX`` and ``MAAX`` (and GRID cards of ``nodes``)."""
    text = ("$ punch written by vibupdate.examples.fe_writers\n" + dmig_text("KAAX", K, dofs, field)
            + dmig_text("MAAX", M, dofs, field))
    text += grid_text(nodes) if nodes else ""
    Path(path).write_text(text)
    return Path(path)


def write_hbmat(folder, K, M, dofs, symmetric=False):
    """``K.matrix``, ``M.matrix`` (Harwell-Boeing, via scipy) and ``K.mapping``; ``symmetric``
    writes one triangle as an ``RSA`` file."""
    import scipy.io

    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    for label, A in (("K", K), ("M", M)):
        A = sp.csc_matrix(sp.tril(A) if symmetric else A)
        path = folder / f"{label}.matrix"
        scipy.io.hb_write(str(path), A)
        if symmetric:
            lines = path.read_text().splitlines(keepends=True)
            lines[2] = "RSA" + lines[2][3:]
            path.write_text("".join(lines))
    rows = ["Matrix Eqn   Node   DOF"] + [f"{k + 1:>10} {d.split(':')[0]:>8}   {ANSYS[d.split(':')[1]]}"
                                        for k, d in enumerate(dofs)]
    (folder / "K.mapping").write_text("\n".join(rows) + "\n")
    return folder


def write_abaqus(folder, K, M, dofs, job="job", step=1):
    """``JOB_STIF<step>.mtx`` and ``JOB_MASS<step>.mtx``: lower triangle, row by row."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    for label, A in (("STIF", K), ("MASS", M)):
        L = sp.tril(sp.csr_matrix(A)).tocsr()
        out = []
        for i in range(L.shape[0]):
            n1, d1 = _split(dofs[i])
            for j, v in zip(L.indices[L.indptr[i]:L.indptr[i + 1]], L.data[L.indptr[i]:L.indptr[i + 1]]):
                n2, d2 = _split(dofs[j])
                out.append(f"{n1},{d1}, {n2},{d2}, {float(v):.17e}")
        (folder / f"{job}_{label}{step}.mtx").write_text("\n".join(out) + "\n")
    return folder
