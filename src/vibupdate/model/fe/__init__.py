"""Models exported by FE codes: one reader per code, each returning an `FEExport`
(`vibupdate.model.fe.export`), and the affine model formed from perturbed exports
(`vibupdate.model.fe.perturbed`), the sensors placed on its mesh (`vibupdate.model.fe.sensors`)
and the oblique DOFs they read (`vibupdate.model.fe.oblique`). ``docs/fe-models.md`` shows each
route."""
