"""The results folder never loses a user's file."""

import json
import os
import stat

import pytest
from outputs_helpers import TINY_CASE, snapshot, write_case

from vibupdate.cli import main
from vibupdate.io.outputs import (
    MANIFEST,
    MAX_NAME,
    file_names,
    prepare_output,
    safe_name,
    write_published,
)
from vibupdate.io.manifests import read_manifest


@pytest.mark.parametrize("text", ["../x", "/abs/x", "a/../../b", "..", ".hidden", "a\\b", "x" * 300, "名前/é", ""])
def test_safe_name_has_no_separator_no_dot_dot_and_a_bounded_length(text):
    name = safe_name(text)
    assert name and len(name) <= MAX_NAME
    assert "/" not in name and "\\" not in name and ".." not in name and not name.startswith(".")


def test_long_and_colliding_configuration_names_get_distinct_file_names():
    names = ["a/b", "a_b", "x" * 300, "x" * 299 + "y", "A"]
    parts = file_names(names)
    assert len(set(parts.values())) == len(names)
    assert parts["A"] == "A"
    assert all(len(p) <= MAX_NAME and "/" not in p for p in parts.values())


def test_out_dot_in_a_folder_with_the_case_its_data_and_a_results_json_keeps_every_file(tmp_path, monkeypatch, capsys):
    # The reported data loss: `cd case-results && vibupdate run ../case.toml --out .` with the
    # case and its data in the folder, and a results.json vibupdate does not know as its own.
    folder = tmp_path / "case-results"
    case = write_case(folder)
    (folder / "frequencies.csv").write_text("mode,hz\n1,37.3397\n")
    (folder / "results.json").write_text('{"mine": true}\n')
    before = snapshot(folder)
    monkeypatch.chdir(folder)
    for extra in ([], ["--force"]):
        assert main(["run", str(case), "--out", ".", *extra]) == 2
        err = capsys.readouterr().err
        assert "did not write" in err and "Traceback" not in err
        assert snapshot(folder) == before


def test_rerun_replaces_only_vibupdates_files_and_needs_force_beside_foreign_ones(tmp_path, monkeypatch, capsys):
    case = write_case(tmp_path / "case")
    out = tmp_path / "case" / "tiny-results"
    assert main(["run", str(case), "--out", str(out)]) == 0
    owned = read_manifest(out)
    assert {"results.json", "report.md", "M_A.mtx", "K_A.mtx", "C_A.mtx", "frf.png", "homotopy.png"} <= set(owned)
    assert sorted(p.name for p in out.iterdir()) == sorted(owned + [MANIFEST])
    # The user adds notes; a file of an older run that this run no longer writes is listed too.
    (out / "notes.txt").write_text("my notes")
    (out / "mac_A.png").write_bytes(b"old plot")
    manifest = json.loads((out / MANIFEST).read_text())
    manifest["files"].append("mac_A.png")
    (out / MANIFEST).write_text(json.dumps(manifest))
    (out / "results.json").write_text("{}")
    capsys.readouterr()
    assert main(["run", str(case), "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert "notes.txt" in err and "--force" in err
    assert (out / "results.json").read_text() == "{}"  # refused before anything was replaced
    # results.json was edited since the run wrote it: kept, and --force does not overwrite it
    assert main(["run", str(case), "--out", str(out), "--force"]) == 2
    err = capsys.readouterr().err
    assert "results.json, changed since `vibupdate run` wrote it" in err
    assert (out / "results.json").read_text() == "{}"
    (out / "results.json").rename(out / "my-results.json")
    assert main(["run", str(case), "--out", str(out), "--force"]) == 0
    assert (out / "notes.txt").read_text() == "my notes" and (out / "my-results.json").read_text() == "{}"
    assert not (out / "mac_A.png").exists()  # vibupdate's stale file is removed
    assert json.loads((out / "results.json").read_text())["case"] == "tiny"
    assert "notes.txt" not in read_manifest(out)
    # Running inside the results folder (`cd tiny-results && vibupdate run ../case.toml --out .`).
    monkeypatch.chdir(out)
    assert main(["run", "../case.toml", "--out", ".", "--force"]) == 0
    assert (out / "notes.txt").read_text() == "my notes" and (tmp_path / "case" / "case.toml").exists()
    assert not [p for p in out.iterdir() if p.name.startswith(".")]  # no staging folder left


def test_a_foreign_file_with_an_output_name_is_never_overwritten(tmp_path, capsys):
    case = write_case(tmp_path)
    out = tmp_path / "out"
    out.mkdir()
    (out / "report.md").write_text("my report")
    assert main(["run", str(case), "--out", str(out), "--force"]) == 2
    assert "report.md" in capsys.readouterr().err
    assert snapshot(out) == {"report.md": snapshot(out)["report.md"]} and (out / "report.md").read_text() == "my report"


def test_default_output_folder_from_a_hostile_case_name_stays_in_the_working_directory(tmp_path, monkeypatch):
    work = tmp_path / "a" / "work"
    case = write_case(work, TINY_CASE.replace('case = "tiny"', 'case = "../../escaped/x"'))
    monkeypatch.chdir(work)
    assert main(["run", str(case)]) == 0
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a"]
    assert sorted(p.name for p in (tmp_path / "a").iterdir()) == ["work"]
    (folder,) = [p for p in work.iterdir() if p.is_dir()]
    assert folder.name == f"{safe_name('../../escaped/x')}-results" and (folder / "results.json").exists()


def test_configuration_names_with_a_separator_or_300_characters_stay_inside_the_folder(tmp_path, capsys):
    for name in ("a/../../b", "c" * 300):
        case = write_case(tmp_path, TINY_CASE.replace('name = "A"', f'name = "{name}"'))
        out = tmp_path / "out"
        code = main(["run", str(case), "--out", str(out), "--force"])
        err = capsys.readouterr().err
        assert code in (0, 2) and "Traceback" not in err, err
        if code == 0:
            assert all(p.parent == out and len(p.name) < 100 for p in out.rglob("*"))
    assert sorted(p.name for p in tmp_path.iterdir()) == ["case.toml", "out"]


def test_results_folder_has_ordinary_permissions(tmp_path):
    case = write_case(tmp_path)
    out = tmp_path / "out"
    old = os.umask(0o022)
    try:
        assert main(["run", str(case), "--out", str(out)]) == 0
    finally:
        os.umask(old)
    assert stat.S_IMODE(out.stat().st_mode) == 0o755
    assert {stat.S_IMODE(p.stat().st_mode) for p in out.iterdir()} == {0o644}


def _no_solve(*args, **kwargs):
    raise AssertionError("the output folder must be checked before solving")


def test_unwritable_output_folder_is_refused_before_solving(tmp_path, monkeypatch, capsys):
    """The folder's write test is made to fail as a read-only folder makes it fail: a real
    read-only folder does not stop root, who runs CI here."""
    import tempfile

    import vibupdate.pipeline

    case = write_case(tmp_path)
    monkeypatch.setattr(vibupdate.pipeline, "update", _no_solve)

    def read_only(*args, **kwargs):
        raise PermissionError(13, "Permission denied")

    monkeypatch.setattr(tempfile, "mkstemp", read_only)
    assert main(["run", str(case), "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert "is not writable" in err and "Permission denied" in err and "Traceback" not in err
    assert not (tmp_path / "out").exists()


def test_output_path_that_is_a_file_is_refused(tmp_path, capsys):
    case = write_case(tmp_path)
    (tmp_path / "out").write_text("a file")
    assert main(["run", str(case), "--out", str(tmp_path / "out")]) == 2
    assert "is not a folder" in capsys.readouterr().err
    assert prepare_output(tmp_path / "new" / "deeper").exists is False


@pytest.fixture(scope="module")
def earlier_results(tmp_path_factory):
    """A case and the results folder of a completed run of it."""
    folder = tmp_path_factory.mktemp("earlier")
    case = write_case(folder)
    assert main(["run", str(case), "--out", str(folder / "out")]) == 0
    return folder


@pytest.mark.parametrize("failure, code", [(KeyboardInterrupt, 130), (RuntimeError("boom"), 3), (ValueError("bad"), 2)])
def test_a_failed_or_interrupted_run_leaves_earlier_results_untouched(earlier_results, tmp_path, monkeypatch, capsys,
                                                                      failure, code):
    import shutil

    import vibupdate.pipeline

    shutil.copytree(earlier_results, tmp_path, dirs_exist_ok=True)
    case, out = tmp_path / "case.toml", tmp_path / "out"
    before = snapshot(tmp_path)
    capsys.readouterr()

    def fail(*args, **kwargs):
        raise failure

    # Fails while the new files are being written, after the solve: the worst moment.
    monkeypatch.setattr(vibupdate.pipeline, "write_results", fail)
    assert main(["run", str(case), "--out", str(out)]) == code
    err = capsys.readouterr().err
    assert "Traceback" not in err and err.strip().count("\n") == 0
    assert snapshot(tmp_path) == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["case.toml", "out"]


def test_large_model_keeps_the_caughey_law_instead_of_a_dense_C(tmp_path):
    """Above 400 DOFs no dense C is built or written; the FRF plot uses the modal law."""
    import numpy as np
    from helpers import chain_model
    from vibupdate import Antiresonance, Configuration, NaturalFrequency, modes
    from vibupdate.io.case import Case, DampingOptions
    from vibupdate.modal.analysis import antiresonances
    from vibupdate.damping.models import CaugheyLaw, caughey_matrix
    from vibupdate.inverse.formulation.options import FormulationOptions
    from vibupdate.inverse.homotopy import SolverOptions
    from vibupdate.pipeline import run_case

    model = chain_model(450, ["k1", "k2", "m3"])
    x = np.array([0.05, -0.05, 0.1])
    w, _ = modes(*model.matrices(x), 4)
    nat = tuple(NaturalFrequency(v, damping_ratio=0.01 * (k + 1)) for k, v in enumerate(w[:3]))
    tip = model.dofs[-1]
    z = antiresonances(*model.matrices(x), model.n_dofs - 1, model.n_dofs - 1, n_zeros=1)
    zeros = (Antiresonance(float(z[0]), tip, tip),)   # a measured receptance: plotted
    case = Case("big", None, (Configuration("A", model, nat, zeros),), SolverOptions(), FormulationOptions(),
                DampingOptions((0.0, 1.0)))
    run_case(case, tmp_path / "out", progress=lambda m: None)
    files = sorted(p.name for p in (tmp_path / "out").iterdir())
    assert "C_A.mtx" not in files and "frf.png" in files and "M_A.mtx" in files
    # the law's modal receptance equals the direct solve with the dense C on a small model
    small = chain_model(6, ["k1"])
    M, K = small.matrices()
    law = CaugheyLaw((0.0, 1.0), (0.3, 2e-4), n_modes=6)
    omega = np.linspace(1.0, 60.0, 25)
    from vibupdate.modal.analysis import receptance

    direct = receptance(M, K, 1, 4, omega, caughey_matrix(M, K, law.exponents, law.beta))
    np.testing.assert_allclose(law.receptance(M, K, 1, 4, omega), direct, rtol=1e-8)


@pytest.mark.parametrize("exists", [False, True])
def test_write_published_stages_publishes_and_cleans_up_for_both_writers(tmp_path, exists):
    """The one stage-and-publish block of run_case and write_extraction: a writer that fails
    leaves the folder as it was and no staging folder behind; one that succeeds has its files
    moved in and listed in the manifest, replacing the previous run's."""
    import vibupdate.io.extraction_io as extraction_io
    import vibupdate.pipeline as pipeline

    out = tmp_path / "out"
    if exists:
        out.mkdir()
        (out / "old.txt").write_text("earlier run")
        (out / MANIFEST).write_text(json.dumps({"files": ["old.txt"]}))
    before = snapshot(tmp_path)

    def broken(folder):
        (folder / "half.txt").write_text("partial")
        raise RuntimeError("writer failed")

    with pytest.raises(RuntimeError, match="writer failed"):
        write_published(prepare_output(out), broken, case="c", version="v")
    assert snapshot(tmp_path) == before

    def writer(folder):
        (folder / "new.txt").write_text("this run")
        return "written"

    assert write_published(prepare_output(out), writer, case="c", version="v") == "written"
    assert sorted(p.name for p in out.iterdir()) == sorted([MANIFEST, "new.txt"])
    assert read_manifest(out) == ["new.txt"]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out"]
    # both writers of a results folder go through it
    assert pipeline.write_published is write_published
    assert "write_published" in extraction_io.write_extraction.__code__.co_names


def test_a_plot_that_fails_costs_a_note_not_the_run(tmp_path, monkeypatch, capsys):
    """results.json and the matrices come before any plot; a plot that raises is named in the
    warnings (results.json, report.md, terminal), the other files are written, exit 0."""
    import vibupdate.report.plots as plots
    from vibupdate.io.results import load_results

    def broken(*args, **kwargs):
        raise ValueError("Too many bins for data range")

    monkeypatch.setattr(plots, "plot_homotopy", broken)
    case = write_case(tmp_path)
    out = tmp_path / "out"
    assert main(["run", str(case), "--out", str(out)]) == 0
    printed = capsys.readouterr()
    note = "homotopy.png was not drawn: ValueError: Too many bins for data range"
    assert note in printed.out
    files = set(read_manifest(out))
    assert {"results.json", "report.md", "M_A.mtx", "K_A.mtx", "C_A.mtx", "frf.png"} <= files
    assert "homotopy.png" not in files and not (out / "homotopy.png").exists()
    assert note in load_results(out / "results.json").warnings
    report = (out / "report.md").read_text()
    assert note in report and "## Parameters" in report and "(homotopy.png)" not in report


def test_a_report_that_fails_leaves_a_short_report_and_the_results(tmp_path, monkeypatch, capsys):
    import vibupdate.report.document as document
    from vibupdate.io.results import load_results

    def broken(*args, **kwargs):
        raise TypeError("unsupported format string passed to NoneType.__format__")

    monkeypatch.setattr(document, "markdown_report", broken)
    case = write_case(tmp_path)
    out = tmp_path / "out"
    assert main(["run", str(case), "--out", str(out)]) == 0
    assert "report.md is a short report" in capsys.readouterr().out
    report = (out / "report.md").read_text()
    assert "could not be written (TypeError: unsupported format string" in report and "results.json" in report
    run = load_results(out / "results.json")
    assert run.success and any("report.md is a short report" in w for w in run.warnings)
    assert {"homotopy.png", "frf.png", "M_A.mtx"} <= set(read_manifest(out))


def test_ctrl_c_while_plotting_still_exits_130_with_nothing_written(earlier_results, tmp_path, monkeypatch, capsys):
    """A plot's failure is a note, an interrupt is not: Ctrl-C after results.json was written
    into the staging folder leaves the earlier results as they were."""
    import shutil

    import vibupdate.report.plots as plots

    shutil.copytree(earlier_results, tmp_path, dirs_exist_ok=True)
    before = snapshot(tmp_path)

    def interrupted(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(plots, "plot_homotopy", interrupted)
    assert main(["run", str(tmp_path / "case.toml"), "--out", str(tmp_path / "out")]) == 130
    assert "interrupted" in capsys.readouterr().err
    assert snapshot(tmp_path) == before


def test_a_second_case_needs_force_and_then_keeps_edited_and_foreign_files(tmp_path, capsys):
    """`run first --out res` then `run second --out res`: refused without --force, every file
    kept; with --force the first case's unchanged files are removed, a file the user edited
    and one the user added survive, and the run names both."""
    first = write_case(tmp_path / "first", TINY_CASE.replace('name = "A"', 'name = "left"'))
    second = write_case(tmp_path / "second", TINY_CASE.replace('case = "tiny"', 'case = "other"'))
    out = tmp_path / "res"
    assert main(["run", str(first), "--out", str(out)]) == 0
    written = read_manifest(out)
    assert {"M_left.mtx", "K_left.mtx", "results.json"} <= set(written)
    hashes = json.loads((out / MANIFEST).read_text())["sha256"]
    assert sorted(hashes) == sorted(written) and all(len(h) == 64 for h in hashes.values())
    before = snapshot(out)
    capsys.readouterr()
    assert main(["run", str(second), "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert "results of case 'tiny'" in err and "--force" in err
    assert snapshot(out) == before
    with open(out / "K_left.mtx", "a") as f:
        f.write("% checked by hand\n")
    (out / "thesis.tex").write_text("\\chapter{Results}\n")
    assert main(["run", str(second), "--out", str(out), "--force"]) == 0
    printed = capsys.readouterr().out
    assert "kept in" in printed and "thesis.tex" in printed and "K_left.mtx" in printed
    assert (out / "K_left.mtx").read_text().endswith("% checked by hand\n")
    assert (out / "thesis.tex").exists()
    assert not (out / "M_left.mtx").exists()         # unchanged since the first run wrote it: removed
    assert set(read_manifest(out)) >= {"M_A.mtx", "results.json"} and "K_left.mtx" not in read_manifest(out)
    assert json.loads((out / "results.json").read_text())["case"] == "other"


def test_an_extraction_of_other_files_into_the_same_folder_needs_force(tmp_path, capsys):
    import numpy as np
    from frf_synthetic import measured

    frfs, *_ = measured(8, repeats=1)
    for name in ("first.npz", "second.npz"):
        np.savez(tmp_path / name, freq_hz=frfs.freq_hz, H=np.stack([h[0] for h in frfs.H], axis=1))

    def extract(table, *extra):
        return main(["extract", str(tmp_path / table), "--responses", "y1", "y2", "y3", "--excitations", "y3",
                     "--band", "20", "300", "--no-plot", "--out", str(tmp_path / "ex"), *extra])

    assert extract("first.npz") == 0
    assert extract("first.npz") == 0                     # the same extraction again: replaced, no --force
    before = snapshot(tmp_path / "ex")
    capsys.readouterr()
    assert extract("second.npz") == 2
    assert "results of case 'extraction of first.npz'" in capsys.readouterr().err
    assert snapshot(tmp_path / "ex") == before
    assert extract("second.npz", "--force") == 0
