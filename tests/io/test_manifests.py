"""One manifest per command: no command removes or replaces a file another command wrote, or
a file the case reads; folders with the older shared manifest are read conservatively."""

import json

import numpy as np
import pytest
from helpers import CHAIN_CASE, write_chain_matrices
from outputs_helpers import TINY_CASE, snapshot, write_case

from vibupdate.cli import main
from vibupdate.io.outputs import (
    LEGACY_MANIFEST,
    MANIFEST,
    manifest_name,
    prepare_output,
    write_published,
)
from vibupdate.io.manifests import read_manifest, read_manifests

EXTRACTION = ("extraction.json", "frequencies.csv", "shapes.csv", "damping.csv", "configuration.toml")


def _extraction_folder(folder, legacy: bool):
    """A folder as `vibupdate extract` leaves it, with the natural frequencies of the tiny case
    in frequencies.csv; ``legacy``: with the shared manifest the extract of earlier versions
    wrote (no command recorded), else with the manifest of ``extract``."""
    folder.mkdir(parents=True, exist_ok=True)
    texts = {"extraction.json": "{}\n", "shapes.csv": "mode,dof,lower,upper\n", "damping.csv": "mode,hz\n",
             "configuration.toml": "[[configuration]]\n",
             "frequencies.csv": "kind,hz,weight,damping_ratio\nnatural,37.3397,1,0.02\nnatural,234.7489,1,0.01\n"}
    if legacy:
        for name, text in texts.items():
            (folder / name).write_text(text)
        (folder / LEGACY_MANIFEST).write_text(json.dumps({"vibupdate": "0.1.0", "case": "extraction",
                                                          "files": sorted(texts)}))
    else:
        def write(staged):
            for name, text in texts.items():
                (staged / name).write_text(text)

        write_published(prepare_output(folder, command="extract"), write, case="extraction", version="0.1.0")
    return folder


#: The tiny case reading its frequencies from the extraction beside it.
READS_EXTRACTION = TINY_CASE.replace('natural_hz = [37.3397, 234.7489]\ndamping_ratios = [0.02, 0.01]\n',
                                     'frequencies_csv = "frequencies.csv"\n')


@pytest.mark.parametrize("legacy", [True, False])
def test_a_run_beside_the_extraction_its_case_reads_keeps_the_extraction(tmp_path, capsys, legacy):
    folder = _extraction_folder(tmp_path / "measured", legacy)
    case = write_case(folder, READS_EXTRACTION)
    extraction = {k: v for k, v in snapshot(folder).items() if k in EXTRACTION}
    assert main(["run", str(case), "--out", str(folder)]) == 2
    err = capsys.readouterr().err
    assert "written by `vibupdate extract`" in err and "--force" in err
    for _ in range(2):   # the case can run again: nothing it reads was removed
        assert main(["run", str(case), "--out", str(folder), "--force"]) == 0
        now = snapshot(folder)
        assert {k: now[k] for k in EXTRACTION} == extraction and "case.toml" in now
        assert {"results.json", "report.md", "M_A.mtx"} <= set(read_manifest(folder))
        assert not set(read_manifest(folder)) & set(EXTRACTION)
    assert sorted(read_manifests(folder)["extract"]) == sorted(EXTRACTION)


@pytest.mark.parametrize("legacy", [True, False])
def test_extract_force_into_a_results_folder_keeps_every_file_of_the_run(tmp_path, capsys, legacy):
    from frf_synthetic import measured

    case = write_case(tmp_path)
    out = tmp_path / "results"
    assert main(["run", str(case), "--out", str(out)]) == 0
    run_files = read_manifest(out)
    assert len(run_files) >= 7
    if legacy:   # as earlier versions wrote it: one shared manifest, no command recorded
        data = json.loads((out / MANIFEST).read_text())
        del data["command"]
        (out / LEGACY_MANIFEST).write_text(json.dumps(data))
        (out / MANIFEST).unlink()
    before = snapshot(out)
    frfs, *_ = measured(8, repeats=1)
    assert {c for _, c in frfs.pairs} == {"y3"}
    table = tmp_path / "frf.npz"
    np.savez(table, freq_hz=frfs.freq_hz, H=np.stack([h[0] for h in frfs.H], axis=1))
    capsys.readouterr()
    args = ["extract", str(table), "--responses", *[r for r, _ in frfs.pairs], "--excitations", "y3",
            "--band", "20", "300", "--out", str(out), "--no-plot"]
    assert main(args) == 2
    assert "written by `vibupdate run`" in capsys.readouterr().err
    assert main(args + ["--force"]) == 0, capsys.readouterr().err
    now = snapshot(out)
    assert {k: now[k] for k in before} == before          # every file of the run, as it was
    assert sorted(read_manifest(out, "extract")) == sorted(EXTRACTION)
    assert sorted(read_manifest(out)) == sorted(run_files)
    # and a later run into the folder keeps the extraction
    extraction = {k: now[k] for k in EXTRACTION}
    assert main(["run", str(case), "--out", str(out), "--force"]) == 0
    assert {k: snapshot(out)[k] for k in EXTRACTION} == extraction
    assert not (out / LEGACY_MANIFEST).exists()            # the run took its legacy files over


def test_a_run_never_replaces_a_file_its_case_reads(tmp_path, capsys):
    """A case whose nominal model is the updated matrices of an earlier run in the same folder:
    the new run would replace them, so it is refused and the folder left as it was."""
    folder = tmp_path / "chain"
    folder.mkdir()
    write_chain_matrices(folder)
    first = folder / "case.toml"
    first.write_text(CHAIN_CASE + "natural_hz = [3.0, 8.4]\n")
    assert main(["run", str(first), "--out", str(folder), "--force"]) in (0, 1)
    assert {"M_only.mtx", "K_only.mtx"} <= set(read_manifest(folder))
    second = folder / "again.toml"
    second.write_text(first.read_text().replace('"M0.mtx"', '"M_only.mtx"').replace('"K0.mtx"', '"K_only.mtx"'))
    before = snapshot(folder)
    capsys.readouterr()
    assert main(["run", str(second), "--out", str(folder), "--force"]) == 2
    err = capsys.readouterr().err
    assert "K_only.mtx, M_only.mtx, which this case reads" in err
    assert snapshot(folder) == before


def test_an_unknown_legacy_manifest_keeps_its_files(tmp_path):
    """A shared manifest that does not say which command wrote it: its files are nobody's."""
    out = tmp_path / "out"
    out.mkdir()
    (out / "a.txt").write_text("a")
    (out / LEGACY_MANIFEST).write_text(json.dumps({"files": ["a.txt"]}))
    for command in ("run", "extract", "sweep", "batch"):
        with pytest.raises(ValueError, match="a.txt written by an earlier vibupdate"):
            prepare_output(out, command=command)
        target = prepare_output(out, command=command, force=True)
        assert target.owned == () and "a.txt" in target.foreign
        write_published(target, lambda staged: (staged / f"{command}.txt").write_text(command), case="c",
                        version="v")
        assert (out / "a.txt").read_text() == "a" and (out / LEGACY_MANIFEST).exists()
    assert {c: read_manifest(out, c) for c in ("run", "extract", "sweep", "batch")} == {
        c: [f"{c}.txt"] for c in ("run", "extract", "sweep", "batch")}
    assert sorted(p.name for p in out.iterdir()) == sorted(
        ["a.txt", LEGACY_MANIFEST, *(f"{c}.txt" for c in ("run", "extract", "sweep", "batch")),
         *(manifest_name(c) for c in ("run", "extract", "sweep", "batch"))])


def test_batch_never_overwrites_a_summary_it_did_not_write(tmp_path, capsys):
    case = write_case(tmp_path / "cases")
    out = tmp_path / "batch"
    out.mkdir()
    (out / "summary.md").write_text("my summary")
    assert main(["batch", str(case), "--out", str(out)]) == 2     # refused before any work
    assert "summary.md, which `vibupdate batch` did not write" in capsys.readouterr().err
    assert sorted(p.name for p in out.iterdir()) == ["summary.md"]
    assert (out / "summary.md").read_text() == "my summary"


@pytest.mark.parametrize("stop", [None, ValueError, KeyboardInterrupt])
def test_files_written_in_place_get_the_hash_of_their_final_content_however_the_command_ends(tmp_path, stop):
    from vibupdate.io.manifests import file_hash
    from vibupdate.io.outputs import written_in_place

    (tmp_path / "earlier.csv").write_text("an earlier run's rows\n")
    with written_in_place(tmp_path, "sweep", case="c", version="0.1.0", files=["earlier.csv"]):
        pass
    (tmp_path / "earlier.csv").write_text("edited by the user since\n")

    def work():
        with written_in_place(tmp_path, "sweep", case="c", version="0.1.0", files=["rows.csv", "gone.csv"]) as listed:
            (tmp_path / "rows.csv").write_text("header\n")
            (tmp_path / "gone.csv").write_text("x")
            listed.add("late.json")
            (tmp_path / "late.json").write_text("{}")
            with open(tmp_path / "rows.csv", "a") as f:   # grows after it was listed
                f.write("row 1\n")
            (tmp_path / "gone.csv").unlink()
            if stop is not None:
                raise stop("stopped")

    if stop is None:
        work()
    else:
        with pytest.raises(stop):
            work()
    manifest = json.loads((tmp_path / manifest_name("sweep")).read_text())
    assert manifest["files"] == ["earlier.csv", "late.json", "rows.csv"]
    # this session's files: their final content; an earlier session's: what that one wrote,
    # so the user's edit of it is seen
    assert manifest["sha256"]["rows.csv"] == file_hash(tmp_path / "rows.csv")
    assert manifest["sha256"]["late.json"] == file_hash(tmp_path / "late.json")
    assert manifest["sha256"]["earlier.csv"] != file_hash(tmp_path / "earlier.csv")
    assert prepare_output(tmp_path, command="sweep", force=True).changed == ("earlier.csv",)
