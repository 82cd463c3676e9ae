"""Second stage: Caughey-series damping from measured modal damping ratios (Eqs. 20-24).

    C = M sum_h beta_h (M^-1 K)^h,          h in Y (any finite set of real exponents)

fitted to the measured ratios of every configuration at once (one ``beta``, `series`) on the
updated model's frequencies, so that the identified ``C`` reproduces the fitted ratios exactly;
built as ``M Phi diag(sum_h beta_h w^(2h)) Phi^T M`` (no matrix powers, `models`). Rayleigh
damping is ``Y = [0, 1]``.
"""
