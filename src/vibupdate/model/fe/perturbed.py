"""Parameter derivatives from perturbed exports, and the affine model they make (the route as the
user reads it: docs/fe-models.md, "Perturbed exports").

The derivative of each matrix ``A`` (K or M) is the difference quotient: with one step ``h`` the
forward difference ``(A(p0 + h) - A(p0)) / h``; with two, ``h1`` and ``h2``, the derivative at
``p0`` of the quadratic through the three exports, ``(h2^2 dA1 - h1^2 dA2) / (h1 h2 (h2 - h1))``
with ``dAk = A(p0 + hk) - A(p0)`` (the central difference when ``h2 = -h1``), and the departure
from affine ``||dA1/h1 - dA2/h2||_F / max(||dA1/h1||_F, ||dA2/h2||_F)``, the larger of K's and
M's. The model's ``matrix_precision`` is the coarsest of the exports'.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from vibupdate.model.affine import AffineModel
from vibupdate.model.build import from_files
from vibupdate.model.fe.export import FEExport, coarser
from vibupdate.model.parameters import Parameter


#: Departure below which a parameter is reported affine (rounding of text exports is far below).
AFFINE_TOL = 1e-6
#: Relative size below which a change or a row of a derivative counts as zero.
ZERO_TOL = 1e-12


@dataclass(frozen=True)
class Perturbation:
    """The exports of one parameter changed from its nominal value.

    Attributes
    ----------
    parameter : Parameter
    step : float
        ``h1``, the change of the parameter in the export, in its unit.
    export : FEExport
    step2 : float, optional
        ``h2``, the change in a second export (e.g. ``-h1``), for the linearization and the
        departure from affine.
    export2 : FEExport, optional
    """

    parameter: Parameter
    step: float
    export: FEExport
    step2: float | None = None
    export2: FEExport | None = None


@dataclass(frozen=True)
class Derivative:
    """``dK/dp`` and ``dM/dp`` of one parameter, shapes (n, n), in N/m and kg per unit of it.

    Attributes
    ----------
    name : str
    dK, dM : scipy.sparse.csr_matrix
    scheme : str
        ``"forward"`` or ``"two-step"`` (``"central"`` when ``h2 = -h1``).
    departure : float or None
        Relative departure from affine (module docstring); None with one step.
    dofs : tuple of str
        DOFs whose rows of dK or dM are not zero: the property group.
    nodes : tuple of str
        Their nodes.
    """

    name: str
    dK: sp.csr_matrix
    dM: sp.csr_matrix
    scheme: str
    departure: float | None
    dofs: tuple
    nodes: tuple

    @property
    def affine(self) -> bool | None:
        """Whether the departure is below `AFFINE_TOL` (None without a second step)."""
        return None if self.departure is None else self.departure <= AFFINE_TOL

    def in_coordinates(self, T: sp.csr_matrix, dofs) -> Derivative:
        """This derivative for the coordinates ``q'`` of ``q = T q'`` (``T`` constant and
        invertible, shape (n, n)): ``T^T dK T`` and ``T^T dM T``, the group named by ``dofs``
        (length n)."""
        from vibupdate.model.fe.oblique import congruent

        dK, dM = congruent(self.dK, T), congruent(self.dM, T)
        return Derivative(self.name, dK, dM, self.scheme, self.departure, *_group(dK, dM, tuple(dofs)))


def _check_same_dofs(nominal: FEExport, other: FEExport, name: str) -> None:
    if other.dofs == nominal.dofs:
        return
    if len(other.dofs) != len(nominal.dofs):
        raise ValueError(f"{other.source}: the export of parameter '{name}' has {len(other.dofs)} DOFs, expected "
                         f"{len(nominal.dofs)} like the nominal export {nominal.source} (is one of them cut short, "
                         "or of another model?)")
    k = next(i for i, (a, b) in enumerate(zip(other.dofs, nominal.dofs)) if a != b)
    raise ValueError(f"{other.source}: the DOF map of parameter '{name}' does not match the nominal export "
                     f"{nominal.source}: DOF {k + 1} is {other.dofs[k]!r}, expected {nominal.dofs[k]!r}")


#: A term larger than this fraction of its matrix's largest entry is one whose absence from
#: another export of the set is refused (`_check_same_terms`).
TERM_TOL = 1e-12


def _check_same_terms(nominal: FEExport, other: FEExport, name: str, p0: float, p1: float) -> None:
    """Refuse a term that one export of the pair gives and the other lacks (exactly zero): a step
    of a parameter does not make a term vanish or appear unless the parameter is zero in one of
    the two exports, so such a term is a line missing from a file (docs/fe/nastran.md). Terms
    below `TERM_TOL` times the matrix's largest entry (an assembly's rounding) are not compared."""
    if p0 == 0 or p1 == 0:
        return
    for label, A0, A1 in (("K", nominal.K, other.K), ("M", nominal.M, other.M)):
        scale = max(abs(A0).max() if A0.nnz else 0.0, abs(A1).max() if A1.nnz else 0.0)
        if not scale:
            continue
        for has, lacks, A, source, lacking in ((A0, A1, A0, nominal.source, other.source),
                                              (A1, A0, A1, other.source, nominal.source)):
            big = sp.csr_matrix(abs(has) > TERM_TOL * scale)
            missing = sp.csr_matrix(big - big.multiply(sp.csr_matrix(lacks != 0)))
            missing.eliminate_zeros()
            if missing.nnz:
                coo = missing.tocoo()
                i, j = int(coo.row[0]), int(coo.col[0])
                raise ValueError(f"{lacking}: {label} has no term at ({nominal.dofs[i]}, {nominal.dofs[j]}), which "
                                 f"{source} gives ({A[i, j]:.6g}); {coo.nnz} entries missing in all. "
                                 f"A step of '{name}' cannot make a term vanish or appear: lines are missing from "
                                 f"{lacking}; is it cut short?")


def _change(nominal: FEExport, other: FEExport, name: str, step: float, p0: float | None = None):
    if not np.isfinite(step) or step == 0:
        raise ValueError(f"parameter '{name}': step must be a finite non-zero number, got {step!r}")
    _check_same_dofs(nominal, other, name)
    if p0 is not None:
        _check_same_terms(nominal, other, name, p0, p0 + step)
    dK, dM = sp.csr_matrix(other.K - nominal.K), sp.csr_matrix(other.M - nominal.M)
    size = max(abs(dK).max() / max(abs(nominal.K).max(), 1e-300), abs(dM).max() / max(abs(nominal.M).max(), 1e-300))
    if size <= ZERO_TOL:
        raise ValueError(f"{other.source}: the export of parameter '{name}' (step {step:g}) is identical to the "
                         f"nominal export {nominal.source}; expected matrices changed by the parameter")
    return dK, dM


def _group(dK, dM, dofs) -> tuple[tuple, tuple]:
    rows = set()
    for A in (dK, dM):
        if A.nnz:
            big = abs(A).max()
            coo = A.tocoo()
            rows.update(coo.row[np.abs(coo.data) > ZERO_TOL * 1e3 * big].tolist())
    names = tuple(dofs[i] for i in sorted(rows))
    nodes = tuple(dict.fromkeys(d.split(":")[0] for d in names))
    return names, nodes


def derivatives(nominal: FEExport, perturbations: Sequence[Perturbation]) -> tuple[Derivative, ...]:
    """The derivative of K and M for each perturbation (module docstring)."""
    out = []
    for pert in perturbations:
        name, h1 = pert.parameter.name, float(pert.step)
        p0 = float(pert.parameter.nominal)
        dK1, dM1 = _change(nominal, pert.export, name, h1, p0)
        if pert.export2 is None:
            dK, dM, scheme, departure = dK1 / h1, dM1 / h1, "forward", None
        else:
            h2 = float(pert.step2) if pert.step2 is not None else float("nan")
            dK2, dM2 = _change(nominal, pert.export2, name, h2, p0)
            if h2 == h1:
                raise ValueError(f"parameter '{name}': the two steps are equal ({h1:g}); a second, different step "
                                 "is expected")
            c = h1 * h2 * (h2 - h1)
            dK, dM = (h2 * h2 * dK1 - h1 * h1 * dK2) / c, (h2 * h2 * dM1 - h1 * h1 * dM2) / c
            scheme = "central" if h2 == -h1 else "two-step"
            departure = 0.0
            for a, b in ((dK1 / h1, dK2 / h2), (dM1 / h1, dM2 / h2)):
                scale = max(spla.norm(a), spla.norm(b))
                if scale:
                    departure = max(departure, float(spla.norm(a - b)) / scale)
        dofs, nodes = _group(dK, dM, nominal.dofs)
        out.append(Derivative(name, sp.csr_matrix(dK), sp.csr_matrix(dM), scheme, departure, dofs, nodes))
    return tuple(out)


def affine_from_exports(nominal: FEExport, perturbations: Sequence[Perturbation]) -> tuple[AffineModel, tuple]:
    """The affine model linearized at the nominal export, and the `Derivative` of each parameter;
    its ``matrix_precision`` is the coarsest of the exports'."""
    ders = derivatives(nominal, perturbations)
    exports = [nominal] + [e for p in perturbations for e in (p.export, p.export2) if e is not None]
    model = from_files(nominal.M, nominal.K, [p.parameter for p in perturbations],
                       dM={d.name: d.dM for d in ders if d.dM.nnz}, dK={d.name: d.dK for d in ders if d.dK.nnz},
                       dofs=nominal.dofs, matrix_precision=coarser(*(e.precision for e in exports)))
    return model, ders
