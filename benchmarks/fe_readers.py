"""Benchmark: the text readers of FE exports on one export of a 2,064-DOF frame, against peers.

Run:  PYTHONPATH=src:tests python benchmarks/fe_readers.py [--size 3 3 6] [--repeat 5]

Data: the space frame of `vibupdate.examples.frame3d` (default 3 x 3 bays, 6 storeys: 2,064
DOFs, 2,112 before the base is fixed) at its nominal values, K and M written once in each text
layout of the import's routes by the test suite's writers (``tests/fe_cases.py``, the layouts
of ``tests/model/test_fe_routes_large.py``): Abaqus ``*MATRIX OUTPUT`` as the lower triangle
and as the square with the zeros of the pattern, Nastran DMIG in free and large field, ANSYS
HBMAT as scipy writes it and as MAPDL writes it.

Measured, in this process, best of ``--repeat`` runs of CPU time (``time.process_time``): each
reader on its export (K and M files, the DOF map) and a peer reading the same files:
``numpy.loadtxt`` of the ``.mtx`` files (comma-separated; no DOF names, no checks, no digits
counted), ``scipy.io.hb_read`` of the HBMAT files scipy wrote, and for the other layouts no
peer (neither numpy nor scipy reads them). Printed per layout: lines, seconds, the ratio to
the peer, and microseconds per matrix term read.

A before/after comparison runs this script twice, once with the old ``src`` on the path.
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time
from pathlib import Path

os.environ.setdefault("OMP_NUM_THREADS", "1")

import numpy as np  # noqa: E402
import scipy.io  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
import fe_cases  # noqa: E402

from vibupdate.examples.frame3d import frame3d  # noqa: E402
from vibupdate.model.fe.abaqus import read_abaqus  # noqa: E402
from vibupdate.model.fe.ansys import read_hbmat  # noqa: E402
from vibupdate.model.fe.nastran import read_dmig  # noqa: E402

LAYOUTS = ("abaqus", "abaqus-square-zeros", "nastran", "nastran-large", "ansys", "ansys-mapdl")


def best(function, repeat: int) -> float:
    """Smallest CPU time of ``repeat`` calls, s."""
    times = []
    for _ in range(repeat):
        start = time.process_time()
        function()
        times.append(time.process_time() - start)
    return min(times)


def readers(layout: str, where: Path):
    """(the reader, the peer or None, the files) of one export."""
    if layout.startswith("abaqus"):
        files = (where / "job_STIF1.mtx", where / "job_MASS1.mtx")
        return (lambda: read_abaqus(*files),
                lambda: [np.loadtxt(f, delimiter=",", comments="*") for f in files], files)
    if layout.startswith("nastran"):
        path = where.with_suffix(".pch")
        return (lambda: read_dmig(path)), None, (path,)
    files = (where / "K.matrix", where / "M.matrix", where / "K.mapping")
    peer = (lambda: [scipy.io.hb_read(str(f)) for f in files[:2]]) if layout == "ansys" else None
    return (lambda: read_hbmat(*files)), peer, files


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--size", type=int, nargs=3, default=(3, 3, 6))
    parser.add_argument("--repeat", type=int, default=5)
    args = parser.parse_args()
    frame = frame3d(*args.size)
    print(f"frame {tuple(args.size)}: {len(frame.dofs)} DOFs; best of {args.repeat} (CPU s, OMP_NUM_THREADS="
          f"{os.environ.get('OMP_NUM_THREADS')})")
    print(f"{'layout':<22} {'lines':>8} {'terms':>8} {'reader s':>9} {'peer s':>8} {'ratio':>7} {'us/term':>8}")
    with tempfile.TemporaryDirectory() as tmp:
        for layout in LAYOUTS:
            where = Path(tmp) / layout
            fe_cases.write_export(layout, where, frame, {})
            read, peer, files = readers(layout, where)
            export = read()
            terms = export.K.nnz + export.M.nnz
            lines = sum(len(Path(f).read_bytes().splitlines()) for f in files)
            mine = best(read, args.repeat)
            theirs = best(peer, args.repeat) if peer else float("nan")
            print(f"{layout:<22} {lines:>8} {terms:>8} {mine:>9.3f} {theirs:>8.3f} {mine / theirs:>7.1f} "
                  f"{1e6 * mine / terms:>8.1f}")


if __name__ == "__main__":
    main()
