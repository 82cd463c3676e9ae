"""Models exported by FE codes: one reader per code, each returning an `FEExport`
(`vibupdate.model.fe.export`), and the affine model formed from perturbed exports
(`vibupdate.model.fe.perturbed`). ``docs/fe-models.md`` shows each route."""
