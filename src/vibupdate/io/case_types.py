"""The case types: what a loaded case holds (`Case`) and its second-stage options
(`DampingOptions`).

They are built by the TOML reader (`vibupdate.io.case.load_case`), by the examples in Python
and by callers of `vibupdate.pipeline.run_case`; this module holds them so that none of those
needs the file reader to name them.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from pathlib import Path

from vibupdate.data.measured import Configuration
from vibupdate.inverse.formulation.options import FormulationOptions
from vibupdate.inverse.homotopy import SolverOptions
from vibupdate.inverse.polish import PolishOptions
from vibupdate.inverse.verify import VerifyOptions
from vibupdate.model.parameters import Parameter


@dataclass(frozen=True)
class DampingOptions:
    """Second-stage options: the Caughey series and the weights of its fit.

    Attributes
    ----------
    exponents : tuple of float
        The Caughey exponents ``Y`` (Eq. 20); ``(0, 1)`` is Rayleigh damping.
    mode_weights : tuple of (int, float)
        ``(mode number, weight)`` pairs, applied in every configuration; 1 for modes not named.
    relative : bool
        Weigh relative errors (``W_ii = w_i / xi_i^2``) when the ratios have no intervals.
    rationale : str
        Why these weights, in words; the report prints it.
    """

    exponents: tuple[float, ...] = (0.0, 1.0)
    mode_weights: tuple[tuple[int, float], ...] = ()
    relative: bool = False
    rationale: str = ""


@dataclass(frozen=True)
class Case:
    """A loaded case: everything a run needs.

    Attributes
    ----------
    name : str
        The case's name (the file's stem unless the file names it).
    path : Path or None
        The case file; None for a case built in Python.
    configurations : tuple of Configuration
        The configurations to update, with the case's parameters free.
    solver : SolverOptions
        The homotopy and its solver.
    formulation : FormulationOptions
        How the first stage's problem is built.
    damping : DampingOptions or None
        The second stage's options; None when the case has no damping stage.
    frequency_tolerance : float
        Relative half-width of the measurement interval of every frequency without its own,
        in [0, 1); 0 when none is stated (docs/case-file.md).
    polish : PolishOptions
        The refinement after the homotopy.
    verification : VerifyOptions
        The thresholds of the checks of the returned model.
    frfs : mapping of str to FRFSet
        Per configuration whose data came from FRF files (``[configuration.frf]``), the
        measured receptances in the extraction band (`vibupdate.data.frf.FRFSet`): the report
        overlays them on the model FRFs.
    frf_notes : mapping of str to tuple of str
        Per such configuration, the extraction's notes
        (`vibupdate.data.extraction.Extraction.notes`): `check` and `run` report them as
        warnings.
    frequency_notes : mapping of str to tuple of str
        Per configuration whose damping ratios make its natural and damped frequencies differ
        by more than their measured intervals, what that means for the data
        (`_frequency_types`): `check` and `run` report them as warnings.
    inputs : tuple of Path
        The files the case reads: the case file and every file a value of it names (matrices,
        builder module, data files); a run never replaces or removes them.
    sensors : tuple of dict
        Measured points on an imported FE mesh (``[model] sensors``): ``sensor``, ``dof``,
        ``sign``, ``distance_m`` per sensor; the report shows the map.
    candidates : tuple of Parameter
        The ``[[candidate]]`` parameters: named in the model as parameters are, held at their
        nominal values in ``configurations`` and freed by `vibupdate suggest`.
    pool : tuple of Configuration
        The configurations with the case's parameters and every candidate free, in that order
        (empty without candidates); `with_candidates` frees a subset.
    undeclared_modes : tuple of str
        The configurations whose measured natural frequencies declare no model mode (read as
        modes 1, 2, ...): `check` and `run` test that pairing against the nominal model.
    """

    name: str
    path: Path | None
    configurations: tuple[Configuration, ...]
    solver: SolverOptions
    formulation: FormulationOptions
    damping: DampingOptions | None
    frequency_tolerance: float = 0.0
    polish: PolishOptions = field(default_factory=PolishOptions)
    verification: VerifyOptions = field(default_factory=VerifyOptions)
    frfs: Mapping = field(default_factory=dict)
    frf_notes: Mapping = field(default_factory=dict)
    frequency_notes: Mapping = field(default_factory=dict)
    inputs: tuple[Path, ...] = ()
    sensors: tuple[dict, ...] = ()
    candidates: tuple[Parameter, ...] = ()
    pool: tuple[Configuration, ...] = ()
    undeclared_modes: tuple[str, ...] = ()

    def with_candidates(self, names) -> "Case":
        """The case with some candidates free beside its own parameters.

        Parameters
        ----------
        names : iterable of str
            Names of candidates to free; the other candidates stay at their nominal values.

        Returns
        -------
        Case
            A copy whose configurations are the pool's, with the case's parameters and the
            named candidates free, in the order of the pool.

        Raises
        ------
        ValueError
            A name is not a candidate of the case.
        """
        from vibupdate.model.affine import restricted

        known = [p.name for p in self.candidates]
        unknown = [n for n in names if n not in known]
        if unknown:
            raise ValueError(f"{', '.join(map(repr, unknown))} {'is' if len(unknown) == 1 else 'are'} not a candidate "
                             f"of case {self.name!r} (its candidates: {', '.join(known) or 'none'})")
        own = [p.name for p in self.pool[0].model.parameters if p.name not in known] if self.pool else []
        free = own + [n for n in known if n in set(names)]
        return replace(self, configurations=tuple(replace(c, model=restricted(c.model, free)) for c in self.pool))

    def verify_options(self) -> VerifyOptions:
        """The verification's options with the case's ``frequency_tolerance``.

        Returns
        -------
        VerifyOptions
            ``verification`` with ``frequency_tolerance`` and ``measurement_tolerance`` set to
            the case's ``frequency_tolerance`` (the measurement interval of the frequencies
            without their own, and the consistency allowance's tolerance); ``verification``
            unchanged when the case states none.
        """
        tol = self.frequency_tolerance
        if not (math.isfinite(tol) and 0 < tol < 1):   # 0: none stated; out of range: refused by check
            return self.verification
        return replace(self.verification, frequency_tolerance=tol, measurement_tolerance=tol)
