"""The data flow runs one way, and the folders show it.

modal kernels (eigen-solves, receptances, zeros and their derivatives on M, K) -> model ->
data -> inverse -> ranges -> damping -> io -> report -> pipeline -> study -> cli.
A stage may import the stages before it, never the ones after it: the inverse problem never
imports the results side (the results object, its writers, the report, the CLI).
"""

import ast
from pathlib import Path

PACKAGE = Path(__file__).resolve().parents[1] / "src" / "vibupdate"

#: Stages in the order the data flow through them; ``pipeline`` and ``cli`` are modules.
STAGES = ["modal", "model", "data", "inverse", "ranges", "damping", "io", "report", "pipeline", "study", "cli"]
#: The stages that make up the inverse problem, and what they must never import.
INVERSE = {"model", "modal", "data", "inverse", "ranges", "damping"}
RESULTS_SIDE = {"io", "report", "pipeline", "cli", "study"}


def imported_stages(path: Path) -> set[str]:
    """Top-level ``vibupdate`` subpackages or modules imported anywhere in ``path``."""
    tree = ast.parse(path.read_text(encoding="utf-8"))
    names = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom) and node.module and node.module.startswith("vibupdate"):
            parts = node.module.split(".")
            if len(parts) > 1:
                names.add(parts[1])
            else:
                names.update(alias.name for alias in node.names)
        elif isinstance(node, ast.Import):
            names.update(a.name.split(".")[1] for a in node.names if a.name.startswith("vibupdate."))
    return names


def stage_of(path: Path) -> str:
    rel = path.relative_to(PACKAGE)
    return rel.parts[0] if len(rel.parts) > 1 else rel.stem


def test_every_module_sits_in_a_stage():
    stray = [str(p.relative_to(PACKAGE)) for p in PACKAGE.rglob("*.py")
             if stage_of(p) not in STAGES + ["__init__", "__main__", "extras", "options", "examples"]]
    assert not stray, stray


def test_inverse_problem_does_not_import_the_results_side():
    offenders = {}
    for path in PACKAGE.rglob("*.py"):
        if stage_of(path) in INVERSE:
            bad = imported_stages(path) & RESULTS_SIDE
            if bad:
                offenders[str(path.relative_to(PACKAGE))] = sorted(bad)
    assert not offenders, offenders


def test_no_stage_imports_a_later_stage():
    order = {name: i for i, name in enumerate(STAGES)}
    offenders = {}
    for path in PACKAGE.rglob("*.py"):
        own = stage_of(path)
        if own not in order:
            continue
        later = {s for s in imported_stages(path) if s in order and order[s] > order[own]}
        if later:
            offenders[str(path.relative_to(PACKAGE))] = sorted(later)
    assert not offenders, offenders


TESTS = PACKAGE.parents[1] / "tests"
#: Tests that exercise a whole run, across stages, stay at the top of ``tests/``.
CROSS_STAGE = {"test_cli", "test_docs", "test_docstrings", "test_layout", "test_fuzz", "test_frf_updating",
               "test_solves", "test_extras"}
#: Folders of whole-run tests: the known-truth acceptance engine (generator, runner, its profile).
CROSS_STAGE_FOLDERS = {"acceptance"}


def test_tests_mirror_the_stages():
    stray = [p.name for p in TESTS.glob("test_*.py") if p.stem not in CROSS_STAGE]
    unknown = [p.parent.name for p in TESTS.glob("*/test_*.py") if p.parent.name not in {*STAGES, *CROSS_STAGE_FOLDERS}]
    assert not stray and not unknown, (stray, unknown)


def test_the_checker_sees_imports():
    assert {"io", "inverse"} <= imported_stages(PACKAGE / "pipeline.py")
    assert stage_of(PACKAGE / "inverse" / "backends" / "casadi_ipopt.py") == "inverse"


def test_the_parts_of_the_formulation_do_not_import_its_entry_point():
    """``inverse/formulation/`` has a module per job and ``formulate`` in its ``__init__``; the
    parts import one another, never the package itself (which imports them all)."""
    folder = PACKAGE / "inverse" / "formulation"
    offenders = []
    for path in folder.glob("*.py"):
        if path.name == "__init__.py":
            continue
        tree = ast.parse(path.read_text(encoding="utf-8"))
        if any(isinstance(node, ast.ImportFrom) and node.module == "vibupdate.inverse.formulation"
               for node in ast.walk(tree)):
            offenders.append(path.name)
    assert stage_of(folder / "blocks.py") == "inverse"
    assert not offenders, offenders


def declares_all(path: Path) -> bool:
    """Whether a module assigns ``__all__`` at its top level."""
    tree = ast.parse(path.read_text(encoding="utf-8"))
    return any(isinstance(t, ast.Name) and t.id == "__all__"
               for node in tree.body if isinstance(node, (ast.Assign, ast.AugAssign, ast.AnnAssign))
               for t in (node.targets if isinstance(node, ast.Assign) else [node.target]))


def test_only_the_facade_names_a_public_surface():
    """The public names are the ones ``vibupdate/__init__.py`` lists (at most 60); every other
    module is internal and declares no ``__all__`` of its own."""
    import vibupdate

    declaring = {str(p.relative_to(PACKAGE)) for p in PACKAGE.rglob("*.py") if declares_all(p)}
    assert declares_all(PACKAGE / "__init__.py")
    assert declaring - {"__init__.py"} == set()
    assert 30 <= len(vibupdate.__all__) <= 60
    assert sorted(vibupdate.__all__) == sorted(vibupdate._WHERE)


def test_the_facade_table_names_the_module_that_defines_each_name():
    """``vibupdate._WHERE`` says where each public name is defined, not a module that imports it
    (a name given to a function of another name, ``from_builder = affine_from_builder``, is
    defined where it is assigned)."""
    import vibupdate

    wrong = {}
    for name, module in vibupdate._WHERE.items():
        obj = getattr(vibupdate, name)
        if obj.__name__ == name and obj.__module__ != module:
            wrong[name] = (module, obj.__module__)
    assert wrong == {}


def test_the_version_is_stated_once_in_the_project_metadata():
    """``vibupdate.__version__`` is the installed distribution's version (pyproject.toml), not a
    second literal in the source."""
    import importlib.metadata

    import vibupdate

    facade = ast.parse((PACKAGE / "__init__.py").read_text(encoding="utf-8"))
    assigned = [t.id for node in facade.body if isinstance(node, ast.Assign) for t in node.targets
                if isinstance(t, ast.Name)]
    assert "__version__" not in assigned
    assert vibupdate.__version__ == importlib.metadata.version("vibupdate")


def _counts_script():
    import importlib.util

    path = PACKAGE.parents[1] / "benchmarks" / "codebase_counts.py"
    spec = importlib.util.spec_from_file_location("codebase_counts", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_the_count_script_finds_what_it_counts_on_a_constructed_tree(tmp_path):
    """benchmarks/codebase_counts.py (its output is in benchmarks/RESULTS.md) on a tree made
    for it: each count sees its case and passes over its look-alike."""
    counts = _counts_script()
    src = tmp_path / "src" / "vibupdate"
    (src / "inner").mkdir(parents=True)
    (src / "__init__.py").write_text('__all__ = ["a", "b"]\n')
    (src / "inner" / "__init__.py").write_text("")
    (src / "inner" / "one.py").write_text(
        '"""Rule X (measured on the frame: 1.5e-9).\nSee Eq. 12 of the measured data.\n\n'
        'Acceptance runs r142 and r254; seeds 8-11.\n"""\n'
        "import os\n"
        "from vibupdate.inner import two\n"
        '__all__ = ["b", "c"]\n'
        "# os._exit in a comment is no trick\n"
        "def f():\n    os._exit(0)\n")
    (src / "inner" / "two.py").write_text("def g():\n    from vibupdate.inner import one\n"
                                          "    from vibupdate.inner.one import _helper, f\n")
    tests = tmp_path / "tests"
    tests.mkdir()
    (tests / "test_x.py").write_text("from vibupdate.inner.one import _hidden, shown\nimport vibupdate._extras\n")

    assert counts.public_names(tmp_path / "src")[:4] == (3, 4, 2, 2)
    assert counts.circles(counts.import_graph(tmp_path / "src")) == [["vibupdate.inner.one", "vibupdate.inner.two"]]
    hits = counts.prose_counts(tmp_path / "src")
    assert [h.rsplit(": ", 1)[1] for h in hits["tricks"]] == ["os._exit"]
    assert len(hits["seeds"]) == 1 and "r142" in hits["seeds"][0]
    assert len(hits["measured"]) == 1 and "1.5e-9" in hits["measured"][0]
    assert [h.split(": ")[1] for h in counts.private_imports(tmp_path / "src")] == ["vibupdate.inner.one._helper"]
    assert [h.split(": ")[1] for h in counts.private_imports(tests)] == ["vibupdate.inner.one._hidden",
                                                                         "vibupdate._extras"]


def test_no_module_imports_a_private_name_of_another():
    """A name two modules share is public (no underscore) in the module that owns it; what
    stays private is used by its own module alone (`codebase_counts.private_imports` on src/)."""
    found = _counts_script().private_imports(PACKAGE.parent)
    assert found == []


def test_every_annotation_of_src_names_what_its_module_imports():
    """The annotations of every function and class resolve (`typing.get_type_hints`) against
    their module's names plus its ``if TYPE_CHECKING:`` imports: with ``from __future__ import
    annotations`` an unimported name in an annotation costs nothing at run time, so nothing else
    finds it (ruff's F821 does; ruff is not a test dependency)."""
    import importlib
    import inspect
    import pkgutil
    import typing

    import vibupdate

    faults = []
    for info in pkgutil.walk_packages(vibupdate.__path__, "vibupdate."):
        try:
            module = importlib.import_module(info.name)
        except ModuleNotFoundError as exc:       # an optional extra not installed
            if exc.name and exc.name.startswith("vibupdate"):
                raise
            continue
        checking: dict = {}
        for node in ast.parse(inspect.getsource(module)).body:
            if isinstance(node, ast.If) and ast.unparse(node.test).endswith("TYPE_CHECKING"):
                exec(compile(ast.Module(node.body, []), info.name, "exec"), checking)
        checking.pop("__builtins__", None)
        for obj in list(vars(module).values()):
            if getattr(obj, "__module__", None) != module.__name__:
                continue
            objects = [obj] + ([v for v in vars(obj).values() if inspect.isfunction(v)] if inspect.isclass(obj) else [])
            for item in objects:
                if inspect.isfunction(item) or inspect.isclass(item):
                    try:
                        typing.get_type_hints(item, localns=checking)
                    except NameError as exc:
                        faults.append(f"{info.name}.{item.__qualname__}: {exc}")
    assert not faults, "\n".join(faults)


def test_no_line_of_src_is_over_120_characters():
    """The source reads without a horizontal scroll: every line of ``src/`` at most 120 characters."""
    long = [f"{path.relative_to(PACKAGE.parent)}:{number}" for path in sorted(PACKAGE.rglob("*.py"))
            for number, line in enumerate(path.read_text(encoding="utf-8").splitlines(), start=1) if len(line) > 120]
    assert not long, long
