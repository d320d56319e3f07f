"""``sklearn-ifog demo``: the package's main job on a simulated campaign, step by step.

:func:`run_demo` is a sequence of named steps, each a short function over library calls:
simulate a campaign, compare the models, repeat the reference paper's experiments, fit the
default model of one gyro, draw, write the report and the model, write the campaign. Every
file goes into one staging directory that becomes the output directory only when all are
written (:func:`sklearn_ifog._io.staged_directory`).
"""

import sys
import time
import warnings
from pathlib import Path

import numpy as np
from sklearn.utils import Bunch

from sklearn_ifog.cli._common import PROGRAM, print_table
from sklearn_ifog.cli._files import check_output_directory
from sklearn_ifog.cli._input import Columns
from sklearn_ifog.cli._progress import Progress
from sklearn_ifog.domain import OutsideCalibrationWarning

__all__ = ["run_demo"]

# Sizes of the demo. "full" is the main job, on the simulator's default campaign (one-minute
# samples, the usual resolution of thermal modelling); "quick" keeps every step on a smaller
# campaign and drops the two slowest baselines; "tiny" (hidden) is for the test suite.
DEMO_SIZES = {
    "full": {
        "campaign": {"n_runs": 5, "sampling_period": 60.0},
        "models": None,
        "max_kernel_samples": 400,
    },
    "quick": {
        "campaign": {"n_runs": 2, "sampling_period": 60.0},
        "models": (
            "raw",
            "bias",
            "linear",
            "poly2_ridge",
            "svr",
            "kernel_ridge",
            "rbf_traditional",
            "rbf_modified",
            "rbf",
        ),
        "max_kernel_samples": 200,
    },
    "tiny": {
        "campaign": {"n_runs": 1, "sampling_period": 120.0},
        "models": ("raw", "bias", "linear", "rbf_modified"),
        "max_kernel_samples": 100,
    },
}
_SEED = 0
_CAMPAIGN_COLUMNS = ["unit", "run", "azimuth", "time", "temperature"]
_MODEL_COLUMNS = Columns(
    temperature=["temperature"], time="time", run="run", rate="rate", reference="reference"
)
_SHOWN = [
    "msd_before",
    "msd_after",
    "after_over_floor",
    "reduction",
    "worst_fold_reduction",
    "fit_time",
]
_SILENCED = (
    "scikit-learn's ConvergenceWarnings of the baselines (e.g. the MLP's lbfgs solver "
    "stopping at max_iter) are silenced in the comparison, and so are the "
    "OutsideCalibrationWarnings of held-out rows: the report's 'Calibration domain' "
    "section gives them per run for the compensated unit."
)
_PAPER_CAPTIONS = {
    "table2": "Table 2: unit trained at 0°, tested at 90°, MSD before and after",
    "table3": "Table 3: trained at 0°, tested at 45°: raw, traditional, modified",
    "table4": "Table 4: trained at 0°, tested at 135°: raw, traditional, modified",
}


# -- steps -----------------------------------------------------------------------------------


def _simulate(size, settings):
    """The campaign, its drift target and model input, and a one-line description."""
    from sklearn_ifog.datasets import make_thermal_campaign

    frame = make_thermal_campaign(**settings["campaign"], random_state=_SEED).frame
    units = sorted(frame["unit"].unique().tolist())
    period = settings["campaign"]["sampling_period"]
    description = (
        f"{len(frame)} samples: {len(units)} simulated gyros, "
        f"{frame['run'].nunique()} runs at azimuths "
        f"{', '.join(f'{a:g}' for a in sorted(frame['azimuth'].unique()))} deg, "
        f"one sample every {period:g} s, "
        f"{frame['temperature'].min():.0f} to {frame['temperature'].max():.0f} °C "
        f"(simulator seed {_SEED}, demo size {size!r})."
    )
    return Bunch(
        frame=frame,
        target=(frame["rate"] - frame["reference"]).to_numpy(),
        X=frame[_CAMPAIGN_COLUMNS],
        units=units,
        description=description,
    )


def _regressors(settings):
    """The models the demo compares: default_regressors, those of the size."""
    from sklearn_ifog.comparison import default_regressors

    regressors = default_regressors(
        max_kernel_samples=settings["max_kernel_samples"], random_state=_SEED
    )
    if settings["models"] is not None:
        regressors = {name: regressors[name] for name in settings["models"]}
    return regressors


def _compare_models(campaign, regressors, n_jobs, advance):
    """compare_regressors, model by model (leave one azimuth out within each gyro)."""
    import pandas as pd
    from sklearn.exceptions import ConvergenceWarning

    from sklearn_ifog.comparison import compare_regressors
    from sklearn_ifog.model_selection import LeaveOneAzimuthOut

    cv = LeaveOneAzimuthOut(within_unit=True)
    summaries, folds = [], []
    for name, regressor in regressors.items():
        # scikit-learn passes these filters on to the joblib workers
        with warnings.catch_warnings():
            warnings.filterwarnings("ignore", category=ConvergenceWarning)
            summary, fold_table = compare_regressors(
                campaign.X,
                campaign.target,
                regressors={name: regressor},
                cv=cv,
                n_jobs=n_jobs,
                return_folds=True,
            )
        summaries.append(summary)
        folds.append(fold_table)
        advance()
    return pd.concat(summaries), pd.concat(folds, ignore_index=True)


def _noise_floor(campaign):
    """MSD a perfect model of the simulated drift would leave, averaged as the folds are."""
    import pandas as pd

    frame = campaign.frame
    # The simulator knows the true thermal drift: what a perfect model would leave is the
    # gyro's noise and run biases, averaged over the same folds (one per unit and azimuth).
    residual = pd.Series((campaign.target - frame["drift"].to_numpy()) ** 2)
    return float(residual.groupby([frame["unit"], frame["azimuth"]]).mean().mean())


def _compare_with_paper(paper):
    """Per table: the range and geometric mean of the raw/modified MSD ratio, here and there."""
    import pandas as pd

    from sklearn_ifog.paper import PAPER_MSD

    def describe(ratios):
        ratios = np.asarray(ratios, dtype=float)
        geometric_mean = float(np.exp(np.mean(np.log(ratios))))
        if ratios.size == 1:
            return f"{ratios[0]:.3g}x"
        return f"{ratios.min():.3g}-{ratios.max():.3g}x (geometric mean {geometric_mean:.3g}x)"

    rows = []
    for name, published in PAPER_MSD.items():
        before, after = ("msd_before", "msd_after") if name == "table2" else ("raw", "modified")
        rows.append(
            {
                "table": name.replace("table", "Table "),
                "this campaign": describe(paper[name][before] / paper[name][after]),
                "paper": describe(
                    [a / b for a, b in zip(published[before], published[after], strict=True)]
                ),
            }
        )
    return pd.DataFrame(rows).set_index("table")


def _fit_first_unit(campaign):
    """The default model (make_compensation_pipeline) of the first gyro, trained at 0°."""
    from sklearn_ifog import RBFNetRegressor, make_compensation_pipeline

    frame = campaign.frame
    first_unit = campaign.units[0]
    train = (frame["unit"] == first_unit) & np.isclose(frame["azimuth"], 0.0)
    test = (frame["unit"] == first_unit) & np.isclose(frame["azimuth"], 90.0)
    model = make_compensation_pipeline(RBFNetRegressor(random_state=_SEED))
    model.fit(frame.loc[train, _MODEL_COLUMNS.model_columns()], campaign.target[train.to_numpy()])
    return Bunch(model=model, unit=first_unit, train=train, test_frame=frame[test])


def _save_paper_fig12(frame, paper, units, azimuths, directory):
    """The reference paper's Fig. 12: raw, traditional and modified output of two gyros."""
    from sklearn_ifog.compensation import compensate
    from sklearn_ifog.plotting import new_figure, plot_compensation, save_figure

    figure, axes = new_figure(len(units), 1)
    axes = np.atleast_1d(axes)
    for ax, unit, azimuth in zip(axes, units, azimuths, strict=True):
        selected = frame[(frame["unit"] == unit) & np.isclose(frame["azimuth"], azimuth)]
        run = selected["run"].iloc[0]
        run_frame = selected[selected["run"] == run]
        models = paper.models[unit]
        rate = run_frame["rate"].to_numpy()
        plot_compensation(
            run_frame["time"].to_numpy(),
            rate,
            {
                "traditional (T, ΔT)": compensate(models["traditional"], run_frame, rate),
                "modified (T, ΔT, T·ΔT)": compensate(models["modified"], run_frame, rate),
            },
            run_frame["temperature"].to_numpy(),
            reference=run_frame["reference"].to_numpy(),
            ax=ax,
            title=f"unit {unit}, azimuth {azimuth:g}°, run {run}",
        )
    return save_figure(figure, directory / "paper_fig12.png")


def _draw(campaign, comparison, fold_table, floor, paper, staging, advance):
    """The MSD-by-model figure and the paper's Fig. 12; their paths."""
    from sklearn_ifog.plotting import plot_msd_by_model, save_figure

    ax = plot_msd_by_model(
        {
            name: fold_table.loc[fold_table["model"] == name, "msd_after"].to_numpy()
            for name in comparison.index
            if name != "raw"
        },
        before=fold_table.loc[fold_table["model"] == "raw", "msd_after"].to_numpy(),
        floor=floor,
        title="MSD after compensation, per held-out azimuth",
    )
    msd_figure = save_figure(ax, staging / "msd_by_model.png")
    advance()
    fig12 = _save_paper_fig12(campaign.frame, paper, campaign.units[1:3], (45.0, 135.0), staging)
    advance()
    return [msd_figure, fig12]


def _start_report(campaign, comparison, paper, versus_paper, floor_text, figures):
    """The report's campaign, model-comparison and paper sections."""
    from sklearn_ifog.report import Report

    report = Report("sklearn-ifog demo: temperature compensation of simulated IFOGs")
    report.add_paragraph(f"Campaign: {campaign.description}")
    report.add_heading("Model comparison")
    report.add_paragraph(
        "Each gyro's runs at one azimuth are compensated by a model trained on the same "
        "gyro's runs at the other azimuths (leave one azimuth out, within each unit). "
        "MSD in (deg/h)^2; reduction = MSD before / MSD after; times in seconds per fit. "
        + floor_text
        + " "
        + _SILENCED
    )
    report.add_table(comparison[_SHOWN])
    report.add_figure(
        figures[0],
        "MSD after compensation per model (bars: mean over folds; dots: folds; grey: "
        "no compensation).",
    )
    report.add_heading("The reference paper's experiments")
    report.add_paragraph(
        "Table 2: a model of the first gyro trained on its runs at azimuth 0° compensates "
        "its runs at 90°. Tables 3-4: the second and third gyros, tested at 45° and 135°, "
        "with the traditional model on (T, ΔT) and the modified one on (T, ΔT, T·ΔT). "
        "MSD in (deg/h)^2."
    )
    for name in ("table2", "table3", "table4"):
        report.add_table(paper[name], caption=f"{name.replace('table', 'Table ')}.")
    report.add_paragraph(
        "MSD reduction (raw / modified model) per test run, this simulated campaign "
        "against the paper's real gyros (computed from its Tables 2-4):"
    )
    report.add_table(versus_paper)
    report.add_figure(
        figures[1],
        "As the paper's Fig. 12: raw and compensated output of the second and third "
        "gyros (one test run each), with the temperature.",
    )
    return report


def _save_model(campaign, fitted, path):
    """Save the first unit's model with its columns and training MSDs; its metadata."""
    from sklearn_ifog.metrics import mean_squared_deviation
    from sklearn_ifog.persistence import save_model

    frame, train = campaign.frame, fitted.train
    columns = _MODEL_COLUMNS.model_columns()
    y_train = campaign.target[train.to_numpy()]
    fitted_drift = fitted.model.predict(frame.loc[train, columns])
    return save_model(
        fitted.model,
        path,
        metadata={
            "columns": _MODEL_COLUMNS.as_dict(),
            "training": {
                "file": "campaign.csv",
                "n_samples": int(train.sum()),
                "msd_before": float(np.mean(y_train**2)),
                "msd_after": float(mean_squared_deviation(y_train, fitted_drift)),
            },
        },
    )


def _write_compensation_report(fitted, metadata, report, staging):
    """The first unit's runs at 90°, compensated: the report's last sections, written."""
    from sklearn_ifog.report import RunColumns, compensation_report

    test_frame = fitted.test_frame
    X = test_frame[_MODEL_COLUMNS.model_columns()]
    columns = RunColumns(
        rate=test_frame["rate"].to_numpy(),
        drift=fitted.model.predict(X),
        reference=test_frame["reference"].to_numpy(),
        temperature=test_frame["temperature"].to_numpy(),
        time=test_frame["time"].to_numpy(),
        run=test_frame["run"].to_numpy(),
    )
    return compensation_report(
        staging,
        columns,
        model=fitted.model,
        X=X,
        model_metadata=metadata,
        data_name=f"unit {fitted.unit} at azimuth 90°",
        report=report,
        heading=(
            f"Unit {fitted.unit}: trained at 0°, compensating its runs at 90° "
            "(as the paper's Fig. 10)"
        ),
    )


def _print_calibration(table, stream):
    """One line on the compensated runs' calibration domain (the report has the table)."""
    if table is None:
        return
    everything = table.loc["(all runs)"]
    print(
        f"Calibration domain: {int(everything['rows_outside'])} of "
        f"{int(everything['samples'])} compensated rows lie outside what the default model "
        f"was calibrated on ({everything['outside_share']:.1%}; see the report's "
        "'Calibration domain' section).",
        file=stream,
    )


def _write_campaign(frame, path):
    from sklearn_ifog._io import atomic_path

    with atomic_path(path) as temporary:
        frame.to_csv(temporary, index=False)


def _print_written(out, written, elapsed, stream):
    print(f"\nDone in {elapsed:.0f} s. Wrote to {out}/:", file=stream)
    for role, paths in written.items():
        names = ", ".join(p.name for p in paths) if isinstance(paths, list) else paths.name
        print(f"  {role}: {names}", file=stream)
    print(
        f"\nTry: {PROGRAM} compensate {out / 'model.joblib'} {out / 'campaign.csv'} "
        f"--drift-column drift_predicted -o compensated.csv",
        file=stream,
    )


# -- the demo --------------------------------------------------------------------------------


def run_demo(out, *, quick=False, size=None, n_jobs=None, stream=None):
    """The demo: simulate, compare, repeat the paper's experiments, plot, report, save.

    Parameters
    ----------
    out : path-like
        Output directory. A new directory appears complete or not at all; in an existing
        one, the demo's files are replaced together, once all are written (others are
        kept). A failure leaves it as it was.
    quick : bool, default=False
        The smaller "quick" size.
    size : {"full", "quick", "tiny"} or None, default=None
        Overrides ``quick``.
    n_jobs : int or None, default=None
        Parallel jobs; None uses every core.
    stream : file-like, default=None
        Where the tables and the list of files go (stdout by default); progress goes to
        stderr.

    Returns
    -------
    written : dict of str to Path
        What was written, by role.
    """
    from sklearn_ifog._io import staged_directory
    from sklearn_ifog.paper import run_paper_experiments
    from sklearn_ifog.rbf import RBFNetRegressor

    stream = sys.stdout if stream is None else stream
    size = size or ("quick" if quick else "full")
    settings = DEMO_SIZES[size]
    n_jobs = -1 if n_jobs is None else n_jobs
    out = Path(out)
    check_output_directory(out)
    progress = Progress(n_steps=7)
    started = time.perf_counter()

    with staged_directory(out) as staging, warnings.catch_warnings():
        # Held-out rows outside their fold model's domain are expected in a comparison;
        # the report tells them per run (and so does _print_calibration).
        warnings.filterwarnings("ignore", category=OutsideCalibrationWarning)
        with progress.step("simulating a thermal-test campaign"):
            campaign = _simulate(size, settings)
        print(f"Campaign: {campaign.description}", file=stream)

        regressors = _regressors(settings)
        with progress.step(
            f"comparing {len(regressors)} models (leave one azimuth out, per gyro)",
            total=len(regressors),
        ) as advance:
            comparison, fold_table = _compare_models(campaign, regressors, n_jobs, advance)
        floor = _noise_floor(campaign)
        # Near the floor every reduction looks alike; the ratio to the floor shows the part
        # of the error a model could still remove, which is where the models differ.
        comparison["after_over_floor"] = comparison["msd_after"] / floor
        print_table(
            "Model comparison: MSD ((deg/h)^2) of each held-out azimuth, mean over "
            f"{int(comparison['n_folds'].iloc[0])} folds:",
            comparison[_SHOWN],
            stream=stream,
        )
        floor_text = (
            f"Noise floor: a perfect model of the simulated thermal drift would leave an MSD "
            f"of {floor:.3g} (angle random walk, bias instability and turn-on bias), a "
            f"reduction of at most {comparison['msd_before'].iloc[0] / floor:.3g}x; "
            "after_over_floor is msd_after over it (1: nothing thermal left to remove)."
        )
        print(floor_text, file=stream)
        print(f"({_SILENCED})", file=stream)

        with progress.step("repeating the paper's experiments (Tables 2-4)"):
            paper = run_paper_experiments(
                campaign.frame, regressor=RBFNetRegressor(random_state=_SEED), n_jobs=n_jobs
            )
        for name, caption in _PAPER_CAPTIONS.items():
            print_table(caption + ":", paper[name], stream=stream)
        versus_paper = _compare_with_paper(paper)
        print_table(
            "MSD reduction (raw / modified model) per test run, this campaign against the "
            "paper's real gyros:",
            versus_paper,
            stream=stream,
        )

        with progress.step(f"fitting the default model of unit {campaign.units[0]} (azimuth 0°)"):
            fitted = _fit_first_unit(campaign)

        with progress.step("drawing the comparison and the paper's Fig. 12", total=2) as advance:
            figures = _draw(campaign, comparison, fold_table, floor, paper, staging, advance)
        report = _start_report(campaign, comparison, paper, versus_paper, floor_text, figures)

        model_path = staging / "model.joblib"
        with progress.step("writing the report (Fig. 10, Allan deviation) and the model"):
            metadata = _save_model(campaign, fitted, model_path)
            result = _write_compensation_report(fitted, metadata, report, staging)

        _print_calibration(result.calibration_table, stream)
        with progress.step("writing the campaign as CSV"):
            _write_campaign(campaign.frame, staging / "campaign.csv")

    written = {
        "report (HTML, figures embedded)": out / result.paths["html"].name,
        "report (Markdown)": out / result.paths["markdown"].name,
        "figures": [out / path.name for path in figures + result.figures],
        "model (joblib)": out / model_path.name,
        "campaign (CSV)": out / "campaign.csv",
    }
    _print_written(out, written, time.perf_counter() - started, stream)
    return written
