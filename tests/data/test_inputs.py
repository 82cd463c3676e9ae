"""Checks of measured FRF input as labs produce it: impact tests with an exponential window,
implausible FRF kinds, zeros at the noise floor, repeated labels and mismatched axes.
Known truth from ``tests/frf_synthetic.py``; the Southampton data read from outside the
repository as in ``test_extraction.py``."""

import json
import math

import numpy as np
import pytest

from frf_synthetic import FRAME_PAIRS, frame_system, impact_measured, true_poles
from vibupdate.cli import main
from vibupdate.data.extraction import extract

BAND = (2 * math.pi * 3.0, 2 * math.pi * 28.0)


def _write_npz(folder, frfs, kind="accelerance"):
    """One npz file per excitation of ``frfs`` (the mean of the repeats, in ``kind``), columns
    in the order of its responses; returns the paths and the excitations."""
    power = {"receptance": 0, "mobility": 1, "accelerance": 2}[kind]
    mean = frfs.mean() * (1j * frfs.omega[None]) ** power
    paths, excitations = [], []
    for exc in dict.fromkeys(c for _, c in frfs.pairs):
        cols = [k for k, (_, c) in enumerate(frfs.pairs) if c == exc]
        path = folder / f"exc_{exc}.npz"
        np.savez(path, freq_hz=frfs.freq_hz, H=mean[cols].T)
        paths.append(str(path))
        excitations.append(exc)
    return paths, excitations


# ----------------------------------------------------------------------------- impact tests

@pytest.fixture(scope="module")
def impact():
    """Hammer tests of the frame, 2 % exponential window, one hit per pair, 2 % sensor noise."""
    return [impact_measured(seed, decay=0.02, repeats=1, noise=0.02)[0] for seed in range(3)]


def test_exponential_window_is_modelled_and_the_damping_ratios_are_the_structures(impact):
    """Known truth in the time domain (response windowed, FFT, over the force's): modelled, the
    damping ratios are within their intervals (measured on 20 seeds: coverage 0.98, errors
    rms 1.0 / 0.35 / 0.23 %); fitted as they are, they read high by 1/(tau w_n), +148, +59,
    +36 %, far outside."""
    wn, zeta = true_poles(*frame_system()[:3])
    tau = 32.0 / -math.log(0.02)
    hits = []
    for frfs in impact:
        plain = extract(frfs, band=BAND, n_modes=3)
        result = extract(frfs, band=BAND, n_modes=3, window="exponential", window_decay=0.02)
        assert result.window == "exponential" and result.window_tau == pytest.approx(tau)
        for m, p, w, z in zip(result.modes, plain.modes, wn, zeta):
            hits.append(m.damping_interval[0] <= z <= m.damping_interval[1])
            assert abs(m.damping_ratio / z - 1) < 0.03
            assert p.damping_ratio == pytest.approx(z + 1 / (tau * w), rel=0.03)   # the first-order shift
            assert not p.damping_interval[0] <= z <= p.damping_interval[1]
        notes = result.notes()
        assert any("exponential window of tau = 8.18 s" in n and "mode 1: 0.299 %" in n for n in notes), notes
        assert not any("half-power" in n for n in notes)            # no Hann note for an impact test
        same = extract(frfs, band=BAND, n_modes=3, window="exponential", window_tau=tau)
        assert [m.damping_ratio for m in same.modes] == pytest.approx([m.damping_ratio for m in result.modes])
    assert sum(hits) >= 8, hits   # 95 % intervals: one miss in nine is expected now and then (seed 2, mode 2)


def test_force_window_is_declared_and_not_modelled(impact):
    plain = extract(impact[0], band=BAND, n_modes=3)
    force = extract(impact[0], band=BAND, n_modes=3, window="force")
    assert force.window == "force" and force.record_s == 0.0
    assert [m.damping_ratio for m in force.modes] == [m.damping_ratio for m in plain.modes]
    assert not any("half-power" in n for n in force.notes())
    assert any("half-power" in n for n in plain.notes())


@pytest.mark.parametrize("kwargs, message", [
    ({"window": "exponential"}, "needs its decay: window_decay"),
    ({"window": "exponential", "window_decay": 1.5}, "in (0, 1), got 1.5"),
    ({"window": "exponential", "window_tau": -2.0}, "positive time constant (s), got -2.0"),
    ({"window": "exponential", "window_tau": 2.0, "window_decay": 0.1}, "one of them"),
    ({"window": "hann", "window_decay": 0.1}, "but window = 'hann'"),
])
def test_exponential_window_bad_arguments_are_clear_errors(impact, kwargs, message):
    with pytest.raises(ValueError, match=None) as err:
        extract(impact[0], band=BAND, n_modes=3, **kwargs)
    assert message in str(err.value)


def test_cli_exponential_window(impact, tmp_path, capsys):
    paths, excitations = _write_npz(tmp_path, impact[0])
    base = ["extract", *paths, "--responses", "x1", "x2", "x3", "--excitations", *excitations, "--kind",
            "accelerance", "--band", "3", "28", "--modes", "3", "--no-plot", "--window", "exponential"]
    out = tmp_path / "ex"
    assert main(base + ["--out", str(out)]) == 2
    assert "needs its decay" in capsys.readouterr().err and not out.exists()
    assert main(base + ["--window-decay", "0.02", "--out", str(out)]) == 0
    printed = capsys.readouterr().out
    assert "note: exponential window of tau = 8.18 s" in printed
    doc = json.loads((out / "extraction.json").read_text())
    assert doc["window"] == "exponential" and doc["window_tau_s"] == pytest.approx(32.0 / -math.log(0.02))
    zeta = true_poles(*frame_system()[:3])[1]
    for n, z in zip(doc["natural"], zeta):
        assert n["damping_ratio_interval"][0] <= z <= n["damping_ratio_interval"][1]
