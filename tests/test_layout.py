"""The data flow runs one way: the inverse problem never imports the results side."""

import ast
from pathlib import Path

PACKAGE = Path(__file__).resolve().parents[1] / "src" / "vibupdate"

INVERSE = ["formulation", "interlacing", "relaxation", "homotopy", "backends/casadi_ipopt", "update", "polish",
           "verify", "pairing", "sensitivities", "correlation", "analysis", "affine", "measured", "status"]
RESULTS_SIDE = {"results", "report", "plots", "pipeline", "cli", "outputs", "case", "extraction_io"}


def imported_modules(path: Path) -> set[str]:
    tree = ast.parse(path.read_text(encoding="utf-8"))
    names = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom) and node.module and node.module.startswith("vibupdate"):
            names.add(node.module.split(".")[1] if "." in node.module else "")
            if node.module == "vibupdate":
                names.update(alias.name for alias in node.names)
        elif isinstance(node, ast.Import):
            names.update(a.name.split(".")[1] for a in node.names if a.name.startswith("vibupdate."))
    return names


def test_inverse_problem_does_not_import_the_results_side():
    offenders = {}
    for name in INVERSE:
        path = PACKAGE / f"{name}.py"
        assert path.exists(), path
        bad = imported_modules(path) & RESULTS_SIDE
        if bad:
            offenders[name] = sorted(bad)
    assert not offenders, offenders


def test_the_checker_sees_imports():
    assert "results" in imported_modules(PACKAGE / "pipeline.py")
