"""What the first-stage problem is: the bilinear least-squares problem of Eqs. 7, 9, 10, 16.

One unknown vector ``u`` per measured natural frequency (a *natural* block, Eq. 7) and per
measured antiresonance (an *antiresonance* block, Eq. 9); stacking every block gives

    R = A_u u + A_x xbar + A_b (xbar[prod_x] * u[prod_u]) + r0,   min sum_k w_k R_k^2

with a product ``xbar_i u_j`` listed only where the matrix of parameter ``i`` is non-zero in
column ``j`` and ``u_j`` is free. The normalization, bounds, scaling and weights the paper
leaves open: docs/method.md, section 4. One module per job (`options`, `blocks`, `scaling`,
`weights`, `stacking`, `problem`); `formulate` runs them in order.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import replace

from vibupdate.data.measured import Configuration, validate_configurations
from vibupdate.inverse.formulation.blocks import build_blocks
from vibupdate.inverse.formulation.options import FormulationOptions
from vibupdate.inverse.formulation.problem import BilinearProblem
from vibupdate.inverse.formulation.scaling import scaled_terms
from vibupdate.inverse.formulation.stacking import stack


def formulate(configurations: Sequence[Configuration], options: FormulationOptions | None = None,
              transforms: Sequence = (), nominal: Sequence | None = None) -> BilinearProblem:
    """Build the bilinear problem of all configurations.

    Parameters
    ----------
    configurations : sequence of Configuration
        Sharing one parameter vector.
    options : FormulationOptions, optional
    transforms : sequence of callables ``(blocks, configurations, options) -> (blocks, notes)``
        Bound transformations applied to the blocks before stacking, e.g.
        `vibupdate.inverse.interlacing.sign_bounds`; what each sets aside and says (typed
        records with a ``message``) becomes the problem's ``notes``.
    nominal : sequence of ModelFrequencies, optional
        The nominal models' modes (`vibupdate.inverse.correlation.model_frequencies` at
        ``xbar = None``), one per configuration, when the caller has them already.
    """
    options = options or FormulationOptions()
    configurations = list(configurations)
    validate_configurations(configurations)
    blocks, owners, scalings = build_blocks(configurations, options, nominal)
    notes = ()
    for transform in transforms:
        blocks, said = transform(blocks, configurations, options)
        notes += tuple(said)
    # one scaled copy of each configuration's matrices, shared by its blocks
    terms = [scaled_terms(cfg.model, scaling) for cfg, scaling in zip(configurations, scalings)]
    problem = stack(configurations[0].model.parameters, configurations[0].model.bounds(),
                    blocks, [terms[k] for k in owners], options)
    return replace(problem, notes=notes) if notes else problem
