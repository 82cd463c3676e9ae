"""Small models shared by the tests."""

import re
from pathlib import Path

import numpy as np

from vibupdate import Assembly, Parameter, from_builder


def uniform_cantilever(n_elements, length=1.0, EI=1.0, rho_a=1.0):
    asm = Assembly("beam")
    for i in range(n_elements + 1):
        asm.node(i, i * length / n_elements)
    for i in range(n_elements):
        asm.beam(i, i + 1, EI=EI, mass_per_length=rho_a)
    asm.clamp(0)
    return asm.system()


def chain_builder(n_masses):
    """Spring-mass chain fixed at the left: parameters k1..kn (springs), m1..mn (masses)."""

    def build(p):
        asm = Assembly("beam")
        for i in range(1, n_masses + 1):
            asm.node(i, float(i))
        for i in range(1, n_masses + 1):
            asm.fix(f"phi{i}")
            asm.mass(f"y{i}", p.get(f"m{i}", 1.0))
        asm.spring("y1", p.get("k1", 1000.0))
        for i in range(2, n_masses + 1):
            asm.spring(f"y{i - 1}", p.get(f"k{i}", 1000.0), f"y{i}")
        return asm.system()

    return build


def chain_model(n_masses, names, nominal=None, spread=0.3, reference=None):
    """Affine chain model with the listed parameters (k*, m*) varying +-spread."""
    nominal = nominal or {}
    params = []
    for name in names:
        v = nominal.get(name, 1000.0 if name.startswith("k") else 1.0)
        params.append(Parameter(name, v, v * (1 - spread), v * (1 + spread)))
    return from_builder(chain_builder(n_masses), params)


def random_spd(rng, n, cond=10.0):
    Q, _ = np.linalg.qr(rng.standard_normal((n, n)))
    return Q @ np.diag(np.linspace(1.0, cond, n)) @ Q.T


#: The case file of docs/case-file.md (its first TOML block), as the docs show it.
CASE_FILE_EXAMPLE = re.search(r"```toml\n(.*?)```",
                              (Path(__file__).resolve().parents[1] / "docs" / "case-file.md").read_text(),
                              re.S).group(1)


#: The three-mass chain of the case-file tests: K of the springs (N/m), M = I; the case file
#: reads M0.mtx, K0.mtx and dK.mtx (= K / 1000, per unit of the parameter k).
CHAIN_K = np.array([[2.0, -1, 0], [-1, 2, -1], [0, -1, 1]]) * 1000
CHAIN_CASE = """
case = "chain"
[model]
type = "matrices"
M0 = "M0.mtx"
K0 = "K0.mtx"
dofs = ["a", "b", "c"]
[model.dK]
k = "dK.mtx"
[[parameter]]
name = "k"
nominal = 1000.0
lower = 500.0
upper = 2000.0
[[configuration]]
name = "only"
"""


def write_chain_matrices(folder):
    """M0.mtx, K0.mtx, dK.mtx of `CHAIN_CASE` in ``folder``; returns the chain's natural
    frequencies at k = 1200 (Hz), the truth of the tests."""
    import scipy.io
    import scipy.sparse as sp

    scipy.io.mmwrite(str(Path(folder) / "M0.mtx"), sp.coo_matrix(np.eye(3)))
    scipy.io.mmwrite(str(Path(folder) / "K0.mtx"), sp.coo_matrix(CHAIN_K))
    scipy.io.mmwrite(str(Path(folder) / "dK.mtx"), sp.coo_matrix(CHAIN_K / 1000))
    return np.sqrt(np.linalg.eigvalsh(CHAIN_K * 1.2)) / (2 * np.pi)


#: The known truth of the biased-sensor chain (`biased_chain`): five springs, N/m.
BIASED_CHAIN_TRUTH = {"k1": 1100.0, "k2": 900.0, "k3": 1050.0, "k4": 950.0, "k5": 1080.0}


def biased_chain(bias_dof="y3", bias=0.10, half_width=0.005, modes=4):
    """A known-truth chain of five unit masses on springs ``k1..k5`` (nominal 1000 N/m, +-30 %),
    its first ``modes`` natural frequencies exact and its shapes measured at every DOF within
    ``+- half_width`` (the largest entry 1), but the entry of ``bias_dof`` (the driving point)
    scaled by ``1 + bias`` in every mode: a biased force cell or sensor.

    Returns the model, the frequencies (Hz) and per mode the measured ``{dof: value}`` of the
    intervals' midpoints (half-width ``half_width`` each)."""
    model = chain_model(5, list(BIASED_CHAIN_TRUTH))
    xbar = np.array([(BIASED_CHAIN_TRUTH[p.name] - p.nominal) / p.reference for p in model.parameters])
    M, K = (A.toarray() for A in model.matrices(xbar))
    import scipy.linalg

    eigenvalues, Phi = scipy.linalg.eigh(K, M)
    freqs, shapes = [], []
    for m in range(modes):
        phi = Phi[:, m] / np.max(np.abs(Phi[:, m]))
        freqs.append(float(np.sqrt(eigenvalues[m]) / (2 * np.pi)))
        shapes.append({d: float(phi[model.dof(d)]) * (1 + bias if d == bias_dof else 1.0) for d in model.dofs})
    return model, freqs, shapes


#: The environment variable naming the folder of the real data sets (not part of the repository).
REALDATA_ENV = "VIBUPDATE_REALDATA"


def realdata(name: str) -> Path:
    """Where a real data set is looked for (never part of the repository, never an absolute path
    written here): ``$VIBUPDATE_REALDATA/name`` when that variable is set, else
    ``<checkout>/../shared/realdata/name``. The folder may not exist: a test that needs it is
    marked ``@pytest.mark.realdata(name)`` and skipped by ``conftest.py`` naming this path."""
    import os

    root = os.environ.get(REALDATA_ENV)
    base = Path(root) if root else Path(__file__).resolve().parents[1].parent / "shared" / "realdata"
    return base / name


def realdata_skip_reason(name: str) -> str | None:
    """Why a test of the real data set ``name`` is skipped (None when the data are there)."""
    folder = realdata(name)
    if folder.is_dir():
        return None
    return (f"real data set {name!r} not found at {folder} (not part of the repository; set "
            f"{REALDATA_ENV} to the folder that holds it)")
