"""Which eigen-solves a piece of code runs: a diagnostic for "no repeated eigen-solves of the
same matrices within a run" (`benchmarks/eigen_solves.py`, `tests/test_solves.py`). A test
instrument: it patches the modules of the package while it runs, so it lives beside the tests,
not in the package.

`counting_solves` wraps the kernels' entry points for the duration of a ``with`` block (the
dense and sparse eigen-solves of a pencil ``(K, M)`` and of an adjunct pencil; a re-use of a
sparse solution from `vibupdate.modal.eigen` is not a solve and is not counted) and records,
per solve, what was solved (a hash of ``M`` and ``K``, and the DOF pair of an adjunct pencil)
and the stage in whose call stack it ran.
"""

from __future__ import annotations

import sys
import traceback
from contextlib import contextmanager
from dataclasses import dataclass

from vibupdate.modal.kept import content_key

__all__ = ["Solve", "counting_solves", "matrices_key"]


@dataclass(frozen=True)
class Solve:
    """One eigen-solve: ``kind`` ("modes" or "zeros"), ``key`` (`matrices_key` of ``M``, ``K``),
    ``pair`` (the adjunct's ``(r, c)``, empty for a pencil) and ``stage`` (the label of the
    first stage whose source file is in the call stack, ``default`` when none is)."""

    kind: str
    key: str
    pair: tuple
    stage: str


def matrices_key(M, K) -> str:
    """A hash of the values of ``M`` and ``K`` (dense or sparse, any storage order;
    `vibupdate.modal.kept.content_key`)."""
    return content_key(M, K)


@contextmanager
def counting_solves(stages, default: str = "other"):
    """Record the eigen-solves run inside the block.

    Parameters
    ----------
    stages : sequence of (str, str)
        ``(label, path part)``: a solve belongs to the first label whose path part (e.g.
        ``"inverse/polish.py"``) occurs in a file of its call stack.
    default : str
        The label of a solve no path part matches.

    Yields
    ------
    list of Solve
        Filled as the block runs.
    """
    from vibupdate.modal import eigen, sensitivities, zeros

    def stage_of(stack) -> str:
        files = [f.filename.replace("\\", "/") for f in stack]
        for label, part in stages:
            if any(part in f for f in files):
                return label
        return default

    log: list[Solve] = []
    points = ((eigen.dense_modes, "modes"), (eigen._solve_sparse_modes, "modes"),
              (zeros.dense_zeros, "zeros"), (zeros._sparse_zeros, "zeros"),
              (sensitivities.adjunct_eigenpairs, "zeros"))
    wrapped = {}
    depth = [0]   # an entry point called inside another (a dense adjunct solve) is one solve
    for original, kind in points:
        def counted(M, K, *args, _original=original, _kind=kind, **kwargs):
            if not depth[0]:
                pair = tuple(args[:2]) if _kind == "zeros" else ()
                log.append(Solve(_kind, matrices_key(M, K), pair, stage_of(traceback.extract_stack())))
            depth[0] += 1
            try:
                return _original(M, K, *args, **kwargs)
            finally:
                depth[0] -= 1

        wrapped[id(original)] = (original, counted)
    # every module that holds one of the entry points by name (``from ... import``) gets the wrapper
    patched = []
    for module in [m for n, m in list(sys.modules.items()) if n.startswith("vibupdate") and m is not None]:
        for attr, value in list(vars(module).items()):
            if id(value) in wrapped and wrapped[id(value)][0] is value:
                setattr(module, attr, wrapped[id(value)][1])
                patched.append((module, attr, value))
    try:
        yield log
    finally:
        for module, attr, value in patched:
            setattr(module, attr, value)
