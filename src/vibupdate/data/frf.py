"""Measured frequency response functions (FRFs): reading, units and DOF names.

An FRF ``H_rc(omega)`` is the response at DOF ``r`` to a unit force at DOF ``c``. Inside
vibupdate every FRF is a **receptance** (m/N or rad/(N m)) on a frequency axis in rad/s: the
readers convert accelerance and mobility at the edge, name DOFs as the dataset-55 reader does
(``x3``, ``rx3``, ``phi3``; a negative UFF direction flips the data's sign), and keep records of
one (response, excitation) pair apart as **repeats**, whose scatter is the noise estimate. The
sources (UFF dataset 58 through pyuff, CSV/text columns, ``.npz``) and every check:
docs/frf-extraction.md, "Input".
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from vibupdate.extras import require


G = 9.80665  # m/s^2, standard gravity
TWO_PI = 2.0 * math.pi
KINDS = ("receptance", "mobility", "accelerance")
_UFF_DIRECTIONS = {1: "x", 2: "y", 3: "z", 4: "rx", 5: "ry", 6: "phi"}
_UFF_ORDINATE_KIND = {8: "receptance", 11: "mobility", 12: "accelerance"}


@dataclass(frozen=True)
class FRFSet:
    """Measured receptances on one frequency axis, grouped by DOF pair.

    Attributes
    ----------
    omega : ndarray, shape (n_freq,)
        Frequency lines, rad/s, strictly increasing and positive.
    pairs : tuple of (str, str)
        ``(response, excitation)`` DOF names of each distinct FRF, in first-seen order.
    H : tuple of ndarray, one per pair, shape (n_repeats, n_freq), complex
        Receptance of every repeat of the pair, m/N (or rad/(N m) for rotations).
    sources : tuple of str
        Where the data came from (file names), for reports.
    measured : str
        What the files held before the conversion to receptance: ``"receptance"``,
        ``"mobility"``, ``"accelerance"`` or ``"mixed"`` (a spectral estimate's window smooths
        that quantity: `vibupdate.data.extraction.extract`'s ``window``).
    """

    omega: np.ndarray
    pairs: tuple
    H: tuple
    sources: tuple = ()
    measured: str = "receptance"

    def __post_init__(self):
        omega = np.asarray(self.omega, dtype=float).ravel()
        if omega.size < 2 or not np.all(np.isfinite(omega)) or omega[0] <= 0 or np.any(np.diff(omega) <= 0):
            raise ValueError("FRF frequencies must be positive, finite and strictly increasing "
                             f"(got {omega.size} lines starting at {omega[:1]} rad/s)")
        if self.measured not in (*KINDS, "mixed"):
            raise ValueError(f"FRF measured quantity must be one of {(*KINDS, 'mixed')}, got {self.measured!r}")
        pairs = tuple((str(r), str(c)) for r, c in self.pairs)
        if len(set(pairs)) != len(pairs):
            raise ValueError(f"FRF pairs must be distinct, got {pairs}")
        if len(self.H) != len(pairs):
            raise ValueError(f"{len(pairs)} FRF pairs but {len(self.H)} data arrays")
        blocks = []
        for pair, h in zip(pairs, self.H):
            h = np.atleast_2d(np.asarray(h, dtype=complex))
            if h.shape[1] != omega.size:
                raise ValueError(f"FRF {pair}: {h.shape[1]} values per repeat, expected {omega.size} (one per line)")
            if not np.all(np.isfinite(h)):
                raise ValueError(f"FRF {pair}: values must be finite")
            h.setflags(write=False)
            blocks.append(h)
        omega.setflags(write=False)
        object.__setattr__(self, "omega", omega)
        object.__setattr__(self, "pairs", pairs)
        object.__setattr__(self, "H", tuple(blocks))
        object.__setattr__(self, "sources", tuple(str(s) for s in self.sources))

    @property
    def freq_hz(self) -> np.ndarray:
        """Frequency lines in Hz, shape (n_freq,)."""
        return self.omega / TWO_PI

    @property
    def n_repeats(self) -> tuple[int, ...]:
        """Number of repeats of each pair, in the order of ``pairs``."""
        return tuple(h.shape[0] for h in self.H)

    def mean(self) -> np.ndarray:
        """Average over repeats.

        Returns
        -------
        ndarray of complex, shape (n_pairs, n_freq)
            The mean receptance of each pair, m/N (rad/(N m) for rotations).
        """
        return np.array([h.mean(axis=0) for h in self.H])

    def band(self, lo: float, hi: float) -> "FRFSet":
        """The lines within a band.

        Parameters
        ----------
        lo, hi : float
            The band's ends, rad/s; the lines with ``lo <= omega <= hi`` are kept.

        Returns
        -------
        FRFSet
            The same pairs and repeats on the kept lines.

        Raises
        ------
        ValueError
            The band holds fewer than two lines.
        """
        keep = (self.omega >= lo) & (self.omega <= hi)
        if keep.sum() < 2:
            raise ValueError(f"band {lo / TWO_PI:.6g}-{hi / TWO_PI:.6g} Hz holds {int(keep.sum())} frequency lines; "
                             f"the data span {self.freq_hz[0]:.6g}-{self.freq_hz[-1]:.6g} Hz")
        return FRFSet(self.omega[keep], self.pairs, tuple(h[:, keep] for h in self.H), self.sources, self.measured)

    def renamed(self, mapping: Mapping[str, str]) -> "FRFSet":
        """DOF names mapped to model DOF names.

        Parameters
        ----------
        mapping : mapping of str to str
            The model's name for each DOF name of the data, e.g.
            ``{"y3": "x2", "y4": "-x3"}``. A leading ``-`` flips the sign (where the data's
            direction opposes the model's). DOFs not in the mapping keep their names.

        Returns
        -------
        FRFSet
            The FRFs under the new names, signs applied; FRFs that come to share a pair become
            repeats of it.
        """
        def target(name):
            new = str(mapping.get(name, name)).strip()
            return (new[1:], -1.0) if new.startswith("-") else (new.lstrip("+"), 1.0)

        moved = ((target(r), target(c), h) for (r, c), h in zip(self.pairs, self.H))
        return _grouped(self.omega, (((r, c), sr * sc * h) for (r, sr), (c, sc), h in moved), self.sources,
                        self.measured)


    def reciprocal(self) -> "FRFSet":
        """Each ``h_rc`` read as ``h_cr`` (Maxwell-Betti reciprocity).

        A roving-hammer test as the extraction takes it: the shapes known at every hammer
        point.

        Returns
        -------
        FRFSet
            The same data with each pair's response and excitation swapped. Repeats stay
            repeats; a pair measured both ways stays two FRFs (each read the other way).
        """
        return FRFSet(self.omega, tuple((c, r) for r, c in self.pairs), self.H, self.sources, self.measured)


class FRFWarning(UserWarning):
    """Measured FRFs that read but look wrong (an implausible kind): the command line prints it."""


#: Slope of ``log |H|`` over ``log omega`` of a receptance (`kind_evidence`): a kind one or two
#: orders off moves it by 1 or 2 (the slopes found: `benchmarks/RESULTS.md`, "Figures behind
#: src/: FRF kinds"; the rule: docs/frf-extraction.md, "Input", "Implausible kinds").
RECEPTANCE_SLOPE = (-2.7, 0.8)
#: Above this slope no receptance of a passive structure runs in a band, while an accelerance
#: read as one rises as omega^2 below its first mode: an error, not a warning.
RISING = 1.5
#: A driving point's receptance has ``Im H <= 0`` at every line (passivity): the weighted share
#: of its lines that do (`kind_evidence`) is near 1 (the shares found: `benchmarks/RESULTS.md`,
#: "Figures behind src/: FRF kinds").
PASSIVE_SHARE = 0.5
TWO_ORDERS = 0.2
SLOPE_BINS = 12


def kind_evidence(frfs: FRFSet) -> tuple[float, dict]:
    """What the data say of their kind: the slope of ``log |H|`` over ``log omega`` of the
    receptances (a line through the medians of `SLOPE_BINS` log-spaced bins; mean over the
    FRFs), and, per shift ``k`` of the kind's order (-2..2), the share of the driving points'
    lines whose ``Im(H / (j omega)^k) < 0``, weighted by ``|Im|`` in the units the file held;
    empty without a driving point."""
    lw = np.log(frfs.omega)
    edges = np.linspace(lw[0], lw[-1], SLOPE_BINS + 1)
    which = np.clip(np.digitize(lw, edges) - 1, 0, SLOPE_BINS - 1)
    used = np.unique(which)
    centres = np.array([lw[which == b].mean() for b in used])
    mean = frfs.mean()
    medians = np.array([np.median(np.log(np.abs(mean[:, which == b]) + 1e-300), axis=1) for b in used])
    slope = float(np.mean(np.polyfit(centres, medians, 1)[0])) if used.size > 1 else 0.0
    order = {"receptance": 0, "mobility": 1, "accelerance": 2}.get(frfs.measured, 0)
    drive = [k for k, (r, c) in enumerate(frfs.pairs) if r == c]
    shares = {}
    if drive:
        held = mean[drive] * frfs.omega[None] ** order
        for k in range(-2, 3):
            im = (held * (-1j) ** k).imag
            shares[k] = float(np.sum(np.maximum(-im, 0.0)) / max(float(np.sum(np.abs(im))), 1e-300))
    return slope, shares


def check_kind(frfs: FRFSet) -> None:
    """Warn (`FRFWarning`) when one file's FRFs do not look like the kind declared, raise
    ValueError when they cannot be: the file, the kind declared, the likely one, the measured
    slope (`kind_evidence`, `RECEPTANCE_SLOPE`) and the driving point's phase share
    (`PASSIVE_SHARE`). Unambiguous: a slope above `RISING`, or outside the receptance range
    with the driving point's phase two orders off, and one kind that fits both."""
    if frfs.measured not in KINDS:
        return
    slope, shares = kind_evidence(frfs)
    lo, hi = RECEPTANCE_SLOPE
    order = KINDS.index(frfs.measured)

    def fits(k):
        return lo <= slope - k <= hi and (not shares or shares[k] >= PASSIVE_SHARE)

    if fits(0):
        return
    shifts = sorted((k for k in (2, 1, -1, -2) if 0 <= order + k < len(KINDS) and fits(k)),
                    key=lambda k: (-shares.get(k, 0.0), abs(k)))     # the phase most like a receptance's first
    likely = [KINDS[order + k] for k in shifts]
    phase = f", the driving point's Im H < 0 on a share {shares[0]:.2f} of it (a receptance: near 1)" if shares else ""
    text = (f"FRF file {', '.join(frfs.sources)}: declared {frfs.measured}, but the data look like "
            f"{' or '.join(likely) if likely else 'no FRF kind'}: log |H| of the receptance runs with log frequency "
            f"at slope {slope:+.2f} (a receptance: {lo:g} to {hi:+g}{phase}); is the kind (--kind, kind =) right?")
    two_off = bool(shares) and shares[0] <= TWO_ORDERS and not lo <= slope <= hi
    if len(likely) == 1 and (slope > RISING or two_off):
        raise ValueError(text)
    if shares and shares[0] <= TWO_ORDERS and lo <= slope <= hi:
        text += " (or the driving point's sign is flipped)"
    warnings.warn(text, FRFWarning, stacklevel=3)


def to_receptance(values, omega, kind: str, g_units: bool = False) -> np.ndarray:
    """Convert accelerance or mobility to receptance.

    Parameters
    ----------
    values : array_like, shape (..., n_freq), complex
        The FRF in ``kind`` units per newton (m/s^2/N, m/s/N or m/N; g/N when ``g_units``).
    omega : array_like, shape (n_freq,)
        rad/s.
    kind : {"receptance", "mobility", "accelerance"}
    """
    if kind not in KINDS:
        raise ValueError(f"FRF kind must be one of {KINDS}, got {kind!r}")
    h = np.asarray(values, dtype=complex) * (G if g_units else 1.0)
    jw = 1j * np.asarray(omega, dtype=float)
    return h if kind == "receptance" else h / jw if kind == "mobility" else h / jw**2


def combine(sets: Sequence[FRFSet]) -> FRFSet:
    """One set from several (files): records of the same pair become repeats.

    All sets must share the frequency axis (to 1e-9 relative).
    """
    if not sets:
        raise ValueError("no FRF data to combine")
    omega = sets[0].omega
    for s in sets:
        if s.omega.size != omega.size or not np.allclose(s.omega, omega, rtol=1e-9, atol=0):
            raise ValueError(f"FRF files {sets[0].sources} and {s.sources} have different frequency lines "
                             f"({omega.size} vs {s.omega.size} lines, "
                             f"{sets[0].freq_hz[0]:.6g}-{sets[0].freq_hz[-1]:.6g} "
                             f"vs {s.freq_hz[0]:.6g}-{s.freq_hz[-1]:.6g} Hz)")
    kinds = {s.measured for s in sets}
    return _grouped(omega, ((pair, h) for s in sets for pair, h in zip(s.pairs, s.H)),
                    [src for s in sets for src in s.sources], kinds.pop() if len(kinds) == 1 else "mixed")


def _grouped(omega, records, sources, measured: str) -> FRFSet:
    """An `FRFSet` of ``records``, ``((response, excitation), values)`` with values of shape
    (n_freq,) or (n_repeats, n_freq): the records of one pair become its repeats."""
    groups: dict = {}
    for pair, h in records:
        groups.setdefault(pair, []).append(np.atleast_2d(h))
    return FRFSet(omega, tuple(groups), tuple(np.vstack(v) for v in groups.values()), tuple(sources), measured)


def read_uff58(path, kind: str | None = None, g_units: bool = False) -> FRFSet:
    """FRFs from the dataset-58 (or 58b) records of a Universal File Format file.

    Parameters
    ----------
    path : path-like
    kind : {"receptance", "mobility", "accelerance"}, optional
        Overrides the record's ordinate type (8 displacement, 11 velocity, 12 acceleration).
    g_units : bool
        The ordinate is in g per newton.
    """
    path = Path(path)
    omega, records, kinds = None, [], set()
    for number, rec in uff_records(path, 58, "FRFs"):
        where = f"UFF file {str(path)!r}, dataset 58 number {number}"
        if int(rec.get("func_type", 4)) != 4:
            raise ValueError(f"{where}: function type {rec.get('func_type')}, expected 4 (frequency response function)")
        x = np.asarray(rec["x"], dtype=float) * TWO_PI
        if omega is None:
            omega = x
        elif x.size != omega.size or not np.allclose(x, omega, rtol=1e-9):
            raise ValueError(f"{where}: its frequency lines differ from the first record's")
        rec_kind = kind or _UFF_ORDINATE_KIND.get(int(rec.get("ordinate_spec_data_type", 0)))
        if rec_kind is None:
            raise ValueError(f"{where}: ordinate type {rec.get('ordinate_spec_data_type')} is not displacement (8), "
                             "velocity (11) or acceleration (12); pass kind= to say what it is")
        names, sign = [], 1.0
        for node_key, dir_key in (("rsp_node", "rsp_dir"), ("ref_node", "ref_dir")):
            direction = int(rec[dir_key])
            if abs(direction) not in _UFF_DIRECTIONS:
                raise ValueError(f"{where}: {dir_key} = {direction}, expected +-1..6")
            names.append(f"{_UFF_DIRECTIONS[abs(direction)]}{int(rec[node_key])}")
            sign *= -1.0 if direction < 0 else 1.0
        h = to_receptance(np.asarray(rec["data"], dtype=complex), np.where(x > 0, x, 1.0), rec_kind, g_units)
        records.append(((names[0], names[1]), sign * h))
        kinds.add(rec_kind)
    keep = omega > 0   # the 0 Hz line dropped
    return _grouped(omega[keep], ((pair, h[keep]) for pair, h in records), (str(path),),
                    kinds.pop() if len(kinds) == 1 else "mixed")


def uff_records(path: Path, dataset: int, what: str):
    """``(number, record)`` of each dataset ``dataset`` of a UFF file through pyuff, numbered from
    1 in file order; a ValueError naming the file when it is missing, cut short
    (`_check_uff_end`), unreadable, or has no such dataset (``what`` they hold, in words)."""
    require("frf", "reading UFF files")
    import pyuff

    if not path.is_file():
        raise ValueError(f"UFF file {str(path)!r} does not exist")
    _check_uff_end(path)
    try:
        uff = pyuff.UFF(str(path))
        types = [int(t) for t in uff.get_set_types()]
    except Exception as exc:  # pyuff raises bare Exceptions on malformed files
        raise ValueError(f"UFF file {str(path)!r} could not be read: {exc}") from None
    indices = [i for i, t in enumerate(types) if t == dataset]
    if not indices:
        raise ValueError(f"UFF file {str(path)!r} has no dataset {dataset} ({what}); datasets found: "
                         f"{', '.join(map(str, types)) or 'none'}")
    for number, i in enumerate(indices, start=1):
        try:
            yield number, uff.read_sets(i)
        except Exception as exc:  # pyuff raises bare Exceptions on malformed records
            raise ValueError(f"UFF file {str(path)!r}: dataset {dataset} number {number} could not be read: "
                             f"{exc}") from None


def _check_uff_end(path: Path) -> None:
    """A ValueError when the file does not end with the ``-1`` line that closes a dataset: a
    file cut short (a copy or a download that stopped), whose last dataset a reader would
    drop without a word."""
    with open(path, "rb") as f:
        f.seek(0, 2)
        f.seek(max(0, f.tell() - 512))
        tail = f.read()
    last = tail.rstrip().rsplit(b"\n", 1)[-1].strip()
    if last == b"-1":
        return
    with open(path, "rb") as f:
        lines = sum(block.count(b"\n") for block in iter(lambda: f.read(1 << 20), b"")) + (not tail.endswith(b"\n"))
    raise ValueError(f"UFF file {str(path)!r} ends at line {lines} inside a dataset (its last line is "
                     f"{last[:40].decode('latin-1')!r}, not the '-1' that closes a dataset): the file is cut short; "
                     "export or copy it again")


def _uff_node_direction(name: str) -> tuple[int, int]:
    """Node and UFF direction code of a DOF name such as ``y3`` (the inverse of `read_uff58`'s naming)."""
    for code, prefix in sorted(_UFF_DIRECTIONS.items(), key=lambda item: -len(item[1])):
        rest = name[len(prefix):]
        if name.startswith(prefix) and rest.isdigit():
            return int(rest), code
    raise ValueError(f"DOF name {name!r} cannot be written to a UFF record: expected a direction "
                     f"({', '.join(_UFF_DIRECTIONS.values())}) followed by a node number, such as 'y3'")


def write_uff58(path, frfs: FRFSet) -> None:
    """Write ``frfs`` as a UFF file of dataset-58 accelerances, one ASCII record per repeat.

    What a test system exports after a hammer test: `read_uff58` reads it back to the same
    receptances (to the file's printed digits) and DOF names.

    Parameters
    ----------
    path : path-like
        The file written (replaced if it exists).
    frfs : FRFSet
        Receptances; every DOF name a direction and a node (``y3``, ``rx12``).
    """
    require("frf", "writing UFF files")
    import pyuff

    sets = []
    for pair, h in zip(frfs.pairs, frfs.H):
        (rsp_node, rsp_dir), (ref_node, ref_dir) = (_uff_node_direction(name) for name in pair)
        for repeat in h:
            sets.append(pyuff.prepare_58(
                func_type=4, rsp_node=rsp_node, rsp_dir=rsp_dir, ref_node=ref_node, ref_dir=ref_dir,
                data=(1j * frfs.omega) ** 2 * repeat, x=frfs.freq_hz, id1="FRF", rsp_ent_name="structure",
                ref_ent_name="structure", abscissa_spacing=1, abscissa_spec_data_type=18,
                ordinate_spec_data_type=12, orddenom_spec_data_type=13, binary=0))
    pyuff.UFF(str(path)).write_sets(sets, mode="overwrite")


def _parse_complex(text: str, where: str) -> complex:
    try:
        return complex(text.strip().replace(" ", "").replace("i", "j"))
    except ValueError:
        hint = " (a decimal comma? write 1.5, not 1,5)" if "," in text else ""
        raise ValueError(f"{where}: expected a complex number like 1.5-2e-3j, got {text!r}{hint}") from None


def _read_columns(path: Path, pairs: bool) -> tuple[np.ndarray, np.ndarray]:
    if path.suffix.lower() == ".npz":
        try:
            with np.load(path) as data:
                f, h = np.asarray(data["freq_hz"], dtype=float), np.asarray(data["H"], dtype=complex)
        except (OSError, KeyError, ValueError) as exc:
            raise ValueError(f"FRF file {str(path)!r}: expected arrays 'freq_hz' (n_freq,) and 'H' "
                             f"(n_freq, n_columns): {exc}") from None
        if h.ndim == 1:
            h = h[:, None]
        if h.ndim != 2 or h.shape[0] != f.size:
            hint = " (one row per column: transpose it)" if h.ndim == 2 and h.shape[1] == f.size else ""
            raise ValueError(f"FRF file {str(path)!r}: 'H' has shape {h.shape}, expected ({f.size}, n_columns): one "
                             f"row per frequency line of 'freq_hz'{hint}")
        return f, h
    try:
        lines = [ln for ln in path.read_text(encoding="utf-8-sig").splitlines()
                 if ln.strip() and not ln.lstrip().startswith("#")]
    except (OSError, UnicodeDecodeError) as exc:
        raise ValueError(f"FRF file {str(path)!r} could not be read: {exc}") from None
    if not lines:
        raise ValueError(f"FRF file {str(path)!r} is empty")
    sep = ";" if ";" in lines[0] else "," if "," in lines[0] else None
    rows = []
    for n, line in enumerate(lines, start=1):
        cells = line.split(sep)
        where = f"FRF file {str(path)!r}, row {n}"
        if n == 1 and not any(ch.isdigit() for ch in cells[0]):
            continue  # a header line
        values = [_parse_complex(c, f"{where}, column {k}") for k, c in enumerate(cells)]
        if pairs:
            if len(values) % 2 != 1:
                raise ValueError(f"{where}: expected the frequency and real/imaginary pairs, got {len(values)} columns")
            values = [values[0]] + [values[k].real + 1j * values[k + 1].real for k in range(1, len(values), 2)]
        if rows and len(values) != len(rows[0]):
            raise ValueError(f"{where}: {len(values)} columns, expected {len(rows[0])} as in the first data row")
        rows.append(values)
    table = np.array(rows, dtype=complex)
    return table[:, 0].real, table[:, 1:]


def read_frf_table(path, responses: Sequence[str], excitation: str, kind: str = "receptance",
                   g_units: bool = False, pairs: bool = False) -> FRFSet:
    """FRFs from columns of a CSV/text or ``.npz`` file (module docstring).

    Parameters
    ----------
    path : path-like
    responses : sequence of str
        Response DOF name of each data column (after the frequency column); a name may repeat
        (repeats of the same FRF).
    excitation : str
        Excitation DOF name shared by the file's columns.
    kind, g_units
        As in `to_receptance`.
    pairs : bool
        The data are real/imaginary column pairs instead of complex text.
    """
    path = Path(path)
    if not path.is_file():
        raise ValueError(f"FRF file {str(path)!r} does not exist")
    freq_hz, table = _read_columns(path, pairs)
    if table.shape[1] != len(responses):
        raise ValueError(f"FRF file {str(path)!r} has {table.shape[1]} data columns but {len(responses)} response "
                         f"DOF names were given ({list(responses)})")
    omega = TWO_PI * freq_hz
    h = to_receptance(table.T, np.where(omega > 0, omega, 1.0), kind, g_units)
    keep = omega > 0   # the 0 Hz line dropped
    return _grouped(omega[keep], [((str(r), str(excitation)), h[k, keep]) for k, r in enumerate(responses)],
                    (str(path),), kind)


def read_frfs(paths, responses: Sequence[str] | None = None, excitations: Sequence[str] | None = None,
              kind: str | None = None, g_units: bool = False, pairs: bool = False,
              mapping: Mapping[str, str] | None = None) -> FRFSet:
    """FRFs from several files (UFF by suffix ``.uff``/``.unv``, else table), combined.

    Records of the same pair in several files become repeats of it (docs/frf-extraction.md
    describes the file layouts).

    Parameters
    ----------
    paths : sequence of str or Path
        The files; all must share the frequency lines (to 1e-9 relative).
    responses : sequence of str, optional
        The response DOF name of each data column, shared by the table files; a name may
        repeat (repeats of the same FRF). Needed when a file is a table.
    excitations : sequence of str, optional
        One excitation DOF name per table file, in the order of the table files.
    kind : {"receptance", "mobility", "accelerance"}, optional
        What the files hold; converted to receptance (m/N). Tables default to receptance;
        a UFF record's own ordinate type is used unless this overrides it.
    g_units : bool
        The ordinate is in g per newton (an accelerance in g/N), converted with standard
        gravity.
    pairs : bool
        The table data are real/imaginary column pairs instead of complex text.
    mapping : mapping of str to str, optional
        Renames DOFs to the model's (`FRFSet.renamed`).

    Returns
    -------
    FRFSet
        The receptances of every file on their common frequency axis.

    Raises
    ------
    ValueError
        A file cannot be read or is given twice, the files' frequency lines differ, a table
        lacks its responses or excitation, the data cannot be a receptance of the kind
        stated, or repeats of one FRF are identical or contradict each other.
    """
    paths = [Path(p) for p in paths]
    sets, k = [], 0
    for path in paths:
        if path.suffix.lower() in (".uff", ".unv"):
            sets.append(read_uff58(path, kind, g_units))
        elif responses is None or excitations is None or k >= len(excitations):
            raise ValueError(f"FRF file {str(path)!r} is a table: give the response DOF of each column and one "
                             f"excitation DOF per table file ({len(excitations or [])} given)")
        else:
            sets.append(read_frf_table(path, responses, excitations[k], kind or "receptance", g_units, pairs))
            k += 1
        check_kind(sets[-1])
    if excitations is not None and k != len(excitations):
        raise ValueError(f"{len(excitations)} excitation DOFs given for {k} table file(s)")
    seen: dict = {}
    for path in paths:
        key = path.resolve()
        if key in seen:
            raise ValueError(f"FRF file {str(path)!r} is given twice ({str(seen[key])!r}): its records would count "
                             "as independent repeats and make the intervals too narrow")
        seen[key] = path
    out = combine(sets)
    check_repeats(out)
    if mapping:
        out = out.renamed(mapping)
        check_repeats(out)  # a mapping may put two different FRFs under one label
    return out


#: Repeats of one FRF whose median difference from their mean, relative to its magnitude, is
#: above this are not repeats (`check_repeats`): repeats differ by about their noise level, two
#: different FRFs by about 1.
CONTRADICTORY = 0.5


def check_repeats(frfs: FRFSet) -> None:
    """Raise ValueError on repeats of one FRF that are identical or that contradict each other
    (`CONTRADICTORY`; why: docs/frf-extraction.md, "Input", "Repeats")."""
    for (r, c), h in zip(frfs.pairs, frfs.H):
        if h.shape[0] < 2:
            continue
        where = f"FRF h_{r},{c} (files {', '.join(frfs.sources)})"
        first: dict = {}
        for i, record in enumerate(h):
            j = first.setdefault(record.tobytes(), i)
            if j != i:
                raise ValueError(f"{where}: repeats {j + 1} and {i + 1} are identical, the same record twice "
                                 "(a file given twice, or one column under two labels?)")
        mean = h.mean(axis=0)
        spread = np.median(np.abs(h - mean[None]) / np.maximum(np.abs(mean), 1e-300)[None], axis=1)
        if spread.max() > CONTRADICTORY:
            worst = int(np.argmax(spread))
            raise ValueError(f"{where}: its {h.shape[0]} repeats are not repeats of one FRF: repeat {worst + 1} "
                             f"differs from their mean by a median {spread[worst]:.2f} of its magnitude (repeats "
                             f"agree within their noise, a few per cent): is a response or an excitation "
                             "mislabelled?")
