"""The command line and the README."""

import json
import re
from pathlib import Path

import pytest

from vibupdate.cli import main
from vibupdate.io.results import validate_document

ROOT = Path(__file__).resolve().parents[1]


def test_example_list(capsys):
    assert main(["example", "--list"]) == 0
    assert "cantilever" in capsys.readouterr().out


def test_unknown_example_is_a_clear_error(capsys, tmp_path):
    assert main(["example", "nothing", "--out", str(tmp_path)]) == 2
    assert "unknown example 'nothing'" in capsys.readouterr().err


def test_readme_opens_with_the_two_commands():
    text = (ROOT / "README.md").read_text()
    first_block = re.search(r"```(?:bash|sh)?\n(.*?)```", text, re.S).group(1)
    assert 'pip install . && vibupdate example cantilever' in first_block
    assert 'pip install ".[test]" && pytest' in first_block


def test_readme_python_example_prints_what_the_readme_claims(tmp_path, monkeypatch, capsys):
    """The README's Python block runs and prints an update that succeeded and reduced the mean
    frequency error, the seven parameters within their bounds, and a Caughey fit of the damping
    better than Rayleigh's (figures as measured: benchmarks/RESULTS.md, "Cantilever and frame:
    first stage, polish, verification and the competent classical fit")."""
    import vibupdate as vu
    from vibupdate.examples import cantilever

    monkeypatch.chdir(tmp_path)
    text = (ROOT / "README.md").read_text()
    blocks = re.findall(r"```python\n(.*?)```", text, re.S)
    assert len(blocks) == 1, "the README has one Python example"
    exec(compile(blocks[0], "README.md", "exec"), {})
    lines = capsys.readouterr().out.splitlines()
    assert len(lines) == 1 + 7 + 1, lines
    status, nominal, updated = re.fullmatch(r"(\S+) mean error ([\d.]+) % -> ([\d.]+) %", lines[0]).groups()
    assert status == str(vu.Status.SUCCESS)
    assert float(nominal) == pytest.approx(4.82, abs=0.005)    # measured 4.82 %
    assert float(updated) == pytest.approx(0.48, abs=0.005)    # measured 0.4766 %, printed 0.48
    parameters = cantilever.configurations()[0].model.parameters
    for line, p in zip(lines[1:8], parameters):
        name, value, unit = line.split()
        low, high = (float(f"{bound:.4g}") for bound in (p.lower, p.upper))   # as printed
        assert (name, unit) == (p.name, p.unit) and low <= float(value) <= high, line
    caughey, rayleigh = map(float, re.fullmatch(r"Caughey ([\d.]+) %, Rayleigh ([\d.]+) %", lines[8]).groups())
    assert caughey < rayleigh


@pytest.fixture(scope="module")
def cantilever_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("cli") / "run"
    import contextlib
    import io

    buffer = io.StringIO()
    with contextlib.redirect_stdout(buffer):
        code = main(["example", "cantilever", "--out", str(out)])
    return code, out, buffer.getvalue()


def test_example_cantilever_writes_results_json(cantilever_run):
    code, out, printed = cantilever_run
    assert code == 0
    doc = json.loads((out / "results.json").read_text())
    validate_document(doc)
    for key in ("case", "parameters", "frequencies", "damping", "summary", "problem_size", "solver"):
        assert key in doc
    rows = doc["frequencies"]
    assert len(rows) == 16
    assert {r["configuration"] for r in rows} == {"A", "B", "C", "D"}
    assert sorted({r["index"] for r in rows if r["kind"] == "natural"}) == [1, 2, 3]
    assert [r["index"] for r in rows if r["kind"] == "antiresonance"] == [1, 1, 1, 1]
    first = rows[0]
    assert first["measured_hz"] == pytest.approx(73.4)
    assert first["error_nominal_pct"] == pytest.approx(
        100 * abs(first["nominal_hz"] - 73.4) / 73.4)
    assert [p["name"] for p in doc["parameters"]] == ["E", "rho", "macc", "mlc", "klc", "Ep", "rho_p"]
    out = printed
    assert "\nFrequencies\n" in out and "paper updated (Table 5) [Hz]" in out and "lambda = 1.0000" in out
    assert "Damping ratios" in out
    assert doc["solver"]["status"] == "success"
    # measured 0.4766 %, the classical least-squares optimum of these data (benchmarks/RESULTS.md,
    # "Cantilever and frame: first stage, polish, verification and the competent classical fit";
    # the paper's Table 5 reports 0.6 % for its own solve), held to its printed digits
    assert doc["summary"]["mean_error_updated_pct"] == pytest.approx(0.4766, abs=5e-4)
    # the default path: the relaxation, then the direct jump to lambda = 1, every solve recorded.
    assert [s["lambda"] for s in doc["solver"]["steps"]] == pytest.approx([0.0, 1.0])
    assert set(doc["solver"]["steps"][0]) >= {"lambda", "objective", "iterations", "status", "seconds"}
    assert doc["solver"]["relaxation_lower_bound"] <= doc["solver"]["objective"]
    assert doc["problem_size"]["n_lifted"] == 552
    assert all(p["lower"] <= p["updated"] <= p["upper"] for p in doc["parameters"])


def test_damping_section_of_the_cantilever(cantilever_run):
    doc = json.loads((cantilever_run[1] / "results.json").read_text())
    assert len(doc["damping"]) == 12
    # measured 12.35 % (Caughey) and 21.46 % (Rayleigh), the figures of tests/damping/test_damping.py
    # (the paper's Table 7: 16.6 % for its Caughey fit), held to their printed digits
    assert doc["summary"]["mean_damping_error_pct"] == pytest.approx(12.35, abs=0.05)
    assert doc["summary"]["mean_damping_error_rayleigh_pct"] == pytest.approx(21.46, abs=0.05)
    assert doc["damping_model"]["exponents"] == [-1.5, -0.75, 0.0]


def test_report_renders_tables_and_plots(cantilever_run):
    out = cantilever_run[1]
    report = (out / "report.md").read_text()
    for title in ("## Parameters", "## Frequencies", "## Damping", "## Solver"):
        assert title in report
    images = re.findall(r"!\[[^\]]*\]\(([^)]+)\)", report)
    assert "frf.png" in images and "homotopy.png" not in images   # a path without steps: no plot
    for name in images:
        data = (out / name).read_bytes()
        assert data.startswith(b"\x89PNG\r\n\x1a\n") and len(data) > 1000
    assert "Relative weights 1/xi^2" in report
    # The verification checks and warnings of the result are in the report, as results.json has them.
    doc = json.loads((out / "results.json").read_text())
    assert doc["checks"] and "## Verification" in report
    assert all(c["name"] in report for c in doc["checks"])
    assert all(w in report for w in doc["warnings"])


def test_results_and_matrices_reload_and_reproduce_the_updated_frequencies(cantilever_run):
    import numpy as np
    import scipy.io

    from vibupdate import antiresonances, modes
    from vibupdate.io.results import load_results

    out = cantilever_run[1]
    run = load_results(out / "results.json")
    for name in "ABCD":
        M = scipy.io.mmread(str(out / f"M_{name}.mtx"))
        K = scipy.io.mmread(str(out / f"K_{name}.mtx"))
        C = scipy.io.mmread(str(out / f"C_{name}.mtx")).toarray()
        omega, Phi = modes(M, K, 3)
        rows = [r for r in run.frequencies if r.configuration == name]
        nat = [r.updated_hz for r in rows if r.kind == "natural"]
        np.testing.assert_allclose(omega / (2 * np.pi), nat, rtol=1e-9)
        z = antiresonances(M, K, 0, 4)  # y1 and y3 are DOFs 0 and 4 of the cantilever
        zhz = [r.updated_hz for r in rows if r.kind == "antiresonance"]
        assert np.min(np.abs(z / (2 * np.pi) - zhz[0])) < 1e-9 * zhz[0]
        ratios = np.diag(Phi.T @ C @ Phi) / (2 * omega)
        identified = [d.identified for d in run.damping if d.configuration == name]
        np.testing.assert_allclose(ratios, identified, rtol=1e-6)
    # Reloaded parameters rebuild the same model.
    from vibupdate.examples import cantilever

    values = [p.updated for p in run.parameters]
    model = cantilever.configurations()[0].model
    M, K = model.matrices_at(values)
    np.testing.assert_allclose(M.toarray(), scipy.io.mmread(str(out / "M_A.mtx")).toarray(), rtol=1e-12)


def test_a_failed_update_exits_non_zero_with_the_reason(tmp_path, capsys):
    from helpers import CASE_FILE_EXAMPLE as EXAMPLE

    case = tmp_path / "case.toml"
    # without the polish no further start can rescue the failed path (`update` restarts by polishing)
    case.write_text(EXAMPLE.replace("[solver]\nn_lambda = 10", "[polish]\nenabled = false\n\n"
                                    "[solver]\nn_lambda = 2\nmax_iter = 1\nmin_step = 0.5"))
    out = tmp_path / "out"
    assert main(["run", str(case), "--out", str(out)]) == 1
    assert "updating failed" in capsys.readouterr().err
    doc = json.loads((out / "results.json").read_text())
    validate_document(doc)
    assert doc["solver"]["status"] != "success" and doc["success"] is False


# --- exit codes and messages ---------------------------------------

BUILDER_CASE = """\
case = "built"

[model]
type = "builder"
builder = "model.py:build"

[[parameter]]
name = "k"
unit = "N/m"
nominal = 1000.0
lower = 500.0
upper = 2000.0

[[configuration]]
name = "A"
natural_hz = [5.0]
"""


@pytest.mark.parametrize("source, expected", [
    ("def build(p):\n    return 1 / 0\n", "ZeroDivisionError"),
    ("def build(p)\n    return None\n", "SyntaxError"),
    ("def build():\n    return None\n", "TypeError"),
    ("import vibupdate_no_such_module\n", "vibupdate_no_such_module"),
])
def test_a_broken_builder_is_bad_input_with_a_message_not_a_traceback(tmp_path, capsys, source, expected):
    (tmp_path / "model.py").write_text(source)
    case = tmp_path / "case.toml"
    case.write_text(BUILDER_CASE)
    for command in (["check", str(case)], ["run", str(case), "--out", str(tmp_path / "out")]):
        assert main(command) == 2
        err = capsys.readouterr().err
        assert err.startswith("vibupdate: error:") and expected in err and "Traceback" not in err, err
        assert str(case) in err or "model.builder" in err
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize("line, key", [("tol = -1e-8", "tol"), ("max_cpu_time = 0", "max_cpu_time"),
                                       ("max_iter = 0", "max_iter")])
def test_solver_options_out_of_range_are_bad_input(tmp_path, capsys, line, key):
    from outputs_helpers import TINY_CASE, write_case

    case = write_case(tmp_path, TINY_CASE.replace("[solver]\n", f"[solver]\n{line}\n"))
    assert main(["run", str(case), "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert key in err and "Traceback" not in err and err.count("\n") == 1
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize("option, value", [("--multistart", "5"), ("--frequency-tolerance", "-3")])
def test_a_sampling_option_without_samples_is_bad_input_not_ignored(tmp_path, capsys, option, value):
    """`run` options that only the sampled ranges read are refused without ``--samples``,
    naming the option, before anything is written (a user folder beside the case is kept)."""
    from outputs_helpers import TINY_CASE, write_case

    case = write_case(tmp_path, TINY_CASE)
    mine = tmp_path / "notes.txt"
    mine.write_text("mine")
    assert main(["run", str(case), option, value, "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert option in err and "--samples" in err and "Traceback" not in err and err.count("\n") == 1
    assert not (tmp_path / "out").exists() and mine.read_text() == "mine"


@pytest.mark.parametrize("old, new, named", [
    ("hz = 164.0447,", "hz = 1e-300,", "antiresonance frequency 1e-300 Hz"),
    ("hz = 164.0447,", "hz = 1e200,", "antiresonance frequency 1e+200 Hz"),
    ("natural_hz = [37.3397,", "natural_hz = [3.7e-7,", "natural frequency 3.7e-07 Hz")])
def test_a_frequency_outside_mechanical_vibration_is_bad_input(tmp_path, capsys, old, new, named):
    """A frequency whose square leaves double precision ended a run as an internal error after
    pages of overflow warnings; now it is refused on reading, naming the value and the range."""
    from outputs_helpers import TINY_CASE, write_case

    case = write_case(tmp_path, TINY_CASE.replace(old, new))
    assert main(["run", str(case), "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert named in err and "1e-06 to 1e+12 Hz" in err and "configuration 'A'" in err, err
    assert "Traceback" not in err and "Warning" not in err and err.count("\n") == 1
    assert not (tmp_path / "out").exists()


def test_the_range_of_measured_frequencies_holds_its_ends():
    from vibupdate import Antiresonance, NaturalFrequency

    assert NaturalFrequency.from_hz(1e-6).freq_hz == pytest.approx(1e-6)
    assert Antiresonance.from_hz(1e12, "y1", "y1").freq_hz == pytest.approx(1e12)
    with pytest.raises(ValueError, match=r"natural frequency 9e-07 Hz .* outside 1e-06 to 1e\+12 Hz"):
        NaturalFrequency.from_hz(9e-7)


def test_an_internal_error_is_one_line_and_debug_prints_the_traceback(tmp_path, monkeypatch, capsys):
    from outputs_helpers import write_case

    import vibupdate.pipeline

    def broken(*args, **kwargs):
        raise ZeroDivisionError("float division by zero")

    monkeypatch.setattr(vibupdate.pipeline, "update", broken)
    case = write_case(tmp_path)
    assert main(["run", str(case), "--out", str(tmp_path / "out")]) == 3
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "internal error" in err and "ZeroDivisionError" in err and "--debug" in err
    assert main(["--debug", "run", str(case), "--out", str(tmp_path / "out")]) == 3
    err = capsys.readouterr().err
    assert "Traceback (most recent call last)" in err and "broken" in err
    assert not (tmp_path / "out").exists()


def test_python_dash_m_vibupdate_runs_the_command_line(tmp_path):
    import os
    import subprocess
    import sys

    from vibupdate import __version__

    done = subprocess.run([sys.executable, "-m", "vibupdate", "--version"], capture_output=True, text=True,
                          env=os.environ, cwd=tmp_path, timeout=120)
    assert done.returncode == 0 and done.stdout.strip() == f"vibupdate {__version__}"
    done = subprocess.run([sys.executable, "-m", "vibupdate", "check", "missing.toml"], capture_output=True,
                          text=True, env=os.environ, cwd=tmp_path, timeout=120)
    assert done.returncode == 2 and "does not exist" in done.stderr and "Traceback" not in done.stderr


def _slow_case(folder: Path) -> Path:
    """The frame example refined 8 times (305 DOFs) without reduction: its lambda = 0 solve
    runs about 20 IPOPT iterations over a second or more."""
    import shutil

    source = ROOT / "examples" / "frame"
    for name in ("frequencies.csv", "shapes.csv"):
        shutil.copy(source / name, folder / name)
    text = (source / "case.toml").read_text()
    text = text.replace('name = "frame"\n', 'name = "frame"\noptions = { subdivisions = 8 }\n', 1)
    # the lambda = 0 step by IPOPT (not the QP solver), so that the signal arrives inside IPOPT
    text += '\n[formulation]\nreduction = "none"\n\n[solver]\nn_lambda = 1\nrelaxation_solver = "nlp"\n'
    path = folder / "case.toml"
    path.write_text(text)
    return path


def test_sigint_during_ipopt_iterations_exits_130_at_once_and_keeps_earlier_results(tmp_path):
    """Ctrl-C while IPOPT iterates: CasADi catches it and would report a failed solve; the run
    must stop at once (inside that solve: its step is never reported), exit 130 and leave the
    previous results folder as it was. No wall-clock bound: the step that was interrupted
    never completing is the measure of "at once". The signal is sent when IPOPT says its first
    iteration, so it lands inside the solve on a machine under any load."""
    import os
    import signal
    import subprocess
    import sys

    from outputs_helpers import snapshot

    case = _slow_case(tmp_path)
    out = tmp_path / "results"
    out.mkdir()  # earlier results of this case (a results folder vibupdate owns)
    (out / "results.json").write_text('{"earlier": true}\n')
    (out / "vibupdate-manifest.json").write_text('{"files": ["results.json"]}\n')
    before = snapshot(tmp_path)
    # the command line with a progress line at every IPOPT iteration (said from inside IPOPT's
    # iteration callback), the cue that IPOPT iterates: neither a wall-clock nor a CPU-time wait
    # can tell when its set-up (the first factorization) ends on a loaded machine
    cue = ("import sys; import vibupdate.inverse.backends.casadi_ipopt as ipopt; "
           "ipopt.PROGRESS_AFTER = ipopt.PROGRESS_EVERY = 0.0; "
           "from vibupdate.cli import main; sys.exit(main())")
    # a user's terminal delivers Ctrl-C; a test runner's worker may ignore SIGINT, and a child
    # inherits an ignored SIGINT (Python then installs no handler): restore the default
    proc = subprocess.Popen([sys.executable, "-c", cue, "run", str(case), "--out", str(out)],
                            stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, env=os.environ, cwd=tmp_path,
                            preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    lines = []
    try:
        for line in proc.stdout:  # IPOPT's first iteration of the lambda = 0 solve (about 22 in all)
            lines.append(line)
            if "lambda = 0.0000: iteration 1," in line:
                break
        assert proc.poll() is None, "".join(lines)
        proc.send_signal(signal.SIGINT)
        rest, _ = proc.communicate(timeout=120)   # a guard against a hang, not a speed figure
    finally:
        proc.kill()
    text = "".join(lines) + rest
    assert proc.returncode == 130, text
    # inside the solve: IPOPT had begun iterating (the cue) and the step never ended; the signal
    # lands in IPOPT's own code (CasADi then warns of a KeyboardInterruptException) or in the
    # iteration callback's Python, and both must end the run at once
    assert "lambda = 0.0000: iteration 1," in text
    # the interrupted step is never reported (its record line: "lambda = 0.0000  objective = ...")
    assert "lambda = 0.0000  objective" not in text and "lambda = 1.0000" not in text and "Traceback" not in text
    assert "interrupted" in rest
    assert snapshot(tmp_path) == before


#: Three springs of a chain of three unit masses, two natural frequencies: fewer data than
#: parameters, so one combination of the springs is not determined by the data.
UNDER_DETERMINED_CHAIN = """\
case = "chain3"

[model]
type = "elements"
kind = "beam"
line = { first = 1, last = 3, start = [1.0], end = [3.0] }
fix = ["phi1", "phi2", "phi3"]
mass = [{ dof = "y1", value = 1.0 }, { dof = "y2", value = 1.0 }, { dof = "y3", value = 1.0 }]
spring = [{ dof = "y1", value = "k1" }, { dof = "y1", other = "y2", value = "k2" },
          { dof = "y2", other = "y3", value = "k3" }]

[[parameter]]
name = "k1"
nominal = 1000.0
lower = 700.0
upper = 1300.0

[[parameter]]
name = "k2"
nominal = 1000.0
lower = 700.0
upper = 1300.0

[[parameter]]
name = "k3"
nominal = 1000.0
lower = 700.0
upper = 1300.0

[[configuration]]
name = "A"
natural_hz = [2.2, 6.1]
"""


def test_an_under_determined_chain_writes_its_results_and_names_the_undetermined_combination(tmp_path, capsys):
    from vibupdate.io.results import load_results

    case = tmp_path / "case.toml"
    case.write_text(UNDER_DETERMINED_CHAIN)
    out = tmp_path / "out"
    assert main(["check", str(case)]) == 0
    code = main(["run", str(case), "--out", str(out)])
    printed = capsys.readouterr()
    assert code in (0, 1), printed.err
    assert "internal error" not in printed.err
    run = load_results(out / "results.json")
    ident = run.identifiability
    assert ident.rank == 2 and ident.condition is None  # infinite: written as null
    (combo,) = ident.undetermined_combinations
    assert all(name in combo for name in ("k1", "k2", "k3"))
    report = (out / "report.md").read_text()
    assert combo in report and "condition inf" in report
    tables = printed.out[printed.out.index("\nFrequencies\n"):]   # the tables printed after the run
    assert combo in tables and "condition inf" in tables


def test_a_reader_that_stops_reading_leaves_the_run_its_exit_code_and_files(tmp_path):
    """``vibupdate example cantilever | head -1``: the pipe closes after one line; the run goes
    on, writes its results and exits 0 (a broken pipe was an internal error, exit 3); a bad
    input read that way still exits 2."""
    import subprocess
    import sys

    run = subprocess.Popen([sys.executable, "-m", "vibupdate", "example", "cantilever", "--out", str(tmp_path / "r")],
                           stdout=subprocess.PIPE, stderr=subprocess.STDOUT, cwd=tmp_path)
    first = run.stdout.readline()
    run.stdout.close()   # the reader is gone
    assert run.wait(timeout=300) == 0 and first.startswith(b"example cantilever")
    assert (tmp_path / "r" / "results.json").is_file()
    bad = subprocess.Popen([sys.executable, "-m", "vibupdate", "run", str(tmp_path / "none.toml")],
                           stdout=subprocess.PIPE, stderr=subprocess.STDOUT, cwd=tmp_path)
    bad.stdout.close()
    assert bad.wait(timeout=120) == 2


def test_a_run_draws_its_plots_without_importing_pyplot(tmp_path):
    """The plots are figures on the Agg canvas (`vibupdate.report.plots.figure`): a run that
    draws them imports matplotlib's figure module but never pyplot (its import is a fixed cost
    of every ``vibupdate run``, and its register of open figures is global state)."""
    import subprocess
    import sys

    from outputs_helpers import write_case

    case = write_case(tmp_path / "case")
    out = tmp_path / "out"
    code = ("import sys\n"
            "from vibupdate.cli import main\n"
            f"code = main(['run', {str(case)!r}, '--out', {str(out)!r}])\n"
            "print(code, 'matplotlib.figure' in sys.modules, 'matplotlib.pyplot' in sys.modules)")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr[-2000:]
    assert done.stdout.splitlines()[-1] == "0 True False"
    assert (out / "frf.png").is_file()


ONE_DOF_CASE = """\
case = "one"

[model]
type = "matrices"
M0 = "M0.mtx"
K0 = "K0.mtx"
dofs = ["y1"]
dK = { k = "dK.mtx" }

[[parameter]]
name = "k"
unit = "N/m"
nominal = 1000.0
lower = 500.0
upper = 2000.0

[[configuration]]
name = "A"
natural_hz = [3.898484]
"""


def test_a_one_dof_case_updates_and_its_antiresonance_is_refused_in_one_line(tmp_path, capsys):
    """A 2 kg mass on a spring whose one frequency says k = 1200 N/m: the run verifies it. The
    one receptance of a 1-DOF model has no zero: a declared antiresonance is bad input naming
    it (the modal solver ended in an IndexError on the empty adjunct pencil)."""
    import scipy.io
    import scipy.sparse as sp

    from outputs_helpers import write_case

    for name, value in (("M0", 2.0), ("K0", 1000.0), ("dK", 1.0)):
        scipy.io.mmwrite(tmp_path / f"{name}.mtx", sp.csr_matrix([[value]]))
    case = write_case(tmp_path, ONE_DOF_CASE)
    assert main(["run", str(case), "--out", str(tmp_path / "out")]) == 0
    doc = json.loads((tmp_path / "out" / "results.json").read_text())
    assert doc["parameters"][0]["updated"] == pytest.approx(1200.0, rel=1e-5)
    capsys.readouterr()
    zero = write_case(tmp_path, ONE_DOF_CASE.replace(
        "natural_hz = [3.898484]", 'natural_hz = [3.898484]\nantiresonances = [{ hz = 2.0, response = "y1", '
        'excitation = "y1" }]'), "zero.toml")
    assert main(["run", str(zero), "--out", str(tmp_path / "out_zero")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "Traceback" not in err and "IndexError" not in err, err
    assert "zero 1 of h_y1,y1 is declared" in err and "only 0 DOFs" in err, err
    assert err.count("configuration 'A'") == 1, err   # named once, not by the library and the reader both
