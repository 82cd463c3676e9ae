"""Worked example: a roving-hammer test of a free-free steel bar, ``vibupdate example bar --out DIR``
(docs/worked-bar.md describes the test, the truth and the model): `write_inputs` writes the
test's UFF file and the two case files, `commands` lists the commands a user runs.

The truth's element is the Timoshenko beam of interdependent interpolation (``Phi = 12 EI /
(k G A L^2)``, exact for static shear bending) with the consistent masses of the Hermite
cubics, on a mesh `TRUTH_REFINE` times finer than the model's (at 3x the first four bending
frequencies differ from 6x by under 4e-5). Noise: complex Gaussian, ``noise * |H|`` plus
``floor * max |H|`` per line and repeat.
"""

from __future__ import annotations

import numpy as np
import scipy.linalg

from pathlib import Path

from vibupdate.data.frf import FRFSet
from vibupdate.model.elements import beam_matrices


#: The bar: length, width, height (m), true Young's modulus (Pa), density (kg/m^3), Poisson's
#: ratio and shear coefficient of a rectangular section.
LENGTH, WIDTH, HEIGHT = 0.6, 0.03, 0.012
E_TRUE, RHO_TRUE, NU, SHEAR_K = 205e9, 7850.0, 0.3, 5 / 6
#: Nominal values of the model (handbook steel) and the other candidates' truth.
E_NOMINAL, RHO_NOMINAL = 210e9, 7850.0
SPRING, TIP_MASS = 2000.0, 0.005
#: Model nodes (17, labels 1..17), support nodes, hammer points; the truth mesh is refined.
MODEL_ELEMENTS, SUPPORTS, TRUTH_REFINE = 16, (5, 13), 3
HAMMER = tuple(range(1, 18, 2))
ACCELEROMETER = 1
DAMPING = 0.006
#: Bending modes measured: the model's modes 3-6 (1 and 2 are the suspension modes).
FIRST_MODE, BAND_HZ, DATA_HZ, STEP_HZ = 3, (100.0, 1600.0), (50.0, 2600.0), 0.5

AREA, INERTIA = WIDTH * HEIGHT, WIDTH * HEIGHT**3 / 12


def timoshenko_matrices(n_elements: int, E: float = E_TRUE, rho: float = RHO_TRUE):
    """Dense free-free K, M (DOFs ``[w1, psi1, w2, psi2, ...]``) of the Timoshenko bar."""
    L = LENGTH / n_elements
    G = E / (2 * (1 + NU))
    phi = 12 * E * INERTIA / (SHEAR_K * G * AREA * L**2)
    k = E * INERTIA / ((1 + phi) * L**3) * np.array([
        [12, 6 * L, -12, 6 * L],
        [6 * L, (4 + phi) * L**2, -6 * L, (2 - phi) * L**2],
        [-12, -6 * L, 12, -6 * L],
        [6 * L, (2 - phi) * L**2, -6 * L, (4 + phi) * L**2]])
    _, m = beam_matrices(0.0, rho * AREA, [L], rotary_inertia=rho * INERTIA)
    n = 2 * (n_elements + 1)
    K, M = np.zeros((n, n)), np.zeros((n, n))
    for e in range(n_elements):
        s = slice(2 * e, 2 * e + 4)
        K[s, s] += k
        M[s, s] += m[0]
    return K, M


def truth_system(accelerometer: int = ACCELEROMETER):
    """K, M of the truth with the suspension springs and the accelerometer's mass at node
    ``accelerometer``, and the truth DOF index of each model node's deflection ``y<label>``."""
    K, M = timoshenko_matrices(MODEL_ELEMENTS * TRUTH_REFINE)
    index = {f"y{j}": 2 * TRUTH_REFINE * (j - 1) for j in range(1, MODEL_ELEMENTS + 2)}
    for node in SUPPORTS:
        K[index[f"y{node}"], index[f"y{node}"]] += SPRING
    M[index[f"y{accelerometer}"], index[f"y{accelerometer}"]] += TIP_MASS
    return K, M, index


def true_modes(accelerometer: int = ACCELEROMETER):
    """Undamped natural frequencies (rad/s) and mass-normalized modes of the truth, ascending."""
    K, M, index = truth_system(accelerometer)
    lam, V = scipy.linalg.eigh(K, M)
    return np.sqrt(np.abs(lam)), V, index


def measured(seed: int, repeats: int = 3, noise: float = 0.01, floor: float = 1e-4,
             accelerometer: int = ACCELEROMETER, hammer=HAMMER):
    """Roving-hammer receptances ``h(y<accelerometer>, yk)`` of the truth, k over ``hammer``,
    as measured (the accelerometer the response): an `FRFSet` over `DATA_HZ` at `STEP_HZ`."""
    w, V, index = true_modes(accelerometer)
    omega = 2 * np.pi * np.arange(DATA_HZ[0], DATA_HZ[1] + STEP_HZ / 2, STEP_HZ)
    denominator = w[None, :] ** 2 - omega[:, None] ** 2 + 2j * DAMPING * w[None, :] * omega[:, None]
    response = V[index[f"y{accelerometer}"]]
    pairs = tuple((f"y{accelerometer}", f"y{k}") for k in hammer)
    rng = np.random.default_rng(seed)
    blocks = []
    for _, c in pairs:
        h = (response * V[index[c]] / denominator).sum(axis=1)
        sigma = noise * np.abs(h) + floor * np.abs(h).max()
        e = rng.standard_normal((repeats, h.size)) + 1j * rng.standard_normal((repeats, h.size))
        blocks.append(h[None] + sigma[None] * e / np.sqrt(2))
    return FRFSet(omega, pairs, tuple(blocks))


#: Model-form tolerances of the case: the frequencies to 0.1 % (the accuracy asked of the
#: model), the shapes to the default 0.02.
NATURAL_TOLERANCE, SHAPE_TOLERANCE = 0.001, 0.02


#: The candidates of the case: name, unit, nominal, lower, upper bound and reference value
#: (the scale of a candidate whose nominal value is 0; None: its nominal value).
CANDIDATES = (("E", "Pa", E_NOMINAL, 180e9, 240e9, None), ("rho", "kg/m^3", RHO_NOMINAL, 7000.0, 8700.0, None),
              ("r", "-", 0.0, 0.0, 10.0, 1.0), ("ks1", "N/m", SPRING, 200.0, 20000.0, None),
              ("ks2", "N/m", SPRING, 200.0, 20000.0, None), ("macc", "kg", TIP_MASS, 0.001, 0.05, None))


def _parameter_tables(parameters) -> str:
    """``[[parameter]]`` tables of the names in ``parameters`` and ``[[candidate]]`` tables of the
    other `CANDIDATES`; an unknown name is refused."""
    known = [c[0] for c in CANDIDATES]
    unknown = [name for name in parameters if name not in known]
    if unknown:
        raise ValueError(f"parameters {unknown} of the bar's case are not among its candidates {known}")
    text = ""
    for name, unit, nominal, lower, upper, reference in CANDIDATES:
        table = "parameter" if name in parameters else "candidate"
        text += (f'[[{table}]]\nname = "{name}"\nunit = "{unit}"\nnominal = {nominal!r}\nlower = {lower!r}\n'
                 f'upper = {upper!r}\n' + (f"reference = {reference!r}\n" if reference is not None else ""))
    return text


def case_text(uff: str = "hammer.uff", parameters=(),
              mass_normalized: bool = True) -> str:
    """The case file: the Euler-Bernoulli model of the bar, the names in ``parameters`` its
    ``[[parameter]]``s (default none), the others of `CANDIDATES` (E, rho, the rotary-inertia
    factor r, the two suspension springs, the tip mass) its ``[[candidate]]``s, and the
    roving-hammer FRFs of ``uff`` read reciprocally; with ``mass_normalized`` their shapes are
    taken as mass-normalized (the test is calibrated in SI units and has its driving point
    ``h_y1,y1``), so that their modal masses see the density apart from E."""
    beams = (f'[[model.beam]]\nnodes = {list(range(1, MODEL_ELEMENTS + 2))}\nEI = "{INERTIA!r}*E"\n'
             f'mass_per_length = "{AREA!r}*rho"\nrotary_inertia = "{RHO_NOMINAL * INERTIA!r}*r"\n')
    springs = "".join(f'[[model.spring]]\ndof = "y{n}"\nvalue = "ks{i}"\n' for i, n in enumerate(SUPPORTS, 1))
    pairs = ", ".join(f'"y{k}"' for k in HAMMER)
    return (f'case = "free-free-bar"\n\n[model]\ntype = "elements"\nkind = "beam"\n'
            f'line = {{ first = 1, last = {MODEL_ELEMENTS + 1}, start = [0.0], end = [{LENGTH!r}] }}\n'
            f'{beams}{springs}[[model.mass]]\ndof = "y{ACCELEROMETER}"\nvalue = "macc"\n\n'
            f'{_parameter_tables(parameters)}\n'
            f'[[configuration]]\nname = "bar"\nmass_normalized_shapes = {str(mass_normalized).lower()}\n'
            f'[configuration.frf]\nfiles = ["{uff}"]\n'
            f'band_hz = [{BAND_HZ[0]!r}, {BAND_HZ[1]!r}]\nfirst_mode = {FIRST_MODE}\nreciprocal = true\n\n'
            + f'[verification]\nnatural_tolerance = {NATURAL_TOLERANCE!r}\nshape_tolerance = {SHAPE_TOLERANCE!r}\n'
            f'# hammer points: {pairs}\n')


#: Seed of the noise of the example's test.
SEED = 0
#: The case files of the example: E alone updated, and E with the rotary-inertia factor.
CASE, CASE_R = "case.toml", "case-r.toml"
PARAMETERS = {CASE: ("E",), CASE_R: ("E", "r")}


def write_inputs(out) -> Path:
    """Write the lab's files into the new folder ``out``: ``hammer.uff`` (the test of seed
    `SEED`) and the case files `CASE` and `CASE_R`; returns ``out``.

    Raises `MissingExtra` without the ``[frf]`` extra (UFF files need pyuff) before any file
    is written, and ValueError for a folder that holds files."""
    from vibupdate.extras import require
    from vibupdate.data.frf import write_uff58
    from vibupdate.examples import new_folder

    require("frf", "the bar example's UFF file")
    out = Path(out)
    new_folder(out)
    write_uff58(out / "hammer.uff", measured(SEED))
    for name, parameters in PARAMETERS.items():
        (out / name).write_text(case_text(parameters=parameters))
    return out


def commands(out) -> list[list[str]]:
    """The command lines of the example in ``out``, in the order a user runs them: extract the
    modes (shapes at all nine points), run with E alone, suggest, run with E and r."""
    out = Path(out)
    band = [f"{f:g}" for f in BAND_HZ]
    return [["extract", str(out / "hammer.uff"), "--reciprocal", "--band", *band, "--first-mode", str(FIRST_MODE),
             "--out", str(out / "extraction"), "--no-plot"],
            ["run", str(out / CASE), "--out", str(out / "results-E")],
            ["suggest", str(out / CASE), "--out", str(out / "suggestion")],
            ["run", str(out / CASE_R), "--out", str(out / "results-E-r")]]


#: True values of the parameters the example updates; r has no true value (it stands in for
#: shear and rotary inertia together).
TRUTH = {"E": E_TRUE, "rho": RHO_TRUE}


def truth_lines(out) -> list[str]:
    """Each updated parameter of the two runs against its truth, from their ``results.json``."""
    import json

    lines = [f"{'run':<12} {'parameter':<10} {'truth':>12} {'updated':>14} {'relative error':>15}  status"]
    for folder in ("results-E", "results-E-r"):
        path = Path(out) / folder / "results.json"
        if not path.is_file():
            continue
        document = json.loads(path.read_text())
        for p in document["parameters"]:
            target = TRUTH.get(p["name"])
            truth, error = (f"{target:>12.6g}", f"{abs(p['updated'] / target - 1):>15.2e}") if target else \
                (f"{'-':>12}", f"{'-':>15}")
            lines.append(f"{folder:<12} {p['name']:<10} {truth} {p['updated']:>14.6g} {error}  "
                         f"{document['solver']['status']}")
    return lines
