"""What the data allow: linearized, certified (outer) and consistent-set parameter ranges."""
