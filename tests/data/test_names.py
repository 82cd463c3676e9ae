"""One name per measured datum (`vibupdate.data.names`): the model mode with the measured
position where they differ, a zero by its receptance and index, the same in the tables of a
run, in its messages and in what `extract` prints."""

import re
from types import SimpleNamespace

import numpy as np
import pytest
from frf_synthetic import measured
from helpers import chain_model
from outputs_helpers import TINY_CASE

from vibupdate import Configuration, NaturalFrequency, modes
from vibupdate.data.measured import Antiresonance
from vibupdate.data.names import frequency_name, mode_column, mode_name, receptance_name, zero_column, zero_name
from vibupdate.inverse.correlation import frequency_rows, model_frequencies
from vibupdate.io.results import FrequencyRow


def test_the_names():
    assert mode_name(3) == "mode 3" and mode_name(3, 3) == "mode 3"
    assert mode_name(3, 1) == "mode 3 (measured 1)"
    assert receptance_name("y1", "y3") == "h_y1,y3"
    assert zero_name("y1", "y1", 4) == "zero 4 of h_y1,y1" and zero_name("y1", "y1", None) == "a zero of h_y1,y1"


def test_the_column_names_hold_no_blank_and_no_comma():
    assert mode_column("A", 3) == "A:mode3_hz" and mode_column("A", 3, "xi") == "A:mode3_xi"
    assert zero_column("A", "y1", "y3", 4) == "A:zero4_h_y1/y3_hz"


def _higher_modes():
    """A chain whose data are its modes 2 and 3 (measured 1 and 2), zero 2 of its first DOF's
    driving point and zero 1 of its second's, listed in that order; the model's own values, so the pairing is not in doubt."""
    model = chain_model(3, ["k1"])
    w, _ = modes(*model.matrices())
    from vibupdate.modal.analysis import antiresonances

    M, K = model.matrices()
    z11 = antiresonances(M, K, 0, 0)
    z22 = antiresonances(M, K, 1, 1)
    cfg = Configuration("A", model, (NaturalFrequency(float(w[1]), mode=2), NaturalFrequency(float(w[2]), mode=3)),
                        (Antiresonance(float(z11[1]), model.dofs[0], model.dofs[0], index=2,
                                       interval=(0.99 * z11[1], 1.01 * z11[1])),
                         Antiresonance(float(z22[0]), model.dofs[1], model.dofs[1], index=1)))
    return cfg


def test_the_frequency_table_names_the_model_mode_the_measured_position_and_the_zero_s_receptance():
    """The bundled bar's table said "natural 1-4" for its model modes 3-6 and "antiresonance 5"
    for a zero of h_y1,y1: each row now names the model mode (with the measured position
    where it differs) or the zero and its receptance, with the measured interval."""
    from vibupdate.report.document import frequency_table

    cfg = _higher_modes()
    rows = frequency_rows([cfg], [model_frequencies(cfg)])
    d1, d2 = cfg.model.dofs[0], cfg.model.dofs[1]
    assert [r["name"] for r in rows] == ["mode 2 (measured 1)", "mode 3 (measured 2)", f"zero 2 of h_{d1},{d1}",
                                         f"zero 1 of h_{d2},{d2}"]
    run = SimpleNamespace(frequencies=tuple(FrequencyRow.from_dict(r) for r in rows), paper=None)
    table = frequency_table(run)
    cells = table.cells()
    assert [c[1] for c in cells] == [r["name"] for r in rows]
    lo, hi = (v / (2 * np.pi) for v in cfg.antiresonances[0].interval)
    assert cells[2][3] == f"[{lo:.6g}, {hi:.6g}]" and cells[0][3] == "-"
    assert frequency_name(rows[2]) == rows[2]["name"]   # the table and results.json say the same


def test_the_damping_and_modal_mass_tables_use_the_model_mode():
    """A damping ratio measured for the first measured frequency, model mode 2, is labelled by
    the damping stage with mode 2, and its table row says "mode 2 (measured 1)"."""
    from vibupdate.damping.stage import damping_data
    from vibupdate.report.document import damping_table

    cfg = _higher_modes()
    damped = Configuration("A", cfg.model, (NaturalFrequency(cfg.natural[0].omega, mode=2, damping_ratio=0.01),
                                            cfg.natural[1]), cfg.antiresonances)
    _, _, labels = damping_data([damped])
    assert labels == (("A", 2),)
    rows = frequency_rows([damped], [model_frequencies(damped)])
    row = SimpleNamespace(configuration="A", mode=2, measured=0.01, rayleigh=0.01, error_rayleigh_pct=0.0,
                          identified=0.01, error_pct=0.0)
    run = SimpleNamespace(frequencies=tuple(FrequencyRow.from_dict(r) for r in rows), paper=None, damping=(row,),
                          damping_model=None)
    assert damping_table(run).cells()[0][1] == "mode 2 (measured 1)"


def test_extract_and_run_name_a_zero_alike(tmp_path, monkeypatch, capsys):
    """`extract` said "zero 4 of h(y1,y1)" where the run said "antiresonance 5": both now name
    each zero of the same FRFs by its receptance and its index, and agree on every one."""
    from vibupdate.cli import main
    from vibupdate.io.case import load_case

    frfs, *_ = measured(8, repeats=1)
    np.savez(tmp_path / "frf.npz", freq_hz=frfs.freq_hz, H=np.stack([h[0] for h in frfs.H], axis=1))
    monkeypatch.chdir(tmp_path)
    assert main(["extract", "frf.npz", "--responses", "y1", "y2", "y3", "--excitations", "y3", "--band", "20", "300",
                 "--no-plot", "--out", "ex"]) == 0
    printed = dict((m.group(1), float(m.group(2))) for m in
                   re.finditer(r"^  (zero \d+ of h_\w+,\w+): ([\d.]+) Hz", capsys.readouterr().out, re.MULTILINE))
    assert len(printed) >= 2, printed
    typed = ('natural_hz = [37.3397, 234.7489]\ndamping_ratios = [0.02, 0.01]\n'
             'antiresonances = [{ hz = 164.0447, response = "y1", excitation = "y1" }]\n')
    assert typed in TINY_CASE
    (tmp_path / "frf.toml").write_text(TINY_CASE.replace(typed, 'frf = { files = ["frf.npz"], responses = ["y1", '
                                                                '"y2", "y3"], excitations = ["y3"] }\n'))
    cfg = load_case(tmp_path / "frf.toml").configurations[0]
    rows = frequency_rows([cfg], [model_frequencies(cfg)])
    named = {r["name"]: r["measured_hz"] for r in rows if r["kind"] == "antiresonance"}
    assert set(named) == set(printed)
    for name, hz in printed.items():
        assert named[name] == pytest.approx(hz, abs=1e-4), name
