"""Build-time pages: the command-line reference and our results beside the paper's tables.

Both are computed from the package when the documentation is built (``builder-inited``), so
they can never drift from the code: the ``--help`` text comes from the parser of
``sklearn_ifog.cli``, and the MSD tables from ``sklearn_ifog.paper`` on the simulator.
Files are rewritten only when their content changes, so an unchanged build stays incremental.
"""

import contextlib
import io
import os
import textwrap
from pathlib import Path

import numpy as np

# Under docs/generated/ (git-ignored, like autosummary's pages), excluded from the sources by
# conf.py: the files are only ever included.
GENERATED = Path(__file__).parent / "generated" / "_pages"

CLI_COMMANDS = ("demo", "fit", "compensate", "report", "export")
HELP_WIDTH = "90"

# The reference paper's published Tables 2-4 (MSD, (deg/h)^2) are quoted once, in
# sklearn_ifog.paper.PAPER_MSD; ours are computed below.
CAMPAIGN_SEED = 0

_SUPERSCRIPT = str.maketrans("-0123456789", "⁻⁰¹²³⁴⁵⁶⁷⁸⁹")


def _write_if_changed(path, text):
    path.parent.mkdir(parents=True, exist_ok=True)
    if path.exists() and path.read_text(encoding="utf-8") == text:
        return
    temporary = path.with_suffix(path.suffix + ".tmp")
    temporary.write_text(text, encoding="utf-8")
    os.replace(temporary, path)


# -- command line ---------------------------------------------------------------------------


def _help_text(argv):
    from sklearn_ifog.cli import main

    buffer = io.StringIO()
    previous = os.environ.get("COLUMNS")
    os.environ["COLUMNS"] = HELP_WIDTH  # argparse wraps to the terminal width
    try:
        with contextlib.redirect_stdout(buffer):
            status = main([*argv, "--help"])
    finally:
        if previous is None:
            del os.environ["COLUMNS"]
        else:
            os.environ["COLUMNS"] = previous
    if status != 0:
        raise RuntimeError(f"sklearn-ifog {' '.join(argv)} --help exited with {status}")
    return buffer.getvalue().rstrip() + "\n"


def write_cli_reference(directory=GENERATED):
    """Write ``cli_<command>.txt`` (and ``cli_main.txt``): the ``--help`` of each command."""
    _write_if_changed(directory / "cli_main.txt", _help_text([]))
    for command in CLI_COMMANDS:
        _write_if_changed(directory / f"cli_{command}.txt", _help_text([command]))


# -- paper comparison -----------------------------------------------------------------------


def _sci(value):
    """``1.72 × 10⁻⁴``, as the paper prints its MSDs."""
    mantissa, exponent = f"{value:.2e}".split("e")
    # No-break spaces: a number must not wrap inside a narrow table cell.
    return f"{mantissa}\u00a0×\u00a010{str(int(exponent)).translate(_SUPERSCRIPT)}"


def _list_table(title, header, rows, widths):
    lines = [
        f".. list-table:: {title}",
        "   :header-rows: 1",
        "   :class: msd-table",
        f"   :widths: {' '.join(str(w) for w in widths)}",
        "",
    ]
    for row in [header, *rows]:
        lines.append(f"   * - {row[0]}")
        lines.extend(f"     - {cell}" for cell in row[1:])
    return "\n".join(lines) + "\n"


def _paper_results():
    from sklearn_ifog.compensation import compensate
    from sklearn_ifog.datasets import make_thermal_campaign
    from sklearn_ifog.paper import run_paper_experiments

    campaign = make_thermal_campaign(random_state=CAMPAIGN_SEED)
    result = run_paper_experiments(campaign, random_state=CAMPAIGN_SEED)
    frame = campaign.frame
    runs = result.runs.copy()
    floor, thermal = [], {"traditional": [], "modified": []}
    for unit, run in zip(runs["unit"], runs["run"], strict=True):
        run_frame = frame[frame["run"] == run]
        measured = (run_frame["rate"] - run_frame["reference"]).to_numpy()
        true_drift = run_frame["drift"].to_numpy()
        # What a perfect model of the thermal drift would leave: the gyro's noise and biases.
        floor.append(float(np.mean((measured - true_drift) ** 2)))
        for name in thermal:
            model = result.models[unit][name]
            predicted = measured - np.asarray(compensate(model, run_frame, measured))
            thermal[name].append(float(np.mean((predicted - true_drift) ** 2)))
    runs["floor"] = floor
    runs["thermal_traditional"] = thermal["traditional"]
    runs["thermal_modified"] = thermal["modified"]
    return campaign, runs


def _ratio(numerator, denominator):
    return float(np.mean(numerator) / np.mean(denominator))


def write_paper_comparison(directory=GENERATED):
    """Write ``paper_tables.rst``: our MSDs beside the paper's Tables 2-4, and a summary."""
    campaign, runs = _paper_results()
    params = campaign.run_params
    parts = []
    from sklearn_ifog.paper import PAPER_MSD as published

    tables = (
        ("table2", "Table 2", published["table2"], 90),
        ("table3", "Table 3", published["table3"], 45),
        ("table4", "Table 4", published["table4"], 135),
    )
    summary_rows = []
    for key, label, paper, azimuth in tables:
        ours = runs[runs["table"] == key].reset_index(drop=True)
        unit = int(ours["unit"].iloc[0])
        test_azimuth = float(ours["test_azimuth"].iloc[0])
        if key == "table2":
            header = [
                "Exp.",
                "Paper: before",
                "Paper: after",
                "Ours: run",
                "Ours: before",
                "Ours: after",
                "Ours: noise floor",
            ]
            rows = [
                [
                    str(i + 1),
                    _sci(paper["msd_before"][i]),
                    _sci(paper["msd_after"][i]),
                    str(int(ours["run"][i])),
                    _sci(ours["raw"][i]),
                    _sci(ours["modified"][i]),
                    _sci(ours["floor"][i]),
                ]
                for i in range(len(ours))
            ]
            widths = (6, 14, 14, 8, 14, 14, 14)
            paper_raw, paper_modified = paper["msd_before"], paper["msd_after"]
            paper_traditional = None
        else:
            header = [
                "Exp.",
                "Paper: raw",
                "Paper: (T, ΔT)",
                "Paper: (T, ΔT, T·ΔT)",
                "Ours: run",
                "Ours: raw",
                "Ours: (T, ΔT)",
                "Ours: (T, ΔT, T·ΔT)",
                "Ours: noise floor",
            ]
            rows = [
                [
                    str(i + 1),
                    _sci(paper["raw"][i]),
                    _sci(paper["traditional"][i]),
                    _sci(paper["modified"][i]),
                    str(int(ours["run"][i])),
                    _sci(ours["raw"][i]),
                    _sci(ours["traditional"][i]),
                    _sci(ours["modified"][i]),
                    _sci(ours["floor"][i]),
                ]
                for i in range(len(ours))
            ]
            widths = (5, 12, 12, 13, 6, 12, 12, 13, 12)
            paper_raw, paper_modified = paper["raw"], paper["modified"]
            paper_traditional = paper["traditional"]
        title = (
            f"{label}: MSD, (deg/h)², per test experiment. Ours: unit {unit}, trained on its "
            f"runs at 0°, tested on its {len(ours)} runs at {test_azimuth:g}° "
            f"(the paper: {azimuth}°)."
        )
        parts.append(f"{label}\n{'-' * len(label)}\n\n" + _list_table(title, header, rows, widths))
        paper_wins = (
            "—"
            if paper_traditional is None
            else f"{int(np.sum(np.array(paper_modified) < np.array(paper_traditional)))} of 5"
        )
        our_wins = f"{int(np.sum(ours['modified'] < ours['traditional']))} of {len(ours)}"
        summary_rows.append(
            [
                label,
                f"{_ratio(paper_raw, paper_modified):.1f}×",
                f"{_ratio(ours['raw'], ours['modified']):.1f}×",
                f"{_ratio(ours['raw'], ours['floor']):.1f}×",
                paper_wins,
                our_wins,
                _sci(float(np.mean(ours["thermal_traditional"]))),
                _sci(float(np.mean(ours["thermal_modified"]))),
            ]
        )

    summary = _list_table(
        "Summary. Cut: mean raw MSD over mean MSD after the modified model. Ceiling: the cut a "
        "perfect model of the thermal drift would give (mean raw MSD over the noise floor). "
        "Thermal residual: mean squared difference between the predicted and the true "
        "(noise-free) drift, known only on the simulator.",
        [
            "",
            "Paper: cut",
            "Ours: cut",
            "Ours: ceiling",
            "Paper: T·ΔT wins",
            "Ours: T·ΔT wins",
            "Ours: thermal residual (T, ΔT)",
            "Ours: thermal residual (T, ΔT, T·ΔT)",
        ],
        summary_rows,
        (8, 9, 9, 9, 10, 10, 14, 14),
    )
    all_wins = int(np.sum(runs["modified"] < runs["traditional"]))
    total_cut = _ratio(runs["raw"], runs["modified"])
    thermal_ratio = _ratio(runs["thermal_traditional"], runs["thermal_modified"])
    n_runs = len(runs)
    if thermal_ratio >= 1.0:
        residual_phrase = f"**{thermal_ratio:.2f}× smaller** than"
    else:
        residual_phrase = f"**{1.0 / thermal_ratio:.2f}× larger** than"
    n_rows = len(campaign.frame)
    findings = textwrap.dedent(
        f"""\
        Computed when this page was built: ``make_thermal_campaign(random_state={CAMPAIGN_SEED})``
        ({n_rows:,} samples, {len(params)} runs), then
        ``run_paper_experiments(campaign, random_state={CAMPAIGN_SEED})``.

        * Over all {n_runs} test runs the modified model cuts the mean MSD
          **{total_cut:.1f}×** against the raw output.
        * The modified model has a lower MSD than the traditional one on **{all_wins} of
          {n_runs}** test runs.
        * Against the true (noise-free) drift, the modified model's thermal residual is
          {residual_phrase} the traditional model's (mean over the test runs).
        """
    )
    text = (
        ".. This file is generated by docs/_hooks.py at build time; do not edit.\n\n"
        + findings
        + "\n"
        + summary
        + "\n"
        + "\n".join(parts)
    )
    _write_if_changed(directory / "paper_tables.rst", text)
