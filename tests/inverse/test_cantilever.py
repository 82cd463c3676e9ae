"""The rebuilt cantilever of paper test case 2 (Section 5.3, Tables 5-7)."""

import numpy as np
import pytest

from vibupdate import Antiresonance, Configuration, NaturalFrequency, ShapeInterval
from vibupdate.inverse.correlation import model_frequencies, percent_error
from vibupdate.examples import cantilever, read_table


def test_nominal_frequencies_close_to_the_paper_nominal_column():
    configurations = cantilever.configurations()
    table = read_table("cantilever_frequencies.csv")
    ours, paper = [], []
    for cfg in configurations:
        freqs = model_frequencies(cfg)
        rows = [r for r in table if r["configuration"] == cfg.name]
        paper += [float(r["paper_nominal_hz"]) for r in rows if r["kind"] == "natural"]
        paper += [float(r["paper_nominal_hz"]) for r in rows if r["kind"] == "antiresonance"]
        ours += list(freqs.natural / 2 / np.pi) + list(freqs.antiresonances / 2 / np.pi)
    assert len(ours) == 16
    errors = percent_error(ours, paper)
    # measured 1.04 % (largest 2.87 %): the rebuilt model is deterministic, the margin is the
    # printed digit
    assert errors.mean() <= 1.05, f"mean {errors.mean():.2f} % against the paper's nominal model"


def test_proof_mass_at_y1_or_y3_leaves_the_antiresonance_unchanged():
    """Evidence for the proof-mass placement (docs/method.md, appendix): B and C keep the 94.8 Hz zero."""
    z = {c.name: model_frequencies(c).antiresonances[0] for c in cantilever.configurations()}
    assert z["B"] == pytest.approx(z["A"], rel=1e-9)
    assert z["C"] == pytest.approx(z["A"], rel=1e-9)
    assert abs(z["D"] / z["A"] - 1) > 0.02


def test_shipped_tables_are_complete():
    configurations = cantilever.configurations()
    assert [c.name for c in configurations] == ["A", "B", "C", "D"]
    assert sum(len(c.natural) for c in configurations) == 12
    assert sum(len(c.antiresonances) for c in configurations) == 4
    assert all(f.damping_ratio is not None for c in configurations for f in c.natural)
    assert configurations[0].natural[0].freq_hz == pytest.approx(73.4)


def test_bad_measured_data_are_named():
    model = cantilever.configurations()[0].model
    f = NaturalFrequency.from_hz(70.0)
    with pytest.raises(ValueError, match="DOF 'y9' does not exist"):
        Configuration("A", model, (f,), (Antiresonance.from_hz(100.0, "y9", "y3"),))
    with pytest.raises(ValueError, match="mode 1: DOF 'z3' does not exist"):
        Configuration("A", model, (NaturalFrequency.from_hz(70.0, shape=ShapeInterval({"z3": (0, 1)})),))
    with pytest.raises(ValueError, match="lower 0.2 > upper 0.1"):
        ShapeInterval({"y3": (0.2, 0.1)})
    with pytest.raises(ValueError, match="positive and finite, got nan"):
        NaturalFrequency.from_hz(float("nan"))
    with pytest.raises(ValueError, match=r"positive and finite, got -3"):
        NaturalFrequency.from_hz(-3.0)
    with pytest.raises(ValueError, match="must not fall"):
        Configuration("A", model, (NaturalFrequency.from_hz(80.0), f))
    with pytest.raises(ValueError, match="damping ratio must be a finite number >= 0"):
        NaturalFrequency.from_hz(70.0, damping_ratio=-0.01)
