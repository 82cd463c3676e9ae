"""Input and output: case files, validation, data files, the results object and its JSON, safe output folders."""
