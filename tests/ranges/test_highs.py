"""HiGHS for the ranges' programs (`vibupdate.ranges.highs`): its banner kept off the terminal."""

import subprocess
import sys
import textwrap

SOLVE = """
    import numpy as np
    from vibupdate.ranges.highs import highs, solve
    h = highs(np.eye(2), -np.ones(2), np.ones(2), -np.ones(2), np.ones(2))
    sys.stderr.write("optimal %s %s\\n" % (solve(h, np.array([1.0, -1.0])), list(h.getSolution().col_value)))
"""


def _child(prelude: str):
    code = textwrap.dedent("import os, sys\n" + prelude) + textwrap.dedent(SOLVE)
    return subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)


def test_the_first_instance_writes_nothing_to_standard_output():
    """HiGHS writes a banner to file descriptor 1 when a process makes its first instance (it
    reached the terminal of `vibupdate run --certify`): a child process that builds and solves
    a program writes nothing to its standard output, and the program's optimum is right."""
    run = _child("")
    assert run.returncode == 0, run.stderr
    assert run.stdout == ""
    assert "optimal True [-1.0, 1.0]" in run.stderr


def test_a_process_without_standard_output_still_solves():
    """Constructed: a process whose descriptor 1 is closed (a service, a detached job): the banner
    has nowhere to go, and the first instance is made without redirecting it."""
    run = _child("os.close(1)\n")
    assert run.returncode == 0, run.stderr
    assert "optimal True [-1.0, 1.0]" in run.stderr
