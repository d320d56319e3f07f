"""One result format for every script in ``benchmarks/``.

Each script writes two files to its results folder (``--out``, default
``benchmarks/results/``), named by a stem (``<stem>_quick`` for ``--quick``):

- ``<stem>.md``: a title line, then ``Command: `python benchmarks/<script>.py ...` (N s).``,
  then the tables, then the verdict lines (``PASS:`` / ``FAIL:`` / ``WIN:`` / ``TIE:`` /
  ``LOSS:``, see ``_verdict.py``) when it has any;
- ``<stem>.json``: ``{"benchmark": "<script>", "command": ..., "seconds": ...,
  "verdicts": [...], "results": {...}}``, where ``results`` is the script's own record.

``write_results`` writes both atomically (a failure leaves neither half-written),
``publish`` also prints the report and its verdict lines, and ``add_out_argument`` gives
every script the same ``--out`` option.
"""

import json
import shlex
import sys
from pathlib import Path

import numpy as np

from sklearn_ifog._io import write_text_files

RESULTS = Path(__file__).resolve().parent / "results"


def add_out_argument(parser, *aliases):
    """``--out DIR`` (and the older spellings in ``aliases``) on an argparse parser."""
    parser.add_argument(
        "--out",
        *aliases,
        dest="out",
        type=Path,
        default=RESULTS,
        help="results folder (default benchmarks/results)",
    )


def command_line(script, argv=None, *, drop=("--out",)):
    """``python benchmarks/<script>.py <arguments>``, as a user would type it.

    ``argv``: the arguments (default ``sys.argv[1:]``); the options in ``drop`` (with their
    value) are left out, since where the results go does not change them.
    """
    argv = list(sys.argv[1:] if argv is None else argv)
    kept, skip = [], False
    for argument in argv:
        if skip:
            skip = False
            continue
        name = argument.split("=", 1)[0]
        if name in drop:
            skip = "=" not in argument
            continue
        kept.append(argument)
    return " ".join(["python", f"benchmarks/{Path(script).stem}.py", *map(shlex.quote, kept)])


def _json_default(value):
    if isinstance(value, np.integer):
        return int(value)
    if isinstance(value, np.floating):
        return float(value)
    if isinstance(value, np.bool_):
        return bool(value)
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, Path):
        return str(value)
    raise TypeError(f"{type(value).__name__} is not JSON serialisable")


def write_results(out, stem, markdown, results, *, script, command, seconds, verdicts=()):
    """Write ``<stem>.md`` and ``<stem>.json`` to ``out`` in the one format; return the paths.

    ``markdown``: the whole Markdown text; ``results``: the script's record (JSON-able,
    numpy scalars and arrays accepted); ``verdicts``: the verdict lines it printed.
    """
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    payload = {
        "benchmark": Path(script).stem,
        "command": command,
        "seconds": None if seconds is None else round(float(seconds), 1),
        "verdicts": list(verdicts),
        "results": results,
    }
    paths = (out / f"{stem}.md", out / f"{stem}.json")
    text = markdown if markdown.endswith("\n") else markdown + "\n"
    write_text_files(
        {
            paths[0]: text,
            paths[1]: json.dumps(payload, indent=1, default=_json_default) + "\n",
        }
    )
    return paths


def publish(out, stem, markdown, results, *, script, command, seconds, verdicts=(), echo=None):
    """:func:`write_results`, then print ``echo`` (default: the Markdown) and the verdict
    lines, one per line, last: what every benchmark ends with (``tests/test_benchmarks.py``
    reads the verdicts from the end of its output)."""
    write_results(
        out,
        stem,
        markdown,
        results,
        script=script,
        command=command,
        seconds=seconds,
        verdicts=verdicts,
    )
    print(markdown if echo is None else echo)
    for line in verdicts:
        print(line)


def read_results(path):
    """The ``results`` record of a ``<stem>.json`` written by :func:`write_results`."""
    return json.loads(Path(path).read_text())["results"]
