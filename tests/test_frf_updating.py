"""From FRFs to the updated model: measured intervals feed the updating.

Frequency intervals (e.g. extracted from FRFs) are the per-datum tolerances of the
consistent parameter ranges; damping-ratio intervals give the damping fit's weights
``1 / half-width^2``. Known truths written here.
"""

import numpy as np
import pytest

from helpers import chain_model
from vibupdate import Antiresonance, Configuration, NaturalFrequency, antiresonances, modes
from vibupdate.io.case import Case, DampingOptions
from vibupdate.damping.stage import identify_damping
from vibupdate.inverse.formulation.options import FormulationOptions
from vibupdate.inverse.homotopy import SolverOptions
from vibupdate.ranges.identifiability import parameter_ranges
from vibupdate.pipeline import damping_stage, frequency_windows


def _chain(truth, tol=None, damping=None, damping_half=None):
    """Three-storey chain, its frequencies and the zeros of h11 as data; intervals of
    relative half-width ``tol`` when given."""
    model = chain_model(3, ["k1", "k2", "k3"])
    M, K = model.matrices(truth)
    omega, _ = modes(M, K)
    zeros = antiresonances(M, K, 0, 0)

    def iv(w):
        return None if tol is None else (w * (1 - tol), w * (1 + tol))

    nat = []
    for k, w in enumerate(omega):
        xi = None if damping is None else damping[k]
        di = None if damping_half is None else (xi - damping_half[k], xi + damping_half[k])
        nat.append(NaturalFrequency(w, interval=iv(w), damping_ratio=xi, damping_interval=di))
    zs = tuple(Antiresonance(z, "y1", "y1", interval=iv(z)) for z in zeros)
    return model, Configuration("C", model, tuple(nat), zs)


def test_frequency_intervals_are_the_per_datum_tolerances_of_the_ranges():
    truth = np.array([0.1, -0.05, 0.08])
    _, plain = _chain(truth)
    _, with_intervals = _chain(truth, tol=2e-3)
    by_tolerance = parameter_ranges([plain], truth, frequency_tolerance=2e-3)
    by_intervals = parameter_ranges([with_intervals], truth, frequency_tolerance=0.5)  # unused: all have intervals
    np.testing.assert_allclose(by_intervals.lower, by_tolerance.lower, rtol=1e-6)
    np.testing.assert_allclose(by_intervals.upper, by_tolerance.upper, rtol=1e-6)
    assert np.all(by_tolerance.width_pct > 0)
    _, wider = _chain(truth, tol=4e-3)
    widths = parameter_ranges([wider], truth).width_pct
    # twice as wide to first order; the ends followed along the bent set add the rest (measured
    # 2.012, 2.011 and 2.004 times; exactly 2 while the ranges were the tangent's alone)
    assert np.all(widths > 1.99 * by_tolerance.width_pct) and np.all(widths < 2.05 * by_tolerance.width_pct)


def test_damping_intervals_weigh_the_damping_fit_and_are_stated():
    truth = np.zeros(3)
    xi, half = [0.010, 0.012, 0.030], [1e-4, 1e-4, 5e-3]
    _, cfg = _chain(truth, damping=xi, damping_half=half)
    case = Case("c", None, (cfg,), SolverOptions(), FormulationOptions(), DampingOptions(relative=True))
    stage, _, info = damping_stage(case, truth, lambda message: None)
    expected = identify_damping([cfg], truth, (0.0, 1.0), 1 / np.array(half) ** 2)
    np.testing.assert_allclose(stage.caughey.beta, expected.caughey.beta, rtol=1e-9)
    unweighted = identify_damping([cfg], truth, (0.0, 1.0), None)
    assert not np.allclose(stage.caughey.beta, unweighted.caughey.beta, rtol=1e-3)
    # the precise ratios are fitted closely, the loose third one gives way
    errors = stage.caughey.errors_pct
    assert errors[0] < errors[2] and errors[1] < errors[2]
    assert "half-width of the measured ratio's interval (mode 1: 0.0001" in info["weights_text"]
    assert "relative = true is superseded" in info["weights_text"]
    # one ratio without an interval: the case's weighting applies to all
    _, partial = _chain(truth, damping=xi)
    case = Case("c", None, (partial,), SolverOptions(), FormulationOptions(), None)
    _, _, info = damping_stage(case, truth, lambda message: None)
    assert info["weights_text"].startswith("W_ii = w_mode with")


def test_frequency_windows_text_names_the_source():
    _, cfg = _chain(np.zeros(3), tol=1e-3)
    case = Case("c", None, (cfg,), SolverOptions(), FormulationOptions(), None, frequency_tolerance=0.01)
    assert frequency_windows(case) == "the half-width of its measured interval (5 of 5 frequencies)"
    _, plain = _chain(np.zeros(3))
    case = Case("c", None, (plain,), SolverOptions(), FormulationOptions(), None, frequency_tolerance=0.01)
    assert frequency_windows(case) == "1 % of each frequency"


@pytest.mark.slow   # four whole runs, about 26 s: in CI's second step (pytest -m slow)
@pytest.mark.parametrize("weighed", [False, True], ids=["shapes", "mass-normalized shapes"])
def test_the_csv_route_and_the_frf_route_give_the_same_verdict_and_parameters(tmp_path, capsys, weighed):
    """The tables `extract` writes carry every interval the FRF route gives (frequency, damping
    ratio, zero numbers, shapes), so a case reading them is held to the same measurement
    intervals and weighs its data the same: same status, same checks, same parameters; with
    ``mass_normalized_shapes`` too, where the modal masses are data (the ``modal_mass`` check)."""
    import json

    from vibupdate.cli import main

    from frf_synthetic import cantilever_frf_case

    head, frf_case = cantilever_frf_case(tmp_path)
    if weighed:
        head += "mass_normalized_shapes = true\n"
        frf_case = head + frf_case[len(head) - len("mass_normalized_shapes = true\n"):]
    (tmp_path / "frf.toml").write_text(frf_case)
    assert main(["extract", str(tmp_path / "hits.uff"), "--band", "20", "300", "--out", str(tmp_path / "ex"),
                 "--no-plot"]) == 0
    (tmp_path / "csv.toml").write_text(head + 'frequencies_csv = "ex/frequencies.csv"\n'
                                       'mode_shapes_csv = "ex/shapes.csv"\n')
    from vibupdate.io.case import load_case

    by_frf, by_csv = (load_case(tmp_path / f"{name}.toml").configurations[0] for name in ("frf", "csv"))
    for a, b in zip((*by_frf.natural, *by_frf.antiresonances), (*by_csv.natural, *by_csv.antiresonances),
                    strict=True):   # equal to the Hz -> rad/s rounding
        np.testing.assert_allclose((b.omega, *b.interval), (a.omega, *a.interval), rtol=1e-14)
        assert getattr(a, "index", None) == getattr(b, "index", None)
    for a, b in zip(by_frf.natural, by_csv.natural):
        assert (a.mode, a.damping_ratio, a.damping_interval, a.shape) == (b.mode, b.damping_ratio,
                                                                          b.damping_interval, b.shape)
    codes, docs = [], []
    for name in ("frf", "csv"):
        codes.append(main(["run", str(tmp_path / f"{name}.toml"), "--out", str(tmp_path / f"out_{name}")]))
        docs.append(json.loads((tmp_path / f"out_{name}" / "results.json").read_text()))
    capsys.readouterr()
    frf, csv = docs
    assert codes[0] == codes[1]
    assert frf["solver"]["status"] == csv["solver"]["status"]
    assert [(c["name"], c["passed"], c.get("limited_by")) for c in frf["solver"]["checks"]] == \
        [(c["name"], c["passed"], c.get("limited_by")) for c in csv["solver"]["checks"]]
    assert weighed == any(c["name"] == "modal_mass" for c in frf["solver"]["checks"])
    if weighed:   # each mode's modal mass reported, typed on reloading, and in the report
        from vibupdate.io.results import ModalMassRow, load_results

        rows = load_results(tmp_path / "out_frf" / "results.json").modal_masses
        assert len(rows) == len(frf["frequencies"]) - sum(r["kind"] == "antiresonance" for r in frf["frequencies"])
        assert all(isinstance(r, ModalMassRow) and r.measured_lower_kg < r.measured_upper_kg for r in rows)
        assert "## Modal masses" in (tmp_path / "out_frf" / "report.md").read_text()
    else:
        assert frf.get("modal_masses", []) == []
    a = np.array([p["updated"] for p in frf["parameters"]])
    b = np.array([p["updated"] for p in csv["parameters"]])
    np.testing.assert_allclose(b, a, rtol=1e-6)


def test_mass_normalized_shapes_without_a_driving_point_exit_2_naming_the_key(tmp_path, capsys):
    """Transfer FRFs alone give shapes scaled to their largest entry, not mass-normalized: a
    case that says they are is refused, naming the key and the FRFs, and nothing is written."""
    from vibupdate.cli import main

    from frf_synthetic import cantilever_frf_case, measured, write_uff

    head, frf_case = cantilever_frf_case(tmp_path)
    write_uff(tmp_path / "hits.uff", measured(9, repeats=3, pairs=(("y1", "y3"), ("y2", "y3")))[0])
    (tmp_path / "case.toml").write_text(head + "mass_normalized_shapes = true\n" + frf_case[len(head):])
    assert main(["run", str(tmp_path / "case.toml"), "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert "mass_normalized_shapes: the extracted shapes are not mass-normalized" in err
    assert "h_y1,y3, h_y2,y3" in err and not (tmp_path / "out").exists()
