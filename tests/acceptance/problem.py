"""The known-truth problem of the acceptance engine and its data, as plain frozen records.

A `Problem` holds a structure (`acceptance.structures`), its parameters, the true values and
the data measured on the true model (`ConfigData` per configuration: `Natural` frequencies with
optional shape intervals, `Zero` s of receptances). It is emitted as a case folder or as
`vibupdate.Configuration` objects by `acceptance.emit`; `acceptance.generator` draws them.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from acceptance import structures as S

__all__ = ["Natural", "Zero", "ConfigData", "Problem"]


@dataclass(frozen=True)
class Natural:
    """A measured natural frequency (Hz), its model mode (1-based, rigid-body modes counted),
    its shape intervals ``{dof: (lower, upper)}`` (ratios to the reference entry) or None, and
    its measured modal damping ratio or None."""

    hz: float
    mode: int
    shape: dict | None = None
    damping: float | None = None


@dataclass(frozen=True)
class Zero:
    """A measured antiresonance (Hz) of ``h_{response, excitation}``, zero ``index`` (1-based)."""

    hz: float
    response: str
    excitation: str
    index: int

    @property
    def receptance(self) -> tuple[str, str]:
        return (self.response, self.excitation)


@dataclass(frozen=True)
class ConfigData:
    """The data of one configuration; ``extra_mass`` ``(dof, kg)`` a known added mass;
    ``declare``: state the modes and zero indices (else the defaults must find them); ``"modes"``:
    the modes alone."""

    name: str
    natural: tuple = ()
    zeros: tuple = ()
    extra_mass: tuple | None = None
    declare: bool | str = True
    interlacing: bool = True

    @property
    def n_data(self) -> int:
        return len(self.natural) + len(self.zeros) + sum(len(n.shape) - 1 for n in self.natural if n.shape)


@dataclass(frozen=True)
class Problem:
    """One known-truth problem (module docstring).

    Attributes
    ----------
    case_id : str
    structure : StructureSpec
    parameters : tuple of Parameter
    truth : dict of str to float
        True physical parameter values.
    data : tuple of ConfigData
    noise : float
        Relative standard deviation of the frequencies (0: exact data).
    shape_noise : float
        Standard deviation of the shape ratios.
    seed : int or None
    symmetries : tuple of tuple of (str, str)
        Exact symmetries, each a tuple of parameter swaps that leaves every frequency unchanged:
        the judge accepts the truth's image under them as the truth.
    csv : bool
        Frequencies in a CSV file of the case folder (else typed in the TOML).
    note : str
    family : str
        The family that drew it (`acceptance.criteria` says what a right answer is for each).
    in_family : bool
        The model family holds the truth and the truth satisfies every datum (False for data of
        another model, or with a measurement error that excludes the truth).
    mass_normalized : bool
        The shapes are mass-normalized entries (up to a common sign), not ratios.
    expected_first : str or None
        The data group (a diagnosis key, ``"CFG/dof/DOF"`` ...) that is wrong by construction,
        which the diagnosis should rank first.
    compromise : bool
        The judge computes its own weighted least-squares compromise and reports each answer's
        distance to it (`acceptance.judge.compromise`).
    damping : tuple or None
        The damping fitted, ``(exponents, beta)``: the exponents of the case's ``[damping]`` and
        the true coefficients of a true Caughey series with them (modal damping ratio ``sum_j
        beta_j w^(2 Y_j) / (2 w)`` at ``w`` rad/s; empty for a truth that is no such series); the
        measured ratios are on the ``Natural`` s.
    damping_noise : float
        Relative standard deviation of the measured damping ratios (0: exact).
    damped : bool
        The case file gives damped frequencies, ``f_n sqrt(1 - zeta^2)`` with the measured ratios,
        and says so (``frequency_type = "damped"``); the natural ones are on the ``Natural`` s.
    frf : dict or None
        The measurement is FRFs, which the case file gives instead of the data: ``exciter``,
        ``responses`` (DOF names), ``rayleigh`` (the true ``(a, b)`` of ``C = a M + b K``),
        ``span_hz`` and ``lines`` (the frequency axis), ``band_hz`` (the extraction band),
        ``repeats``, ``noise`` (relative), ``floor`` (of the largest
        ``|H|``) and ``seed`` of their noise (`acceptance.emit.write_frfs`). The ``Natural`` s are
        then the true modes in the band, and ``noise`` the judge's own tolerance on them.
    """

    case_id: str
    structure: S.StructureSpec
    parameters: tuple
    truth: dict
    data: tuple
    noise: float = 0.0
    shape_noise: float = 0.0
    seed: int | None = None
    symmetries: tuple = ()
    csv: bool = False
    note: str = ""
    family: str = "random"
    in_family: bool = True
    mass_normalized: bool = False
    expected_first: str | None = None
    compromise: bool = False
    damping: tuple | None = None
    damping_noise: float = 0.0
    damped: bool = False
    frf: dict | None = None

    @property
    def kind(self) -> str:
        """``"P1"`` frequencies with shapes, ``"P2"`` frequencies, ``"P3"`` antiresonances,
        ``"P4"`` frequencies and antiresonances, ``"mix"`` shapes and antiresonances."""
        shapes = any(n.shape for c in self.data for n in c.natural)
        natural = any(c.natural for c in self.data)
        zeros = any(c.zeros for c in self.data)
        if shapes:
            return "mix" if zeros else "P1"
        if natural:
            return "P4" if zeros else "P2"
        return "P3"

    @property
    def tolerance(self) -> float:
        """Relative half-width of every frequency interval (3 sigma; 0 for exact data)."""
        return 3.0 * self.noise

    @property
    def exact(self) -> bool:
        return self.noise == 0.0

    @property
    def n_data(self) -> int:
        return sum(c.n_data for c in self.data)

    @property
    def xbar_true(self) -> np.ndarray:
        return np.array([(self.truth[p.name] - p.nominal) / p.reference for p in self.parameters])

    @property
    def structure_class(self) -> str:
        label = self.structure.label
        if self.structure.export:
            label = "matrices-" + ("massless" if self.structure.massless else label.split("-")[0])
        return label

    def classes(self) -> dict:
        """The class labels of the tables (determinacy is judged by the runner)."""
        return {"family": self.family, "structure": self.structure_class, "kind": self.kind, "data": "exact" if self.exact else "noisy",
                "fewer_data": self.n_data < len(self.parameters), "expected_first": self.expected_first}

    def configurations(self, judge: bool = False):
        """The Python route's `vibupdate.Configuration` s (`acceptance.emit.configurations`)."""
        from acceptance.emit import configurations

        return configurations(self, judge=judge)

    def write_case(self, folder):
        """Write the case folder; returns the path of ``case.toml`` (`acceptance.emit.write_case`)."""
        from acceptance.emit import write_case

        return write_case(self, folder)
