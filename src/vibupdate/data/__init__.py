"""Measured data: typed frequencies, antiresonances and shape intervals, their pairing with model
modes, and extraction from FRFs."""
