"""Second stage: Caughey-series damping from measured modal damping ratios, paper Eqs. 20-24 (the
method and its decisions: docs/method.md, section 8): the fit (`series`), the damping matrix or
its modal law (`models`), their sanity checks (`sanity`) and the stage over several
configurations (`stage`).
"""
