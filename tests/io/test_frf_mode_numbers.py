"""Mode numbers and zero indices of data extracted from FRFs in a case file
(``[configuration.frf]``): the zeros of each FRF numbered in the order of their frequencies, and
``natural_modes`` stating which model mode each extracted mode is."""

import numpy as np
import pytest

from vibupdate import antiresonances, modes
from vibupdate.cli import main
from vibupdate.data.pairing import declare
from vibupdate.io.case import load_case

MODEL = '''import vibupdate as vu


def build(p):
    """Five unit masses y1..y5 between two walls, springs 10 kN/m times kA (left three) and kB."""
    a = vu.Assembly("beam")
    for i in range(1, 6):
        a.node(i, float(i))
        a.fix(f"phi{i}")
        a.mass(f"y{i}", 1.0)
    a.spring("y1", 1e4 * p["kA"])
    a.spring("y1", 1e4 * p["kA"], "y2")
    a.spring("y2", 1e4 * p["kA"], "y3")
    a.spring("y3", 1e4 * p["kB"], "y4")
    a.spring("y4", 1e4 * p["kB"], "y5")
    a.spring("y5", 1e4 * p["kB"])
    return a.system()
'''
RESPONSES = ["y1", "y2", "y3", "y4", "y5"]


def write_test(folder, truth=(1.04, 0.99), frf_keys=""):
    """The chain's receptances to a force at ``y3`` (near a node of modes 2 and 4 at ``truth``:
    their modal constants there 0.2 % and 1.6 % of mode 1's), 1 % proportional damping at mode 1,
    three repeats with 0.5 % noise, in 4-36 Hz; and the case reading them. Returns the case path
    and the truth's (M, K)."""
    (folder / "model.py").write_text(MODEL, encoding="utf-8")
    namespace = {}
    exec(MODEL, namespace)
    from vibupdate import Parameter, from_builder

    model = from_builder(namespace["build"], [Parameter("kA", 1.0, 0.5, 2.0), Parameter("kB", 1.0, 0.5, 2.0)])
    M, K = (A.toarray() for A in model.matrices_at(np.array(truth)))
    C = 2e-4 * K + 0.1 * M
    f = np.arange(2.0, 40.0, 0.05)
    w = 2 * np.pi * f
    H = np.linalg.inv(K[None] - w[:, None, None] ** 2 * M[None] + 1j * w[:, None, None] * C[None])
    H = H[:, [model.dof(r) for r in RESPONSES], model.dof("y3")]
    rng = np.random.default_rng(1)
    for k in range(3):
        noise = rng.standard_normal(H.shape) + 1j * rng.standard_normal(H.shape)
        np.savez(folder / f"rep{k}.npz", freq_hz=f, H=H * (1 + 0.005 * noise))
    parameters = "".join(f'[[parameter]]\nname = "{n}"\nnominal = 1.0\nlower = 0.5\nupper = 2.0\n\n'
                         for n in ("kA", "kB"))
    (folder / "case.toml").write_text(
        f'case = "chain"\n\n[model]\ntype = "builder"\nbuilder = "model.py:build"\n\n{parameters}'
        '[[configuration]]\nname = "A"\n\n[configuration.frf]\nfiles = ["rep0.npz", "rep1.npz", "rep2.npz"]\n'
        f'responses = {RESPONSES}\nexcitations = ["y3", "y3", "y3"]\nkind = "receptance"\nband_hz = [4.0, 36.0]\n'
        + frf_keys, encoding="utf-8")
    return folder / "case.toml", model, (M, K)


def test_the_zeros_of_each_frf_are_numbered_in_the_order_of_their_frequencies(tmp_path, capsys):
    """The driving point's first two zeros (15.84 and 16.23 Hz) straddle mode 2, which the
    exciter barely moves: the extraction's local refit of the lower one passed the upper one, and
    the case was refused ("antiresonances of h_y3,y3 must be strictly ascending"). Every FRF's
    zeros now carry rising indices, each the true zero's, and the run verifies the truth."""
    case, model, (M, K) = write_test(tmp_path)
    cfg = load_case(case).configurations[0]
    for rc in cfg.receptances():
        mine = [a for a in cfg.antiresonances if a.receptance == rc]
        true = antiresonances(M, K, model.dof(rc[0]), model.dof(rc[1]))
        assert [a.index for a in mine] == [1 + int(np.argmin(np.abs(true - a.omega))) for a in mine], rc
        assert all(b.omega > a.omega for a, b in zip(mine, mine[1:]))
    assert main(["run", str(case), "--out", str(tmp_path / "out")]) == 0
    assert "verdict verified" in capsys.readouterr().out


def test_natural_modes_in_an_frf_section_number_the_modes_and_leave_the_zeros_to_the_nominal_model(tmp_path):
    """``natural_modes`` gives each extracted mode its model mode, and the zeros their indices by
    the default from the nominal model (`vibupdate.data.pairing`; the extraction's count in the
    band assumes no mode skipped): here every index the true one."""
    case, model, (M, K) = write_test(tmp_path, frf_keys="natural_modes = [1, 2, 3, 4, 5]\n")
    cfg = load_case(case).configurations[0]
    assert [n.mode for n in cfg.natural] == [1, 2, 3, 4, 5]
    _, zeros = declare(cfg)
    assert zeros == cfg.antiresonances and len(zeros) == 14
    for a in zeros:
        true = antiresonances(M, K, model.dof(a.response), model.dof(a.excitation))
        assert a.index == 1 + int(np.argmin(np.abs(true - a.omega)))
    assert np.allclose([n.omega for n in cfg.natural], modes(M, K, 5)[0], rtol=1e-3)


@pytest.mark.parametrize("keys, message", [
    ("natural_modes = [1, 2, 3, 5]\n", r"gives 4 mode numbers, but the extraction found 5 modes \(8\.29.* Hz\)"),
    ("natural_modes = [1, 2, 3, 5, 5]\n", r"must be rising integers >= 1 \(model modes\), got \[1, 2, 3, 5, 5\]"),
    ("natural_modes = [1, 2, 3, 4, 5]\nfirst_mode = 2\n", r"states every extracted mode's number; remove first_mode"),
])
def test_natural_modes_that_do_not_fit_the_extraction_are_refused_naming_the_key(tmp_path, keys, message):
    case, *_ = write_test(tmp_path, frf_keys=keys)
    with pytest.raises(ValueError, match=r"configuration 'A'\.frf\.natural_modes: " + message):
        load_case(case)


def test_frfs_that_skip_modes_are_numbered_by_their_shapes_and_a_stated_first_mode_is_kept(tmp_path, capsys):
    """A symmetric truth (``kA = kB = 1.2``) puts the exciter ``y3`` on the node of modes 2 and 4:
    the extraction finds modes 1, 3 and 5. Without ``first_mode`` their shapes' MAC with the
    nominal model's modes numbers them 1, 3, 5, with a note; with ``first_mode = 1`` they are 1, 2,
    3 as stated, the run is not verified, and its correspondence warning names 1, 3, 5 by the same
    MAC (the first stage's frequencies, fitted under the wrong modes, paired them with 1, 3, 4)."""
    case, *_ = write_test(tmp_path, truth=(1.2, 1.2))
    assert [n.mode for n in load_case(case).configurations[0].natural] == [1, 3, 5]
    assert main(["check", str(case)]) == 0
    assert "are model modes [1, 3, 5] by the MAC of their shapes" in capsys.readouterr().out
    case, *_ = write_test(tmp_path, truth=(1.2, 1.2), frf_keys="first_mode = 1\n")
    assert [n.mode for n in load_case(case).configurations[0].natural] == [1, 2, 3]
    assert main(["run", str(case), "--out", str(tmp_path / "out")]) == 1
    assert "state natural_modes = [1, 3, 5] in configuration 'A'" in capsys.readouterr().out
