"""The inverse problem: correlation with the data, formulation, reduction, lifting and relaxation,
the homotopy solve, polish and verification."""
