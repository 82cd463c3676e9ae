"""Second stage: Caughey-series damping from measured modal damping ratios (Eqs. 20-24).

    C = M sum_h beta_h (M^-1 K)^h,          h in Y (any finite set of real exponents)

For mass-normalized modes ``Phi`` of the updated ``(K, M)``, ``Phi^T C Phi`` is diagonal with
``2 xi_k w_k = sum_h beta_h w_k^(2h)``, so (Eq. 21)

    xi_k = 1/2 sum_h beta_h w_k^(2h - 1).

Stacking every measured ratio of every configuration gives ``Theta beta = xi`` (Eqs. 22-23),
solved in the weighted least-squares sense ``beta = (Theta^T W Theta)^-1 Theta^T W xi``
(Eq. 24). One ``beta`` is shared by all configurations. The frequencies in ``Theta`` are those
of the updated model, so that the identified ``C`` reproduces the fitted ratios exactly.
``C`` itself is built as ``M Phi diag(sum_h beta_h w^(2h)) Phi^T M`` (no matrix powers).
Rayleigh damping is ``Y = [0, 1]``.
The public names of its modules (docs/method.md lists them) are importable from here.
"""

from vibupdate.damping.models import CaugheyLaw, caughey_damping, caughey_matrix
from vibupdate.damping.sanity import LARGE_MODEL_CHECKED_MODES, damping_sanity, negative_bands
from vibupdate.damping.series import DampingFit, DampingWarning, fit_caughey, modal_damping
from vibupdate.damping.stage import DampingStage, damping_data, damping_weights, identify_damping
