"""FRFs measured at a sensor (a combination of DOFs) through the case file's FRF route: the
shapes the modal fit gives at the sensor are data like the DOFs' shapes, the natural frequencies
as usual, and the antiresonances of an FRF whose response or excitation is a sensor are left
out with a note naming the FRF. A three-mass chain, its FRFs computed exactly; the known truth
and the dense reference of the sensor's zeros (the bordered pencil) written here."""

import json
from pathlib import Path

import numpy as np
import pytest
import scipy.io
import scipy.linalg
import scipy.sparse as sp

from vibupdate.cli import main
from vibupdate.io.case import load_case

MASS = np.array([2.0, 1.5, 1.0])            # kg
SPRING = np.array([4e4, 3e4, 2e4])          # N/m, nominal; k1 ties x1 to the ground
TRUTH = {"k1": 0.9, "k2": 1.1, "k3": 0.95}  # factors on the nominal springs
SENSOR = {"x1": 1.0, "x2": 0.5}             # the sensor s12 reads x1 + 0.5 x2
DOFS = ["x1", "x2", "x3"]


def _spring(i: int) -> np.ndarray:
    K = np.zeros((3, 3))
    K[i, i] = 1.0
    if i > 0:
        K[i - 1, i - 1] = 1.0
        K[i, i - 1] = K[i - 1, i] = -1.0
    return SPRING[i] * K


def _truth():
    return np.diag(MASS), sum(TRUTH[f"k{i + 1}"] * _spring(i) for i in range(3))


def bordered_zeros_hz(w, c) -> np.ndarray:
    """The dense reference: the zeros of ``w^T H(s) c`` (response weights ``w``, excitation
    weights ``c``) are the finite eigenvalues of the bordered pencil
    ``([[K, c], [w^T, 0]], [[M, 0], [0, 0]])``; Hz, ascending."""
    M, K = _truth()
    A, B = np.zeros((4, 4)), np.zeros((4, 4))
    A[:3, :3], A[:3, 3], A[3, :3], B[:3, :3] = K, c, w, M
    ev = scipy.linalg.eigvals(A, B)
    ev = ev[np.isfinite(ev)]
    return np.sort(np.sqrt(ev.real[ev.real > 0])) / (2 * np.pi)


def _weights(name: str) -> np.ndarray:
    return np.array([SENSOR.get(d, 0.0) for d in DOFS]) if name == "s12" else np.eye(3)[DOFS.index(name)]


#: Where the sensor is: response and excitation names of the FRFs (one excitation, three responses).
VARIANTS = {"response": (["s12", "x2", "x3"], "x1"), "excitation": (["x1", "x2", "x3"], "s12"),
            "driving point": (["s12", "x2", "x3"], "s12")}


def write_case(folder, sensor_is="response") -> str:
    """Matrices of the chain (nominal springs, one dK per spring), the exact receptances of the
    truth (damping 0.5 M + 2e-5 K) in one table file, and the case reading them; the sensor at
    the place `VARIANTS` names (as excitation: a force spread with the sensor's weights). The
    driving point at the sensor gives mass-normalized shapes."""
    scipy.io.mmwrite(str(folder / "M0.mtx"), sp.coo_matrix(np.diag(MASS)))
    scipy.io.mmwrite(str(folder / "K0.mtx"), sp.coo_matrix(sum(_spring(i) for i in range(3))))
    for i in range(3):
        scipy.io.mmwrite(str(folder / f"dK{i + 1}.mtx"), sp.coo_matrix(_spring(i)))
    M, K = _truth()
    C = 0.5 * M + 2e-5 * K
    f_hz = np.arange(2.0, 120.0, 0.05)
    w = 2 * np.pi * f_hz
    H = np.linalg.inv(K[None] - w[:, None, None] ** 2 * M[None] + 1j * w[:, None, None] * C[None])
    responses, excitation = VARIANTS[sensor_is]
    columns = [np.einsum("i,fij,j->f", _weights(r), H, _weights(excitation)) for r in responses]
    np.savez(folder / "hits.npz", freq_hz=f_hz, H=np.array(columns).T)
    params = "".join(f'[[parameter]]\nname = "{name}"\nnominal = 1.0\nlower = 0.5\nupper = 1.5\n' for name in TRUTH)
    sensor = ", ".join(f"{d} = {v!r}" for d, v in SENSOR.items())
    path = folder / "case.toml"
    path.write_text(f"""case = "sensor-frf"
[model]
type = "matrices"
M0 = "M0.mtx"
K0 = "K0.mtx"
dofs = ["x1", "x2", "x3"]
[model.dK]
k1 = "dK1.mtx"
k2 = "dK2.mtx"
k3 = "dK3.mtx"
{params}
[[sensor]]
name = "s12"
dofs = {{ {sensor} }}

[[configuration]]
name = "test"
mass_normalized_shapes = {str(sensor_is == "driving point").lower()}
[configuration.frf]
files = ["hits.npz"]
responses = {json.dumps(responses)}
excitations = ["{excitation}"]
band_hz = [3.0, 60.0]
""")
    return str(path)


@pytest.mark.parametrize("sensor_is", list(VARIANTS))
def test_an_frf_at_a_sensor_gives_its_shapes_and_frequencies_and_its_zeros_are_left_out_with_a_note(tmp_path,
                                                                                                     sensor_is):
    case = load_case(write_case(tmp_path, sensor_is))
    cfg = case.configurations[0]
    M, K = _truth()
    omega2, Phi = scipy.linalg.eigh(K, M)
    np.testing.assert_allclose([f.freq_hz for f in cfg.natural], np.sqrt(omega2) / (2 * np.pi), rtol=1e-6)
    responses, excitation = VARIANTS[sensor_is]
    assert all(sorted(f.shape.bounds) == sorted(responses) for f in cfg.natural)
    if sensor_is == "driving point":   # mass-normalized through the driving point at the sensor
        S = cfg.model.measurement(responses)
        for f, phi in zip(cfg.natural, Phi.T):
            mid = np.array([f.shape.midpoint[r] for r in responses])
            np.testing.assert_allclose(np.abs(mid), np.abs(S @ phi), rtol=1e-4)
    # only the zeros between DOFs are data (h_x2,x1 of the sensor as response)
    assert all("s12" not in a.receptance for a in cfg.antiresonances)
    assert [a.receptance for a in cfg.antiresonances] == ([("x2", "x1")] if sensor_is == "response" else [])
    notes = [n for n in case.frf_notes["test"] if "are not used" in n]
    # one note per FRF at the sensor with zeros between the fitted poles (the extraction keeps
    # those), naming them: the zeros of the dense reference, to the note's 6 digits
    poles = [f.freq_hz for f in cfg.natural]
    expected = {}
    for r in responses:
        z = bordered_zeros_hz(_weights(r), _weights(excitation))
        z = z[(z > poles[0]) & (z < poles[-1])]
        if "s12" in (r, excitation) and z.size:
            expected[f"h_{r},{excitation}"] = z
    assert len(notes) == len(expected) == {"response": 1, "excitation": 2, "driving point": 2}[sensor_is], notes
    for label, z in expected.items():
        note = next(n for n in notes if n.startswith(f"the antiresonances of {label} ({z.size}, at "))
        assert ("its response and its excitation are the sensor 's12'" if label == "h_s12,s12" else
                f"its {'response' if label.startswith('h_s12') else 'excitation'} 's12' is a sensor") in note
        stated = [float(v) for v in note.split(" at ")[1].split(" Hz")[0].split(", ")]
        np.testing.assert_allclose(stated, z, rtol=2e-5)


def test_the_run_recovers_the_truth_from_frfs_at_a_sensor_and_lists_the_sensor(tmp_path, capsys):
    code = main(["run", write_case(tmp_path), "--out", str(tmp_path / "out")])
    out, err = capsys.readouterr()
    assert code == 0, err
    doc = json.loads((tmp_path / "out" / "results.json").read_text())
    updated = {p["name"]: p["updated"] for p in doc["parameters"]}
    assert max(abs(updated[k] - TRUTH[k]) for k in TRUTH) <= 1e-6, updated
    assert any("the antiresonances of h_s12,x1 (2, at" in w for w in doc["warnings"])
    assert "the antiresonances of h_s12,x1" in out + err
    assert doc["mac_matrix"]["test"]["dofs"] == ["x2", "x3", "s12"]   # the sensor's shape entries are data
    assert min(doc["mac"]["test"]) >= 1 - 1e-9
    # the declared sensor is listed with its weights, reloaded typed, and shown in the report
    from vibupdate.io.results import DeclaredSensor, load_results

    assert doc["declared_sensors"] == [{"sensor": "s12", "weights": SENSOR}]
    assert load_results(tmp_path / "out" / "results.json").declared_sensors == (DeclaredSensor("s12", SENSOR),)
    report = (tmp_path / "out" / "report.md").read_text()
    assert "## Sensors" in report and "| s12 | 1 x1 + 0.5 x2 |" in report


def test_a_uff_channel_mapped_to_a_sensor_is_data_at_the_sensor(tmp_path):
    """A UFF file names nodes and directions: ``map = { y9 = "s12" }`` makes its channel the
    sensor's, as a table file's ``responses`` does."""
    pytest.importorskip("pyuff")
    from vibupdate.data.frf import FRFSet, write_uff58

    by_table = load_case(write_case(tmp_path)).configurations[0]
    frfs = np.load(tmp_path / "hits.npz")
    pairs = (("y9", "x1"), ("x2", "x1"), ("x3", "x1"))
    write_uff58(tmp_path / "hits.uff", FRFSet(2 * np.pi * frfs["freq_hz"], pairs, tuple(h[None] for h in frfs["H"].T)))
    text = (tmp_path / "case.toml").read_text()
    head = text[:text.index("files = ")]
    (tmp_path / "uff.toml").write_text(head + 'files = ["hits.uff"]\nband_hz = [3.0, 60.0]\nmap = { y9 = "s12" }\n')
    case = load_case(tmp_path / "uff.toml")
    by_uff = case.configurations[0]
    for a, b in zip(by_table.natural, by_uff.natural, strict=True):   # the same to the UFF's 12 digits
        assert sorted(b.shape.bounds) == ["s12", "x2", "x3"]
        np.testing.assert_allclose(b.omega, a.omega, rtol=1e-9)
        np.testing.assert_allclose([b.shape.midpoint[d] for d in ("s12", "x2", "x3")],
                                   [a.shape.midpoint[d] for d in ("s12", "x2", "x3")], rtol=1e-9)
    assert any(n.startswith("the antiresonances of h_s12,x1 (2, at ") for n in case.frf_notes["test"])


@pytest.mark.parametrize("band", ["[60.0, 3.0]", "[0.0, 60.0]", "[3.0]"])
def test_a_band_not_low_then_high_in_hz_is_refused_naming_the_key_and_the_values_given(tmp_path, band):
    """The case states the band in Hz: the error repeats the Hz the user wrote (it said rad/s
    values before), names the key and what is expected."""
    path = Path(write_case(tmp_path))
    path.write_text(path.read_text().replace("band_hz = [3.0, 60.0]", f"band_hz = {band}"))
    with pytest.raises(ValueError, match=r"frf\.band_hz.*must be \[low, high\] in Hz with 0 < low < high, got "
                                         + band.replace("[", r"\[").replace("]", r"\]").replace(".", r"\.")):
        load_case(path)

