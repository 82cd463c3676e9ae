"""Writers of the FE codes' export formats (`vibupdate.examples.fe_writers`, where the worked
examples use them) and the comparison of the tests of the readers."""

from __future__ import annotations

from pathlib import Path

import scipy.sparse as sp

from vibupdate.examples.fe_writers import (ANSYS, COMPONENT, dmig_text, grid_text, write_abaqus,  # noqa: F401
                                           write_dmig, write_hbmat)


def relative_difference(A, B) -> float:
    A, B = sp.csr_matrix(A), sp.csr_matrix(B)
    scale = abs(B).max() if B.nnz else 0.0
    return float(abs(A - B).max() / scale) if scale else float(abs(A).max() if A.nnz else 0.0)


def write_mapdl_hbmat(folder, K, M, dofs, rhs: bool = False, exponent: str = "D", per_line: int = 1,
                      triangle: str = "lower", digits: int = 15):
    """``K.matrix``, ``M.matrix`` and ``K.mapping`` in the layout MAPDL's ``HBMAT`` writes (the
    Harwell-Boeing layout of Duff, Grimes and Lewis, 1992, as the ANSYS command reference
    describes the command's output): a title line, ``RSA`` (one ``triangle``), ``(I14)`` pointers
    and row indices, values ``(d25.15)`` with ``exponent`` (``D`` or ``E``), ``per_line`` numbers
    a line (a repeat count ``(4I14)``, ``(1P,4D25.15)`` when more than one), and with ``rhs`` a
    fourth format, a fifth header line and a right-hand side of zeros."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    r = "" if per_line == 1 else str(per_line)
    for label, A in (("K", K), ("M", M)):
        A = sp.csc_matrix(sp.tril(A) if triangle == "lower" else sp.triu(A))
        A.sort_indices()
        n = A.shape[0]

        def block(numbers):
            return ["".join(numbers[k:k + per_line]) for k in range(0, len(numbers), per_line)]

        ptr = block([f"{p + 1:>14}" for p in A.indptr])
        ind = block([f"{i + 1:>14}" for i in A.indices])

        def real(v):
            mantissa, exp = f"{v:.{digits - 1}E}".split("E")
            sign = "-" if mantissa.startswith("-") else " "
            # MAPDL's 0.ddd form: the leading digit moved behind the point
            m = mantissa.lstrip("-").replace(".", "")
            e = int(exp) + 1 if float(v) != 0 else 0
            return f"{sign}0.{m}{exponent}{e:+03d}".rjust(digits + 10)

        val = block([real(float(v)) for v in A.data])
        rhs_lines = block([real(0.0) for _ in range(n)]) if rhs else []
        fmt = f"({r}I14)"
        vfmt = f"({r}d{digits + 10}.{digits})" if per_line == 1 else f"(1P,{r}D{digits + 10}.{digits})"
        counts = [len(ptr) + len(ind) + len(val) + len(rhs_lines), len(ptr), len(ind), len(val), len(rhs_lines)]
        head = [f"{label} matrix of the test frame (MAPDL HBMAT layout)".ljust(72) + label,
                "".join(f"{c:>14}" for c in counts),
                "RSA" + " " * 11 + "".join(f"{c:>14}" for c in (n, n, A.nnz, 0)),
                f"{fmt:<16}{fmt:<16}{vfmt:<20}" + (f"{vfmt:<20}" if rhs else "")]
        if rhs:
            head.append("F" + " " * 13 + f"{1:>14}{0:>14}")
        (folder / f"{label}.matrix").write_text("\n".join(head + ptr + ind + val + rhs_lines) + "\n")
    rows = ["Matrix Eqn   Node   DOF"] + [f"{k + 1:>10} {d.split(':')[0]:>8}   {ANSYS[d.split(':')[1]]}"
                                        for k, d in enumerate(dofs)]
    (folder / "K.mapping").write_text("\n".join(rows) + "\n")
    return folder


def write_abaqus_layout(folder, K, M, dofs, layout: str = "lower", zeros: bool = False, job: str = "job"):
    """``JOB_STIF1.mtx`` and ``JOB_MASS1.mtx`` in one of the layouts ``*MATRIX INPUT`` allows (the
    Abaqus Keywords Reference): the ``lower`` or ``upper`` triangle or the ``square`` matrix, every
    double in full; with ``zeros``, the zeros of the sparsity pattern too (every term of the 6 x 6
    blocks of node pairs that share an element, as an assembled pattern holds them)."""
    import numpy as np

    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    nodes = np.array([int(d.split(":")[0]) for d in dofs])
    comps = np.array([COMPONENT[d.split(":")[1]] for d in dofs])
    for label, A in (("STIF", K), ("MASS", M)):
        A = sp.csr_matrix(A)
        if zeros:
            # the node pairs coupled in K or M, expanded to all their DOF pairs
            coupled = sp.csr_matrix((abs(sp.csr_matrix(K)) + abs(sp.csr_matrix(M))) != 0).tocoo()
            _, node_index = np.unique(nodes, return_inverse=True)
            pairs = np.unique(np.c_[node_index[coupled.row], node_index[coupled.col]], axis=0)
            per_node = [np.flatnonzero(node_index == k) for k in range(node_index.max() + 1)]
            rows = np.concatenate([np.repeat(per_node[a], len(per_node[b])) for a, b in pairs])
            cols = np.concatenate([np.tile(per_node[b], len(per_node[a])) for a, b in pairs])
            values = np.asarray(A[rows, cols]).ravel()
        else:
            coo = A.tocoo()
            rows, cols, values = coo.row, coo.col, coo.data
        keep = {"lower": rows >= cols, "upper": rows <= cols, "square": np.ones(rows.size, bool)}[layout]
        order = np.lexsort((cols[keep], rows[keep]))
        r, c, v = rows[keep][order], cols[keep][order], values[keep][order]
        lines = [f"{nodes[i]},{comps[i]}, {nodes[j]},{comps[j]}, {x:.16E}" for i, j, x in zip(r, c, v)]
        (folder / f"{job}_{label}1.mtx").write_text("\n".join(lines) + "\n")
    return folder
