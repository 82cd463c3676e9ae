"""The report and plots: writers that read the results object."""
