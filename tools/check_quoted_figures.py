"""Every figure quoted next to a benchmark citation appears in the results it cites.

A *citation* is a committed results file (``benchmarks/results/<name>.md`` or ``.json``, or
the bare ``<name>.md``) or a benchmark command (``python benchmarks/<script>.py ...``, which
cites the results files that script writes). A *block* is where a citation holds: a section
of a reStructuredText or Markdown page (text between two headings), one entry of
``CHANGELOG.md`` (a top-level ``- `` item with its continuation lines), one docstring or
comment block of a Python file. In a block with a citation, every *figure* must be found in
at least one of the cited files:

- a figure is a number written with a decimal point or an exponent (``0.0976``, ``3.53e-4``,
  ``1.93``), optionally followed by ``%`` or a times sign;
- it is found when some number of the file, rounded to the figure's precision (decimals, or
  significant digits for an exponent), equals it; a percentage also matches a fraction
  (``7.6 %`` matches ``0.076``);
- inline literals (````...````, ``:param:`...``` roles) and literal blocks (code, after
  ``::``) are not prose and are left out: they hold parameter values, not measurements;
- a paragraph that cites a commit (``at commit 768ed07``) quotes a past measurement, which
  the current results cannot confirm: it is reported as *historical* and not checked.

A block without a citation is not checked: a figure there is a parameter, a unit or a
definition, not a measurement. What the check cannot catch: a figure rounded to one or two
digits that equals an unrelated number of the cited file (``about 0.08x`` was "found" as a
latency of 0.0846 µs while the ratio it meant was 0.0976), so quote measured figures to
three significant digits. Exits 1 and lists every unfound figure with its file and
line; ``.ci/run`` runs it. Run::

    python tools/check_quoted_figures.py            # the whole tree
    python tools/check_quoted_figures.py -v         # also the blocks that passed
"""

import argparse
import ast
import json
import math
import re
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
RESULTS = ROOT / "benchmarks" / "results"

# The results-file stem each benchmark script writes (its tags and ``_quick`` add suffixes).
SCRIPT_STEMS = {
    "bench_conformal": "conformal",
    "bench_export": "bench_export",
    "bench_extrapolation": "extrapolation",
    "bench_rbf": "bench_rbf",
    "bench_streaming": "bench_streaming",
    "bench_thermal_accuracy": "thermal_accuracy",
    "bench_thermal_state": "thermal_state",
    "bench_unitwise": "unitwise",
    "check_unchanged": "check_unchanged",
    "conformal_difficulty_check": "conformal_difficulty",
    "paper_claim_check": "paper_claim",
    "rbf_run_folds_check": "rbf_run_folds",
    "rbf_scale_check": "rbf_scale",
    "rbf_variance_check": "rbf_variance",
    "unitwise_selection": "unitwise_selection",
}

FIGURE = re.compile(
    r"(?<![\w.\-/])(?P<number>\d+\.\d+(?:[eE][-+]?\d+)?|\d+[eE][-+]?\d+)"
    r"(?P<unit>\s?%)?(?![\w.]*\d)(?!\.\d)"
)
RESULT_NUMBER = re.compile(r"[-+]?(?:\d+\.\d*|\.\d+|\d+)(?:[eE][-+]?\d+)?")
RESULT_FILE = re.compile(
    r"(?:benchmarks/results/|results/|\b)(?P<stem>[a-z][a-z0-9_]*)\.(?:md|json)\b"
)
COMMAND = re.compile(r"benchmarks/(?P<script>[a-z_]+)\.py")
COMMIT = re.compile(r"\b(?:at|from|before|until)\s+commit\b|\bat\s+[0-9a-f]{7,40}\b")
# A power of ten alone (``1e-12``) is a tolerance or a scale, not a measurement.
POWER_OF_TEN = re.compile(r"^1(?:\.0*)?[eE][-+]?\d+$")
INLINE_LITERAL = re.compile(r"``.*?``|:[a-z:]+:`[^`]*`|`[^`]*`_?")
HEADING_RULE = re.compile(r"^([=\-~^\"'`#*+])\1{2,}\s*$")


def result_stems(results=RESULTS):
    """Stems of the committed results files (``thermal_state``, ``bench_rbf_quick``...)."""
    return sorted(
        {path.stem for path in results.glob("*.md")} | {p.stem for p in results.glob("*.json")}
    )


def numbers_of(stem, results=RESULTS):
    """Every finite number written in ``results/<stem>.md`` and ``.json``, as floats."""
    found = set()
    for suffix in (".md", ".json"):
        path = results / f"{stem}{suffix}"
        if path.is_file():
            text = path.read_text(encoding="utf-8")
            if suffix == ".json":
                found.update(_json_numbers(json.loads(text)))
            found.update(float(n) for n in RESULT_NUMBER.findall(text))
    return {value for value in found if math.isfinite(value)}


def _json_numbers(value):
    if isinstance(value, bool):
        return
    if isinstance(value, (int, float)):
        yield float(value)
    elif isinstance(value, dict):
        for item in value.values():
            yield from _json_numbers(item)
    elif isinstance(value, list):
        for item in value:
            yield from _json_numbers(item)


def cited_stems(text, stems):
    """The results stems a block cites: files named in it, and files its commands write."""
    cited = set()
    for match in RESULT_FILE.finditer(text):
        if match["stem"] in stems:
            cited.add(match["stem"])
    for match in COMMAND.finditer(text):
        prefix = SCRIPT_STEMS.get(match["script"])
        if prefix is not None:
            cited.update(s for s in stems if s == prefix or s.startswith(prefix + "_"))
    return cited


def _matches(figure, percent, values):
    """Whether ``figure`` (its text) is some value rounded to the figure's precision."""
    quoted = float(figure)
    if "e" in figure.lower():
        mantissa = figure.lower().split("e")[0]
        digits = len(mantissa.replace(".", "").lstrip("0")) or 1
        candidates = values
        tolerance = 0.5 * 10 ** (math.floor(math.log10(abs(quoted))) - digits + 1) if quoted else 0
    else:
        decimals = len(figure.split(".")[1]) if "." in figure else 0
        tolerance = 0.5 * 10**-decimals
        candidates = values
    scales = (1.0, 100.0) if percent else (1.0,)
    for value in candidates:
        for scale in scales:
            if abs(abs(value) * scale - quoted) <= tolerance * (1 + 1e-9):
                return True
    return False


def figures(text):
    """``(line offset, figure text, is a percentage)`` of the prose of a block."""
    found = []
    for offset, line in enumerate(text.splitlines()):
        prose = INLINE_LITERAL.sub(" ", line)
        for match in FIGURE.finditer(prose):
            if POWER_OF_TEN.match(match["number"]):
                continue
            found.append((offset, match["number"], bool(match["unit"])))
    return found


def page_blocks(path):
    """``(first line number, text)`` of each section of a reST/Markdown page."""
    lines = path.read_text(encoding="utf-8").splitlines()
    lines = _strip_literals(lines, markdown=path.suffix == ".md")
    blocks, start, current = [], 1, []
    for number, line in enumerate(lines, start=1):
        is_heading = (line.startswith("#") and path.suffix == ".md") or (
            HEADING_RULE.match(line) and current and current[-1].strip()
        )
        if is_heading:
            # the block starts at its title: a Markdown heading line, or the reST title
            # above its underline (blanked, so that offsets stay line numbers)
            title = [line] if line.startswith("#") else [current.pop(), ""]
            if current:
                blocks.append((start, "\n".join(current)))
            start, current = number - len(title) + 1, title
            continue
        current.append(line)
    if current:
        blocks.append((start, "\n".join(current)))
    return blocks


def _strip_literals(lines, markdown):
    """Blank out code: fenced blocks in Markdown, literal blocks and directives' bodies in reST."""
    kept = []
    fence = False
    block_indent = None
    pending, pending_indent = False, 0
    for line in lines:
        stripped = line.strip()
        indent = len(line) - len(line.lstrip())
        if markdown:
            if stripped.startswith("```"):
                fence = not fence
                kept.append("")
                continue
            kept.append("" if fence else line)
            continue
        if block_indent is not None:
            if not stripped or indent > block_indent:
                kept.append("")
                continue
            block_indent = None
        if pending:
            if not stripped:
                kept.append("")
                continue
            pending = False
            if indent > pending_indent:
                block_indent = pending_indent
                kept.append("")
                continue
        if stripped.endswith("::") or re.match(
            r"\.\. (code-block|code|literalinclude|math)", stripped
        ):
            pending, pending_indent = True, indent
            if stripped.startswith(".."):
                kept.append("")
                continue
        kept.append(line)
    return kept


def _drop_doctests(lines):
    """Blank out doctest examples and their printed output (up to the next blank line)."""
    kept, in_example = [], False
    for line in lines:
        if line.lstrip().startswith(">>>"):
            in_example = True
        elif not line.strip():
            in_example = False
        kept.append("" if in_example else line)
    return kept


def changelog_blocks(path):
    """``(first line number, text)`` of each top-level entry of the changelog."""
    blocks, start, current = [], 1, []
    for number, line in enumerate(path.read_text(encoding="utf-8").splitlines(), start=1):
        if line.startswith(("- ", "#")):
            if current:
                blocks.append((start, "\n".join(current)))
            start, current = number, [line]
        else:
            current.append(line)
    if current:
        blocks.append((start, "\n".join(current)))
    return blocks


def python_blocks(path):
    """``(first line number, text)`` of each docstring and comment block of a Python file."""
    source = path.read_text(encoding="utf-8")
    blocks = []
    for node in ast.walk(ast.parse(source)):
        if not isinstance(node, (ast.Module, ast.ClassDef, ast.FunctionDef, ast.AsyncFunctionDef)):
            continue
        text = ast.get_docstring(node, clean=False)
        if text is not None:
            lines = _drop_doctests(_strip_literals(text.splitlines(), markdown=False))
            blocks.append((node.body[0].lineno, "\n".join(lines)))
    comment, start = [], None
    for number, line in enumerate(source.splitlines(), start=1):
        stripped = line.strip()
        if stripped.startswith("#"):
            if not comment:
                start = number
            comment.append(stripped.lstrip("#"))
        elif comment:
            blocks.append((start, "\n".join(comment)))
            comment = []
    return blocks


def documents(root=ROOT):
    """Every file whose prose may quote a measurement, with its blocks."""
    paths = [root / "README.md", root / "CHANGELOG.md"]
    paths += sorted((root / "docs").rglob("*.rst"))
    paths += sorted((root / "sklearn_ifog").rglob("*.py"))
    paths += sorted((root / "examples").glob("*.py"))
    paths += sorted((root / "benchmarks").glob("*.py"))
    for path in paths:
        if not path.is_file():
            continue
        if any(part.startswith(("_build", "generated", "auto_examples")) for part in path.parts):
            continue
        if path.name == "CHANGELOG.md":
            yield path, changelog_blocks(path)
        elif path.suffix == ".py":
            yield path, python_blocks(path)
        else:
            yield path, page_blocks(path)


def _historical_lines(text):
    """Line offsets of the paragraphs of ``text`` that cite a past commit."""
    past, paragraph = set(), []
    for offset, line in enumerate([*text.splitlines(), ""]):
        if line.strip():
            paragraph.append((offset, line))
            continue
        if paragraph and COMMIT.search(" ".join(line for _, line in paragraph)):
            past.update(offset for offset, _ in paragraph)
        paragraph = []
    return past


def check(root=ROOT, verbose=False):
    """``(failures, historical, checked)``: lists of report lines and the figure count."""
    results = root / "benchmarks" / "results"
    stems = result_stems(results)
    numbers = {stem: numbers_of(stem, results) for stem in stems}
    failures, historical, checked = [], [], 0
    for path, blocks in documents(root):
        relative = path.relative_to(root)
        for first, text in blocks:
            cited = cited_stems(text, stems)
            if not cited:
                continue
            quoted = figures(text)
            if not quoted:
                continue
            past = _historical_lines(text)
            if past:
                historical.append(f"{relative}:{first}: a paragraph cites a commit")
            values = set().union(*(numbers[stem] for stem in cited))
            for offset, figure, percent in quoted:
                if offset in past:
                    continue
                checked += 1
                if not _matches(figure, percent, values):
                    failures.append(
                        f"{relative}:{first + offset}: {figure}{'%' if percent else ''} "
                        f"not in {', '.join(sorted(cited))}"
                    )
            if verbose:
                print(f"ok {relative}:{first}: {len(quoted)} figures in {sorted(cited)}")
    return failures, historical, checked


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("-v", "--verbose", action="store_true")
    args = parser.parse_args(argv)
    failures, historical, checked = check(verbose=args.verbose)
    if args.verbose:
        print("\n".join(historical))
    for line in failures:
        print(f"FAIL: {line}")
    print(
        f"{checked} quoted figures checked against the results they cite, "
        f"{len(failures)} not found; {len(historical)} blocks quote a past commit"
    )
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
