"""Reading FRFs: UFF dataset 58 (pyuff round trip), CSV/npz columns, units, DOF names."""

import math

import numpy as np
import pytest

from vibupdate.data.frf import (G, FRFSet, combine, read_frf_table, read_frfs, read_uff58, to_receptance,
                                write_uff58)


def _receptance(omega):
    """A two-mode receptance, m/N, shape (n_freq,)."""
    s = 1j * omega
    return 1e-3 / (s**2 + 2 * 0.01 * 100 * s + 100**2) + 5e-4 / (s**2 + 2 * 0.02 * 300 * s + 300**2)


def _write_uff58(path, records, freq_hz, ordinate=12):
    import pyuff

    uff = pyuff.UFF(str(path))
    sets = []
    for rsp_node, rsp_dir, ref_node, ref_dir, data in records:
        sets.append(pyuff.prepare_58(
            func_type=4, rsp_node=rsp_node, rsp_dir=rsp_dir, ref_node=ref_node, ref_dir=ref_dir,
            data=data, x=freq_hz, id1="FRF", rsp_ent_name="frame", ref_ent_name="frame",
            abscissa_spacing=1, abscissa_spec_data_type=18, ordinate_spec_data_type=ordinate,
            orddenom_spec_data_type=13, binary=0))
    uff.write_sets(sets, mode="overwrite")


def test_uff58_round_trip_converts_accelerance_names_dofs_and_groups_repeats(tmp_path):
    freq_hz = np.arange(1.0, 80.0, 0.5)
    omega = 2 * math.pi * freq_hz
    h = _receptance(omega)
    acc = (1j * omega) ** 2 * h
    path = tmp_path / "hits.uff"
    _write_uff58(path, [(3, 2, 1, 2, acc), (3, 2, 1, 2, 1.01 * acc), (4, -2, 1, 2, acc)], freq_hz)
    frfs = read_uff58(path)
    assert frfs.pairs == (("y3", "y1"), ("y4", "y1"))
    assert frfs.n_repeats == (2, 1)
    assert np.allclose(frfs.omega, omega)
    assert np.allclose(frfs.H[0][0], h, rtol=1e-5)
    assert np.allclose(frfs.H[0][1], 1.01 * h, rtol=1e-5)
    assert np.allclose(frfs.H[1][0], -h, rtol=1e-5)  # -Y response: sign flipped to +Y
    assert frfs.sources == (str(path),)


def test_the_uff58_writer_is_read_back_to_the_same_receptances_names_and_repeats(tmp_path):
    """`write_uff58` writes what `read_uff58` reads: accelerances, one record per repeat, the DOF
    names as direction and node; a name without them is refused by name."""
    omega = 2 * math.pi * np.arange(1.0, 80.0, 0.5)
    h = _receptance(omega)
    frfs = FRFSet(omega, (("y3", "y1"), ("rx12", "y1")), (np.array([h, 1.01 * h]), np.array([2 * h])))
    pytest.importorskip("pyuff")
    write_uff58(tmp_path / "out.uff", frfs)
    back = read_uff58(tmp_path / "out.uff")
    assert back.pairs == frfs.pairs and back.n_repeats == (2, 1) and back.measured == "accelerance"
    for a, b in zip(back.H, frfs.H):
        np.testing.assert_allclose(a, b, rtol=1e-5)
    bad = FRFSet(omega, (("tip", "y1"),), (np.array([h]),))
    with pytest.raises(ValueError, match="DOF name 'tip' cannot be written to a UFF record"):
        write_uff58(tmp_path / "bad.uff", bad)


def test_uff58_kind_override_g_units_and_errors(tmp_path):
    freq_hz = np.arange(0.0, 50.0, 1.0)
    omega = 2 * math.pi * freq_hz
    h = _receptance(np.where(omega > 0, omega, 1.0))
    path = tmp_path / "mob.uff"
    _write_uff58(path, [(1, 1, 1, 1, (1j * omega) * h / G)], freq_hz, ordinate=11)
    frfs = read_uff58(path, g_units=True)
    assert frfs.omega[0] > 0  # the 0 Hz line is dropped
    assert np.allclose(frfs.H[0][0], h[1:], rtol=1e-5)
    assert frfs.pairs == (("x1", "x1"),)
    with pytest.raises(ValueError, match="does not exist"):
        read_uff58(tmp_path / "none.uff")
    import pyuff

    only55 = tmp_path / "modes.uff"
    pyuff.UFF(str(only55)).write_sets([pyuff.prepare_55(
        model_type=1, id1="m", id2="", id3="", id4="", id5="", analysis_type=2, data_ch=2, spec_data_type=8,
        data_type=5, n_data_per_node=3, load_case=1, mode_n=1, freq=10.0, modal_m=1.0, modal_damp_vis=0.01,
        modal_damp_his=0.0, node_nums=np.array([1]), r1=np.array([1.0 + 0j]), r2=np.array([0j]),
        r3=np.array([0j]))], mode="overwrite")
    with pytest.raises(ValueError, match="has no dataset 58"):
        read_uff58(only55)


def test_csv_complex_text_semicolons_no_header_like_southampton(tmp_path):
    freq_hz = np.arange(0.03125, 10.0, 0.03125)
    omega = 2 * math.pi * freq_hz
    h = _receptance(omega)
    acc = (1j * omega) ** 2 * h
    lines = [f"{f}+0j;{a.real:.17g}{a.imag:+.17g}j;{2 * a.real:.17g}{2 * a.imag:+.17g}j" for f, a in zip(freq_hz, acc)]
    path = tmp_path / "test_1.csv"
    path.write_text("\n".join(lines) + "\n")
    frfs = read_frf_table(path, ["x1", "x2"], "x1", kind="accelerance")
    assert frfs.pairs == (("x1", "x1"), ("x2", "x1"))
    assert np.allclose(frfs.H[0][0], h) and np.allclose(frfs.H[1][0], 2 * h)


def test_csv_real_imaginary_pairs_with_header_and_repeated_columns(tmp_path):
    freq_hz = np.linspace(1, 20, 40)
    h = _receptance(2 * math.pi * freq_hz)
    path = tmp_path / "frf.csv"
    rows = ["freq,re1,im1,re2,im2"] + [f"{f},{v.real},{v.imag},{1.1 * v.real},{1.1 * v.imag}" for f, v in zip(freq_hz, h)]
    path.write_text("\n".join(rows))
    frfs = read_frf_table(path, ["y2", "y2"], "y1", pairs=True)
    assert frfs.pairs == (("y2", "y1"),) and frfs.n_repeats == (2,)
    assert np.allclose(frfs.H[0][1], 1.1 * h)


def test_npz_columns(tmp_path):
    freq_hz = np.linspace(1, 20, 40)
    h = _receptance(2 * math.pi * freq_hz)
    path = tmp_path / "frf.npz"
    np.savez(path, freq_hz=freq_hz, H=np.column_stack([h, 3 * h]))
    frfs = read_frf_table(path, ["y1", "y2"], "y1")
    assert np.allclose(frfs.H[1][0], 3 * h)


def test_table_errors_name_file_row_and_column(tmp_path):
    path = tmp_path / "bad.csv"
    path.write_text("1.0;1+2j;3+4j\n2.0;1+2j;oops\n")
    with pytest.raises(ValueError, match=r"bad.csv', row 2, column 2: expected a complex number.*'oops'"):
        read_frf_table(path, ["x1", "x2"], "x1")
    path.write_text("1.0;1+2j;3+4j\n2.0;1+2j\n")
    with pytest.raises(ValueError, match="row 2: 2 columns, expected 3"):
        read_frf_table(path, ["x1", "x2"], "x1")
    path.write_text("1.0;1+2j;3+4j\n2.0;1+2j;3+1j\n")
    with pytest.raises(ValueError, match="has 2 data columns but 1 response DOF names"):
        read_frf_table(path, ["x1"], "x1")
    with pytest.raises(ValueError, match="FRF kind must be one of"):
        read_frf_table(path, ["x1", "x2"], "x1", kind="inertance")
    with pytest.raises(ValueError, match="one excitation DOF per table file"):
        read_frfs([path], ["x1", "x2"], None)


def test_combine_groups_repeats_across_files_and_checks_the_axis(tmp_path):
    omega = np.linspace(1.0, 10.0, 10)
    a = FRFSet(omega, [("x1", "x1")], [np.ones((1, 10))], ("a",))
    b = FRFSet(omega, [("x1", "x1"), ("x2", "x1")], [2 * np.ones((1, 10)), np.ones((1, 10))], ("b",))
    both = combine([a, b])
    assert both.pairs == (("x1", "x1"), ("x2", "x1")) and both.n_repeats == (2, 1)
    assert np.allclose(both.mean()[0], 1.5)
    c = FRFSet(omega * 1.01, [("x1", "x1")], [np.ones((1, 10))], ("c",))
    with pytest.raises(ValueError, match="different frequency lines"):
        combine([a, c])


def test_mapping_renames_and_flips_signs():
    omega = np.linspace(1.0, 10.0, 10)
    s = FRFSet(omega, [("y3", "y1"), ("y4", "y1")], [np.ones((1, 10)), np.ones((1, 10))])
    m = s.renamed({"y3": "x2", "y4": "-x3", "y1": "x1"})
    assert m.pairs == (("x2", "x1"), ("x3", "x1"))
    assert np.allclose(m.H[1], -1.0)
    merged = s.renamed({"y4": "-y3"})
    assert merged.pairs == (("y3", "y1"),) and merged.n_repeats == (2,)
    assert np.allclose(merged.H[0][1], -1.0)


def test_frfset_validation():
    omega = np.linspace(1.0, 10.0, 10)
    with pytest.raises(ValueError, match="strictly increasing"):
        FRFSet(omega[::-1], [("x1", "x1")], [np.ones((1, 10))])
    with pytest.raises(ValueError, match=r"9 values per repeat, expected 10"):
        FRFSet(omega, [("x1", "x1")], [np.ones((1, 9))])
    with pytest.raises(ValueError, match="must be distinct"):
        FRFSet(omega, [("x1", "x1"), ("x1", "x1")], [np.ones((1, 10))] * 2)


def test_to_receptance_units():
    omega = np.array([10.0, 20.0])
    assert np.allclose(to_receptance([-100.0, -400.0], omega, "accelerance"), [1.0, 1.0])
    assert np.allclose(to_receptance([10j, 20j], omega, "mobility"), [1.0, 1.0])
    assert np.allclose(to_receptance([-100.0 / G, -400.0 / G], omega, "accelerance", g_units=True), [1.0, 1.0])


def _noisy(h, seed, level=0.03):
    rng = np.random.default_rng(seed)
    return h * (1 + level * (rng.standard_normal(h.size) + 1j * rng.standard_normal(h.size)) / np.sqrt(2))


def _table(path, freq_hz, columns):
    path.write_text("\n".join(f"{f};" + ";".join(f"{c[k].real:.17g}{c[k].imag:+.17g}j" for c in columns)
                              for k, f in enumerate(freq_hz)) + "\n")
    return path


def test_mislabelled_or_repeated_input_is_refused_naming_the_file(tmp_path):
    """The same file twice, identical repeats, two different FRFs under one label, a transposed
    .npz and a decimal comma: each a clear error, where they used to read as data (intervals
    40-60x too narrow, one mode instead of three, zeros moved, bogus modes)."""
    freq_hz = np.linspace(1, 80, 200)
    h = _receptance(2 * math.pi * freq_hz)
    a = _table(tmp_path / "a.csv", freq_hz, [_noisy(h, 1)])
    b = _table(tmp_path / "b.csv", freq_hz, [_noisy(h, 2)])
    frfs = read_frfs([a, b], ["y2"], ["y1", "y1"])       # two hits of one FRF: repeats
    assert frfs.n_repeats == (1 + 1,)
    with pytest.raises(ValueError, match=r"a.csv' is given twice"):
        read_frfs([a, tmp_path / "." / "a.csv"], ["y2"], ["y1", "y1"])
    c = _table(tmp_path / "c.csv", freq_hz, [_noisy(h, 1)])   # a copy of a.csv under another name
    with pytest.raises(ValueError, match=r"FRF h_y2,y1 .*repeats 1 and 2 are identical"):
        read_frfs([a, c], ["y2"], ["y1", "y1"])
    other = _table(tmp_path / "d.csv", freq_hz, [_noisy(_receptance(2 * math.pi * freq_hz * 1.7) * 4, 3)])
    with pytest.raises(ValueError, match=r"FRF h_y2,y1 .*are not repeats of one FRF.*mislabelled"):
        read_frfs([a, other], ["y2"], ["y1", "y1"])   # hit at another point, labelled the same
    with pytest.raises(ValueError, match=r"not repeats of one FRF"):
        read_frfs([_table(tmp_path / "e.csv", freq_hz, [_noisy(h, 4), 5 * _noisy(h[::-1], 5)])], ["y2", "y2"], ["y1"])
    npz = tmp_path / "t.npz"
    np.savez(npz, freq_hz=freq_hz, H=np.vstack([h, 2 * h]))   # (n_columns, n_freq)
    with pytest.raises(ValueError, match=r"t.npz'.*shape \(2, 200\), expected \(200, n_columns\).*transpose it"):
        read_frf_table(npz, ["y1", "y2"], "y1")
    comma = tmp_path / "comma.csv"
    comma.write_text("1,5;0,25+0,1j\n2,5;0,3+0,1j\n")
    with pytest.raises(ValueError, match=r"comma.csv', row 1, column 0: .*decimal comma"):
        read_frf_table(comma, ["y1"], "y1")


def test_the_cli_refuses_a_file_given_twice_and_writes_nothing(tmp_path, capsys):
    from vibupdate.cli import main

    freq_hz = np.linspace(1, 80, 200)
    a = _table(tmp_path / "a.csv", freq_hz, [_noisy(_receptance(2 * math.pi * freq_hz), 1)])
    out = tmp_path / "ex"
    assert main(["extract", str(a), str(a), "--responses", "y2", "--excitations", "y1", "y1", "--out", str(out)]) == 2
    assert "is given twice" in capsys.readouterr().err and not out.exists()
