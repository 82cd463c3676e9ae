"""Every user mistake of the list below ends before any work with exit 2 and one line that
names the file, key or option and the value expected: no traceback, no internal error (exit 3),
nothing written, nothing of the user's removed.

Each row: a name, the files it needs (``setup(folder)``), the command line, and a pattern the
error line must match. The commands run in a fresh folder holding the tiny case
(``case.toml``) and a table of synthetic FRFs (``frf.npz``, three receptances of the
cantilever, 20-300 Hz)."""

from __future__ import annotations

import os
import re
import sys

import numpy as np
import pytest
from frf_synthetic import measured, write_uff
from outputs_helpers import TINY_CASE, snapshot

from vibupdate.cli import main

#: The responses of ``frf.npz``: its columns, all driven at y3.
RESPONSES = ("y1", "y2", "y3")


def _extract(*options, table="frf.npz", band=("20", "300")):
    return ["extract", table, "--responses", *RESPONSES, "--excitations", "y3", "--band", *band, "--no-plot",
            "--out", "ex", *options]



def _edit(old: str, new: str, name: str = "edited.toml"):
    """A setup writing the tiny case with ``old`` replaced by ``new`` as ``name``."""
    def setup(folder):
        assert old in TINY_CASE
        (folder / name).write_text(TINY_CASE.replace(old, new, 1))
    return setup


def _with_file(name: str, text: str, then=None):
    def setup(folder):
        (folder / name).write_text(text)
        if then is not None:
            then(folder)
    return setup


def _symlink(folder):
    os.symlink("nowhere/at/all", folder / "dangling")


def _zero_frf(folder):
    with np.load(folder / "frf.npz") as data:
        np.savez(folder / "zero.npz", freq_hz=data["freq_hz"], H=0 * data["H"])


def _huge_frf(folder):
    with np.load(folder / "frf.npz") as data:
        np.savez(folder / "huge.npz", freq_hz=data["freq_hz"] * 1e300, H=data["H"])


def _cut_uff(folder):
    frfs, *_ = measured(8, repeats=1)
    write_uff(folder / "whole.uff", frfs)
    lines = (folder / "whole.uff").read_text().splitlines(True)
    (folder / "cut.uff").write_text("".join(lines[: len(lines) // 2]))


NO_MODES = 'natural_hz = [37.3397, 234.7489]\ndamping_ratios = [0.02, 0.01]'
#: The typed data of the tiny case's configuration.
TYPED = NO_MODES + '\nantiresonances = [{ hz = 164.0447, response = "y1", excitation = "y1" }]'
#: A free beam on two soft springs: two suspension modes (about 5 and 9 Hz) below its first
#: flexible ones (226 and 624 Hz), measured at 235 and 650 Hz without saying which modes they are.
SUSPENDED = (TINY_CASE.replace("clamp = [4]\n", "")
             .replace("[[parameter]]", '[[model.spring]]\ndof = "y1"\nvalue = "1e-9*E"\n[[model.spring]]\n'
                                       'dof = "y4"\nvalue = "1e-9*E"\n\n[[parameter]]', 1)
             .replace("natural_hz = [37.3397, 234.7489]", "natural_hz = [235.0, 650.0]")
             .replace('antiresonances = [{ hz = 164.0447, response = "y1", excitation = "y1" }]\n', ""))

MISTAKES = [
    # output folders
    ("dangling-symlink --out", _symlink, ["run", "case.toml", "--out", "dangling"],
     r"output path 'dangling' is a symbolic link to 'nowhere/at/all', which does not exist; expected a folder"),
    ("300-character --out", None, ["run", "case.toml", "--out", "x" * 300],
     r"the name 'x{40}'\.\.\. is 300 bytes long; the file system allows at most \d+"),
    ("--out inside a file", _with_file("notes.txt", "mine"), ["run", "case.toml", "--out", "notes.txt/res"],
     r"cannot be created: 'notes.txt' is not a folder"),
    ("sweep --out onto a read-only file system", None,
     ["sweep", "case.toml", "--samples", "2", "--frequency-tolerance", "0.01", "--out", "/proc/vibupdate-sweep"],
     r"output folder '/proc' is not writable"),
    # extract's options
    ("extract --modes 0", None, _extract("--modes", "0"), r"--modes must be an integer >= 1 .*got 0"),
    ("extract --first-mode 0", None, _extract("--first-mode", "0"),
     r"--first-mode must be an integer >= 1 .*got 0"),
    ("extract --map y1=", None, _extract("--map", "y1="), r"--map entries are FROM=TO with two DOF names.*'y1='"),
    ("extract --map =x1", None, _extract("--map", "=x1"), r"--map entries are FROM=TO .*'=x1'"),
    ("extract --band 15 1", None, _extract(band=("15", "1")),
     r"--band 15 1: expected two frequencies in Hz, 0 < F1 < F2"),
    ("extract --fit-band 300 20", None, _extract("--fit-band", "300", "20"),
     r"--fit-band 300 20: expected two frequencies in Hz"),
    ("extract --confidence 95", None, _extract("--confidence", "95"), r"--confidence must be between 0 and 1"),
    ("extract of an all-zero FRF", _zero_frf, _extract(table="zero.npz"),
     r"h\(y1,y3\), h\(y2,y3\), h\(y3,y3\): zero .* at every line of the band 20-300 Hz; expected a measured FRF"),
    ("extract of frequencies of 1e300 Hz", _huge_frf, _extract(table="huge.npz", band=("2e301", "3e302")),
     r"h\(y1,y3\): frequencies up to 3e\+302 Hz .* beyond the range of floating point; expected frequencies in Hz"),
    ("extract of a UFF file cut short", _cut_uff, ["extract", "cut.uff", "--band", "20", "300", "--out", "ex"],
     r"UFF file 'cut.uff' ends at line \d+ inside a dataset .*cut short"),
    # case files
    ("modes = 0 in a configuration's FRF section", _edit(TYPED, 'frf = { files = ["frf.npz"], responses = '
                                                                   '["y1", "y2", "y3"], excitations = ["y3"], '
                                                                   'modes = 0 }'),
     ["check", "edited.toml"], r"configuration 'A'\.frf\.modes: must be an integer >= 1 .*got 0"),
    ("first_mode = 0 in a configuration's FRF section",
     _edit(TYPED, 'frf = { files = ["frf.npz"], responses = ["y1", "y2", "y3"], excitations = ["y3"], '
                     'first_mode = 0 }'),
     ["check", "edited.toml"], r"configuration 'A'\.frf\.first_mode: must be an integer >= 1"),
    ("a builder calling sys.exit(0)",
     _with_file("builder.py", "import sys\n\ndef build(p):\n    sys.exit(0)\n",
                _edit(TINY_CASE[TINY_CASE.index("[model]"):TINY_CASE.index("[[parameter]]")],
                      '[model]\ntype = "builder"\nbuilder = "builder.py:build"\n\n')),
     ["run", "edited.toml", "--out", "res"], r"model\.builder: builder\.py:build called sys\.exit\(0\)"),
    ("a builder module calling sys.exit when imported",
     _with_file("builder.py", "import sys\nsys.exit(0)\n",
                _edit(TINY_CASE[TINY_CASE.index("[model]"):TINY_CASE.index("[[parameter]]")],
                      '[model]\ntype = "builder"\nbuilder = "builder.py:build"\n\n')),
     ["run", "edited.toml", "--out", "res"], r"model\.builder: importing 'builder\.py' called sys\.exit\(0\)"),
    ("a parameter name given twice", _edit('name = "rho"', 'name = "E"'), ["check", "edited.toml"],
     r"parameter\[2\]\.name: 'E' is declared twice \(parameter\[1\] and parameter\[2\]\)"),
    ("a parameter name with a blank", _edit('name = "rho"', 'name = "r ho"'), ["check", "edited.toml"],
     r"parameter\[2\]\.name: 'r ho' is not a name the model's expressions can use: expected letters, digits"),
    ("a parameter name klc+E", _edit('name = "rho"', 'name = "klc+E"'), ["check", "edited.toml"],
     r"parameter\[2\]\.name: 'klc\+E' is not a name"),
    ("a spring from a DOF to itself",
     _edit("[[parameter]]", '[[model.spring]]\ndof = "y2"\nother = "y2"\nvalue = "1e-7*E"\n\n[[parameter]]'),
     ["check", "edited.toml"], r"model\.spring\[1\]\.other: is the spring's own DOF 'y2'"),
    ("natural_hz beside frequencies_csv",
     _with_file("f.csv", "kind,hz\nnatural,37.3397\nnatural,234.7489\n",
                _edit("natural_hz =", 'frequencies_csv = "f.csv"\nnatural_hz =')),
     ["check", "edited.toml"], r"natural_hz: natural_hz and frequencies_csv both give the natural frequencies"),
    ("damping_ratios beside frequencies_csv",
     _with_file("f.csv", "kind,hz\nnatural,37.3397\nnatural,234.7489\n",
                _edit('natural_hz = [37.3397, 234.7489]\n', 'frequencies_csv = "f.csv"\n')),
     ["check", "edited.toml"], r"configuration 'A'\.damping_ratios: damping_ratios goes with natural_hz, but the "
                               r"natural frequencies come from frequencies_csv \(f\.csv\); give them in its "
                               r"'damping_ratio' column"),
    ("natural_modes beside FRF files",
     _edit(TYPED, 'natural_modes = [1, 2]\nfrf = { files = ["frf.npz"], responses = ["y1", "y2", "y3"], '
                  'excitations = ["y3"] }'),
     ["check", "edited.toml"], r"configuration 'A'\.natural_modes: natural_modes goes with natural_hz, which this "
                               r"configuration does not give \(its natural frequencies come from frf\); remove "
                               r"natural_modes; state the extracted modes' numbers in \[configuration\.frf\] instead"),
    ("a misspelt CSV column",
     _with_file("f.csv", "kind,hz,dampign_ratio\nnatural,37.3397,0.02\nnatural,234.7489,0.01\n",
                _edit(NO_MODES, 'frequencies_csv = "f.csv"')),
     ["check", "edited.toml"], r"f\.csv': unknown column 'dampign_ratio' \(did you mean 'damping_ratio'\?\)"),
    ("undeclared modes read as near-zero suspension modes", _with_file("edited.toml", SUSPENDED),
     ["check", "edited.toml"],
     r"natural frequency 1 \(235 Hz\) declares no model mode, so it is read as mode 1, which the nominal model has "
     r"at 5\.\d+ Hz .*natural_modes"),
]


@pytest.fixture
def folder(tmp_path, monkeypatch):
    (tmp_path / "case.toml").write_text(TINY_CASE)
    frfs, *_ = measured(8, repeats=1)
    assert tuple(r for r, _ in frfs.pairs) == RESPONSES
    np.savez(tmp_path / "frf.npz", freq_hz=frfs.freq_hz, H=np.stack([h[0] for h in frfs.H], axis=1))
    monkeypatch.chdir(tmp_path)
    return tmp_path


@pytest.mark.parametrize("name, setup, argv, pattern", MISTAKES, ids=[m[0] for m in MISTAKES])
def test_a_user_mistake_is_exit_2_before_any_work_naming_what_is_expected(folder, capsys, monkeypatch, name, setup,
                                                                          argv, pattern):
    if setup is not None:
        setup(folder)
    before = snapshot(folder)
    solved = []
    import vibupdate.pipeline as pipeline

    monkeypatch.setattr(pipeline, "update", lambda *a, **k: solved.append(1))   # no solve may start
    code = main(argv)
    err = capsys.readouterr().err
    assert code == 2, err
    assert "Traceback" not in err and "internal error" not in err
    lines = err.strip().splitlines()
    assert len(lines) == 1 and re.search(pattern, lines[0]), lines
    assert not solved
    assert snapshot(folder) == before                # nothing written, nothing removed
    sys.modules.pop("vibupdate_case_builder", None)  # the builder module of the next row is another file


def test_the_suspended_beam_passes_check_once_its_modes_are_declared(folder, capsys):
    """The constructed case of the pairing row is fine when it says which modes it measured:
    the check is about the pairing, not the model."""
    (folder / "declared.toml").write_text(SUSPENDED.replace("natural_hz = [235.0, 650.0]",
                                                            "natural_hz = [235.0, 650.0]\nnatural_modes = [3, 4]"))
    assert main(["check", "declared.toml"]) == 0, capsys.readouterr().err
