"""Modal analysis kernels on mass and stiffness matrices: eigen-solutions, receptances, their zeros
and exact derivatives."""
