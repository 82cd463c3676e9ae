"""OpenSees models: K and M of a model built by the user's openseespy code.

The user writes ``builder(p)``, a function of a dict of parameter values that builds the model
with the openseespy API (``model``, ``node``, ``fix``, ``element``, ``mass`` ...), as they would
before an eigen analysis. `export_from_builder` wipes the domain, calls it, and takes K and M
from the analysis system: a ``FullGeneral`` system, a ``Plain`` numberer and constraint handler,
and the ``GimmeMCK`` integrator with factors (0, 0, 1) for K and (1, 0, 0) for M; each
equation's node and DOF come from ``nodeDOFs`` (a constrained DOF has no equation, so it is not
in the export), the coordinates from ``nodeCoord``. Models of ``-ndf 6`` (3-D frames) and
``-ndf 3`` with ``-ndm 2`` (planar frames: ``x, y, rz``) are named; other DOFs are refused.

The API comes from the ``opensees`` package (``opensees.openseespy``), which ships its own
numerical libraries, or from ``openseespy`` where that wheel runs (it needs a system
``libblas.so.3``). Both are optional: ``pip install "vibupdate[fe]"``.
"""

from __future__ import annotations

import contextlib
import io

import numpy as np
import scipy.sparse as sp

from vibupdate.model.fe.export import FEExport

__all__ = ["export_from_builder", "openseespy"]


def openseespy():
    """The openseespy module: ``opensees.openseespy`` (the ``[fe]`` extra), else the
    ``openseespy`` package when it loads; `MissingExtra` naming ``[fe]`` otherwise."""
    from vibupdate._extras import MissingExtra, require

    try:
        require("fe", "an OpenSees model", modules=("opensees",))
        from opensees import openseespy as ops
        return ops
    except MissingExtra as missing:
        try:
            import openseespy.opensees as ops
            return ops
        except (ImportError, OSError):   # its wheel needs a system BLAS some machines lack
            raise missing from None


def _system_matrix(ops, factors) -> np.ndarray:
    ops.integrator("GimmeMCK", *factors)
    with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()):
        ops.analyze(1, 0.0)   # assembles the system; the (singular) M solve may complain: ignored
    A = np.asarray(ops.printA("-ret"), dtype=float)
    n = int(round(np.sqrt(A.size)))
    if n * n != A.size:
        raise ValueError(f"OpenSees returned a system of {A.size} terms, not a square matrix")
    return A.reshape(n, n)


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
    tags = [int(t) for t in ops.getNodeTags()]
    if not tags:
        raise ValueError(f"{name}: the OpenSees builder made no nodes")
    ops.wipeAnalysis()
    ops.constraints("Plain")
    ops.numberer("Plain")
    ops.system("FullGeneral")
    ops.algorithm("Linear")
    ops.analysis("Transient")
    K = _system_matrix(ops, (0.0, 0.0, 1.0))
    M = _system_matrix(ops, (1.0, 0.0, 0.0))
    n = K.shape[0]
    ndf = {len(ops.nodeDOFs(t)) for t in tags}
    ndm = len(ops.nodeCoord(tags[0]))
    if ndf == {6}:
        directions = ("x", "y", "z", "rx", "ry", "rz")
    elif ndf == {3} and ndm == 2:
        directions = ("x", "y", "rz")
    else:
        raise ValueError(f"{name}: nodes with {sorted(ndf)} DOFs in {ndm} dimensions; -ndf 6 in 3-D or -ndf 3 in "
                         "2-D is expected")
    equations = {}
    for t in tags:
        for d, eq in zip(directions, ops.nodeDOFs(t)):
            if eq >= 0:
                equations[int(eq)] = f"{t}:{d}"
    if sorted(equations) != list(range(n)):
        raise ValueError(f"{name}: OpenSees equation numbers are not 0..{n - 1}")
    nodes = {str(t): np.asarray(ops.nodeCoord(t), dtype=float) for t in tags}
    ops.wipe()
    # FullGeneral assembles in floating point: symmetrize the last bits
    K, M = 0.5 * (K + K.T), 0.5 * (M + M.T)
    return FEExport(sp.csr_matrix(K), sp.csr_matrix(M), tuple(equations[k] for k in range(n)), name, nodes)
