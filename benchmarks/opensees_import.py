"""OpenSees import: K and M from probe motions against the dense ``printA`` route.

Run:  python benchmarks/opensees_import.py [--sizes 3,3,4 6,6,10 10,10,18] [--dense-up-to 2000]

The model is the space frame of `vibupdate.examples.frame3d` built with the openseespy API
(`vibupdate.examples.frame3d_opensees.build_frame`: ``elasticBeamColumn`` columns and beams,
each member split in two, zeroLength base springs, lumped floor masses), at ``bays_x, bays_y,
storeys``:

    3,3,4: 1,392 DOFs;  6,6,10: 11,067 DOFs;  10,10,18: 50,259 DOFs.

Times are wall (``s``) and the process's CPU time (``CPU s``, OpenSees runs in the process):
on a shared machine the wall time grows with the load, which the output gives.

Each size runs in its own process (its peak resident memory, ``ru_maxrss``, is its own; it
includes OpenSees's C++ memory, which tracemalloc does not see):

* ``probe, one build``: `export_from_builder` at the nominal values;
* ``import, 8 builds``: `vibupdate.io.fe_import.read_import` of an import file with the five
  parameters of the example and a second step on E_col and m_floor (1 + 5 + 2 = 8 builds),
  the whole import (affine check, sensors) as ``vibupdate import`` does it;
* ``dense, one build`` (sizes up to ``--dense-up-to`` DOFs): the route before, a
  ``FullGeneral`` system, ``GimmeMCK``, ``printA -ret`` parsed by the API, twice per build;
  its matrices are compared with the probes' (largest difference relative to the largest
  entry).

The frame's own generator (`frame3d`, which the builder calls for its geometry, cached per
process) is timed apart as ``builder warm-up``: it is the user's code, not the import.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

os.environ.setdefault("OMP_NUM_THREADS", "1")

PARAMETERS = (("E_col", 210e9, 0.1, True), ("E_beam", 200e9, 0.1, False), ("rho_col", 7850.0, 0.1, False),
              ("m_floor", 400.0, 0.1, True), ("k_base", 4e7, 0.1, False))


def dense_export(builder, values):
    """The route before: two dense systems through ``printA -ret`` (the API's own parse)."""
    import numpy as np
    import scipy.sparse as sp

    from vibupdate.model.fe.opensees import openseespy

    ops = openseespy()
    ops.wipe()
    builder(dict(values))
    ops.wipeAnalysis()
    for command in (("constraints", "Plain"), ("numberer", "Plain"), ("system", "FullGeneral"),
                    ("algorithm", "Linear"), ("analysis", "Transient")):
        getattr(ops, command[0])(command[1])
    out = []
    for factors in ((0.0, 0.0, 1.0), (1.0, 0.0, 0.0)):
        ops.integrator("GimmeMCK", *factors)
        ops.analyze(1, 0.0)
        A = np.asarray(ops.printA("-ret"), dtype=float)
        n = int(round(np.sqrt(A.size)))
        out.append(A.reshape(n, n))
    names = ("x", "y", "z", "rx", "ry", "rz")
    dofs = {}
    for t in ops.getNodeTags():
        for d, eq in zip(names, ops.nodeDOFs(t)):
            if eq >= 0:
                dofs[int(eq)] = f"{t}:{d}"
    ops.wipe()
    K, M = out
    return sp.csr_matrix(0.5 * (K + K.T)), sp.csr_matrix(0.5 * (M + M.T)), [dofs[k] for k in range(len(dofs))]


def one_size(size: tuple, dense_up_to: int) -> dict:
    """Measurements of one frame size (run in a child process)."""
    from vibupdate.examples.frame3d import frame3d
    from vibupdate.examples.frame3d_opensees import build_frame
    from vibupdate.io.fe_import import read_import
    from vibupdate.model.fe.opensees import export_from_builder, openseespy

    openseespy()
    out = {"size": list(size)}
    t = time.perf_counter()
    frame3d(*size)
    out["builder warm-up s"] = time.perf_counter() - t
    build = lambda p: build_frame(p, size)   # noqa: E731
    t, cpu = time.perf_counter(), time.process_time()
    probe = export_from_builder(build, {})
    out["probe, one build s"] = time.perf_counter() - t
    out["probe, one build CPU s"] = time.process_time() - cpu
    out["dofs"] = len(probe.dofs)
    out["K nnz"] = int(probe.K.nnz)
    with tempfile.TemporaryDirectory() as folder:
        folder = Path(folder)
        (folder / "frame_ops.py").write_text("from vibupdate.examples.frame3d_opensees import build_frame\n\n\n"
                                             f"def build(p):\n    build_frame(p, {tuple(size)!r})\n")
        lines = ['format = "opensees"', 'builder = "frame_ops.py:build"']
        for name, nominal, step, second in PARAMETERS:
            lines += ["[[parameter]]", f'name = "{name}"', f"nominal = {nominal!r}", f"lower = {0.5 * nominal!r}",
                      f"upper = {1.5 * nominal!r}", f"step = {step * nominal!r}"]
            if second:
                lines.append(f"step2 = {-step * nominal!r}")
        (folder / "import.toml").write_text("\n".join(lines) + "\n")
        t, cpu = time.perf_counter(), time.process_time()
        read_import(folder / "import.toml")
        out["import, 8 builds s"] = time.perf_counter() - t
        out["import, 8 builds CPU s"] = time.process_time() - cpu
    if len(probe.dofs) <= dense_up_to:
        t, cpu = time.perf_counter(), time.process_time()
        K, M, dofs = dense_export(build, {})
        out["dense, one build s"] = time.perf_counter() - t
        out["dense, one build CPU s"] = time.process_time() - cpu
        order = [probe.dofs.index(d) for d in dofs]
        for label, mine, theirs in (("K", probe.K, K), ("M", probe.M, M)):
            gap = abs(mine[order][:, order] - theirs).max()
            out[f"{label} difference (relative)"] = float(gap / abs(theirs).max())
        out["dense / probe, one build"] = out["dense, one build s"] / out["probe, one build s"]
    out["peak RSS MB"] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    out["load average (1 min) at the end"] = os.getloadavg()[0]
    return out


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", nargs="+", default=["3,3,4", "6,6,10", "10,10,18"])
    parser.add_argument("--dense-up-to", type=int, default=2000)
    parser.add_argument("--child", help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.child:
        size = tuple(int(x) for x in args.child.split(","))
        print(json.dumps(one_size(size, args.dense_up_to)))
        return 0
    for size in args.sizes:
        run = subprocess.run([sys.executable, __file__, "--child", size, "--dense-up-to", str(args.dense_up_to)],
                             capture_output=True, text=True, check=True)
        result = json.loads(run.stdout.strip().splitlines()[-1])
        print(json.dumps(result, indent=1), flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
