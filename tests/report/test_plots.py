"""Plots solve each model once: the receptances of every plotted pair come from one
eigen-solve (or one factorization per frequency) per model, never one per pair."""

import math

import numpy as np
import pytest
import scipy.linalg
import scipy.sparse.linalg
from frf_synthetic import cantilever_system, measured

from vibupdate.damping.models import CaugheyLaw
from vibupdate.modal import eigen
from vibupdate.modal.analysis import receptance, receptances
from vibupdate.report.plots import model_receptance, model_receptances, plot_measured_frf


@pytest.fixture
def eigen_solves(monkeypatch):
    """Counts every call of the dense and sparse eigen-solvers vibupdate uses: scipy's, and
    `vibupdate.modal.eigen._eigh`, through which the dense symmetric solves call LAPACK."""
    calls = []
    for module, names in ((scipy.linalg, ("eig", "eigh")), (scipy.sparse.linalg, ("eigs", "eigsh")),
                          (eigen, ("_eigh",))):
        for name in names:
            original = getattr(module, name)

            def counted(*args, _original=original, **kwargs):
                calls.append(1)
                return _original(*args, **kwargs)

            monkeypatch.setattr(module, name, counted)
    return calls


def _damping(kind, M, K, C):
    if kind == "matrix":
        return C
    if kind == "law":
        return CaugheyLaw((0.0, 1.0), (1.0, 2e-5), M.shape[0])
    return None


@pytest.mark.parametrize("kind", ["undamped", "matrix", "law"])
def test_measured_frf_plot_solves_each_model_once_whatever_the_number_of_pairs(tmp_path, eigen_solves, kind):
    frfs, *_ = measured(4, repeats=1)
    frfs = frfs.band(2 * math.pi * 20, 2 * math.pi * 300)
    M, K, C, dofs = cantilever_system()
    nominal, updated = (M, 1.05 * K, None), (M, K, _damping(kind, M, K, C))
    assert len(frfs.pairs) == 3
    # what one pair of each model costs
    r, c = dofs.index(frfs.pairs[0][0]), dofs.index(frfs.pairs[0][1])
    for model in (nominal, updated):
        model_receptance(model, r, c, frfs.omega)
    one_pair_each = len(eigen_solves)
    assert one_pair_each > 0
    eigen_solves.clear()
    plot_measured_frf(tmp_path / "frf.png", frfs, dofs, nominal, updated, "A", "nominal", "updated")
    assert len(eigen_solves) == one_pair_each   # three panels, one solve per model


@pytest.mark.parametrize("kind", ["undamped", "matrix", "law"])
@pytest.mark.parametrize("n_lines", [7, 80])   # direct solves, and the state-space modes over 50 lines
def test_receptances_of_several_pairs_equal_the_single_pair_receptances(kind, n_lines):
    M, K, C, dofs = cantilever_system()
    omega = np.linspace(10.0, 2500.0, n_lines)
    pairs = [(0, 4), (4, 0), (2, 2), (0, 13), (13, 4)]   # repeated excitations, a driving point
    model = (M, K, _damping(kind, M, K, C))
    together = model_receptances(model, pairs, omega)
    assert together.shape == (len(pairs), n_lines)
    for h, (r, c) in zip(together, pairs):
        alone = model_receptance(model, r, c, omega)
        np.testing.assert_allclose(h, alone, rtol=1e-10, atol=1e-12 * np.abs(alone).max())
    if kind != "law":   # the kernels against a direct solve per line
        Cd = np.zeros_like(M) if model[2] is None else model[2]
        for h, (r, c) in zip(together, pairs):
            direct = np.array([np.linalg.solve(K + 1j * w * Cd - w**2 * M, np.eye(M.shape[0])[:, c])[r]
                               for w in omega])
            assert np.abs(h - direct).max() < 1e-7 * np.abs(direct).max()


def test_receptances_of_a_large_model_share_one_factorization_per_line(monkeypatch):
    """Over DENSE_LIMIT DOFs: one sparse LU per frequency for every pair."""
    import scipy.sparse as sp

    from vibupdate.modal import eigen
    M, K, C, dofs = cantilever_system()
    monkeypatch.setattr(eigen, "DENSE_LIMIT", 5)
    factorizations = []
    original = scipy.sparse.linalg.splu
    monkeypatch.setattr(scipy.sparse.linalg, "splu", lambda A, *a, **k: factorizations.append(1) or original(A, *a, **k))
    omega = np.linspace(10.0, 2500.0, 6)
    pairs = [(0, 4), (2, 2), (13, 4)]
    h = receptances(sp.csr_matrix(M), sp.csr_matrix(K), pairs, omega, sp.csr_matrix(C))
    assert len(factorizations) == omega.size
    for row, (r, c) in zip(h, pairs):
        direct = np.array([np.linalg.solve(K + 1j * w * C - w**2 * M, np.eye(M.shape[0])[:, c])[r] for w in omega])
        np.testing.assert_allclose(row, direct, rtol=1e-9)
    with pytest.raises(ValueError, match="at least one .* pair, got none"):
        receptances(M, K, [], omega)
    with pytest.raises(ValueError, match=r"receptance index c=14 is out of range for a model of 14 DOFs"):
        receptance(M, K, 0, 14, omega)


def test_large_model_nominal_curve_is_the_law_s_modal_sum_without_damping(tmp_path, monkeypatch):
    """Above DENSE_LIMIT the nominal (undamped) curve of `plot_receptances` uses the updated damping
    law's modal sum with zero damping, not one sparse LU per plotted line, and agrees with the
    direct solve away from the resonances (the modes left out are in the Krylov vectors of the
    sum: 1.3e-12 of the static compliance measured)."""
    import scipy.sparse as sp

    from vibupdate import NaturalFrequency
    from vibupdate.modal.eigen import DENSE_LIMIT
    from vibupdate.report import plots

    import matplotlib.figure

    def chain(n):
        k = np.full(n, 1e4)
        return (sp.identity(n, format="csc"),
                sp.diags([np.r_[k[:-1] + k[1:], k[-1]], -k[1:], -k[1:]], [0, 1, -1], format="csc"))

    legends = []
    real_save = matplotlib.figure.Figure.savefig

    def save(fig, *args, **kwargs):      # the legend the figure is written with
        legends.append([text.get_text() for legend in fig.legends for text in legend.get_texts()])
        return real_save(fig, *args, **kwargs)

    monkeypatch.setattr(matplotlib.figure.Figure, "savefig", save)

    class Cfg:
        name = "c"
        natural = [NaturalFrequency(1.0)]
        antiresonances = []

    M, K = chain(30)                     # no damping law: each curve is its own undamped model
    plots.plot_receptances(tmp_path / "small.png", [(Cfg, (M, 1.1 * K, None), (M, K, None), [(29, 29, "h", [])])])
    assert legends.pop()[:2] == ["nominal model (undamped)", "updated model (undamped)"]

    n = DENSE_LIMIT + 50
    M, K = chain(n)
    law = CaugheyLaw((0.0, 1.0), (0.5, 1e-5), 40)
    nominal, updated = (M, 1.1 * K, None), (M, K, law)
    curve = (M, 1.1 * K, CaugheyLaw((), (), 40))   # the nominal curve the legend below names

    from vibupdate.modal.eigen import modes

    w, _ = modes(M, 1.1 * K, 12)
    omega = np.r_[0.0, 0.5 * (w[:-1] + w[1:])[:10]]   # static, and between the lowest modes
    tip = np.zeros(n)
    tip[-1] = 1.0
    exact = np.array([sp.linalg.spsolve(sp.csc_matrix(1.1 * K - x**2 * M), tip)[-1] for x in omega])
    # 40 modes and the Krylov vectors of the excitation: the modes left out are not lost (with
    # the modes alone the chain's tip was ~0.4 % of its static compliance off)
    assert np.abs(model_receptance(curve, n - 1, n - 1, omega) - exact).max() < 1e-8 * abs(exact[0])

    lus = []
    real_splu = scipy.sparse.linalg.splu
    monkeypatch.setattr(scipy.sparse.linalg, "splu", lambda A, *a, **kw: lus.append(1) or real_splu(A, *a, **kw))

    Cfg.natural = [NaturalFrequency(float(w[2]))]
    plots.plot_receptances(tmp_path / "f.png", [(Cfg, nominal, updated, [(n - 1, n - 1, "h", [])])])
    # one shift-invert factorization per model's eigen-solve, not one per plotted line (2,000)
    assert len(lus) <= 2 and (tmp_path / "f.png").stat().st_size > 5000
    assert legends.pop()[:2] == ["nominal model (undamped, 40 modes)", "updated model (damping law, 40 modes)"]


def test_report_range_widths_below_one_percent_keep_two_digits():
    """A linearized range 0.042 % wide printed as "0.0" would read as a zero-width range."""
    from vibupdate.io.results import Identifiability
    from vibupdate.report.ranges_text import ranges_table

    widths = {"a": 0.0424, "b": 134.5, "c": 1e-7, "d": None}
    ident = Identifiability.from_dict({"rank": 4, "condition": 1.0, "singular_values": [], "column_norm": {},
                                       "undetermined_combinations": [], "minimum_change": None, "alternatives": [],
                                       "ranges": {name: {"lower": 1.0, "upper": 2.0, "width_pct": w}
                                                  for name, w in widths.items()}})
    table = ranges_table(ident, list(widths))
    column = [c.name for c in table.columns].index("width %")
    assert [row[column] for row in table.rows] == ["0.042", "134.5", "1e-07", "-"]


@pytest.mark.parametrize("kind", ["undamped", "matrix", "law"])
def test_the_receptance_of_a_sensor_is_its_weighted_sum_of_dof_receptances(kind):
    """A sensor reading ``w^T u`` as response, or a force spread with its weights as
    excitation: ``w^T H c``, against a direct solve per line (the damping law: against the
    weighted single-pair receptances it is built from)."""
    from vibupdate.report.plots import reading_receptances

    M, K, C, dofs = cantilever_system()
    omega = np.linspace(10.0, 2500.0, 60)
    model = (M, K, _damping(kind, M, K, C))
    w = np.zeros(len(dofs))
    w[[0, 2, 3]] = [1.0, -0.5, 0.25]                       # y1 - 0.5 y2 + 0.25 phi2
    reads = {"s": tuple((i, w[i]) for i in np.flatnonzero(w)), "y3": ((4, 1.0),)}
    got = reading_receptances(model, [("s", "y3"), ("y3", "s"), ("s", "s"), ("y3", "y3")], reads, omega)
    e = np.eye(len(dofs))[4]
    for h, (a, b) in zip(got, [(w, e), (e, w), (w, w), (e, e)]):
        if kind == "law":
            singles = {(i, j): model_receptance(model, i, j, omega) for i in np.flatnonzero(a) for j in np.flatnonzero(b)}
            expected = sum(a[i] * b[j] * singles[i, j] for i, j in singles)
        else:
            Cd = np.zeros_like(M) if model[2] is None else model[2]
            expected = np.array([a @ np.linalg.solve(K + 1j * x * Cd - x**2 * M, b) for x in omega])
        assert np.abs(h - expected).max() < 1e-7 * np.abs(expected).max()


def test_the_measured_frf_plot_draws_an_frf_measured_at_a_sensor(tmp_path):
    from vibupdate.data.frf import FRFSet
    from vibupdate.model.measurement import Sensor

    M, K, C, dofs = cantilever_system()
    omega = 2 * math.pi * np.arange(20.0, 300.0, 0.5)
    H = np.linalg.inv(K[None] - omega[:, None, None] ** 2 * M[None] + 1j * omega[:, None, None] * C[None])
    frfs = FRFSet(omega, (("tip", "y3"),), ((H[:, 0, 4] + 0.5 * H[:, 2, 4])[None],))
    sensor = Sensor("tip", (("y1", 1.0), ("y2", 0.5)))
    path = plot_measured_frf(tmp_path / "frf.png", frfs, dofs, (M, K, None), (M, K, C), "A", "nominal", "updated",
                             (sensor,))
    assert path.is_file() and path.stat().st_size > 0


def test_the_homotopy_plot_draws_each_path_as_its_own_line(tmp_path, monkeypatch):
    """A direct jump (lambda 0, 1) then the stepped restart (0, 0.5, 1): two lines, not one
    that runs from lambda 1 back to 0."""
    from types import SimpleNamespace

    import matplotlib.figure

    from vibupdate.inverse.status import Status
    from vibupdate.report.plots import plot_homotopy

    drawn = []
    real = matplotlib.figure.Figure.savefig
    monkeypatch.setattr(matplotlib.figure.Figure, "savefig",
                        lambda fig, *a, **k: drawn.append([line.get_xdata().tolist() for line in fig.axes[0].lines
                                                           if line.get_linestyle() == "-"]) or real(fig, *a, **k))
    steps = [SimpleNamespace(lam=lam, objective=obj, status=Status.SUCCESS)
             for lam, obj in ((0.0, 1e-8), (1.0, 3.0), (0.0, 1e-8), (0.5, 1e-3), (1.0, 1e-6))]
    plot_homotopy(tmp_path / "homotopy.png", steps)
    assert drawn == [[[0.0, 1.0], [0.0, 0.5, 1.0]]]


def test_log_tick_labels_read_as_matplotlib_writes_them_in_plain_text():
    from vibupdate.report.plots import plain_label

    assert plain_label("$\\mathdefault{10^{-5}}$") == "10\u207b\u2075"
    assert plain_label("$\\mathdefault{10^{12}}$") == "10\u00b9\u00b2"
    assert plain_label("$\\mathdefault{4.85\\times10^{-1}}$") == "4.85\u00d710\u207b\u00b9"
    assert plain_label("") == ""
    assert plain_label("0.5") == "0.5"


def test_log_axis_plots_parse_no_mathtext(tmp_path, monkeypatch):
    """The log axes' tick labels are plain text: matplotlib's mathtext parse of each label was
    half the cost of a homotopy plot (and the first in a process builds its parser)."""
    from types import SimpleNamespace

    import matplotlib.figure
    import matplotlib.mathtext

    from vibupdate.inverse.status import Status
    from vibupdate.report.plots import plot_homotopy

    parsed, labels = [], []
    real_parse = matplotlib.mathtext.MathTextParser.parse
    monkeypatch.setattr(matplotlib.mathtext.MathTextParser, "parse",
                        lambda self, s, *a, **k: parsed.append(s) or real_parse(self, s, *a, **k))
    real_save = matplotlib.figure.Figure.savefig

    def save(fig, *a, **k):
        out = real_save(fig, *a, **k)   # drawn: the tick labels are set
        labels.extend(t.get_text() for t in fig.axes[0].get_yticklabels() + fig.axes[0].get_yticklabels(minor=True))
        return out

    monkeypatch.setattr(matplotlib.figure.Figure, "savefig", save)
    steps = [SimpleNamespace(lam=lam, objective=obj, status=Status.SUCCESS)
             for lam, obj in ((0.0, 1e-8), (0.5, 1e-3), (1.0, 3.0))]
    plot_homotopy(tmp_path / "homotopy.png", steps)
    assert parsed == []
    assert "10\u207b\u2074" in labels and not any("$" in t for t in labels)
