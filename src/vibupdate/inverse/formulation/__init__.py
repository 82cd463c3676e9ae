"""What the first-stage problem is: the bilinear least-squares problem of Eqs. 7, 9, 10, 16.

For every measured natural frequency (a *natural* block, Eq. 7) and every measured
antiresonance (an *antiresonance* block on the adjunct system, Eq. 9) there is one unknown
vector ``u``, and the residual

    R = D_r ( K(xbar) - w^2 M(xbar) )[rows, cols] S u
      = A0 u + sum_i xbar_i A_i u                      (M, K affine in xbar, Eq. 16)

is linear in ``u`` for fixed ``xbar`` and vice versa. Stacking every block gives

    R = A_u u + A_x xbar + A_b (xbar[prod_x] * u[prod_u]) + r0,   min sum_k w_k R_k^2

where the products ``xbar_i u_j`` are listed only for the columns ``j`` on which the matrix
of parameter ``i`` is non-zero and only for free entries (a product with a fixed entry is
linear and sits in ``A_x``). Those products are what the relaxation lifts (Section 3.3).

Choices the paper leaves open (docs/method.md, section 4):

* normalization against ``u = 0``: one entry of each vector is fixed (item 1, 2);
* rotational entries are scaled by a characteristic length ``S`` (item 3) and residual rows
  by ``D_r = diag(K0)^(-1/2)`` (Jacobi);
* default weight ``alpha = 1 / (w^2 ||D_r M0 S v0||)^2`` so that each residual approximates
  the relative eigenvalue error (item 4), times the user's weight.

One module per job; `formulate` below runs them in order:

* `options`: `FormulationOptions`, what the user chooses;
* `blocks`: one `VectorBlock` per measured frequency, its normalization, bounds and start;
* `scaling`: the entry scaling ``S`` and the row scaling ``D_r``, the matrix terms scaled once;
* `weights`: the weight of each block's residual;
* `stacking`: the blocks' rows split into the arrays of the problem;
* `problem`: `BilinearProblem`, what the solvers read (its residual, objective and sizes).
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
    terms = {}
    for k, scaling in zip(owners, scalings):
        if k not in terms:   # one scaled copy of each configuration's matrices, shared by its blocks
            terms[k] = scaled_terms(configurations[k].model, scaling)
    problem = stack(configurations[0].model.parameters, configurations[0].model.bounds(),
                    blocks, [terms[k] for k in owners], options)
    return replace(problem, notes=notes) if notes else problem
