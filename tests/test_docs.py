"""The documentation stands on its own: it cites nothing outside the repository, and every
relative link in ``docs/*.md`` and ``README.md`` resolves (file and, for markdown targets,
heading anchor)."""

from __future__ import annotations

import re
import unicodedata
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]

#: Documents that are not in the repository and must not be cited by it.
OUTSIDE = ("DESIGN.md", "../shared")

TEXT_SUFFIXES = {".py", ".md", ".toml", ".txt", ".csv", ".json", ".rst", ".cfg", ".ini", ".yaml", ".yml"}

LINK = re.compile(r"(?<!\!)\[(?:[^\]\[]|\[[^\]]*\])*\]\(\s*<?([^)\s>]+)>?(?:\s+\"[^\"]*\")?\s*\)")
IMAGE = re.compile(r"!\[[^\]]*\]\(\s*<?([^)\s>]+)>?(?:\s+\"[^\"]*\")?\s*\)")
REFERENCE = re.compile(r"^[ \t]{0,3}\[[^\]]+\]:\s*<?(\S+?)>?(?:\s+.*)?$", re.MULTILINE)
FENCE = re.compile(r"^([ \t]{0,3})(```|~~~).*?^\1\2[^\n]*$", re.MULTILINE | re.DOTALL)
CODE_SPAN = re.compile(r"(`+)(?!`).*?(?<!`)\1(?!`)", re.DOTALL)


def _text_files(*parts: str) -> list[Path]:
    files = []
    for part in parts:
        path = ROOT / part
        if path.is_file():
            files.append(path)
        elif path.is_dir():
            files += [p for p in sorted(path.rglob("*"))
                      if p.is_file() and p.suffix in TEXT_SUFFIXES and "__pycache__" not in p.parts]
    return files


def _citations(files: list[Path], root: Path = ROOT) -> list[str]:
    """``file:line: cites NAME`` for every line that names a document outside the repository."""
    found = []
    for path in files:
        text = path.read_text(encoding="utf-8", errors="replace")
        for lineno, line in enumerate(text.splitlines(), 1):
            for name in OUTSIDE:
                if name in line:
                    found.append(f"{path.relative_to(root)}:{lineno}: cites {name!r}")
    return found


def _strip_code(text: str) -> str:
    """Markdown without fenced blocks and code spans (links there are examples, not links)."""
    return CODE_SPAN.sub("", FENCE.sub("", text))


def _slug(heading: str) -> str:
    """GitHub's anchor of a heading: lower case, punctuation dropped, spaces to hyphens."""
    text = re.sub(r"`|\*\*|__", "", heading.strip()).lower()
    text = re.sub(r"\[([^\]]*)\]\([^)]*\)", r"\1", text)
    kept = "".join(ch for ch in text
                   if ch in " -_" or unicodedata.category(ch)[0] in ("L", "N"))
    return kept.replace(" ", "-")


def _anchors(path: Path) -> set[str]:
    seen: dict[str, int] = {}
    out = set()
    for line in FENCE.sub("", path.read_text(encoding="utf-8")).splitlines():
        m = re.match(r"^[ \t]{0,3}#{1,6}\s+(.*?)\s*#*\s*$", line)
        if not m:
            continue
        slug = _slug(m.group(1))
        n = seen.get(slug, 0)
        out.add(slug if n == 0 else f"{slug}-{n}")
        seen[slug] = n + 1
    return out


def broken_links(path: Path, root: Path = ROOT) -> list[str]:
    """Relative links of a markdown file that do not resolve inside ``root``."""
    text = _strip_code(path.read_text(encoding="utf-8"))
    targets = LINK.findall(text) + IMAGE.findall(text) + REFERENCE.findall(text)
    bad = []
    for target in targets:
        if re.match(r"^[a-zA-Z][a-zA-Z0-9+.-]*:", target):   # http:, https:, mailto:, ...
            continue
        file_part, _, anchor = target.partition("#")
        dest = (path.parent / file_part).resolve() if file_part else path
        if file_part and root.resolve() not in dest.parents and dest != root.resolve():
            bad.append(f"{path.name}: {target!r} points outside the repository")
            continue
        if not dest.exists():
            bad.append(f"{path.name}: {target!r} does not exist")
            continue
        if anchor and dest.suffix == ".md" and anchor not in _anchors(dest):
            bad.append(f"{path.name}: {target!r} has no heading with anchor #{anchor}")
    return bad


def _markdown_documents() -> list[Path]:
    return ([ROOT / "README.md"] + sorted((ROOT / "docs").glob("*.md")) + sorted((ROOT / "docs" / "fe").glob("*.md"))
            + sorted((ROOT / "docs" / "notes").glob("*.md")))


def test_docs_readme_and_examples_cite_nothing_outside_the_repository():
    found = _citations(_text_files("README.md", "docs", "examples"))
    assert not found, "\n".join(found)


def test_code_cites_nothing_outside_the_repository():
    found = _citations(_text_files("src"))
    assert not found, "\n".join(found)


#: A pointer from the code to a heading of the benchmarks' record: ``benchmarks/RESULTS.md``,
#: then (optionally ``heading``) the heading's text in double quotes, across line breaks.
RESULTS_POINTER = re.compile(r'RESULTS\.md`?,?\s*(?:heading\s*)?"([^"]+)"')


def results_pointers(source: str) -> list[str]:
    """The headings a module's text points to in ``benchmarks/RESULTS.md``, each with its line
    breaks, comment marks and indentation folded into single spaces."""
    flat = re.sub(r"\s*\n\s*(?:#:?\s*)?", " ", source)
    return [" ".join(quoted.split()) for quoted in RESULTS_POINTER.findall(flat)]


def test_the_pointer_reader_folds_comments_and_docstrings():
    source = ('#: the figures (`benchmarks/RESULTS.md`, "Figures behind\n#: src/: FRF kinds").\n'
              '"""See `benchmarks/RESULTS.md`, heading "OpenSees\n    import: probes".\n"""')
    assert results_pointers(source) == ["Figures behind src/: FRF kinds", "OpenSees import: probes"]


def test_every_results_heading_the_code_points_to_exists():
    """A docstring that states a rule and points to its figures names a heading of
    ``benchmarks/RESULTS.md`` that exists (a heading may carry a date or branch after it)."""
    headings = [line.lstrip("#").strip() for line in (ROOT / "benchmarks" / "RESULTS.md").read_text(
        encoding="utf-8").splitlines() if line.startswith("#")]
    pointed = [(str(path.relative_to(ROOT)), quoted) for path in _text_files("src") if path.suffix == ".py"
               for quoted in results_pointers(path.read_text(encoding="utf-8"))]
    assert len(pointed) >= 10
    missing = [f"{where}: {quoted!r}" for where, quoted in pointed
               if not any(h == quoted or h.startswith(quoted + " (") for h in headings)]
    assert not missing, "\n".join(missing)


def test_the_api_page_lists_every_public_name_and_no_other():
    """The table under "What is public" in docs/python-api.md names exactly the facade's names."""
    import vibupdate

    text = (ROOT / "docs" / "python-api.md").read_text(encoding="utf-8")
    section = text.split("## What is public", 1)[1].split("\n## ", 1)[0]
    rows = [line for line in section.splitlines() if line.startswith("| ") and line != "| what | names |"]
    listed = [name for row in rows for name in re.findall(r"`(\w+)`", row.split("|")[2])]
    assert sorted(listed) == sorted(vibupdate.__all__)


def test_the_method_and_vocabulary_pages_exist_and_are_linked_from_the_readme():
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    for page in ("docs/method.md", "docs/vocabulary.md", "docs/case-file.md"):
        assert (ROOT / page).is_file(), page
        assert f"]({page})" in readme, f"README does not link {page}"


    for page in ("docs/python-api.md", "docs/cli.md"):
        assert f"]({page})" in readme, f"README does not link {page}"


def test_the_readme_is_short_and_the_manual_is_in_docs():
    assert len((ROOT / "README.md").read_text(encoding="utf-8").splitlines()) <= 130


def test_the_python_examples_of_the_api_page_run(tmp_path, monkeypatch):
    """Every Python block of docs/python-api.md runs, each in a fresh namespace."""
    monkeypatch.chdir(tmp_path)
    text = (ROOT / "docs" / "python-api.md").read_text(encoding="utf-8")
    blocks = re.findall(r"```python\n(.*?)```", text, re.S)
    assert blocks
    for block in blocks:
        exec(compile(block, "docs/python-api.md", "exec"), {})


@pytest.mark.parametrize("path", _markdown_documents(), ids=lambda p: str(p.relative_to(ROOT)))
def test_every_command_line_shown_parses(path):
    """Every ``vibupdate ...`` line of a bash block parses with the command line's own parser,
    and the case files it names exist."""
    from vibupdate.cli import parser

    text = path.read_text(encoding="utf-8")
    for block in re.findall(r"```bash\n(.*?)```", text, re.S):
        for line in block.splitlines():
            if line.startswith("vibupdate "):
                words = line.split("&&")[0].split()
                args = parser().parse_args(words[1:])
                if getattr(args, "case", None):
                    assert (ROOT / args.case).is_file(), line


def _cli_options() -> dict[str, set[str]]:
    import argparse

    from vibupdate.cli import parser

    commands = next(a for a in parser()._actions if isinstance(a, argparse._SubParsersAction)).choices
    return {name: {o for a in sub._actions if a.help != argparse.SUPPRESS for o in a.option_strings
                   if o not in ("-h", "--help")} for name, sub in commands.items()}


def test_every_command_and_option_is_in_the_cli_page():
    """docs/cli.md is the command-line reference: it names every command and every option."""
    text = (ROOT / "docs" / "cli.md").read_text(encoding="utf-8")
    missing = [f"{name} {option}" for name, options in _cli_options().items()
               for option in sorted(options) if f"`{option}" not in text]
    missing += [name for name in _cli_options() if f"`{name} " not in text and f"`vibupdate {name} " not in text]
    assert not missing, missing


@pytest.mark.parametrize("path", _markdown_documents(), ids=lambda p: str(p.relative_to(ROOT)))
def test_every_relative_link_resolves(path):
    bad = broken_links(path)
    assert not bad, "\n".join(bad)


def test_the_link_checker_finds_broken_links(tmp_path):
    """The checker itself: a missing file, a missing anchor and a path out of the tree are
    reported; a good file link, good anchors (also of a heading between two fenced blocks), a URL
    and a link inside code are not."""
    (tmp_path / "sub").mkdir()
    (tmp_path / "sub" / "other.md").write_text("# A title, with `code`\n\n## Second step\n", encoding="utf-8")
    page = tmp_path / "sub" / "page.md"
    page.write_text(
        "# Page\n"
        "[ok](other.md) [ok anchor](other.md#a-title-with-code) [self](#page) [web](https://example.org)\n"
        "[later heading](#after-the-fence)\n"
        "`[in code](missing.md)`\n\n"
        "```\n[in a fence](missing.md)\n```\n\n"
        "## After the fence\n\n"
        "```\nsecond = fence\n```\n"
        "[missing](nothere.md) [bad anchor](other.md#third-step) [outside](../../x.md)\n",
        encoding="utf-8")
    bad = broken_links(page, root=tmp_path)
    assert len(bad) == 3, bad
    assert any("nothere.md" in b for b in bad)
    assert any("#third-step" in b for b in bad)
    assert any("outside the repository" in b for b in bad)


def test_the_citation_scan_finds_a_citation(tmp_path):
    cited = tmp_path / "note.md"
    cited.write_text("See DESIGN.md, item 4.\nNothing here.\nAnd ../shared/paper.\n", encoding="utf-8")
    assert _citations([cited], root=tmp_path) == ["note.md:1: cites 'DESIGN.md'", "note.md:3: cites '../shared'"]


# -- the commands of the docs run as written -----------------------------------------------------

#: Pages whose command blocks a reader types (the notes are measurement narratives).
COMMAND_PAGES = ["README.md", *sorted(str(p.relative_to(ROOT)) for p in (ROOT / "docs").rglob("*.md")
                                      if "notes" not in p.relative_to(ROOT / "docs").parts)]
BLOCK = re.compile(r"^```(bash|sh|shell)\n(.*?)^```", re.MULTILINE | re.DOTALL)


def doc_commands(text: str) -> list[str]:
    """The commands of a page's shell blocks, in order: continuation lines joined, comments
    dropped, ``a && b`` split, installs and the test run (``pip``, ``pytest``) left out."""
    out = []
    for _, body in BLOCK.findall(text):
        for line in body.replace("\\\n", " ").splitlines():
            line = line.split(" #", 1)[0].strip()
            for part in (p.strip() for p in line.split("&&")):
                if part and not part.startswith(("pip ", "pytest", "#")):
                    out.append(" ".join(part.split()))
    return out


#: What each command of the docs gives, run in order per page in a fresh folder holding a copy
#: of ``examples/`` (the real Southampton files linked in where the page reads them): exit
#: code, a line of its standard output (a regular expression), and whether it is too long
#: for CI (``slow``). ``None`` as the code: not run, with the reason instead of the line.
EXPECTED = {
    "vibupdate example cantilever": (0, r"^wrote cantilever-results/ \(results\.json", False),
    "vibupdate example --list": (0, r"^cantilever$", False),
    "vibupdate check examples/cantilever/case.toml": (0, r"^examples/cantilever/case\.toml: OK; case ", False),
    "vibupdate run examples/cantilever/case.toml --out case-results":
        (0, r"^wrote case-results/ \(results\.json", False),
    "vibupdate run examples/cantilever/case.toml --certify 60 --out cantilever-certified":
        (0, r"^wrote cantilever-certified/ ", True),
    "vibupdate sweep examples/cantilever/case.toml --samples 200 --frequency-tolerance 0.005 --out sweep":
        (0, r" of 200 samples; wrote sweep/$", True),
    "vibupdate sweep examples/cantilever/case.toml --samples 200 --frequency-tolerance 0.005 --scheduler "
    "tcp://10.0.0.5:8786": (None, "needs a Dask scheduler running at that address", True),
    "vibupdate run examples/cantilever/case.toml --samples 100 --frequency-tolerance 0.005 --out cantilever-results":
        (0, r"^wrote cantilever-results/ ", True),
    **{f"vibupdate example fe-{code} --out fe-{code}":
       (0, rf"^wrote fe-{code}/model/case\.toml: the model with the measured data$", True)
       for code in ("abaqus", "ansys", "nastran", "opensees")},
    **{f"vibupdate import fe-{code}/exports/import.toml --out my-model":
       (0, r"^wrote my-model/model\.toml and its matrix files", True) for code in ("abaqus", "ansys", "nastran",
                                                                                  "opensees")},
    "vibupdate example bar --out bar": (0, r"^example bar: wrote the test in bar/hammer\.uff", True),
    "vibupdate extract bar/hammer.uff --reciprocal --band 100 1600 --first-mode 3 --out extraction":
        (0, r"^  mode 3: ", True),
    "vibupdate extract Experimental.csv test_2.csv test_3.csv --responses x1 x2 x3 --excitations x1 x2 x3 --kind "
    "accelerance --band 3 28 --modes 3 --out soton-extraction": (0, r"^3 mode\(s\), ", True),
}


def test_every_command_of_the_docs_has_an_expected_outcome():
    found = {c for page in COMMAND_PAGES for c in doc_commands((ROOT / page).read_text(encoding="utf-8"))}
    assert found == set(EXPECTED), (sorted(found - set(EXPECTED)), sorted(set(EXPECTED) - found))


def test_the_command_reader_joins_lines_and_leaves_installs_out():
    text = "```bash\npip install . && vibupdate example cantilever  # first\nvibupdate run a.toml \\\n" \
           "    --out b\n```\n```text\nvibupdate not this\n```\n"
    assert doc_commands(text) == ["vibupdate example cantilever", "vibupdate run a.toml --out b"]


def _page_runs(page: str, slow: bool) -> list[str]:
    """The commands of ``page`` that run, in order; without ``slow`` only those fast enough for CI."""
    return [c for c in doc_commands((ROOT / page).read_text(encoding="utf-8"))
            if EXPECTED[c][0] is not None and (slow or not EXPECTED[c][2])]


def _missing_dependency(commands: list[str]) -> str | None:
    """Why ``commands`` cannot run here, or None: the OpenSees example asks the route itself for
    its package (`vibupdate.model.fe.opensees.openseespy`), so the skip follows what the route
    imports."""
    if any("fe-opensees" in c for c in commands):
        from vibupdate.extras import MissingExtra
        from vibupdate.model.fe.opensees import openseespy

        try:
            openseespy()
        except MissingExtra as exc:
            return str(exc)
    return None


def test_the_opensees_page_runs_where_the_route_s_package_is_installed():
    """The page is skipped only when the route's own import fails, not on another package's."""
    pytest.importorskip("opensees")
    commands = doc_commands((ROOT / "docs/fe/opensees.md").read_text(encoding="utf-8"))
    assert any("fe-opensees" in c for c in commands) and _missing_dependency(commands) is None
    assert _missing_dependency(["vibupdate example cantilever"]) is None


#: Each page twice: its fast commands in CI, all of them on demand (``-m slow``).
RUNS = [pytest.param(p, False, id=f"{p}-fast") for p in COMMAND_PAGES if _page_runs(p, False)] + [
    pytest.param(p, True, id=f"{p}-all", marks=pytest.mark.slow) for p in COMMAND_PAGES
    if len(_page_runs(p, True)) > len(_page_runs(p, False))]


#: Commands that read nothing but their arguments, run once per session for every page and test
#: file that runs them (`conftest.run_once`): two pages and tests/pipeline/test_bar_example.py
#: run the bar example, 65 s on one core; each page of docs/fe/ and tests/model/test_fe_examples.py
#: run that code's worked example.
ONCE = {"vibupdate example bar --out bar",
        *(f"vibupdate example fe-{code} --out fe-{code}" for code in ("abaqus", "ansys", "nastran", "opensees"))}


@pytest.mark.parametrize("page, slow", RUNS)
def test_the_commands_of_a_page_run_as_written(page, slow, tmp_path, run_once):
    import os
    import shlex
    import shutil
    import subprocess
    import sys

    shutil.copytree(ROOT / "examples", tmp_path / "examples")
    commands = _page_runs(page, slow)
    missing = _missing_dependency(commands)
    if missing:
        pytest.skip(missing)
    if any("Experimental.csv" in c for c in commands):
        from helpers import realdata

        soton = realdata("soton3storey")
        if not soton.is_dir():
            pytest.skip("the Southampton frame's files are not on this machine (helpers.realdata)")
        for name in ("Experimental.csv", "test_2.csv", "test_3.csv"):
            (tmp_path / name).symlink_to(soton / name)
    env = dict(os.environ, OMP_NUM_THREADS="1", PYTHONPATH=os.pathsep.join(
        [str(ROOT / "src"), *filter(None, [os.environ.get("PYTHONPATH")])]))
    for command in commands:
        code, line, _ = EXPECTED[command]
        argv = shlex.split(command)
        if command in ONCE:
            done = subprocess.CompletedProcess(argv, *run_once(command)[:3])
            for entry in run_once(command)[3].iterdir():
                (shutil.copytree if entry.is_dir() else shutil.copy2)(entry, tmp_path / entry.name, symlinks=True)
        else:
            done = subprocess.run([sys.executable, "-m", "vibupdate", *argv[1:]], cwd=tmp_path, capture_output=True,
                                  text=True, env=env, timeout=1800)
        assert done.returncode == code, f"{page}: {command}\n{done.stdout[-2000:]}\n{done.stderr[-2000:]}"
        assert "Traceback" not in done.stderr, done.stderr[-3000:]
        assert re.search(line, done.stdout, re.MULTILINE), f"{page}: {command}: no line {line!r} in\n{done.stdout}"


def test_reading_results_back_runs_on_the_readme_s_results(tmp_path, monkeypatch):
    """docs/outputs.md's "Reading results back" reads the folder the README's `run` writes."""
    import contextlib
    import io

    from vibupdate.cli import main

    import shutil

    run = next(c for c in doc_commands((ROOT / "README.md").read_text(encoding="utf-8"))
               if c.startswith("vibupdate run ") and "--certify" not in c)
    shutil.copytree(ROOT / "examples", tmp_path / "examples")
    monkeypatch.chdir(tmp_path)
    with contextlib.redirect_stdout(io.StringIO()):
        assert main(run.split()[1:]) == 0
    block = re.search(r"```python\n(from vibupdate\.io\.results import load_results\n.*?)```",
                      (ROOT / "docs" / "outputs.md").read_text(encoding="utf-8"), re.DOTALL).group(1)
    with contextlib.redirect_stdout(io.StringIO()) as printed:
        exec(compile(block, "docs/outputs.md", "exec"), {})
    assert printed.getvalue().startswith("cantilever-case-file success True")
