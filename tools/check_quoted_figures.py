"""Every figure quoted beside a benchmark citation is in the one results file it cites.

Citations
---------
A *citation* names one committed result, in the prose itself:

- a results file: ``benchmarks/results/<stem>.md`` (or ``.json``, or the bare ``<stem>.md``);
  the ``.md`` and the ``.json`` of one stem are one result, written by one run;
- a benchmark command, ``python benchmarks/<script>.py [options]``: the result whose
  ``Command:`` line is that command (``--n-jobs``/``--jobs`` and their value ignored, since
  they change no number); a command without a committed result is reported;
- either one, followed by a *selector* that narrows it to some lines of its ``.md``:
  ``row "<text>"``, ``line "<text>"`` or ``verdict "<text>"`` (plural forms, and several
  quoted texts joined by ``,``, ``and`` or ``or``, are the same). A table row is selected by
  its leading cells, whole, written with `` | `` between them (``*`` stands for any one
  cell; "distance" is not "distance c=0.7");
  any other line by its opening words: ``conformal.md`` row "layered seed 2 | warm->cycle |
  ours" is that split's row of ``ours`` (not ``ours_flat``; "seed 1" is not "seed 10"),
  rows "* | warm->cold | ours" every campaign's, and verdict "FAIL: layered seed 8" the
  verdict lines that begin so. ``column "<header>"`` (or ``columns "a" and "b"``) after
  the quoted texts keeps only the cells under the header cells that start so, and
  ``under "<words>"`` keeps the rows whose table follows a line holding those words (its
  heading or caption): ``rows "RBFNet" column "state MSD/floor" under "layered, 60 s"``.
  A header ``<name> (<part>; <part>)`` heads cells of parts joined by ``;``: ``column
  "width / oracle (mean)"`` keeps the mean of ``1.06-1.29; 1.16`` under ``width / oracle
  (range; mean)``.
  A selector that selects nothing, or that follows no citation, is reported. The text of a
  selector is a label, not a figure: a number it holds is not a value of the selected lines
  (``line "Hindsight constant band (every fold at 0.85)"`` leaves the numbers after it),
  and a figure of the prose equal to it names the row (``the clamp 1.5``, cited ``row
  "clamp 1.5"``) and is not checked.

Which citation a figure is checked against
------------------------------------------
A *block* is a section of a reStructuredText or Markdown page (text between two headings),
one entry of ``CHANGELOG.md`` (a top-level ``- `` item with its continuation lines), or one
docstring or comment block of a Python file. A block without a citation is not checked: a
figure there is a parameter, a unit or a definition, not a measurement. In a block with one,
every figure is checked against the citations of its own *sentence*; a sentence without one
uses the nearest citation before it in the block (the block's first citation, for sentences
before it). So a citation holds until the next one, and a sentence that quotes a figure of
another file, row or verdict line cites it.

Figures
-------
- A figure is a number written with a decimal point or an exponent (``0.0976``, ``3.53e-4``,
  ``1.93``), optionally followed by ``%``; a power of ten alone (``1e-12``) is a tolerance or
  a scale and is left out. It is found when some number of the cited lines (or of the whole
  result, ``.md`` and ``.json``, without a selector) equals it to three significant figures,
  or to the figure's own precision where it gives more: ``0.85`` needs 0.850, not 0.846; a
  percentage also matches a fraction (``7.61 %`` matches ``0.0761``).
- A count, ``N of M`` (``3 of 30``), is found when the cited lines hold ``N of M`` or
  ``N/M``.
- Inline literals (````...````, ``:param:`...``` roles) and literal blocks (code, after
  ``::``, fenced code in Markdown, doctest examples and their output) are not prose and are
  left out: they hold parameter values, not measurements.

History
-------
A sentence that names a commit (``at commit 768ed07``, ``at 768ed07``) quotes a past
measurement: its figures, and those that inherit a citation from it, are checked against
the cited results as committed at that commit (``git show
<commit>:benchmarks/results/<stem>.md``) and as they are now (such a sentence usually
compares the two); a result that did not exist at that commit is reported. A paragraph
holding ``[history]`` quotes what no committed file holds: it is skipped, and listed with
``-v``.

The prose checked: ``README.md``, ``CHANGELOG.md``, ``benchmarks/README.md``, the ``docs``
pages, and the docstrings and comments of the package, the examples and the benchmarks.

Why rows: a random figure of three decimals in [0.5, 1.5] passes a citation of the whole of
``conformal.md`` 70 % of the time (it holds hundreds of such numbers), and one of its rows
about one time in a hundred. ``--wide`` lists the figures whose citation would accept
more than 2 % of random figures of their precision (within half and one and a half times
them); ``tests/test_quoted_figures.py`` feeds random figures to row citations, on results
shaped like the benchmarks' and on the tree's own, and requires that at most 2 % pass.
Exits 1 and lists every unfound figure or count, every citation of a command without a
committed result and every selector that selects nothing, with its file and line;
``.ci/run`` runs it. Run::

    python tools/check_quoted_figures.py            # the whole tree
    python tools/check_quoted_figures.py -v         # also every figure that passed
    python tools/check_quoted_figures.py --wide     # the citations too wide to fail
"""

import argparse
import ast
import json
import math
import re
import shlex
import subprocess
import sys
from dataclasses import dataclass, field
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
RESULTS = ROOT / "benchmarks" / "results"

FIGURE = re.compile(
    r"(?<![\w.\-/])(?P<number>\d+\.\d+(?:[eE][-+]?\d+)?|\d+[eE][-+]?\d+)"
    r"(?P<unit>\s?%)?(?![\w.]*\d)(?!\.\d)(?![A-Za-wyz_])"
)
COUNT = re.compile(r"(?<![\w.\-/])(?P<n>\d+)\s+of\s+(?P<m>\d+)(?![\w]|\.\d)")
RESULT_NUMBER = re.compile(r"[-+]?(?:\d+\.\d*|\.\d+|\d+)(?:[eE][-+]?\d+)?")
_JOIN = r"\s*(?:,|,?\s*and|or)\s*"
_QUOTES = rf'"[^"]{{1,160}}"(?:{_JOIN}"[^"]{{1,160}}")*'
_PARTS = (
    rf"(?:rows?|lines?|verdicts?)\s+(?P<labels>{_QUOTES})"
    rf"(?:\s+columns?\s+(?P<columns>{_QUOTES}))?"
    r'(?:\s+under\s+(?P<context>"[^"]{1,160}"))?'
)
_ONE_SELECTOR = re.sub(r"\(\?P<\w+>", "(?:", _PARTS)
_SELECTOR = rf"(?:{_ONE_SELECTOR}(?:{_JOIN}{_ONE_SELECTOR})*)"
_TAIL = rf"(?P<tail>[`\s,:;(]*{_SELECTOR})?"
RESULT_FILE = re.compile(
    r"(?:benchmarks/results/|results/|(?<![\w/.-]))(?P<stem>[a-z][a-z0-9_]*)\.(?:md|json)\b"
    + _TAIL
)
COMMAND = re.compile(r"python\s+benchmarks/(?P<script>[a-z_]+)\.py\b")
TAIL = re.compile(_TAIL)
# Inside an inline literal a command's options run to its closing backticks (across a line
# break); in prose, a command has none.
LITERAL_SPAN = re.compile(r"``.+?``|`[^`]+`", re.S)
QUOTED = re.compile(r'"([^"]+)"')
COMMIT = re.compile(
    r"\b(?i:at|from|before|until)\s+commit\s+(?P<a>[0-9a-f]{7,40})\b|\bat\s+(?P<b>[0-9a-f]{7,40})\b"
)
HISTORY = "[history]"
# A power of ten alone (``1e-12``) is a tolerance or a scale, not a measurement.
POWER_OF_TEN = re.compile(r"^1(?:\.0*)?[eE][-+]?\d+$")
INLINE_LITERAL = re.compile(r"``.*?``|:[a-z:]+:`[^`]*`|`[^`]*`_?")
HEADING_RULE = re.compile(r"^([=\-~^\"'`#*+])\1{2,}\s*$")
# A sentence ends at a full stop (or ! ?) before a capital, a parenthesis, a quote or a
# list item, and at a blank line; a list item starts one.
SENTENCE_END = re.compile(r"(?<=[.!?])\s+(?=[A-Z(`\"*])|\n\s*\n|\n(?=\s*[-*] )")
# Options that choose how a run is spread over cores, not what it measures.
NEUTRAL_OPTIONS = {"--n-jobs", "--jobs"}
SIGNIFICANT = 3
PROSE_DIRECTIVES = {"list-table", "csv-table", "table", "note", "warning", "seealso"}
# The share of random figures a citation may accept before --wide lists it (issue 42).
WIDE = 0.02


def _normalise_command(words):
    kept, skip = [], False
    for word in words:
        if skip:
            skip = False
            continue
        name = word.split("=", 1)[0]
        if name in NEUTRAL_OPTIONS:
            skip = "=" not in word
            continue
        kept.append(" ".join(word.split()))
    return " ".join(kept)


def _command_words(text):
    try:
        return shlex.split(text)
    except ValueError:
        return text.split()


def _command_of(markdown):
    """The normalised command of a results file's ``Command:`` line, or None."""
    match = re.search(r"^Command: `(python benchmarks/[^`]*)`", markdown, re.M)
    return _normalise_command(_command_words(match[1])) if match else None


@dataclass
class Result:
    """One committed result (``<stem>.md`` and ``.json``): its lines and numbers."""

    lines: list
    json_numbers: set = field(default_factory=set)

    def values(self, selectors=None):
        """The numbers of the selected lines (all lines and the JSON without selectors)."""
        lines = self.select(selectors)
        found = {float(n) for line in lines for n in RESULT_NUMBER.findall(line)}
        if selectors is None:
            found |= self.json_numbers
        return {value for value in found if math.isfinite(value)}

    def select(self, selectors=None):
        """The lines ``selectors`` name (``(cells, context)`` pairs), or all of them."""
        if selectors is None:
            return self.lines
        patterns = [
            (_selector_pattern(cells), columns, context and _phrase(context))
            for cells, columns, context in selectors
        ]
        selected, context_lines, header = [], [], None
        for line in self.lines:
            # a line's context: the text since the table before it (its heading, its caption)
            if line.startswith("|"):
                header = header or _cells(line)
            else:
                if header is not None:
                    context_lines, header = [], None
                if line.strip():
                    context_lines.append(_words(line))
            label = _table_words(line).removeprefix("- ")
            # a table row's label is whole cells ("distance" is not "distance c=0.7")
            end = r"(?= \||$)" if line.startswith("|") else r"(?!\w)"
            for pattern, columns, context in patterns:
                matched = re.match(pattern.pattern + end, label)
                if not matched or (
                    context is not None and not any(context.search(x) for x in context_lines)
                ):
                    continue
                if columns is None:
                    # the words the selector names are its label, not a figure
                    selected.append(label[matched.end() :])
                else:
                    selected += _column_cells(_cells(line), header or [], columns)
                break
        return selected


def _column_cells(cells, header, columns):
    """The cells (or parts of cells) of a table row under the ``columns`` named.

    A column is named by the start of its header cell. A header cell written
    ``<name> (<part>; <part>)`` heads cells of as many parts joined by ``;`` (``width /
    oracle (range; mean)`` over ``1.06-1.29; 1.16``): ``<name> (<part>)`` names one part.
    """
    found = []
    for i, name in enumerate(header):
        if i >= len(cells):
            break
        if any(name.startswith(c) for c in columns):
            found.append(cells[i])
            continue
        compound = re.fullmatch(r"(?P<base>.+?) \((?P<parts>[^()]+;[^()]+)\)", name)
        if compound is None:
            continue
        parts = [part.strip() for part in compound["parts"].split(";")]
        values = [value.strip() for value in cells[i].split(";")]
        if len(values) != len(parts):
            continue
        found += [
            value
            for part, value in zip(parts, values, strict=True)
            if any(f"{compound['base']} ({part})".startswith(c) for c in columns)
        ]
    return found


def _selector_pattern(text):
    """A selector's leading cells (``*``: any one cell), as a regex anchored at a line's start."""
    cells = _table_words(text).split(" | ")
    cells = [r"[^|]*?" if cell == "*" else re.escape(cell) for cell in cells]
    return re.compile(r" \| ".join(cells))


def _cells(line):
    return [_words(cell) for cell in line.strip().strip("|").split("|")]


def _phrase(text):
    return re.compile(r"(?<!\w)" + re.escape(" ".join(text.split())) + r"(?!\w)")


def _table_words(text):
    """``text`` with its whitespace collapsed and its table bars written `` | ``."""
    text = re.sub(r"\s*\|\s*", " | ", " ".join(text.split()))
    return text.strip(" |")


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


def _result(md_text, json_text):
    numbers = set()
    if json_text is not None:
        try:
            numbers = set(_json_numbers(json.loads(json_text)))
        except json.JSONDecodeError:
            numbers = {float(n) for n in RESULT_NUMBER.findall(json_text)}
    return Result((md_text or "").splitlines(), {v for v in numbers if math.isfinite(v)})


class Results:
    """The committed results of a tree, and of its past commits on demand."""

    def __init__(self, root=ROOT):
        self.root = Path(root)
        self.folder = self.root / "benchmarks" / "results"
        stems = {p.stem for p in self.folder.glob("*.md")}
        stems |= {p.stem for p in self.folder.glob("*.json")}
        self.stems = sorted(stems)
        self._now = {}
        self._past = {}
        self._past_commands = {}
        self.commands = {}
        for stem in self.stems:
            key = _command_of("\n".join(self.now(stem).lines[:5]))
            if key is not None:
                self.commands.setdefault(key, stem)

    def now(self, stem):
        if stem not in self._now:
            md, js = self.folder / f"{stem}.md", self.folder / f"{stem}.json"
            self._now[stem] = _result(
                md.read_text(encoding="utf-8") if md.is_file() else None,
                js.read_text(encoding="utf-8") if js.is_file() else None,
            )
        return self._now[stem]

    def at(self, commit, stem):
        """The result as committed at ``commit``, or None when it had no such file."""
        key = (commit, stem)
        if key not in self._past:
            texts = [
                self._git_show(commit, f"benchmarks/results/{stem}{s}") for s in (".md", ".json")
            ]
            self._past[key] = None if texts == [None, None] else _result(*texts)
        return self._past[key]

    def command_at(self, commit, command):
        """The stem whose ``Command:`` line was ``command`` at ``commit``, or None."""
        if commit not in self._past_commands:
            listing = subprocess.run(
                [
                    "git",
                    "-C",
                    str(self.root),
                    "ls-tree",
                    "--name-only",
                    commit,
                    "benchmarks/results/",
                ],
                capture_output=True,
                text=True,
                check=False,
            ).stdout.split()
            commands = {}
            for path in listing:
                if path.endswith(".md"):
                    stem = Path(path).stem
                    key = _command_of(self._git_show(commit, path) or "")
                    if key is not None:
                        commands.setdefault(key, stem)
            self._past_commands[commit] = commands
        return self._past_commands[commit].get(command)

    def _git_show(self, commit, path):
        completed = subprocess.run(
            ["git", "-C", str(self.root), "show", f"{commit}:{path}"],
            capture_output=True,
            text=True,
            check=False,
        )
        return completed.stdout if completed.returncode == 0 else None


@dataclass(frozen=True)
class Citation:
    """One cited result, and the lines of it a selector names (None: all of it)."""

    stem: str
    selectors: tuple = None
    command: str = None  # the command cited, when it has no committed result (stem None)

    def __str__(self):
        if self.stem is None:
            return f"`{self.command}` (no committed result)"
        if self.selectors is None:
            return self.stem
        return f"{self.stem} {_describe(self.selectors)}"


def _describe(selectors):
    return " or ".join(
        f'"{cells}"'
        + (" column " + " and ".join(f'"{c}"' for c in columns) if columns else "")
        + (f' under "{context}"' if context else "")
        for cells, columns, context in selectors
    )


def _selectors(tail):
    """``(leading cells, columns or None, context or None)`` of each row a selector names."""
    if not tail:
        return None
    found = []
    for match in re.finditer(_PARTS, tail):
        columns = match["columns"] and tuple(_words(t) for t in QUOTED.findall(match["columns"]))
        context = match["context"] and _words(match["context"].strip('"'))
        found += [(_words(text), columns, context) for text in QUOTED.findall(match["labels"])]
    return tuple(found)


def _words(text):
    return " ".join(text.split())


def citations(text, results):
    """``(position, Citation or the text of an uncommitted command)`` in ``text``, in order."""
    found, tails = [], []
    for match in RESULT_FILE.finditer(text):
        if match["tail"]:
            tails.append(match.span("tail"))
        if match["stem"] in results.stems:
            found.append((match.start(), Citation(match["stem"], _selectors(match["tail"]))))
    literals = [m.span() for m in LITERAL_SPAN.finditer(text)]
    for match in COMMAND.finditer(text):
        end = match.end()
        for start, stop in literals:
            if start < match.start() < stop:
                end = stop
        args = text[match.end() : end].rstrip("`")
        words = [f"benchmarks/{match['script']}.py", *_command_words(args)]
        key = _normalise_command(["python", *words])
        stem = results.commands.get(key)
        tail = TAIL.match(text, end)["tail"]
        if tail:
            tails.append((end, end + len(tail)))
        found.append((match.start(), Citation(stem, _selectors(tail), key)))
    for match in re.finditer(_ONE_SELECTOR, _blank_literals(text)):
        if not any(start <= match.start() < stop for start, stop in tails):
            found.append((match.start(), match.group()))
    return sorted(found, key=lambda item: item[0])


def tolerance(figure):
    """Half a unit of the figure's last digit, or of its third significant one if finer."""
    quoted = abs(float(figure))
    if quoted == 0:
        return 0.0
    mantissa = figure.lower().split("e")[0]
    exponent = int(figure.lower().split("e")[1]) if "e" in figure.lower() else 0
    decimals = len(mantissa.split(".")[1]) if "." in mantissa else 0
    own = 0.5 * 10.0 ** (exponent - decimals)
    three = 0.5 * 10.0 ** (math.floor(math.log10(quoted)) - SIGNIFICANT + 1)
    return min(own, three)


def matches(figure, percent, values):
    """Whether ``figure`` (its text) equals some value to its checked precision."""
    quoted = float(figure)
    tol = tolerance(figure) * (1 + 1e-9)
    scales = (1.0, 100.0) if percent else (1.0,)
    return any(abs(abs(v) * s - quoted) <= tol for v in values for s in scales)


def count_found(n, m, lines):
    pattern = re.compile(rf"(?<![\w.]){n}(?: of |/){m}(?![\w]|\.\d)")
    return any(pattern.search(line) for line in lines)


def acceptance(text, percent, values=(), lines=()):
    """The share of random figures like ``text`` that the cited values or lines would accept.

    A random figure has the quoted one's precision and lies within half and one and a half
    times it (a count ``N of M``: any N from 0 to M); the share is counted on that grid,
    not sampled.
    """
    if " of " in text:
        m = text.split(" of ")[1]
        return sum(count_found(n, m, lines) for n in range(int(m) + 1)) / (int(m) + 1)
    quoted = abs(float(text))
    step = 2 * tolerance(text)
    if quoted == 0 or step == 0:
        return 0.0
    low, high = math.ceil(0.5 * quoted / step - 1e-9), math.floor(1.5 * quoted / step + 1e-9)
    hits = set()
    for value in values:
        for scale in (1.0, 100.0) if percent else (1.0,):
            k = round(abs(value) * scale / step)
            if low <= k <= high and abs(k * step - abs(value) * scale) <= step / 2 * (1 + 1e-9):
                hits.add(k)
    return len(hits) / (high - low + 1)


def random_like(text, rng):
    """A random figure of ``text``'s precision within half and one and a half times it."""
    if " of " in text:
        m = text.split(" of ")[1]
        return f"{rng.randint(0, int(m))} of {m}"
    mantissa, _, exponent = text.lower().partition("e")
    decimals = len(mantissa.split(".")[1]) if "." in mantissa else 0
    step = 10.0**-decimals
    value = round(rng.uniform(0.5, 1.5) * float(mantissa) / step) * step
    return f"{value:.{decimals}f}" + (f"e{exponent}" if exponent else "")


def _blank_literals(text):
    """``text`` with its inline literals blanked (same length, so positions stay)."""
    return "".join(
        INLINE_LITERAL.sub(lambda m: " " * len(m.group()), line)
        for line in text.splitlines(keepends=True)
    )


# A numpydoc parameter line, ``margin : float, default=1.5``: a specification, not prose.
PARAMETER_LINE = re.compile(
    r"^[ \t]*[A-Za-z_*][\w*]*(?:[ \t]*,[ \t]*[A-Za-z_*][\w*]*)*[ \t]+:[ \t].*$", re.M
)


def _prose(text):
    """``text`` with its inline literals, numpydoc parameter lines and selectors blanked
    (positions stay)."""
    prose = _blank_literals(text)
    prose = PARAMETER_LINE.sub(lambda m: " " * len(m.group()), prose)
    # a commit's hash is a name too ("at commit 4e51234" is not 4e51234, nor 4 x 10^51234)
    prose = COMMIT.sub(lambda m: " " * len(m.group()), prose)
    # a row's label names it ("clamp 1.5"): it is not a figure
    return re.sub(_SELECTOR, lambda m: re.sub(r"[^\n]", " ", m.group()), prose)


def figures(text):
    """``(position, line offset, figure text, is a percentage)`` of the prose of ``text``."""
    prose = _prose(text)
    return [
        (m.start(), prose.count("\n", 0, m.start()), m["number"], bool(m["unit"]))
        for m in FIGURE.finditer(prose)
        if not POWER_OF_TEN.match(m["number"])
    ]


def counts(text):
    """``(position, line offset, n, m)`` of the ``N of M`` phrases of the prose of ``text``."""
    prose = _prose(text)
    return [
        (m.start(), prose.count("\n", 0, m.start()), m["n"], m["m"]) for m in COUNT.finditer(prose)
    ]


def sentences(text):
    """``(start, end)`` of each sentence of ``text``."""
    spans, start = [], 0
    for match in SENTENCE_END.finditer(text):
        spans.append((start, match.start()))
        start = match.end()
    spans.append((start, len(text)))
    return spans


def paragraphs(text):
    spans, start = [], 0
    for match in re.finditer(r"\n\s*\n", text):
        spans.append((start, match.start()))
        start = match.end()
    spans.append((start, len(text)))
    return spans


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
        directive = re.match(r"\.\. ([a-z-]+)::", stripped)
        # a table directive's body is prose (its cells are measurements); other directives'
        # bodies and a paragraph's closing "::" are code, names or options
        if directive and directive[1] in PROSE_DIRECTIVES:
            kept.append("")
            continue
        if stripped.endswith("::") or directive:
            pending, pending_indent = True, indent
            if directive:
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
    root = Path(root)
    paths = [root / "README.md", root / "CHANGELOG.md", root / "benchmarks" / "README.md"]
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


@dataclass
class Quote:
    """One checked figure or count, and the lines it was checked against."""

    where: str
    text: str
    percent: bool
    scope: list  # (label, Result, selectors)
    lines: list = field(default_factory=list)
    values: set = field(default_factory=set)

    @property
    def is_count(self):
        return " of " in self.text

    def found(self, text=None):
        """Whether the cited lines hold this figure (or ``text`` in its place)."""
        text = self.text if text is None else text
        if self.is_count:
            n, m = text.split(" of ")
            return count_found(n, m, self.lines)
        return matches(text, self.percent, self.values)

    @property
    def acceptance(self):
        return acceptance(self.text, self.percent, self.values, self.lines)


def _span_of(position, spans):
    for start, end in spans:
        if start <= position <= end:
            return start, end
    return spans[-1]


def block_quotes(relative, first, text, results):
    """``(quotes, problems, history)`` of one block: what to check, and what cannot be."""
    quotes, problems, history = [], [], []
    cited = []
    for position, citation in citations(text, results):
        if isinstance(citation, str):
            line = first + text.count("\n", 0, position)
            problems.append(f"{relative}:{line}: {citation} follows no citation")
        else:
            cited.append((position, citation))
    if not cited:
        return quotes, problems, history
    quoted = figures(text) + [(p, o, f"{n} of {m}", False) for p, o, n, m in counts(text)]
    sentence_spans = sentences(text)
    paragraph_spans = paragraphs(text)
    # a citation is read at the commits its own sentence names, wherever it is inherited
    commits_of = {}
    for position, _ in cited:
        c_start, c_end = _span_of(position, sentence_spans)
        commits_of[position] = [m["a"] or m["b"] for m in COMMIT.finditer(text[c_start:c_end])]
    for position, offset, figure, percent in sorted(quoted):
        where = f"{relative}:{first + offset}"
        p_start, p_end = _span_of(position, paragraph_spans)
        if HISTORY in _blank_literals(text[p_start:p_end]):
            history.append(f"{where}: {figure} [history]")
            continue
        s_start, s_end = _span_of(position, sentence_spans)
        own = [(p, c) for p, c in cited if s_start <= p <= s_end]
        if not own:
            own = [(p, c) for p, c in cited if p < s_start][-1:] or cited[:1]
        # a file named bare and with a selector in one sentence: the selector says which lines
        narrowed = {c.stem for _, c in own if c.selectors is not None}
        own = [(p, c) for p, c in own if c.selectors is not None or c.stem not in narrowed]
        own_commits = [m["a"] or m["b"] for m in COMMIT.finditer(text[s_start:s_end])]
        scope = []
        for cited_at, citation in own:
            commits = list(dict.fromkeys(commits_of[cited_at] + own_commits))
            if citation.stem is not None:
                scope.append((citation.stem, results.now(citation.stem), citation.selectors))
            for commit in commits:
                stem = citation.stem or results.command_at(commit, citation.command)
                past = results.at(commit, stem) if stem else None
                if past is None:
                    problems.append(f"{where}: {citation} was not committed at {commit}")
                else:
                    scope.append((f"{stem}@{commit}", past, citation.selectors))
            if citation.stem is None and not commits:
                problems.append(f"{where}: {figure} cites {citation}")
        if _names_a_label(figure, scope):
            continue
        quote = Quote(where, figure, percent, scope)
        for label, result, selectors in scope:
            lines = result.select(selectors)
            if not lines:
                problems.append(f"{where}: no line of {label} is {_describe(selectors)}")
            quote.lines += lines
            quote.values |= result.values(selectors)
        quotes.append(quote)
    return quotes, problems, history


def _names_a_label(figure, scope):
    """Whether ``figure`` is written in a selector of its citations (``row "clamp 1.5"``,
    ``row "scale >= 0.85"``): the prose then names that row, it quotes no measurement."""
    if not FIGURE.fullmatch(figure):
        return False  # a count, N of M
    texts = [
        text
        for _, _, selectors in scope
        for cells, columns, context in selectors or ()
        for text in (cells, *(columns or ()), context or "")
    ]
    return any(float(n) == float(figure) for text in texts for n in RESULT_NUMBER.findall(text))


def collect(root=ROOT):
    """``(quotes, problems, history)`` of the whole tree."""
    results = Results(root)
    quotes, problems, history = [], [], []
    for path, blocks in documents(root):
        relative = path.relative_to(root)
        for first, text in blocks:
            q, p, h = block_quotes(relative, first, text, results)
            quotes += q
            problems += p
            history += h
    return quotes, sorted(set(problems), key=problems.index), history


def check(root=ROOT, verbose=False):
    """``(failures, history, checked)``: report lines, skipped history, the checked count."""
    return _report(*collect(root), verbose=verbose)


def _report(quotes, problems, history, verbose=False):
    failures = list(problems)
    for quote in quotes:
        if quote.scope and not quote.found():
            where = ", ".join(sorted({str(label) for label, _, _ in quote.scope}))
            failures.append(
                f"{quote.where}: {quote.text}{'%' if quote.percent else ''} not in {where}"
                + _selector_note(quote)
            )
        elif verbose:
            print(f"ok {quote.where}: {quote.text}")
    return failures, history, len(quotes)


def _selector_note(quote):
    selected = [s for _, _, s in quote.scope if s is not None]
    return f" ({'; '.join(_describe(s) for s in selected)})" if selected else ""


def wide(quotes, limit=WIDE):
    """The figures whose citation would also accept more than ``limit`` of random figures."""
    return [
        f"{q.where}: {q.text} cites {', '.join(sorted({str(lb) for lb, _, _ in q.scope}))}"
        f"{_selector_note(q)}, which would accept {q.acceptance:.0%} of random figures"
        for q in quotes
        if not q.is_count and q.acceptance > limit
    ]


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("-v", "--verbose", action="store_true")
    parser.add_argument(
        "--wide",
        action="store_true",
        help="list the figures whose citation is too wide to fail (cite a row)",
    )
    args = parser.parse_args(argv)
    quotes, problems, history = collect()
    failures, history, checked = _report(quotes, problems, history, verbose=args.verbose)
    if args.verbose:
        print("\n".join(history))
    too_wide = wide(quotes)
    if args.wide:
        print("\n".join(too_wide))
    for line in failures:
        print(f"FAIL: {line}")
    print(
        f"{checked} quoted figures and counts checked against the results they cite, "
        f"{len(failures)} problems; {len(history)} marked [history] and skipped; "
        f"{len(too_wide)} figures cite lines that would accept more than {WIDE:.0%} of "
        "random figures (--wide lists them)"
    )
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
