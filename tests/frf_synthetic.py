"""Known-truth FRFs for the extraction tests: the cantilever of the paper's test case 2
(configuration A, nominal parameters) with non-proportional viscous damping, and noisy
repeated measurements of its receptances; a Southampton-like frame, measured exactly
(`frame_measured`) or through the leakage bias of a Hann-windowed H1 estimate
(`frame_windowed`, checked against a closed-form time-domain route, `lagged_accelerance`)."""

from __future__ import annotations

import numpy as np
import scipy.linalg

from vibupdate.examples import bar, cantilever
from vibupdate.data.frf import FRFSet
from vibupdate.data.frf import write_uff58 as write_uff  # noqa: F401  (the tests' name for it)

PAIRS = (("y1", "y3"), ("y2", "y3"), ("y3", "y3"))
DASHPOT = 3.0  # N s/m at the load cell (y3): makes the damping non-proportional


def cantilever_system():
    """Dense M, K, C (SI) and DOF names; C = 2e-5 K + 1.0 M + a dashpot at y3."""
    p = {q.name: q.nominal for q in cantilever.parameters()}
    system = cantilever.build(p)
    M, K = system.M.toarray(), system.K.toarray()
    C = 2e-5 * K + 1.0 * M
    k = list(system.dofs).index("y3")
    C[k, k] += DASHPOT
    return M, K, C, list(system.dofs)


def true_poles(M, K, C):
    """Undamped natural frequencies |lam| (rad/s) and damping ratios of the damped system, ascending."""
    n = M.shape[0]
    A = np.block([[np.zeros((n, n)), np.eye(n)], [-scipy.linalg.solve(M, K), -scipy.linalg.solve(M, C)]])
    lam = scipy.linalg.eigvals(A)
    lam = lam[lam.imag > 0]
    lam = lam[np.argsort(np.abs(lam))]
    return np.abs(lam), -lam.real / np.abs(lam)


def true_zeros(M, K, r: int, c: int):
    """Antiresonances of the undamped receptance h_rc, rad/s, ascending: det of K - w^2 M
    without row r and column c."""
    rows = [i for i in range(M.shape[0]) if i != r]
    cols = [i for i in range(M.shape[0]) if i != c]
    ev = scipy.linalg.eigvals(K[np.ix_(rows, cols)], M[np.ix_(rows, cols)])
    ev = ev[np.isfinite(ev)]
    ev = ev[(np.abs(ev.imag) < 1e-6 * np.abs(ev)) & (ev.real > 0)].real
    return np.sort(np.sqrt(ev))


#: Measured pairs of `chain_system` (floors 1-3 measured, the light fourth mass not).
CHAIN_PAIRS = (("x1", "x1"), ("x2", "x1"), ("x3", "x1"), ("x3", "x3"))


def chain_system():
    """A four-mass chain whose light top mass (0.2 kg; 1 kg below) puts a mode at 50.3 Hz
    just above the third (47.2 Hz; the first two at 11.9 and 30.4 Hz), like a frame with an
    out-of-band mode just above its band; masses x1..x4 fixed at x1's side. Dense M, K, C
    (C = 1e-5 K + 0.5 M + a 2 N s/m dashpot at x1) and DOF names."""
    masses, springs = np.array([1.0, 1.0, 1.0, 0.2]), np.array([4e4, 3e4, 2e4, 1.5e4])
    K = np.diag(springs + np.append(springs[1:], 0.0)) - np.diag(springs[1:], 1) - np.diag(springs[1:], -1)
    M = np.diag(masses)
    C = 1e-5 * K + 0.5 * M
    C[0, 0] += 2.0
    return M, K, C, ["x1", "x2", "x3", "x4"]


def measured(seed: int, repeats: int = 5, noise: float = 0.03, floor: float = 1e-3, step_hz: float = 0.25,
             band_hz=(20.0, 300.0), system=None, pairs=PAIRS):
    """Noisy repeated receptances: complex noise of ``noise * |H|`` plus ``floor * max |H|`` per
    line (the -60 dB floor), Gaussian, independent per repeat. ``system`` (M, K, C, dofs)
    defaults to `cantilever_system`. Returns (FRFSet, M, K, C, dofs)."""
    M, K, C, dofs = cantilever_system() if system is None else system
    omega = 2 * np.pi * np.arange(band_hz[0], band_hz[1] + step_hz / 2, step_hz)
    H = np.linalg.inv(K[None] - omega[:, None, None] ** 2 * M[None] + 1j * omega[:, None, None] * C[None])
    rng = np.random.default_rng(seed)
    blocks = []
    for r, c in pairs:
        h = H[:, dofs.index(r), dofs.index(c)]
        sigma = noise * np.abs(h) + floor * np.abs(h).max()
        e = rng.standard_normal((repeats, h.size)) + 1j * rng.standard_normal((repeats, h.size))
        blocks.append(h[None] + sigma[None] * e / np.sqrt(2))
    return FRFSet(omega, pairs, tuple(blocks)), M, K, C, dofs


def score(result, M, K, C, dofs, pairs=PAIRS):
    """Errors and interval hits of an extraction against the truth in its band.

    Returns a dict: ``freq_err``, ``damping_err``, ``zero_err`` (relative, lists), ``freq_hit``,
    ``damping_hit``, ``zero_hit`` (bools), ``zero_count_ok`` (bool per FRF), ``n_modes_ok``.
    """
    lo, hi = result.band
    wn, zeta = true_poles(M, K, C)
    inside = (wn > lo) & (wn < hi)
    wn, zeta = wn[inside], zeta[inside]
    out = {k: [] for k in ("freq_err", "damping_err", "zero_err", "freq_hit", "damping_hit", "zero_hit",
                           "zero_count_ok")}
    out["n_modes_ok"] = len(result.modes) == wn.size
    if out["n_modes_ok"]:
        for m, w, z in zip(result.modes, wn, zeta):
            out["freq_err"].append(abs(m.omega / w - 1))
            out["damping_err"].append(abs(m.damping_ratio / z - 1))
            out["freq_hit"].append(m.omega_interval[0] <= w <= m.omega_interval[1])
            out["damping_hit"].append(m.damping_interval[0] <= z <= m.damping_interval[1])
    for r, c in pairs:
        truth = true_zeros(M, K, dofs.index(r), dofs.index(c))
        truth = truth[(truth > lo) & (truth < hi)]
        got = [z for z in result.zeros if (z.response, z.excitation) == (r, c)]
        out["zero_count_ok"].append(len(got) == truth.size)
        if len(got) == truth.size:
            for z, t in zip(got, truth):
                out["zero_err"].append(abs(z.omega / t - 1))
                out["zero_hit"].append(z.interval[0] <= t <= z.interval[1])
    return out


#: Measured pairs of `frame_system`: the full 3x3 matrix of the sway DOFs.
FRAME_PAIRS = tuple((f"x{r}", f"x{c}") for c in (1, 2, 3) for r in (1, 2, 3))


def frame_system():
    """A three-storey shear frame like the Southampton one: storey masses 5.2 kg,
    storey stiffnesses 33.7, 36.7, 39.5 kN/m (modes at 6.5, 17.0 and 24.5 Hz), and two
    out-of-plane DOFs ``z1``, ``z2`` (5.2 kg, 28.9 and 42.1 Hz alone) tied to the floors by
    weak 1.8 kN/m springs, so that two light modes just above the band show in the sway FRFs
    (peaks of about 0.5 (m/s^2)/N against 5-25 for the sway modes, as measured there).
    Damping about 0.2 % and non-proportional: C = 0.12 M + 2.3e-5 K + a 0.3 N s/m dashpot at
    x1. Dense M, K, C (SI) and DOF names."""
    k = 0.88 * np.array([38.35e3, 41.65e3, 44.9e3])
    K = np.zeros((5, 5))
    K[:3, :3] = np.diag(k + np.append(k[1:], 0.0)) - np.diag(k[1:], 1) - np.diag(k[1:], -1)
    M = np.diag([5.2] * 5)
    K[3, 3], K[4, 4] = 5.2 * (2 * np.pi * 28.9) ** 2, 5.2 * (2 * np.pi * 42.1) ** 2
    for a, b in ((2, 3), (1, 4), (0, 3)):  # weak ties: floor 3 and 1 to z1, floor 2 to z2
        K[np.ix_([a, b], [a, b])] += 0.88 * 2e3 * np.array([[1.0, -1.0], [-1.0, 1.0]])
    C = 0.12 * M + 2.3e-5 * K
    C[0, 0] += 0.3
    return M, K, C, ["x1", "x2", "x3", "z1", "z2"]


def frame_measured(seed: int, repeats: int = 1, floor: float = 4e-3, noise: float = 0.005,
                   step_hz: float = 0.03125, band_hz=(3.0, 56.0)):
    """Noisy accelerances of `frame_system` as the Southampton data are (one record per pair,
    0.03125 Hz lines), returned as receptances: complex Gaussian noise of ``floor``
    ((m/s^2)/N, the measured floor between the peaks) plus ``noise * |A|`` per line and
    repeat, then divided by ``-omega^2``. Returns (FRFSet, M, K, C, dofs)."""
    M, K, C, dofs = frame_system()
    omega = 2 * np.pi * np.arange(band_hz[0], band_hz[1] + step_hz / 2, step_hz)
    H = np.linalg.inv(K[None] - omega[:, None, None] ** 2 * M[None] + 1j * omega[:, None, None] * C[None])
    A = np.array([-omega**2 * H[:, dofs.index(r), dofs.index(c)] for r, c in FRAME_PAIRS])
    return _noisy_frame_records(A, omega, seed, repeats, floor, noise), M, K, C, dofs


def _noisy_frame_records(A, omega, seed, repeats, floor, noise):
    """FRFSet of `FRAME_PAIRS` from noise-free accelerances ``A`` (shape (n_pairs, n_freq),
    (m/s^2)/N): per pair and repeat complex Gaussian noise of ``floor + noise * |A|`` per line,
    then divided by ``-omega^2`` (receptances, m/N)."""
    rng = np.random.default_rng(seed)
    blocks = []
    for a in A:
        sigma = floor + noise * np.abs(a)
        e = rng.standard_normal((repeats, a.size)) + 1j * rng.standard_normal((repeats, a.size))
        blocks.append((a[None] + sigma[None] * e / np.sqrt(2)) / -omega[None] ** 2)
    return FRFSet(omega, FRAME_PAIRS, tuple(blocks), measured="accelerance")


#: Points per line of the fine grid and half-span (lines) of the window kernel in `windowed_accelerance`.
KERNEL_POINTS_PER_LINE = 32
KERNEL_SPAN_LINES = 64


def window_power_kernel(u, window: str = "hann"):
    """Power kernel ``|W(u)|^2 / integral |W|^2`` of a data window over one record of length
    ``T``, at frequency offsets ``u`` (array, in lines: ``u = f T``, one line = ``1/T`` Hz);
    its integral over ``u`` is 1.

    ``"hann"``: ``w(t) = sin^2(pi t / T)`` on ``[0, T]``, whose transform is, up to a phase,
    ``T (sinc(u) / 2 + sinc(u - 1) / 4 + sinc(u + 1) / 4)`` (``sinc(x) = sin(pi x) / (pi x)``),
    and ``integral |W|^2 du = 3 / 8`` in those units. ``"boxcar"`` (no window): ``sinc(u)^2``.
    """
    u = np.asarray(u, dtype=float)
    if window == "hann":
        return (0.5 * np.sinc(u) + 0.25 * np.sinc(u - 1) + 0.25 * np.sinc(u + 1)) ** 2 / 0.375
    if window == "boxcar":
        return np.sinc(u) ** 2
    raise ValueError(f"window {window!r} is not known: expected 'hann' or 'boxcar'")


def windowed_accelerance(M, K, C, dofs, pairs, omega, window: str = "hann",
                         points_per_line: int = KERNEL_POINTS_PER_LINE, span_lines: int = KERNEL_SPAN_LINES):
    """Expected H1 estimate of the accelerances under a flat-spectrum random force, each
    record of length ``T = 2 pi / (omega[1] - omega[0])`` weighted by ``window``.

    With ``x`` and ``f`` windowed over one record, ``E[X F*] / E[|F|^2]`` is the true FRF
    smoothed by the window's power kernel (`window_power_kernel`)::

        E[A1](f) = integral A(nu) |W(f - nu)|^2 dnu / integral |W|^2

    the leakage bias of a windowed spectral estimate: a lightly damped peak comes out lower
    and wider, the more so the fewer lines its half-power bandwidth ``2 zeta f`` spans. The
    integral is a sum over a grid of ``points_per_line`` points per line, the kernel cut at
    ``+-span_lines`` lines and normalized to a unit sum (the sum converges geometrically: a
    peak one line wide is resolved by about 20 points; doubling either number changes the
    result by under 1e-6 relative, a test), computed by one FFT convolution per call.

    Parameters
    ----------
    M, K, C : ndarray, shape (n, n)
        Mass (kg), stiffness (N/m) and viscous damping (N s/m) matrices.
    dofs : sequence of str, length n
    pairs : sequence of (response, excitation) DOF names, length n_pairs
    omega : ndarray, shape (n_freq,)
        Equally spaced lines, rad/s.
    window : str
        ``"hann"`` or ``"boxcar"``.

    Returns
    -------
    ndarray, complex, shape (n_pairs, n_freq)
        Accelerances, (m/s^2)/N.
    """
    import scipy.signal

    omega = np.asarray(omega, dtype=float)
    step = omega[1] - omega[0]
    if not np.allclose(np.diff(omega), step, rtol=1e-9, atol=0.0):
        raise ValueError("windowed_accelerance needs equally spaced lines omega")
    P, L = int(points_per_line), int(span_lines)
    offsets = np.arange(-L * P, L * P + 1) / P
    kernel = window_power_kernel(offsets, window)
    kernel /= kernel.sum()
    fine = omega[0] + step * np.arange(-L * P, (omega.size - 1) * P + L * P + 1) / P
    H = np.linalg.inv(K[None] - fine[:, None, None] ** 2 * M[None] + 1j * fine[:, None, None] * C[None])
    rows = [dofs.index(r) for r, _ in pairs]
    cols = [dofs.index(c) for _, c in pairs]
    A = -fine[None] ** 2 * H[:, rows, cols].T
    smoothed = scipy.signal.fftconvolve(A, kernel[None], mode="valid", axes=1)
    return smoothed[:, ::P]


def frame_windowed(seed: int, repeats: int = 1, floor: float = 4e-3, noise: float = 0.005,
                   step_hz: float = 0.03125, band_hz=(3.0, 56.0), window: str = "hann"):
    """As `frame_measured` (same system, pairs, lines and noise model: ``floor + noise * |A|``
    per line, (m/s^2)/N), but the noise-free accelerances are the expected H1 estimate of a
    random-excitation test with a Hann window over each record of ``T = 1 / step_hz`` s
    (`windowed_accelerance`): the exact FRF smoothed by the window's power kernel, the leakage
    bias of the estimate. The truth is still the system's poles and undamped zeros; the bias is
    part of the error an estimator faces. With the same seed the noise draws are those of
    `frame_measured`. Returns (FRFSet of receptances, m/N; M, K, C, dofs)."""
    M, K, C, dofs = frame_system()
    omega = 2 * np.pi * np.arange(band_hz[0], band_hz[1] + step_hz / 2, step_hz)
    A = windowed_accelerance(M, K, C, dofs, FRAME_PAIRS, omega, window)
    return _noisy_frame_records(A, omega, seed, repeats, floor, noise), M, K, C, dofs


def _exp_moments(a):
    """``integral_0^1 exp(a x) dx`` and ``integral_0^1 x exp(a x) dx``, elementwise (a complex,
    away from 0)."""
    ea = np.exp(a)
    return (ea - 1) / a, ea / a - (ea - 1) / a**2


def _hann_lag(z):
    """``integral_0^1 exp(z x) g(x) dx`` for the Hann window's normalized autocorrelation
    ``g(x) = (2/3) [(1 - x)(1 + cos(2 pi x) / 2) + 3 sin(2 pi x) / (4 pi)]`` (``x = t / T``),
    cos and sin written as exponentials."""
    total = 0.0
    for m, c_cos, c_sin in ((0, 1.0, 0.0), (1, 0.25, 3 / (8j * np.pi)), (-1, 0.25, -3 / (8j * np.pi))):
        i0, i1 = _exp_moments(z + 2j * np.pi * m)
        total = total + c_cos * (i0 - i1) + c_sin * i0
    return 2 / 3 * total


#: ``integral_0^1 exp(z x) g(x) dx`` of the lag window ``g`` (``x = t / T``) of an estimate:
#: random force with a Hann window or none (``g`` the window's normalized autocorrelation),
#: or one impact per record at ``t = 0`` with no window or an exponential one that ends at 1 %
#: (``g`` the window itself).
LAG_WINDOWS = {
    "random, hann": _hann_lag,
    "random, boxcar": lambda z: _exp_moments(z)[0] - _exp_moments(z)[1],
    "impact, no window": lambda z: _exp_moments(z)[0],
    "impact, exponential 1 %": lambda z: _exp_moments(z - np.log(100.0))[0],
}


def lagged_accelerance(M, K, C, dofs, pairs, omega, lag: str = "random, hann", record_s: float | None = None):
    """The expectation of an FRF estimate as the transform of the impulse response times a lag
    window ``g`` over the record ``[0, T]`` (``T = record_s``, s; default
    ``2 pi / (omega[1] - omega[0])``, one record per line spacing), in closed
    form from the modal expansion of the accelerance: an independent route to
    `windowed_accelerance` (``"random, hann"``: with a flat-spectrum force and a window ``w``,
    ``E[X F*] / E[|F|^2]`` is the transform of ``h(t) g(t)``, ``g`` the normalized
    autocorrelation of ``w``) and other estimates (`LAG_WINDOWS`).

    With the state-space poles ``lam_k`` and residues ``rho_k`` of the receptance,
    ``A(s) = D + sum_k rho_k lam_k^2 / (s - lam_k)`` (``D = (M^-1)_rc``), and the estimate is
    ``D + sum_k rho_k lam_k^2 T integral_0^1 exp((lam_k - j omega) T x) g(x) dx``.

    Parameters are those of `windowed_accelerance` (``omega`` rad/s, shape (n_freq,), any
    lines when ``record_s`` is given), ``lag`` a key of `LAG_WINDOWS`; returns accelerances,
    (m/s^2)/N, complex, shape (n_pairs, n_freq).
    """
    if lag not in LAG_WINDOWS:
        raise ValueError(f"lag window {lag!r} is not known: expected one of {sorted(LAG_WINDOWS)}")
    omega = np.asarray(omega, dtype=float)
    T = 2 * np.pi / (omega[1] - omega[0]) if record_s is None else float(record_s)
    n = M.shape[0]
    Minv = scipy.linalg.inv(M)
    lam, V = scipy.linalg.eig(np.block([[np.zeros((n, n)), np.eye(n)], [-Minv @ K, -Minv @ C]]))
    W = scipy.linalg.inv(V)
    integral = LAG_WINDOWS[lag]((lam[None, :] - 1j * omega[:, None]) * T) * T  # (n_freq, 2n)
    out = []
    for r, c in pairs:
        i, j = dofs.index(r), dofs.index(c)
        rho = V[i, :] * (W[:, n:] @ Minv[:, j])
        out.append(Minv[i, j] + integral @ (rho * lam**2))
    return np.array(out)


def impact_measured(seed: int, decay: float = 0.05, repeats: int = 3, noise: float = 2e-3, record_s: float = 32.0,
                    fs: float = 1024.0, pulse_s: float = 2e-3, band_hz=(3.0, 56.0)):
    """Hammer tests of `frame_system` in the time domain, as a lab processes them: per hit a
    half-sine force pulse (``pulse_s`` long, unit peak) at each excitation of `FRAME_PAIRS`,
    the acceleration responses computed exactly at ``fs`` samples per second over the record
    (modal superposition of the state-space poles, convolved with the sampled pulse, plus the
    direct term ``M^-1 f``), Gaussian sensor noise of ``noise`` times the response's largest
    value added, an exponential window ending at ``decay`` applied to the response (the force
    window leaves the pulse as it is), and ``FFT(a w) / FFT(f)`` on the lines in ``band_hz``.
    Returns (FRFSet of receptances, measured accelerance; M, K, C, dofs)."""
    M, K, C, dofs = frame_system()
    n = M.shape[0]
    Minv = scipy.linalg.inv(M)
    lam, V = scipy.linalg.eig(np.block([[np.zeros((n, n)), np.eye(n)], [-Minv @ K, -Minv @ C]]))
    W = scipy.linalg.inv(V)
    dt, samples = 1.0 / fs, int(round(record_s * fs))
    t = np.arange(samples) * dt
    force = np.zeros(samples)
    width = int(round(pulse_s * fs))
    force[:width + 1] = np.sin(np.pi * np.arange(width + 1) / width)
    window = decay ** (t / record_s)
    freq = np.fft.rfftfreq(samples, dt)
    keep = (freq >= band_hz[0] - 1e-9) & (freq <= band_hz[1] + 1e-9)
    spectrum = np.fft.rfft(force)[keep]
    rng = np.random.default_rng(seed)
    blocks = []
    for r, c in FRAME_PAIRS:
        i, j = dofs.index(r), dofs.index(c)
        rho = V[i, :] * (W[:, n:] @ Minv[:, j])
        impulse = (np.exp(np.outer(t, lam)) @ (rho * lam**2)).real      # accelerance impulse response, t > 0
        response = dt * np.convolve(impulse, force)[:samples] + Minv[i, j] * force
        records = response[None] + noise * np.abs(response).max() * rng.standard_normal((repeats, samples))
        accelerance = np.fft.rfft(records * window[None], axis=1)[:, keep] / spectrum[None]
        blocks.append(accelerance / -(2 * np.pi * freq[keep][None]) ** 2)
    return FRFSet(2 * np.pi * freq[keep], FRAME_PAIRS, tuple(blocks), measured="accelerance"), M, K, C, dofs


def cantilever_frf_case(folder):
    """The cantilever's known-truth hits (`measured`, seed 9, three repeats) as ``hits.uff`` in
    ``folder``, and the case text: its head (model and parameters, one configuration ``A``)
    and the whole case reading the hits through ``[configuration.frf]`` in 20-300 Hz."""
    from vibupdate.examples import bar, cantilever

    frfs, *_ = measured(9, repeats=3)
    write_uff(folder / "hits.uff", frfs)
    params = "\n".join(f'[[parameter]]\nname = "{p.name}"\nnominal = {p.nominal!r}\nlower = {p.lower!r}\n'
                       f'upper = {p.upper!r}\n' for p in cantilever.parameters())
    head = (f'case = "frf"\n[model]\ntype = "builder"\nbuilder = "vibupdate.examples.cantilever:build"\n{params}\n'
            '[[configuration]]\nname = "A"\n')
    return head, head + '[configuration.frf]\nfiles = ["hits.uff"]\nband_hz = [20, 300]\n'


def bar_true_shapes(n_modes: int = 4):
    """The mass-normalized bending modes of the bar example's truth (`vibupdate.examples.bar`) at
    the hammer points, ``{dof: value}`` per mode, and their frequencies (Hz): the model's modes
    `bar.FIRST_MODE` on."""
    w, V, index = bar.true_modes()
    flexible = np.flatnonzero(w > 2 * np.pi * 1.0)   # the suspension modes are a few Hz; rigid ones 0
    chosen = flexible[bar.FIRST_MODE - 1:bar.FIRST_MODE - 1 + n_modes]
    return [{f"y{k}": float(V[index[f"y{k}"], m]) for k in bar.HAMMER} for m in chosen], w[chosen] / (2 * np.pi)
