"""Second stage: Caughey-series damping from measured modal damping ratios (Eqs. 20-24).

    C = M sum_h beta_h (M^-1 K)^h,          h in Y (any finite set of real exponents)

fitted to the measured ratios of every configuration at once (one ``beta``, `series`) on the
updated model's frequencies, so that the identified ``C`` reproduces the fitted ratios exactly;
built as ``M Phi diag(sum_h beta_h w^(2h)) Phi^T M`` (no matrix powers, `models`). Rayleigh
damping is ``Y = [0, 1]``. The public names of the modules (docs/method.md lists them) are
importable from here.
"""

from vibupdate.damping.models import CaugheyLaw, caughey_damping, caughey_matrix
from vibupdate.damping.sanity import LARGE_MODEL_CHECKED_MODES, damping_sanity, negative_bands
from vibupdate.damping.series import DampingFit, DampingWarning, fit_caughey, modal_damping
from vibupdate.damping.stage import DampingStage, damping_data, damping_weights, identify_damping
