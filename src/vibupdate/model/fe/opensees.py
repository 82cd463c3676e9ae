"""OpenSees models: K and M of a model built by the user's openseespy code, sparse.

The user writes ``builder(p)``, a function of a dict of parameter values that builds the model
with the openseespy API. `export_from_builder` wipes the domain, calls it, and reads K and M
column by column from the model's own forces, by probes of the nodes of one colour at a time
(`probe_colours`), after checking that each direction is linear about rest (`_check_linear`);
multi-point constraints are refused (docs/fe/opensees.md, "How K and M are read, and what is
refused"). Stiffness probes set and commit displacements and take one step of the ``GimmeMCK``
integrator on a ``Diagonal`` system, which updates the elements to the committed response
(``setNodeDisp`` alone does not). ``-ndf 6`` and planar ``-ndf 3 -ndm 2`` models are read. The
cost, ``ndf (c + 2)`` element updates for ``c`` colours: `benchmarks/RESULTS.md`, heading
"OpenSees import: probes against the dense printA".
"""

from __future__ import annotations

import json
import tempfile
from pathlib import Path

import numpy as np
import scipy.sparse as sp

from vibupdate.model.fe.export import SYMMETRY_TOL, FEExport


#: Probe motion (m or rad; m/s^2 or rad/s^2): a power of two, so dividing by it is exact, small
#: enough that a material linear up to a strain of a few 1e-5 is probed and checked (up to 30
#: probes' motion) in its linear range.
PROBE = 2.0 ** -20

# Tcl procedures: one interpreter call per node list or per probe instead of one per node.
_TCL = r"""
proc vu_flat {cmd tags} {set o {}; foreach t $tags {lappend o {*}[$cmd $t]}; return $o}
proc vu_count {cmd tags} {set o {}; foreach t $tags {lappend o [llength [$cmd $t]]}; return $o}
proc vu_probe_M {moved values d rows} {
    foreach t $moved v $values {setNodeAccel $t $d $v}
    reactions -dynamic
    set o [vu_flat nodeReaction $rows]
    foreach t $moved {setNodeAccel $t $d 0.0}
    return $o
}
proc vu_probe_K {moved values d rows} {
    foreach t $moved v $values {setNodeDisp $t $d $v -commit}
    domainChange
    set ok [analyze 1 0.0]
    if {$ok == 0} {reactions; set o [vu_flat nodeReaction $rows]} else {set o "failed $ok"}
    foreach t $moved {setNodeDisp $t $d 0.0 -commit}
    return $o
}
"""


def openseespy():
    """The openseespy API of the ``opensees`` package (the ``[fe]`` extra); `MissingExtra`
    naming ``[fe]`` otherwise. The route needs its Tcl interpreter (``eval``), which the
    ``openseespy`` wheel does not have."""
    from vibupdate.extras import require

    require("fe", "an OpenSees model", modules=("opensees",))
    from opensees import openseespy as ops
    return ops


def _ints(text) -> np.ndarray:
    return np.array(str(text).split(), dtype=np.int64)


def _floats(text) -> np.ndarray:
    return np.array(str(text).split(), dtype=float)


def probe_colours(adjacency: sp.spmatrix) -> np.ndarray:
    """Colours of the nodes such that two nodes of one colour are neither neighbours nor share
    a neighbour: greedy, in node order, on the square of the neighbour graph.

    Parameters
    ----------
    adjacency : sparse matrix, shape (N, N)
        Non-zero where two nodes share an element (the diagonal need not be set).

    Returns
    -------
    ndarray of int, shape (N,)
        Colour of each node, 0 .. c - 1.
    """
    N = adjacency.shape[0]
    A = (sp.csr_matrix(adjacency, dtype=bool) + sp.identity(N, dtype=bool, format="csr")).astype(np.int8)
    reach = sp.csr_matrix((A @ A) != 0)
    colour = np.full(N, -1, dtype=np.int64)
    for k in range(N):   # one pass over the nodes; the test of a colour is vectorized
        taken = colour[reach.indices[reach.indptr[k]:reach.indptr[k + 1]]]
        free = np.ones(taken.max() + 2, dtype=bool)
        free[taken[taken >= 0]] = False
        colour[k] = int(np.argmax(free))
    return colour


def _printed(ops) -> dict:
    """The ``patterns`` and ``constraints`` arrays of the model's JSON print (the interpreter has
    no command listing the load patterns; only these two arrays are parsed)."""
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "model.json"
        ops.eval(f"print -JSON -file {{{path}}}")
        text = path.read_text()
    out = {}
    for key in ("patterns", "constraints"):
        at = text.find(f'"{key}"')
        out[key] = json.JSONDecoder().raw_decode(text, text.index("[", at))[0] if at >= 0 else []
    return out


def _model(ops, name: str):
    """Nodes, their directions, the fixed DOFs and the neighbour graph of the built model."""
    tags = _ints(ops.eval("getNodeTags"))
    if tags.size == 0:
        raise ValueError(f"{name}: the OpenSees builder made no nodes")
    ops.eval(_TCL)
    printed = _printed(ops)
    for pattern in printed["patterns"]:   # their loads would add to every probe's forces
        ops.eval(f"remove loadPattern {int(pattern['name'])}")
    tag_list = "{" + " ".join(map(str, tags)) + "}"
    ndf = set(_ints(ops.eval(f"vu_count nodeDisp {tag_list}")).tolist())
    ndm = set(_ints(ops.eval(f"vu_count nodeCoord {tag_list}")).tolist())
    if ndf == {6} and ndm == {3}:
        directions = ("x", "y", "z", "rx", "ry", "rz")
    elif ndf == {3} and ndm == {2}:
        directions = ("x", "y", "rz")
    else:
        raise ValueError(f"{name}: nodes with {sorted(ndf)} DOFs in {sorted(ndm)} dimensions; -ndf 6 in 3-D or "
                         "-ndf 3 in 2-D is expected")
    tied = _ints(ops.eval("constrainedNodes"))
    if tied.size:
        retained = _ints(ops.eval("retainedNodes"))
        raise ValueError(f"{name}: node(s) {', '.join(map(str, tied[:5]))}{' ...' if tied.size > 5 else ''} are "
                         f"tied to node(s) {', '.join(map(str, retained[:5]))} by a multi-point constraint "
                         "(equalDOF, rigidLink or rigidDiaphragm), which this import does not eliminate; model the "
                         "tie with stiff elements instead")
    coords = _floats(ops.eval(f"vu_flat nodeCoord {tag_list}")).reshape(tags.size, next(iter(ndm)))
    index = {int(t): k for k, t in enumerate(tags)}
    nd = len(directions)
    free = np.ones((tags.size, nd), dtype=bool)
    # The fixed DOFs from the print's single-point constraints (``fix``; those of load patterns are
    # not listed), not from ``fixedDOFs``: in opensees 0.1.32 that command scans six entries of a
    # vector sized by the node's DOFs, so on a 2-D node it reads past the end and now and then
    # reports a DOF 6 (`benchmarks/RESULTS.md`, heading "The slow step: where its time goes, and
    # repeated runs removed").
    fixed = np.array([(c["node"], c["dof"]) for c in printed["constraints"]], dtype=np.int64).reshape(-1, 2)
    if fixed.size:
        if not (np.all(np.isin(fixed[:, 0], tags)) and np.all((fixed[:, 1] >= 1) & (fixed[:, 1] <= nd))):
            shown = " ".join(map(str, fixed.ravel()))[:200]
            raise ValueError(f"{name}: OpenSees printed fixed DOFs (node, DOF) {shown!r}, expected nodes of the model "
                             f"and DOFs 1 to {nd}")
        free[[index[int(t)] for t in fixed[:, 0]], fixed[:, 1] - 1] = False
    elements = _ints(ops.eval("getEleTags"))
    ele_list = "{" + " ".join(map(str, elements)) + "}"
    counts = _ints(ops.eval(f"vu_count eleNodes {ele_list}")) if elements.size else np.zeros(0, np.int64)
    ends = _ints(ops.eval(f"vu_flat eleNodes {ele_list}")) if elements.size else np.zeros(0, np.int64)
    lookup = np.searchsorted(np.sort(tags), ends)
    order = np.argsort(tags)
    incidence = sp.csr_matrix((np.ones(ends.size), (np.repeat(np.arange(elements.size), counts), order[lookup])),
                              shape=(elements.size, tags.size))
    adjacency = sp.csr_matrix(incidence.T @ incidence + sp.identity(tags.size, format="csr"))
    return tags, directions, coords, free, elements, incidence, adjacency


def _forces(ops, kind: str, tags: np.ndarray, moved: np.ndarray, values: np.ndarray, d: int, rows: np.ndarray,
            name: str) -> np.ndarray:
    """Forces at the DOFs of the nodes ``rows`` when DOF ``d`` of the nodes ``moved`` moves by
    ``values`` (accelerations for M, displacements for K), shape (len(rows) nd,)."""
    moved_list = "{" + " ".join(map(str, tags[moved])) + "}"
    value_list = "{" + " ".join(map(repr, values.tolist())) + "}"
    rows_list = "{" + " ".join(map(str, tags[rows])) + "}"
    got = ops.eval(f"vu_probe_{kind} {moved_list} {value_list} {d + 1} {rows_list}")
    if got.startswith("failed"):
        raise ValueError(f"{name}: OpenSees could not update the model to a probe displacement (DOF {d + 1} of "
                         f"node(s) {', '.join(map(str, tags[moved][:5]))} ...; analyze returned {got.split()[1]}): "
                         "a DOF with neither stiffness nor mass?")
    return _floats(got)


def _responses(ops, nd: int, colour: np.ndarray, tags: np.ndarray, free: np.ndarray, adjacency: sp.csr_matrix,
               kind: str, name: str) -> np.ndarray:
    """Forces per unit probe at the node DOFs next to the moved nodes, shape (c nd, N nd), row
    ``colour * nd + d`` (zero away from the moved nodes' neighbours, where no element carries a
    force)."""
    c = int(colour.max()) + 1
    out = np.zeros((c * nd, tags.size * nd))
    near = sp.csr_matrix(adjacency, dtype=bool)
    for col in range(c):
        for d in range(nd):
            moved = np.flatnonzero((colour == col) & free[:, d])
            if moved.size == 0:
                continue
            rows = np.flatnonzero(near @ ((colour == col) & free[:, d]))
            columns = (rows[:, None] * nd + np.arange(nd)).ravel()
            out[col * nd + d, columns] = _forces(ops, kind, tags, moved, np.full(moved.size, PROBE), d, rows,
                                                 name) / PROBE
    return out


def _check_linear(ops, nd: int, colour: np.ndarray, tags: np.ndarray, free: np.ndarray, elements: np.ndarray,
                  incidence: sp.csr_matrix, kind: str, name: str) -> None:
    """Refuse a model not linear about rest along each direction (docs/fe/opensees.md): DOF ``d``
    of every node moves by ``(1 + 2 colour) s`` and then by ``-2`` times that; the forces must
    be exactly ``-2`` times as large."""
    everywhere = np.arange(tags.size)
    bad = np.zeros(tags.size, dtype=bool)
    for d in range(nd):
        moved = np.flatnonzero(free[:, d])
        if moved.size == 0:
            continue
        values = PROBE * (1.0 + 2.0 * colour[moved])
        once = _forces(ops, kind, tags, moved, values, d, everywhere, name)
        twice = _forces(ops, kind, tags, moved, -2.0 * values, d, everywhere, name)
        bad |= np.any((twice != -2.0 * once).reshape(tags.size, nd), axis=1)
    if not bad.any():
        return
    nodes = tags[bad].tolist()
    hit = elements[(incidence @ bad.astype(float)) > 0].tolist()
    what = "displacements" if kind == "K" else "accelerations"
    raise ValueError(f"{name}: OpenSees forces are not linear in the probe {what} at node(s) "
                     f"{', '.join(map(str, nodes[:5]))}{' ...' if len(nodes) > 5 else ''} (elements "
                     f"{', '.join(map(str, hit[:5]))}{' ...' if len(hit) > 5 else ''}): a Corotational geometric "
                     "transformation, a PDelta transformation on an inclined member or a material that is not "
                     "linear from rest has a tangent the probes cannot read exactly; use Linear transformations "
                     "and elastic materials for the modal model")


def _assemble(R: np.ndarray, adjacency: sp.csr_matrix, colour: np.ndarray, keep: np.ndarray, nd: int) -> sp.csr_matrix:
    """The matrix from the probe forces ``R`` (shape (c nd, N nd)): entry (i, j) for node i next to
    node j is the force at i of the probe of j's colour and direction."""
    A = adjacency.tocoo()
    a, b = np.repeat(A.row, nd * nd), np.repeat(A.col, nd * nd)
    e = np.tile(np.repeat(np.arange(nd), nd), A.nnz)
    d = np.tile(np.arange(nd), nd * A.nnz)
    rows, cols = a * nd + e, b * nd + d
    values = R[colour[b] * nd + d, rows]
    position = np.full(keep.size, -1, dtype=np.int64)
    position[keep] = np.arange(int(keep.sum()))
    ok = keep[rows] & keep[cols] & (values != 0.0)
    n = int(keep.sum())
    return sp.csr_matrix((values[ok], (position[rows[ok]], position[cols[ok]])), shape=(n, n))


def export_from_builder(builder, values: dict, name: str = "builder") -> FEExport:
    """K and M of the OpenSees model ``builder(values)`` builds (module docstring).

    Parameters
    ----------
    builder : callable
        ``builder(p)`` with ``p`` a dict of parameter values; builds the model, returns nothing.
    values : dict of str to float
    name : str
        How messages name the builder.
    """
    ops = openseespy()
    ops.wipe()
    builder(dict(values))
    tags, directions, coords, free, elements, incidence, adjacency = _model(ops, name)
    nd = len(directions)
    colour = probe_colours(adjacency)
    ops.eval("wipeAnalysis; constraints Plain; numberer Plain; system Diagonal; algorithm Linear -factorOnce; "
             "analysis Transient; integrator GimmeMCK 1.0 0.0 1.0")
    keep = free.ravel()
    matrices = {}
    for kind in ("M", "K"):   # mass first: the elements are at rest until the first stiffness probe
        _check_linear(ops, nd, colour, tags, free, elements, incidence, kind, name)
        matrices[kind] = _assemble(_responses(ops, nd, colour, tags, free, adjacency, kind, name), adjacency,
                                   colour, keep, nd)
    ops.wipe()
    for kind, A in matrices.items():
        scale = abs(A).max() if A.nnz else 0.0
        gap = abs(A - A.T).max() if A.nnz else 0.0
        if gap > SYMMETRY_TOL * scale:
            raise ValueError(f"{name}: the {kind} read from OpenSees is not symmetric (largest |A - A^T| {gap:.3g} "
                             f"against largest entry {scale:.3g}); a symmetric matrix is expected")
        matrices[kind] = sp.csr_matrix(0.5 * (A + A.T))   # the two triangles differ in the last bits
    dofs = tuple(f"{t}:{d}" for t in tags for d in directions)
    kept = tuple(dof for dof, k in zip(dofs, keep) if k)
    nodes = {str(t): np.asarray(xyz, dtype=float) for t, xyz in zip(tags, coords)}
    return FEExport(matrices["K"], matrices["M"], kept, name, nodes)
