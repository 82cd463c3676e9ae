import os

import pytest

os.environ.setdefault("OMP_NUM_THREADS", "1")


def pytest_runtest_setup(item):
    """A test marked ``@pytest.mark.realdata(name)`` is skipped, naming the path looked at, when
    the real data set is not there (`helpers.realdata`)."""
    from helpers import realdata_skip_reason

    for mark in item.iter_markers("realdata"):
        reason = realdata_skip_reason(*mark.args)
        if reason:
            pytest.skip(reason)


#: Longest wait (s) for another worker's run of the same command (`run_once`).
ONCE_WAIT = 1800


def _run_once_in(root, command: str):
    """``(exit code, stdout, stderr, folder)`` of ``command`` (``vibupdate ...``) run in a fresh
    empty folder under ``root``: the first caller runs it and writes a record; a later one, in this
    process or another, waits for the record and reads the same folder."""
    import hashlib
    import json
    import shlex
    import subprocess
    import sys
    import time
    from pathlib import Path

    key = hashlib.sha256(command.encode()).hexdigest()[:16]
    folder, record = Path(root) / f"once-{key}", Path(root) / f"once-{key}.json"
    try:
        (Path(root) / f"once-{key}.lock").mkdir()   # atomic: one caller gets it
    except FileExistsError:
        waited = 0.0
        while not record.exists():
            if waited > ONCE_WAIT:
                raise TimeoutError(f"no record of {command!r} in {record} after {ONCE_WAIT} s")
            time.sleep(0.5)
            waited += 0.5
    else:
        folder.mkdir()
        done = {"code": None, "stdout": "", "stderr": f"the run of {command!r} raised"}
        try:
            src = str(Path(__file__).resolve().parents[1] / "src")
            env = dict(os.environ, PYTHONPATH=os.pathsep.join([src, *filter(None, [os.environ.get("PYTHONPATH")])]))
            ran = subprocess.run([sys.executable, "-m", "vibupdate", *shlex.split(command)[1:]], cwd=folder,
                                 capture_output=True, text=True, env=env, timeout=ONCE_WAIT)
            done = {"code": ran.returncode, "stdout": ran.stdout, "stderr": ran.stderr}
        finally:
            record.with_suffix(".part").write_text(json.dumps(done))
            record.with_suffix(".part").rename(record)
    done = json.loads(record.read_text())
    return done["code"], done["stdout"], done["stderr"], folder


def _once_root(tmp_path_factory):
    """The session's temporary folder shared by the xdist workers (each worker's own folder sits
    in it), or this process's when there are none."""
    base = tmp_path_factory.getbasetemp()
    return base.parent if os.environ.get("PYTEST_XDIST_WORKER") else base


@pytest.fixture(scope="session")
def run_once(tmp_path_factory):
    """``run_once(command)``: ``(exit code, stdout, stderr, folder)`` of a ``vibupdate`` command
    run once per test session, across worker processes, in a fresh empty folder. Only for a
    command that reads nothing but its arguments (``vibupdate example bar --out bar``), so that
    every caller would see the same run: test files checking one such long command share it."""
    root = _once_root(tmp_path_factory)
    return lambda command: _run_once_in(root, command)
