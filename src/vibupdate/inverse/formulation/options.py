"""Options of the first-stage formulation: normalization margins, scaling, weighting, reduction
(apart from the code that reads them, so that each part of the formulation and the case
reader can import them alone).
"""

from __future__ import annotations

from dataclasses import dataclass

from vibupdate.options import check, default


#: DOF-name prefixes that mark rotations (scaled by the characteristic length).
ROTATION_PREFIXES = ("phi", "rx", "ry", "rz", "theta")


@dataclass(frozen=True)
class FormulationOptions:
    """Options of the first-stage formulation.

    Attributes
    ----------
    shape_margin : float
        Unmeasured mode entries are bounded by ``+- shape_margin * max|v0|`` with ``v0`` the
        nominal mode in the block's normalization (the paper uses [-1, 1]).
    adjunct_margin : float
        Adjunct entries are bounded by ``+- adjunct_margin`` around a fixed unit entry.
    sign_delta : float
        Distance from zero of a sign bound from interlacing (Section 3.6), in the block's
        normalization.
    length_scale : float, optional
        Characteristic length (m) that scales rotational entries; default from ``K0``
        (`vibupdate.inverse.formulation.scaling.length_scale`).
    rotation_prefixes : tuple of str
        DOF-name prefixes that mark rotations.
    weighting : {"relative", "unit"}
        ``"relative"``: relative eigenvalue error (docs/method.md, "Default weights"); ``"unit"``:
        alpha = 1 (paper test case 1).
    interlacing : bool
        Apply the sign bounds derived from the pole/zero pattern (Eq. 11).
    reduction : {"auto", "none", "craig-bampton"}
        Solve on a Craig-Bampton reduced model (`vibupdate.inverse.reduction`) that keeps the measured
        DOFs; ``"auto"`` does so above `reduction_threshold` DOFs when there are DOFs to keep.
    reduction_modes : int
        Fixed-interface modes of the reduction.
    reduction_threshold : int
        DOFs above which ``"auto"`` reduces (docs/notes/homotopy.md, "Craig-Bampton
        reduction").
    """

    shape_margin: float = default("formulation", "shape_margin")
    adjunct_margin: float = default("formulation", "adjunct_margin")
    sign_delta: float = default("formulation", "sign_delta")
    length_scale: float | None = default("formulation", "length_scale")
    rotation_prefixes: tuple[str, ...] = ROTATION_PREFIXES
    weighting: str = default("formulation", "weighting")
    interlacing: bool = default("formulation", "interlacing")
    reduction: str = default("formulation", "reduction")
    reduction_modes: int = default("formulation", "reduction_modes")
    reduction_threshold: int = default("formulation", "reduction_threshold")

    def __post_init__(self):
        check("formulation", self)      # types and ranges: vibupdate.options
