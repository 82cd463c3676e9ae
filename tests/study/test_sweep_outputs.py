"""The files of a sweep, of `run --samples` and of a batch: the histogram bins come from the
data's spread (identical samples do not stop it), and a plot that fails is a note, never the
sweep or the run."""

import json
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from sweep_cases import write_chain_case
from vibupdate.report.sweep_plots import histogram_bins, plot_histograms


def _document(values, lower, upper):
    return {"samples": len(values), "verified": len(values), "unverified": 0, "failed": 0,
            "parameters": [{"name": "m", "unit": "kg", "lower": lower, "upper": upper, "nominal": 0.5 * (lower + upper),
                            "spread_of_bounds": None}]}


def test_identical_samples_at_a_bound_make_a_histogram(tmp_path):
    """The README sweep of the cantilever: every verified mlc at its lower bound 0.0853 (to
    6e-17), which equal-width bins over the data's range cannot resolve."""
    values = [0.0853, 0.0853, 0.08530000000000006, 0.0853, 0.0853, 0.08530000000000004]
    rows = [{"index": i, "outcome": "verified", "p:m": v} for i, v in enumerate(values)]
    path = plot_histograms(tmp_path / "hist.png", _document(values, 0.0853, 0.4997), rows)
    assert path.read_bytes().startswith(b"\x89PNG")
    assert histogram_bins(values, 0.0853, 0.4997)[0] == 1


@settings(max_examples=200, deadline=None)
@given(center=st.floats(-1e12, 1e12, allow_nan=False), spread=st.sampled_from([0.0, 1e-17, 1e-12, 1e-6, 1e-3, 1.0]),
       n=st.integers(1, 40), width=st.sampled_from([0.0, 1e-9, 1.0, 1e6]), seed=st.integers(0, 9))
def test_the_bins_are_resolvable_for_any_spread(center, spread, n, width, seed):
    values = center + spread * max(abs(center), 1.0) * np.random.default_rng(seed).random(n)
    bins, span = histogram_bins(list(values) + [math.nan, None], center - width, center + width)
    assert 1 <= bins <= 30 and span[0] < span[1]
    counts, edges = np.histogram(values, bins=bins, range=span)   # what matplotlib does; raises if unresolvable
    assert counts.sum() == n and np.all(np.diff(edges) > 0)
    assert histogram_bins([None, math.inf], 0.0, 1.0) == (0, None)


def test_a_failing_sweep_plot_is_left_out_with_a_warning(tmp_path, monkeypatch):
    import vibupdate.report.sweep_plots as sweep_plots
    from vibupdate.io.case import load_case
    from vibupdate.io.outputs import OutputWarning

    case = load_case(write_chain_case(tmp_path / "chain.toml"))
    names = [p.name for p in case.configurations[0].model.parameters]
    values = {f"p:{n}": p.nominal for n, p in zip(names, case.configurations[0].model.parameters)}
    rows = [{"index": i, "outcome": "verified", **values} for i in range(3)]
    document = {"samples": 3, "verified": 3, "unverified": 0, "failed": 0, "predictions": [],
                "parameters": [{"name": p.name, "unit": p.unit, "lower": p.lower, "upper": p.upper,
                                "nominal": p.nominal, "spread_of_bounds": 0.0}
                               for p in case.configurations[0].model.parameters]}

    def broken(*args, **kwargs):
        raise ValueError("Too many bins for data range. Cannot create 5 finite-sized bins.")

    monkeypatch.setattr(sweep_plots, "plot_frequency_bands", broken)
    with pytest.warns(OutputWarning, match="frequency_bands.png was not drawn: ValueError: Too many bins"):
        files = sweep_plots.write_sweep_plots(tmp_path, case, rows, document)
    assert [f.name for f in files] == ["parameters_hist.png", "parameters_pairs.png", "frf_band_A.png"]
    assert not (tmp_path / "frequency_bands.png").exists()


@pytest.fixture(scope="module")
def client():
    from vibupdate.study.engine import open_client

    with open_client(1) as c:   # the local cluster a sweep starts itself
        yield c


def test_a_sweep_whose_plot_fails_keeps_its_rows_and_says_so(client, tmp_path, monkeypatch):
    import vibupdate.report.sweep_plots as sweep_plots
    from vibupdate.io.manifests import read_manifest
    from vibupdate.study.sweep import run_sweep

    def broken(*args, **kwargs):
        raise ValueError("Too many bins for data range")

    monkeypatch.setattr(sweep_plots, "plot_histograms", broken)
    said = []
    out = tmp_path / "sweep"
    summary = run_sweep(write_chain_case(tmp_path / "chain.toml"), out, 2, client=client, progress=said.append)
    assert summary.verified == 2
    doc = json.loads((out / "sweep.json").read_text())
    note = "parameters_hist.png was not drawn: ValueError: Too many bins for data range"
    assert doc["warnings"] == [note] and f"warning: {note}" in said
    listed = set(read_manifest(out, "sweep"))
    assert {"samples.csv", "line_ends.csv", "sweep.json", "sweep-settings.json", "frequency_bands.png"} <= listed
    assert "parameters_hist.png" not in listed and not (out / "parameters_hist.png").exists()


def test_run_with_samples_whose_plot_fails_keeps_the_run(client, tmp_path, monkeypatch):
    import vibupdate.report.sweep_plots as sweep_plots
    from vibupdate.io.case import load_case
    from vibupdate.io.manifests import read_manifest
    from vibupdate.io.results import load_results
    from vibupdate.pipeline import run_case
    from vibupdate.study.sampled_ranges import SampledRanges

    def broken(*args, **kwargs):
        raise ValueError("Too many bins for data range")

    monkeypatch.setattr(sweep_plots, "plot_histograms", broken)
    case = load_case(write_chain_case(tmp_path / "chain.toml"))
    out = tmp_path / "run"
    run = run_case(case, out, study=SampledRanges(2, starts=0, client=client))
    note = "sampled_hist.png was not drawn: ValueError: Too many bins for data range"
    assert run.success and note in run.warnings
    written = load_results(out / "results.json")
    assert note in written.warnings and written.sampled.verified == 2
    assert {"samples.csv", "line_ends.csv", "report.md"} <= set(read_manifest(out))
    assert note in (out / "report.md").read_text()
