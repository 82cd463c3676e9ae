"""Studies over many solves: sampling of the data intervals, sweeps, batches and multistarts on Dask."""
