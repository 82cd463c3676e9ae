"""The model: parameters, elements, assembly, the affine form M(p), K(p) and physical checks."""
