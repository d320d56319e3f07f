"""``tools/check_quoted_figures.py``: each quoted figure is in the results file it cites."""

import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tools"))
import check_quoted_figures as checker  # noqa: E402

sys.path.remove(str(ROOT / "tools"))


@pytest.fixture
def tree(tmp_path):
    """A project with one results file and an empty docs folder."""
    results = tmp_path / "benchmarks" / "results"
    results.mkdir(parents=True)
    (results / "thermal_state.md").write_text(
        "| model | MSD/floor |\n|---|---|\n| RBFNet | 1.0371 |\n| Ridge | 0.09757 |\n"
    )
    (results / "thermal_state.json").write_text('{"cells": [{"coverage": 0.8934}]}')
    (tmp_path / "docs").mkdir()
    (tmp_path / "README.md").write_text("# Project\n")
    (tmp_path / "CHANGELOG.md").write_text("# Changelog\n")
    return tmp_path


def _page(tree, text):
    (tree / "docs" / "page.rst").write_text(text)
    failures, historical, checked = checker.check(tree)
    return failures, historical, checked


def test_found_figures_pass_at_their_own_precision(tree):
    failures, _, checked = _page(
        tree,
        "Title\n=====\n\nMeasured by ``python benchmarks/bench_thermal_state.py``: the network "
        "leaves 1.037 (1.04 rounded), the ratio is 0.0976, coverage 89.3 % (JSON).\n",
    )
    assert failures == []
    assert checked == 4


def test_a_figure_absent_from_the_cited_results_fails_with_file_and_line(tree):
    failures, _, _ = _page(
        tree,
        "Title\n=====\n\nResults in ``benchmarks/results/thermal_state.md``.\n\n"
        "The network measures 1.038 and about 0.08x.\n",
    )
    assert failures == [
        "docs/page.rst:6: 1.038 not in thermal_state",
        "docs/page.rst:6: 0.08 not in thermal_state",
    ]


def test_a_section_without_citation_and_code_are_not_checked(tree):
    failures, _, checked = _page(
        tree,
        "Title\n=====\n\nA margin of 1.5 and a width of 2.25 are parameters.\n\n"
        "Other\n=====\n\nSee ``thermal_state.md``; run::\n\n    fit(margin=3.75)\n\n"
        "with ``alpha=4.5`` and a tolerance of 1e-12.\n",
    )
    assert failures == []
    assert checked == 0


def test_a_paragraph_citing_a_commit_is_historical(tree):
    failures, historical, checked = _page(
        tree,
        "Title\n=====\n\nResults in ``thermal_state.md``: 1.037.\n\n"
        "Before, it measured 1.232 (at\ncommit 768ed07).\n",
    )
    assert failures == []
    assert checked == 1
    assert historical == ["docs/page.rst:1: a paragraph cites a commit"]


def test_docstring_doctest_output_is_not_prose(tree):
    package = tree / "sklearn_ifog"
    package.mkdir()
    (package / "module.py").write_text(
        'def f():\n    """Measured in ``thermal_state.md``: 1.037.\n\n'
        '    >>> f()\n    46.25\n    """\n'
    )
    failures, _, checked = checker.check(tree)
    assert failures == []
    assert checked == 1


def test_the_changelog_is_checked_entry_by_entry(tree):
    (tree / "CHANGELOG.md").write_text(
        "# Changelog\n\n## [Unreleased]\n\n- Faster (``python benchmarks/bench_thermal_state.py``"
        "): 0.0976x.\n- Another entry: 0.0977x, no citation.\n"
    )
    failures, _, checked = checker.check(tree)
    assert failures == []
    assert checked == 1


def test_the_committed_tree_quotes_only_figures_its_results_hold():
    failures, _, checked = checker.check()
    assert failures == []
    assert checked > 100


def test_markdown_lines_are_reported_where_they_are(tree):
    (tree / "README.md").write_text(
        "# Project\n\nIntro.\n\n## Speed\n\n"
        "Measured by ``python benchmarks/bench_thermal_state.py``:\n\n1.038 faster.\n"
    )
    failures, _, _ = checker.check(tree)
    assert failures == ["README.md:9: 1.038 not in thermal_state"]
