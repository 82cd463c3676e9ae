"""Solver backends for the homotopy steps. Each maps its own outcome codes to `Status`."""
