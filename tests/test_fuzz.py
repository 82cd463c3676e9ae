"""Fuzz suite: hypothesis mutates the bundled case files and data files, then
runs ``vibupdate check`` (and ``run`` on a small sample) in-process through
`vibupdate.cli.main`. For every mutation:

* the exit code is 0, 1 or 2;
* nothing escapes as an exception and no traceback is printed;
* exit 2 prints one message that names the file and the place in it (a key of the case file,
  a row or line of a data file);
* nothing is written by ``check``; a ``run`` that fails writes nothing, one that ends leaves
  a complete output folder and no partial one.

Mutations: the parsed case file with a key deleted, a value replaced (other types, NaN,
infinities, huge and tiny numbers, empty and unicode strings, empty arrays and tables), an
unknown key added, an array entry duplicated or removed; the raw bytes of the case file with
garbage inserted, overwritten or cut; the data files (the frame's CSV tables) with rows
duplicated, removed or swapped, cells replaced, garbage bytes and unicode.

Profiles: the default (CI) one is derandomized with a few examples per strategy, about 30-40 s
on two shared cores; ``pytest -m slow tests/test_fuzz.py`` runs ten times as many examples
with random seeds.
"""

import contextlib
import io
import json
import math
import re
import shutil
import tempfile
import tomllib
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from vibupdate.cli import main

ROOT = Path(__file__).resolve().parents[1]
EXAMPLES = {name: ROOT / "examples" / name for name in ("cantilever", "frame")}
CI = dict(deadline=None, derandomize=True, database=None,
          suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])
LONG = dict(deadline=None, database=None, suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])


# -- a TOML writer (inline tables only, enough for round trips of parsed case files) -------------


def _toml_string(text: str) -> str:
    quoted = json.dumps(text, ensure_ascii=False)
    return quoted.replace("\x7f", "\\u007f")


def _toml_key(key: str) -> str:
    return key if re.fullmatch(r"[A-Za-z0-9_-]+", key) else _toml_string(key)


def _toml_value(value) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        if math.isnan(value):
            return "nan"
        if math.isinf(value):
            return "inf" if value > 0 else "-inf"
        return repr(value)
    if isinstance(value, str):
        return _toml_string(value)
    if isinstance(value, list):
        return "[" + ", ".join(_toml_value(v) for v in value) + "]"
    if isinstance(value, dict):
        return "{ " + ", ".join(f"{_toml_key(k)} = {_toml_value(v)}" for k, v in value.items()) + " }" \
            if value else "{}"
    raise TypeError(f"cannot write {value!r} as TOML")


def to_toml(data: dict) -> str:
    return "".join(f"{_toml_key(k)} = {_toml_value(v)}\n" for k, v in data.items())


# -- running the CLI and checking what it did ---------------------------------------------------


def _snapshot(folder: Path) -> dict:
    return {str(p.relative_to(folder)): (p.stat().st_size, p.stat().st_mtime_ns)
            for p in sorted(folder.rglob("*")) if "__pycache__" not in p.parts}


def _cli(args) -> tuple[int, str, str]:
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = main(args)
    return code, out.getvalue(), err.getvalue()


_PLACE = re.compile(r"^vibupdate: error: (?P<file>[^:]+?): (?P<place>[^:]+?): ", re.M)


def _assert_names_a_place(err: str, folder: Path) -> None:
    """The one error message names a file of the folder and a key, row or line in it."""
    assert err.count("vibupdate: error:") == 1, err
    # "CSV file '/.../x.csv' needs a column 'hz'", else "FILE: KEY: ..." or "FILE: row N: ..."
    m = re.search(r"vibupdate: error: (case|CSV|UFF|matrix) file '(?P<file>[^']+)' (?P<place>.*)", err) \
        or _PLACE.search(err)
    assert m is not None, f"no file named in: {err}"
    assert Path(m.group("file")).resolve().parent == folder.resolve(), err
    assert m.group("place").strip(), err


def _check_outcome(code: int, out: str, err: str, folder: Path) -> None:
    assert code in (0, 1, 2), (code, err)
    assert "Traceback" not in err and "Traceback" not in out, err
    if code == 2:
        _assert_names_a_place(err, folder)


def _copy(name: str, into: Path) -> Path:
    for p in EXAMPLES[name].iterdir():
        if p.is_file() and p.suffix in (".toml", ".csv"):
            shutil.copy(p, into / p.name)
    return into / "case.toml"


def _check_case(folder: Path, case: Path) -> int:
    before = _snapshot(folder)
    code, out, err = _cli(["check", str(case)])
    _check_outcome(code, out, err, folder)
    assert _snapshot(folder) == before, "check wrote or changed files"
    return code


# -- strategies -----------------------------------------------------------------------------------

ODD_VALUES = st.one_of(
    st.integers(min_value=-(2**63), max_value=2**63 - 1),
    st.sampled_from([0, -1, 1, 2, 10**6]),
    st.floats(allow_nan=True, allow_infinity=True),
    st.sampled_from([0.0, -0.0, 1e-300, 1e300, -1e300, math.nan, math.inf, -math.inf, 0.5, 2.0]),
    st.text(max_size=12),
    st.sampled_from(["", "y1", "y99", "E", "nan", "1e400", "2*E*E", "../x", "/abs/x", "é ü 中文 🙂", "a" * 300,
                     "q1", "natural", "craig-bampton", "0.001*rho"]),
    st.booleans(),
    st.lists(st.floats(allow_nan=True, allow_infinity=True), max_size=4),
    st.just([]),
    st.just({}),
    st.dictionaries(st.text(max_size=6), st.integers(), max_size=2),
)


def _paths(node, prefix=()):
    """Every key and array index of a parsed TOML document."""
    items = node.items() if isinstance(node, dict) else enumerate(node) if isinstance(node, list) else ()
    for key, child in items:
        yield prefix + (key,)
        yield from _paths(child, prefix + (key,))


def _parent(doc, path):
    node = doc
    for key in path[:-1]:
        node = node[key]
    return node


@st.composite
def case_mutation(draw, original: dict) -> tuple[dict, str]:
    doc = json.loads(json.dumps(original))   # a deep copy (the case files hold no NaN)
    paths = list(_paths(doc))
    path = draw(st.sampled_from(paths))
    parent, key = _parent(doc, path), path[-1]
    op = draw(st.sampled_from(["delete", "replace", "replace", "extra", "duplicate"]))
    if op == "delete":
        del parent[key]
    elif op == "replace":
        parent[key] = draw(ODD_VALUES)
    elif op == "extra":
        target = parent if isinstance(parent, dict) else doc
        target[draw(st.sampled_from(["speed", "Name", "é", "mass", "natural", " "]))] = draw(ODD_VALUES)
    else:
        if isinstance(parent, list):
            parent.insert(key, json.loads(json.dumps(parent[key])))
        else:
            parent[key] = draw(ODD_VALUES)
    return doc, f"{op} {'.'.join(map(str, path))}"


@st.composite
def byte_mutation(draw, data: bytes) -> bytes:
    pos = draw(st.integers(0, len(data)))
    junk = draw(st.one_of(st.binary(min_size=1, max_size=8),
                          st.sampled_from([b"\x00", b"\xff\xfe", b"[[", b"]]", b"=", b'"', b"\n[model]\n",
                                           "é中🙂".encode(), b"\r\n", b"nan", b"#"])))
    op = draw(st.sampled_from(["insert", "overwrite", "cut"]))
    if op == "insert":
        return data[:pos] + junk + data[pos:]
    if op == "overwrite":
        return data[:pos] + junk + data[pos + len(junk):]
    return data[:pos]


@st.composite
def csv_mutation(draw, text: str) -> bytes:
    lines = text.splitlines()
    data_rows = [i for i, line in enumerate(lines) if line and not line.startswith("#")][1:]
    i = draw(st.sampled_from(data_rows))
    op = draw(st.sampled_from(["duplicate", "delete", "swap", "cell", "cell", "header", "bytes"]))
    if op == "duplicate":
        lines.insert(i, lines[i])
    elif op == "delete":
        del lines[i]
    elif op == "swap":
        j = draw(st.sampled_from(data_rows))
        lines[i], lines[j] = lines[j], lines[i]
    elif op in ("cell", "header"):
        row = i if op == "cell" else data_rows[0] - 1
        cells = lines[row].split(",")
        k = draw(st.integers(0, len(cells) - 1))
        cells[k] = draw(st.one_of(st.sampled_from(["", "nan", "inf", "-1", "0", "1.7", "1e400", "é", "y1", "a,b",
                                                   '"', "natural", "antiresonance", "mode"]),
                                  st.text(max_size=8).map(lambda s: s.replace("\n", " ").replace("\r", " "))))
        lines[row] = ",".join(cells)
    else:
        joined = "\n".join(lines).encode()
        pos = draw(st.integers(0, len(joined)))
        return joined[:pos] + draw(st.binary(min_size=1, max_size=6)) + joined[pos:]
    return ("\n".join(lines) + "\n").encode()


def _original(name: str) -> dict:
    return tomllib.loads((EXAMPLES[name] / "case.toml").read_text(encoding="utf-8"))


# -- tests ----------------------------------------------------------------------------------------


@pytest.mark.parametrize("name", sorted(EXAMPLES))
def test_the_toml_writer_round_trips_the_bundled_case_files(tmp_path, name):
    original = _original(name)
    assert tomllib.loads(to_toml(original)) == original
    case = _copy(name, tmp_path)
    case.write_text(to_toml(original), encoding="utf-8")
    assert _check_case(tmp_path, case) == 0


def _case_body(name: str, mutation) -> None:
    doc, _ = mutation
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        case = _copy(name, folder)
        case.write_text(to_toml(doc), encoding="utf-8")
        _check_case(folder, case)


def _bytes_body(name: str, data: bytes) -> None:
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        case = _copy(name, folder)
        case.write_bytes(data)
        _check_case(folder, case)


def _csv_body(file: str, data: bytes) -> None:
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        case = _copy("frame", folder)
        (folder / file).write_bytes(data)
        _check_case(folder, case)


CANTILEVER, FRAME = _original("cantilever"), _original("frame")
CANTILEVER_BYTES = (EXAMPLES["cantilever"] / "case.toml").read_bytes()
SHAPES = (EXAMPLES["frame"] / "shapes.csv").read_text()
FREQUENCIES = (EXAMPLES["frame"] / "frequencies.csv").read_text()


@settings(max_examples=40, **CI)
@given(case_mutation(CANTILEVER))
def test_mutated_cantilever_case(mutation):
    _case_body("cantilever", mutation)


@settings(max_examples=20, **CI)
@given(case_mutation(FRAME))
def test_mutated_frame_case(mutation):
    _case_body("frame", mutation)


@settings(max_examples=25, **CI)
@given(byte_mutation(CANTILEVER_BYTES))
def test_garbage_bytes_in_the_case_file(data):
    _bytes_body("cantilever", data)


@settings(max_examples=20, **CI)
@given(st.one_of(csv_mutation(SHAPES).map(lambda d: ("shapes.csv", d)),
                 csv_mutation(FREQUENCIES).map(lambda d: ("frequencies.csv", d))))
def test_mutated_data_files(mutation):
    _csv_body(*mutation)


def _run_body(mutation) -> None:
    doc, _ = mutation
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        case = _copy("cantilever", folder)
        case.write_text(to_toml(doc), encoding="utf-8")
        out = folder / "out"
        before = _snapshot(folder)
        code, stdout, err = _cli(["run", str(case), "--out", str(out)])
        _check_outcome(code, stdout, err, folder)
        leftovers = [str(p) for p in folder.rglob("*partial*")]   # the staging folders of a run
        assert not leftovers, leftovers
        if code == 2:
            assert _snapshot(folder) == before, "a rejected run wrote files"
        else:
            assert {"results.json", "report.md", "vibupdate-manifest-run.json"} <= {p.name for p in out.iterdir()}


CHEAP = json.loads(json.dumps(CANTILEVER))
CHEAP["solver"] = {"n_lambda": 1, "max_iter": 60}


@settings(max_examples=2, **CI)
@given(case_mutation(CHEAP))
def test_mutated_cantilever_run(mutation):
    _run_body(mutation)


# -- the long profile (on demand) ---------------------------------------------------------------


@pytest.mark.slow
@settings(max_examples=400, **LONG)
@given(st.one_of(case_mutation(CANTILEVER).map(lambda m: ("cantilever", m)),
                 case_mutation(FRAME).map(lambda m: ("frame", m))))
def test_long_mutated_cases(named):
    _case_body(*named)


@pytest.mark.slow
@settings(max_examples=250, **LONG)
@given(byte_mutation(CANTILEVER_BYTES))
def test_long_garbage_bytes(data):
    _bytes_body("cantilever", data)


@pytest.mark.slow
@settings(max_examples=200, **LONG)
@given(st.one_of(csv_mutation(SHAPES).map(lambda d: ("shapes.csv", d)),
                 csv_mutation(FREQUENCIES).map(lambda d: ("frequencies.csv", d))))
def test_long_mutated_data_files(mutation):
    _csv_body(*mutation)


@pytest.mark.slow
@settings(max_examples=20, **LONG)
@given(case_mutation(CHEAP))
def test_long_mutated_runs(mutation):
    _run_body(mutation)


# -- command-line options -------------------------------------------------------------------------

#: Values tried for options and positional arguments: odd numbers, empty and unicode text, long
#: names, paths that are files, links to nothing, folders that are not writable.
ODD_ARGS = ("0", "-1", "1", "2", "3", "15", "300", "1e308", "nan", "inf", "-inf", "0.5", "", " ", "x", "ü-名",
            "a" * 300, "y1=", "=x1", "y1=x2", "y1=-x2", "--", "-", ".", "..", "notes.txt", "notes.txt/out",
            "dangling", "/proc/vibupdate", "case.toml", "frf.npz", "missing.toml", "results")
FUZZED = ("run", "check", "extract", "sweep")


def _options(command: str) -> list:
    """The optional arguments of a sub-command of the parser: ``(flag, nargs)``."""
    from vibupdate.cli import parser

    sub = next(a for a in parser()._actions if a.dest == "command").choices[command]
    return [(a.option_strings[-1], a.nargs) for a in sub._actions if a.option_strings and a.dest != "help"]


def _user_files(folder: Path) -> dict:
    """Every regular file under ``folder`` with the SHA-1 of its content (links left out)."""
    import hashlib

    return {str(p.relative_to(folder)): hashlib.sha1(p.read_bytes()).hexdigest() for p in sorted(folder.rglob("*"))
            if p.is_file() and not p.is_symlink()}


def _fuzzed_argv(rng) -> list[str]:
    command = FUZZED[rng.integers(len(FUZZED))]
    argv = [command]
    if command == "extract":
        argv += ["frf.npz", "--responses", "y1", "y2", "y3", "--excitations", "y3"][: rng.integers(2, 8)]
    else:
        argv.append(str(rng.choice(["case.toml", "case.toml", "missing.toml", "notes.txt", "frf.npz", ""])))
    for flag, nargs in _options(command):
        if rng.random() < 0.15:
            count = 0 if nargs == 0 else (2 if nargs == 2 else rng.integers(1, 3) if nargs in ("+", "*") else 1)
            argv += [flag, *(str(rng.choice(ODD_ARGS)) for _ in range(count))]
    return argv


def test_fuzzed_command_lines_end_in_a_known_code_without_a_traceback_or_a_lost_file(tmp_path, monkeypatch):
    """300 command lines from a seeded generator over the options of run, check, extract and
    sweep, in a folder holding the user's files (a case, FRFs, notes, an earlier run's results
    with an edited file, a link to nothing). The work itself (the solve, the fit, the sweep's
    tasks) is replaced by Ctrl-C, so a line that gets past every check ends with 130: what is
    fuzzed is the checking. Every exit is 0, 1, 2 or 130, nothing escapes, no traceback is
    printed, and every file of the user's is still there, unchanged."""
    import os

    import numpy as np
    from frf_synthetic import measured
    from outputs_helpers import TINY_CASE

    import vibupdate.data.extraction as extraction
    import vibupdate.pipeline as pipeline
    import vibupdate.study.sweep as sweep

    def stop(*args, **kwargs):
        raise KeyboardInterrupt

    (tmp_path / "case.toml").write_text(TINY_CASE.replace('case = "tiny"', 'case = "tiny"\nfrequency_tolerance = 0.01'))
    (tmp_path / "notes.txt").write_text("mine")
    frfs, *_ = measured(8, repeats=1)
    np.savez(tmp_path / "frf.npz", freq_hz=frfs.freq_hz, H=np.stack([h[0] for h in frfs.H], axis=1))
    os.symlink("nowhere", tmp_path / "dangling")
    monkeypatch.chdir(tmp_path)
    assert main(["run", "case.toml", "--out", "results"]) == 0   # an earlier run, then edited by the user
    with open(tmp_path / "results" / "report.md", "a") as f:
        f.write("\nmy note\n")
    monkeypatch.setattr(pipeline, "update", stop)
    monkeypatch.setattr(extraction, "extract", stop)
    monkeypatch.setattr(sweep, "_sweep", stop)
    before = _user_files(tmp_path)
    rng = np.random.default_rng(20261206)
    codes = {}
    for _ in range(300):
        argv = _fuzzed_argv(rng)
        try:
            code, out, err = _cli(argv)
        except SystemExit as exc:   # argparse: an unknown choice or a missing value, its usage line
            code, err = exc.code, ""
        assert code in (0, 1, 2, 130), (argv, err[-2000:])
        assert "Traceback" not in err, (argv, err[-2000:])
        now = _user_files(tmp_path)
        assert {k: now.get(k) for k in before} == before, argv
        codes[code] = codes.get(code, 0) + 1
    assert {0, 2, 130} <= set(codes), codes   # not degenerate: lines were refused, checked, and reached the work
