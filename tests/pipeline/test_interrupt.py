"""Ctrl-C and unwritable output: one line, exit 130 (or the command's own code), no traceback
from any process, a line that says what was kept, and a rerun that works.

Ctrl-C is sent at a deterministic point: the child process wraps a library function so that,
once it returns, the whole process group gets SIGINT, as a terminal does (the Dask workers
included); no test waits on a clock or polls a file."""

import json
import os
import subprocess
import sys

import pytest
from outputs_helpers import TINY_CASE, snapshot, write_case

from vibupdate.cli import main
from vibupdate.io.results import validate_document

#: A child that runs the command line with SIGINT sent to its process group after ``argv[1]``
#: (``module:function`` or ``module:Class.method``) first returns.
CHILD = r"""
import functools, importlib, os, signal, sys
signal.signal(signal.SIGINT, signal.default_int_handler)   # as at a terminal, even when started in the background
target, argv = sys.argv[1], sys.argv[2:]
module, _, name = target.partition(":")
owner_name, _, attribute = name.rpartition(".")
owner = importlib.import_module(module)
if owner_name:
    owner = getattr(owner, owner_name)
real = getattr(owner, attribute)

@functools.wraps(real)
def interrupting(*args, **kwargs):
    out = real(*args, **kwargs)
    os.killpg(0, signal.SIGINT)
    return out

setattr(owner, attribute, interrupting)
from vibupdate.cli import main
sys.argv = ["vibupdate", *argv]
sys.exit(main())
"""

pytestmark = pytest.mark.skipif(not sys.platform.startswith("linux"), reason="process groups and signals of Linux")


def _interrupted(cwd, after: str, *argv) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-c", CHILD, after, *map(str, argv)], cwd=cwd, capture_output=True,
                          text=True, start_new_session=True, timeout=600,
                          env=dict(os.environ, OMP_NUM_THREADS="1"))


def _one_line(done) -> str:
    assert done.returncode == 130, done.stderr[-3000:]
    assert "Traceback" not in done.stderr and "Traceback" not in done.stdout, done.stderr[-3000:]
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("vibupdate: interrupted; "), done.stderr[-3000:]
    return lines[0]


SWEPT = TINY_CASE.replace('case = "tiny"', 'case = "tiny"\nfrequency_tolerance = 0.01')


@pytest.mark.slow
def test_ctrl_c_in_a_sweep_says_which_rows_it_kept_and_a_rerun_needs_no_cleanup(tmp_path):
    write_case(tmp_path, SWEPT)
    sweep = ["sweep", "case.toml", "--samples", "4", "--workers", "2", "--out", "sw", "--no-walk"]
    # before any sample finished: nothing kept, the folder it made is gone
    line = _one_line(_interrupted(tmp_path, "vibupdate.study.engine:open_client", *sweep))
    assert line.endswith("no sample finished; nothing kept (sw/ removed)") and not (tmp_path / "sw").exists()
    # the same command again, stopped after its first row: the row is kept and named
    line = _one_line(_interrupted(tmp_path, "vibupdate.study.engine:Progress.tick", *sweep))
    assert "kept 1 sample row(s) in sw/samples.csv" in line and "--resume" in line
    assert len((tmp_path / "sw" / "samples.csv").read_text().splitlines()) == 2
    assert "samples.csv" in json.loads((tmp_path / "sw" / "vibupdate-manifest-sweep.json").read_text())["sha256"]


@pytest.mark.slow
def test_ctrl_c_in_a_batch_names_the_case_folders_it_kept(tmp_path):
    for name in ("one", "two", "three"):
        write_case(tmp_path / name, TINY_CASE.replace('case = "tiny"', f'case = "{name}"'))
    args = ["batch", "one/case.toml", "two/case.toml", "three/case.toml", "--workers", "1", "--out", "b"]
    line = _one_line(_interrupted(tmp_path, "vibupdate.study.engine:Progress.tick", *args))
    kept = sorted(p.name for p in (tmp_path / "b").iterdir())
    assert line.endswith("no summary written") and all(name in line for name in kept) and kept
    assert not [p for p in (tmp_path / "b").rglob("*") if ".vibupdate-partial-" in p.name]
    assert all((tmp_path / "b" / name / "results.json").is_file() for name in kept)


def test_ctrl_c_while_a_run_draws_its_plots_keeps_the_folder_and_the_rerun_needs_no_force(tmp_path, monkeypatch,
                                                                                           capsys):
    write_case(tmp_path)
    out = tmp_path / "res"
    out.mkdir()
    (out / "notes.txt").write_text("mine")
    before = snapshot(out)
    line = _one_line(_interrupted(tmp_path, "vibupdate.report.plots:plot_receptances", "run", "case.toml",
                                  "--out", "res", "--force"))
    assert line == "vibupdate: interrupted; nothing written (earlier results are untouched)"
    assert snapshot(out) == before and sorted(p.name for p in out.iterdir()) == ["notes.txt"]

    def stop(*args, **kwargs):
        raise KeyboardInterrupt

    import vibupdate.pipeline as pipeline

    monkeypatch.setattr(pipeline, "update", stop)
    assert main(["run", str(tmp_path / "case.toml"), "--out", str(tmp_path / "new")]) == 130
    assert capsys.readouterr().err == "vibupdate: interrupted; nothing written (earlier results are untouched)\n"
    assert not (tmp_path / "new").exists()
    monkeypatch.undo()
    assert main(["run", str(tmp_path / "case.toml"), "--out", str(tmp_path / "new")]) == 0


def test_ctrl_c_while_the_results_move_into_place_says_they_were_written(tmp_path):
    write_case(tmp_path)
    line = _one_line(_interrupted(tmp_path, "vibupdate.io.outputs:_move_into_place", "run", "case.toml",
                                  "--out", "res"))
    assert line == "vibupdate: interrupted; the results were written to res/ before it"
    assert (tmp_path / "res" / "results.json").is_file() and (tmp_path / "res" / "vibupdate-manifest-run.json").is_file()


def test_ctrl_c_in_the_uniqueness_search_writes_the_verified_answer_and_says_so(tmp_path):
    # SIGINT once the search has its weakest-direction starts: the answer is verified already,
    # so the run ends its search, writes the answer with what it sought, and exits 130
    write_case(tmp_path)
    line = _one_line(_interrupted(tmp_path, "vibupdate.inverse.search:Search.weak_starts", "run", "case.toml",
                                  "--out", "res"))
    assert line == ("vibupdate: interrupted; the uniqueness search was interrupted; the update's answer (verified) was "
                    "written to res/ without the damping fit and the range computation")
    solver = json.loads((tmp_path / "res" / "results.json").read_text())["solver"]
    assert solver["verdict"] == "verified", solver["verdict"]
    sought = solver["sought"]
    assert sought["interrupted"] is True and sought["uniqueness_searched"] is False
    assert sought["reason"].startswith("uniqueness search interrupted (Ctrl-C)")
    assert [s["purpose"] for s in sought["starts"]] == ["fit"]   # no uniqueness start finished
    assert any("uniqueness search interrupted" in w for w in json.loads(
        (tmp_path / "res" / "results.json").read_text())["warnings"])


def test_ctrl_c_in_the_ranges_writes_the_answer_without_them(tmp_path):
    # SIGINT once the linearized ranges are computed, before the run stores them: the stage is
    # interrupted, the stages after it are skipped, and the answer is written at once
    write_case(tmp_path)
    line = _one_line(_interrupted(tmp_path, "vibupdate.ranges.identifiability:parameter_ranges", "run", "case.toml",
                                  "--certify", "5", "--out", "res"))
    assert line == ("vibupdate: interrupted; the range computation was interrupted; the update's answer "
                    "(not_unique) was written to res/ without the certification")
    doc = json.loads((tmp_path / "res" / "results.json").read_text())
    validate_document(doc)
    assert doc["success"] is True and doc["solver"]["verdict"] == "not_unique"
    assert doc["identifiability"].get("ranges") is None and doc["identifiability"].get("certified") is None
    assert doc["identifiability"]["ranges_note"] == "consistent ranges not computed: the run was interrupted (Ctrl-C)"
    assert ("the range computation was interrupted (Ctrl-C): the results hold what was computed before it; not "
            "computed: the certification") in doc["warnings"]
    assert (tmp_path / "res" / "report.md").is_file()


def test_ctrl_c_in_a_diagnosis_writes_the_answer_that_did_not_verify_without_it(tmp_path):
    from test_diagnosis_run import write_case as biased_case

    biased_case(tmp_path, 0.10)
    line = _one_line(_interrupted(tmp_path, "vibupdate.inverse.diagnosis:rank", "run", "case.toml", "--out", "res"))
    assert line == ("vibupdate: interrupted; the diagnosis was interrupted; the update's answer (not_verified) was "
                    "written to res/")
    doc = json.loads((tmp_path / "res" / "results.json").read_text())
    validate_document(doc)
    assert doc["success"] is False and doc["diagnosis"] is None
    assert "the diagnosis was interrupted (Ctrl-C): the results hold what was computed before it" in doc["warnings"]


def test_ctrl_c_in_an_fe_example_removes_its_inputs_so_that_it_runs_again(tmp_path):
    line = _one_line(_interrupted(tmp_path, "vibupdate.io.fe_import:import_model", "example", "fe-nastran",
                                  "--out", "fe"))
    assert line.endswith("nothing of value was written (fe/ removed; run it again)")
    assert not (tmp_path / "fe").exists()


@pytest.mark.parametrize("stream", ["closed", "full"])
def test_an_unwritable_standard_output_costs_no_exit_code_and_no_traceback(tmp_path, stream):
    write_case(tmp_path)
    if stream == "closed":
        done = subprocess.run([sys.executable, "-m", "vibupdate", "check", "case.toml"], cwd=tmp_path,
                              stderr=subprocess.PIPE, text=True, timeout=300, preexec_fn=lambda: os.close(1))
    else:
        with open("/dev/full", "w") as full:
            done = subprocess.run([sys.executable, "-m", "vibupdate", "check", "case.toml"], cwd=tmp_path,
                                  stdout=full, stderr=subprocess.PIPE, text=True, timeout=300)
    assert done.returncode == 0 and done.stderr == "", done.stderr[-3000:]


def _stopped_on(prefix: str):
    """A ``progress`` that says its lines until one starts with ``prefix``, where Ctrl-C comes."""
    said: list[str] = []

    def say(line: str) -> None:
        if line.startswith(prefix):
            raise KeyboardInterrupt
        said.append(line)
    return say, said


def test_ctrl_c_while_the_ranges_are_said_keeps_them_and_skips_what_follows(tmp_path):
    # the range computation is done when its line is said: a Ctrl-C there keeps the ranges whole
    # (no note that they were not computed) and skips the certification after them
    from vibupdate import load_case, run_case
    from vibupdate.io.interrupted import Interrupted

    say, said = _stopped_on("parameters determined within 5 %")
    with pytest.raises(Interrupted) as stop:
        run_case(load_case(write_case(tmp_path)), tmp_path / "res", progress=say, certify=5.0)
    doc = json.loads((tmp_path / "res" / "results.json").read_text())
    validate_document(doc)
    assert doc["identifiability"]["ranges"] and "ranges_note" not in doc["identifiability"]
    assert str(stop.value) == ("the run was interrupted after the range computation; the update's answer (not_unique) "
                               f"was written to {tmp_path / 'res'}/ without the certification")
    assert doc["identifiability"].get("certified") is None and not any(s.startswith("certified") for s in said)
    assert ("the run was interrupted after the range computation (Ctrl-C): the results hold what was computed before "
            "it; not computed: the certification") in doc["warnings"]


def test_ctrl_c_while_the_damping_fit_is_said_keeps_it_and_leaves_the_ranges_out_saying_so(tmp_path):
    from vibupdate import load_case, run_case
    from vibupdate.io.interrupted import Interrupted

    say, said = _stopped_on("damping: Caughey")
    with pytest.raises(Interrupted) as stop:
        run_case(load_case(write_case(tmp_path)), tmp_path / "res", progress=say)
    doc = json.loads((tmp_path / "res" / "results.json").read_text())
    validate_document(doc)
    assert doc["damping_model"]["beta"] and doc["identifiability"].get("ranges") is None
    assert str(stop.value).startswith("the run was interrupted after the damping fit; ")
    assert str(stop.value).endswith(" without the range computation")
    assert doc["identifiability"]["ranges_note"] == "consistent ranges not computed: the run was interrupted (Ctrl-C)"
    assert not any(s.startswith("parameters determined") for s in said)
