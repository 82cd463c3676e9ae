"""Counts that say how much of the codebase a maintainer has to hold, on the tree it is run in.

Usage::

    python benchmarks/codebase_counts.py                 # the checkout holding this script
    python benchmarks/codebase_counts.py --root DIR      # another checkout (e.g. main)
    python benchmarks/codebase_counts.py --list          # also the lines behind each count

Printed as one table, each count with its limit where the project states one:

* public names: the union of the names in every ``__all__`` list under ``src/vibupdate`` (the
  top-level facade's included), and the facade's own count;
* untyped fields of ``UpdateResult`` and ``RunResult``: an annotation that is a ``dict`` (or
  ``Mapping``, ``Any``, ``object``) whose values are not given a type, or a tuple or list of
  such, optionally ``| None``; read from the classes' resolved annotations, so the tree's
  ``src`` is imported;
* import circles: strongly connected components of more than one module in the static graph
  of ``vibupdate`` imports (every ``import`` statement of a module, at its top or inside a
  function, but not under ``if TYPE_CHECKING:``);
* process tricks: occurrences of ``os._exit``, ``gc.freeze`` and ``multiprocessing`` in the
  code of ``src/`` (comments and docstrings not counted);
* acceptance seed ids in comments or docstrings of ``src/``: ``seed 21``, ``seeds 8-11``, or
  an acceptance run ``r358``;
* measurement narratives: comment or docstring lines of ``src/`` with the word "measured"
  beside a figure (a digit on the same line, not inside an equation number such as "Eq. 12"),
  and, of those, the lines where "measured" reports a measurement ("measured on the frame",
  "(measured: 5e-9") rather than names measured data ("the measured frequency of mode 2");
* lines of ``src/`` (``*.py``);
* imports of private names by the tests: ``from vibupdate... import _name`` or an import of a
  private module (a dotted part starting with one underscore), at any depth of ``tests/``
  (reported, no limit stated); and the same between the modules of ``src/`` (limit 0: a name
  two modules share is public in the module that owns it);
* lines of each docs page (``README.md``, ``docs/*.md``, ``docs/fe/*.md``; limit 700), and,
  listed apart and without a limit, the notes under ``docs/notes/``.

Static counts only (no run of the library beyond importing the two result classes); a few
seconds.
"""

from __future__ import annotations

import argparse
import ast
import io
import re
import subprocess
import sys
import tokenize
from pathlib import Path

DOCS_PAGE_LIMIT = 700
#: The project's stated ceilings (benchmarks/RESULTS.md, "Codebase counts").
LIMITS = {"public names": 60, "untyped UpdateResult fields": 0, "untyped RunResult fields": 0,
          "import circles": 0, "os._exit / gc.freeze / multiprocessing": 0,
          "seed ids in comments/docstrings": 0, "'measured' beside a figure": 50,
          "private names imported between src modules": 0}

SEED = re.compile(r"\bseeds?\s+\d+|\bruns?\s+r\d+|\br\d{2,4}\b", re.IGNORECASE)
#: "measured" as a report of a measurement, not as the adjective of measured data: followed by
#: a colon, a bracket, a figure or a preposition ("measured on the frame", "(measured: 5e-9",
#: "measured 1.1e-8"), or after a form of "to be" ("was measured").
WORD_MEASURED = re.compile(r"\bmeasured\b", re.IGNORECASE)
MEASURED = re.compile(
    r"\bmeasured\b(?=\s*(?:[:(+\-\u2212]|\*?:|\d|(?:on|at|with|in|by|from|over|against|for|before|after"
    r"|here|there|when|while|across|again|once|twice|so|as|to)\b))"
    r"|\b(?:was|were|is|are|been|be)\s+measured\b", re.IGNORECASE)
FIGURE = re.compile(r"\d")
EQUATION = re.compile(r"\b(?:Eqs?|Sections?|Table|Fig)\.?\s+\d+(?:[-.]\d+)?", re.IGNORECASE)
TRICKS = re.compile(r"\bos\._exit\b|\bgc\.freeze\b|\bmultiprocessing\b")


def python_files(src: Path) -> list[Path]:
    return sorted(p for p in src.rglob("*.py") if "__pycache__" not in p.parts)


def module_name(path: Path, src: Path) -> str:
    parts = list(path.relative_to(src).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


# --- public names -------------------------------------------------------------------------

def all_lists(tree: ast.Module) -> list[str]:
    """Names of every ``__all__ = [...]`` / ``__all__ += [...]`` at a module's top level."""
    names = []
    for node in tree.body:
        targets = []
        if isinstance(node, ast.Assign):
            targets, value = node.targets, node.value
        elif isinstance(node, (ast.AugAssign, ast.AnnAssign)):
            targets, value = [node.target], node.value
        if any(isinstance(t, ast.Name) and t.id == "__all__" for t in targets) and value is not None:
            try:
                names += list(ast.literal_eval(value))
            except ValueError:          # a computed __all__: count what is written out
                names += [n.value for n in ast.walk(value)
                          if isinstance(n, ast.Constant) and isinstance(n.value, str)]
    return names


def public_names(src: Path) -> tuple[int, int, int, int, list[str]]:
    union: set[str] = set()
    entries = 0
    lists = 0
    facade = 0
    rows = []
    for path in python_files(src):
        names = all_lists(ast.parse(path.read_text(encoding="utf-8")))
        if not names:
            continue
        lists += 1
        entries += len(names)
        union.update(names)
        rows.append(f"{path.relative_to(src.parent)}: {len(names)}")
        if path == src / "vibupdate" / "__init__.py":
            facade = len(names)
    return len(union), entries, lists, facade, rows


# --- untyped result fields ----------------------------------------------------------------

FIELDS_PROBE = r"""
import dataclasses, sys, typing, collections.abc
src, names = sys.argv[1], sys.argv[2:]
sys.path.insert(0, src)
import importlib
for spec in names:
    module, _, cls_name = spec.rpartition(".")
    mod = importlib.import_module(module)
    if not mod.__file__.startswith(src):
        raise SystemExit(f"imported {mod.__file__}, not the tree's {src}")
    cls = getattr(mod, cls_name)
    hints = typing.get_type_hints(cls)

    def untyped(tp):
        origin, args = typing.get_origin(tp), typing.get_args(tp)
        if tp in (dict, typing.Any, object) or origin is None and tp is collections.abc.Mapping:
            return True
        if origin in (dict, collections.abc.Mapping, collections.abc.MutableMapping):
            return not args or untyped(args[-1]) or args[-1] in (dict, typing.Any, object)
        if origin in (tuple, list, collections.abc.Sequence):
            return any(untyped(a) for a in args if a is not Ellipsis)
        if origin in (typing.Union, getattr(__import__("types"), "UnionType", None)):
            return any(untyped(a) for a in args if a is not type(None))
        return False

    fields = dataclasses.fields(cls) if dataclasses.is_dataclass(cls) else ()
    bad = [f.name for f in fields if untyped(hints[f.name])]
    print(cls_name, len(fields), " ".join(bad))
"""


def class_paths(src: Path, wanted: tuple[str, ...]) -> dict[str, str]:
    """``{class name: dotted path}`` of the first module under ``src`` defining each class."""
    found: dict[str, str] = {}
    for path in python_files(src):
        text = path.read_text(encoding="utf-8")
        if not any(f"class {name}" in text for name in wanted):
            continue
        for node in ast.parse(text).body:
            if isinstance(node, ast.ClassDef) and node.name in wanted and node.name not in found:
                found[node.name] = f"{module_name(path, src)}.{node.name}"
    return found


def untyped_fields(src: Path) -> dict[str, tuple[int, list[str]]]:
    paths = class_paths(src, ("UpdateResult", "RunResult"))
    out = subprocess.run([sys.executable, "-c", FIELDS_PROBE, str(src), *paths.values()],
                         capture_output=True, text=True, check=True).stdout
    result = {}
    for line in out.splitlines():
        name, count, *bad = line.split()
        result[name] = (int(count), bad)
    return result


# --- import circles -----------------------------------------------------------------------

def _type_checking_nodes(tree: ast.Module) -> set[int]:
    skip = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.If) and "TYPE_CHECKING" in ast.unparse(node.test):
            skip.update(id(n) for stmt in node.body for n in ast.walk(stmt))
    return skip


def import_graph(src: Path) -> dict[str, set[str]]:
    modules = {module_name(p, src): p for p in python_files(src)}
    graph: dict[str, set[str]] = {m: set() for m in modules}

    def resolve(name: str) -> str | None:
        while name:                      # a name imported from a module is that module
            if name in modules:
                return name
            name = name.rpartition(".")[0]
        return None

    for mod, path in modules.items():
        tree = ast.parse(path.read_text(encoding="utf-8"))
        skip = _type_checking_nodes(tree)
        package = mod if path.name == "__init__.py" else mod.rpartition(".")[0]
        for node in ast.walk(tree):
            if id(node) in skip:
                continue
            targets = []
            if isinstance(node, ast.Import):
                targets = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom):
                base = node.module or ""
                if node.level:
                    anchor = package.split(".")
                    anchor = anchor[:len(anchor) - (node.level - 1)]
                    base = ".".join(anchor + ([base] if base else []))
                targets = [f"{base}.{a.name}" for a in node.names]
            for target in targets:
                dest = resolve(target)
                if dest and dest != mod and not mod.startswith(dest + "."):
                    graph[mod].add(dest)      # a package's own __init__ above it is no circle
    return graph


def circles(graph: dict[str, set[str]]) -> list[list[str]]:
    """Strongly connected components of more than one module (Tarjan, iterative)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    found = []
    counter = 0
    for root in sorted(graph):
        if root in index:
            continue
        work = [(root, iter(sorted(graph[root])))]
        index[root] = low[root] = counter
        counter += 1
        stack.append(root)
        on_stack.add(root)
        while work:
            node, children = work[-1]
            for child in children:
                if child not in index:
                    index[child] = low[child] = counter
                    counter += 1
                    stack.append(child)
                    on_stack.add(child)
                    work.append((child, iter(sorted(graph[child]))))
                    break
                if child in on_stack:
                    low[node] = min(low[node], index[child])
            else:
                work.pop()
                if work:
                    low[work[-1][0]] = min(low[work[-1][0]], low[node])
                if low[node] == index[node]:
                    component = []
                    while True:
                        member = stack.pop()
                        on_stack.discard(member)
                        component.append(member)
                        if member == node:
                            break
                    if len(component) > 1:
                        found.append(sorted(component))
    return sorted(found)


# --- comments, docstrings and code of src/ ------------------------------------------------

def text_lines(path: Path) -> tuple[list[tuple[int, str]], list[tuple[int, str]]]:
    """``(comment and docstring lines, code lines)`` of a module, each as ``(line, text)``;
    a code line is the source line with its comments and string literals taken out."""
    source = path.read_text(encoding="utf-8")
    tree = ast.parse(source)
    prose: list[tuple[int, str]] = []
    doc_ids = set()
    for node in ast.walk(tree):
        if isinstance(node, (ast.Module, ast.ClassDef, ast.FunctionDef, ast.AsyncFunctionDef)):
            body = node.body
            if body and isinstance(body[0], ast.Expr) and isinstance(body[0].value, ast.Constant) \
                    and isinstance(body[0].value.value, str):
                doc_ids.add((body[0].lineno, body[0].col_offset))
        # attribute docstrings (a string statement after an assignment) count as docstrings too
        if isinstance(node, ast.Expr) and isinstance(node.value, ast.Constant) and isinstance(node.value.value, str):
            doc_ids.add((node.lineno, node.col_offset))
    code = {i: line for i, line in enumerate(source.splitlines(), 1)}
    for tok in tokenize.generate_tokens(io.StringIO(source).readline):
        if tok.type == tokenize.COMMENT:
            prose.append((tok.start[0], tok.string))
            line = code[tok.start[0]]
            code[tok.start[0]] = line[:tok.start[1]] + line[tok.end[1]:]
        elif tok.type == tokenize.STRING:
            if tok.start in doc_ids:
                for offset, text in enumerate(tok.string.splitlines()):
                    prose.append((tok.start[0] + offset, text))
            for row in range(tok.start[0], tok.end[0] + 1):
                line = code[row]
                lo = tok.start[1] if row == tok.start[0] else 0
                hi = tok.end[1] if row == tok.end[0] else len(line)
                code[row] = line[:lo] + " " * (hi - lo) + line[hi:]
    return prose, sorted(code.items())


def prose_counts(src: Path) -> dict[str, list[str]]:
    hits: dict[str, list[str]] = {"tricks": [], "seeds": [], "measured": [], "reports": []}
    for path in python_files(src):
        rel = path.relative_to(src.parent)
        prose, code = text_lines(path)
        for lineno, text in code:
            for match in TRICKS.finditer(text):
                hits["tricks"].append(f"{rel}:{lineno}: {match.group(0)}")
        for lineno, text in prose:
            if SEED.search(text):
                hits["seeds"].append(f"{rel}:{lineno}: {text.strip()}")
            if WORD_MEASURED.search(text) and FIGURE.search(EQUATION.sub("", text)):
                hits["measured"].append(f"{rel}:{lineno}: {text.strip()}")
                if MEASURED.search(text):
                    hits["reports"].append(f"{rel}:{lineno}: {text.strip()}")
    return hits


# --- private names imported by the tests and between the modules of src/ -------------------

def _private(dotted: str) -> bool:
    return any(part.startswith("_") and not part.startswith("__") for part in dotted.split("."))


def private_imports(folder: Path) -> list[str]:
    """``file:line: name`` of every import of a private ``vibupdate`` name or module in ``folder``
    (``tests/`` or ``src/``)."""
    found = []
    for path in sorted(folder.rglob("*.py")):
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            names = []
            if isinstance(node, ast.ImportFrom) and (node.module or "").startswith("vibupdate"):
                names = [f"{node.module}.{a.name}" for a in node.names]
            elif isinstance(node, ast.Import):
                names = [a.name for a in node.names if a.name.startswith("vibupdate")]
            found += [f"{path.relative_to(folder.parent)}:{node.lineno}: {n}" for n in names if _private(n)]
    return found


# --- line counts --------------------------------------------------------------------------

def line_count(path: Path) -> int:
    return len(path.read_text(encoding="utf-8").splitlines())


def docs_pages(root: Path) -> tuple[list[tuple[str, int]], list[tuple[str, int]]]:
    pages = [root / "README.md", *sorted((root / "docs").glob("*.md")), *sorted((root / "docs" / "fe").glob("*.md"))]
    notes = sorted((root / "docs" / "notes").glob("*.md"))
    return ([(str(p.relative_to(root)), line_count(p)) for p in pages if p.is_file()],
            [(str(p.relative_to(root)), line_count(p)) for p in notes])


# --- report -------------------------------------------------------------------------------

def git_head(root: Path) -> str:
    try:
        out = subprocess.run(["git", "-C", str(root), "log", "-1", "--format=%h %s"],
                             capture_output=True, text=True, check=True).stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        return "(not a git checkout)"
    return out[:90]


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--root", type=Path, default=Path(__file__).resolve().parents[1],
                        help="the checkout to count (default: the one holding this script)")
    parser.add_argument("--list", action="store_true", help="also list what each count found")
    args = parser.parse_args(argv)
    root = args.root.resolve()
    src = root / "src"

    n_public, n_entries, n_lists, n_facade, list_rows = public_names(src)
    fields = untyped_fields(src)
    cycles = circles(import_graph(src))
    hits = prose_counts(src)
    src_lines = sum(line_count(p) for p in python_files(src))
    private = private_imports(root / "tests") if (root / "tests").is_dir() else []
    shared = private_imports(src)
    pages, notes = docs_pages(root)

    rows = [
        ("public names", n_public,
         f"union of {n_lists} __all__ lists ({n_entries} entries); the facade's {n_facade}"),
    ]
    for name in ("UpdateResult", "RunResult"):
        total, bad = fields.get(name, (0, []))
        rows.append((f"untyped {name} fields", len(bad), f"of {total}: {', '.join(bad) or '-'}"))
    rows += [
        ("import circles", len(cycles), "; ".join(" - ".join(c) for c in cycles) or "-"),
        ("os._exit / gc.freeze / multiprocessing", len(hits["tricks"]),
         ", ".join(sorted({h.split(":")[0] for h in hits["tricks"]})) or "-"),
        ("seed ids in comments/docstrings", len(hits["seeds"]),
         ", ".join(sorted({h.split(":")[0] for h in hits["seeds"]})) or "-"),
        ("'measured' beside a figure", len(hits["measured"]),
         f"comment or docstring lines; {len(hits['reports'])} of them report a measurement "
         "(\"measured on ...\", \"(measured: ...\"), the rest say \"measured data\" next to a number"),
        ("src/ lines", src_lines, f"{len(python_files(src))} files"),
        ("private names imported by tests", len(private),
         f"in {len({h.split(':')[0] for h in private})} test files"),
        ("private names imported between src modules", len(shared),
         ", ".join(h.split(": ")[1] for h in shared) or "-"),
    ]
    over = [(name, n) for name, n in pages if n > DOCS_PAGE_LIMIT]
    rows.append((f"docs pages over {DOCS_PAGE_LIMIT} lines", len(over),
                 ", ".join(f"{name} {n}" for name, n in over) or "-"))

    print(f"tree: {root} at {git_head(root)}")
    print()
    print("| count | value | limit | ok | detail |")
    print("|---|---:|---:|---|---|")
    for name, value, detail in rows:
        limit = LIMITS.get(name, 0 if name.startswith("docs pages") else None)
        ok = "" if limit is None else ("yes" if value <= limit else "**no**")
        print(f"| {name} | {value} | {'' if limit is None else limit} | {ok} | {detail} |")
    print()
    print("| docs page | lines | over 700 |")
    print("|---|---:|---|")
    for name, n in pages:
        print(f"| {name} | {n} | {'**yes**' if n > DOCS_PAGE_LIMIT else ''} |")
    for name, n in notes:
        print(f"| {name} (notes) | {n} | |")

    if args.list:
        for title, items in (("__all__ lists", list_rows), ("process tricks", hits["tricks"]),
                             ("seed ids", hits["seeds"]), ("'measured' beside a figure", hits["measured"]),
                             ("of which measurement reports", hits["reports"]),
                             ("private names imported by tests", private),
                             ("private names imported between src modules", shared)):
            print(f"\n{title}:")
            for item in items:
                print(f"  {item}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
