"""The report and the plots tell the user where the model was outside its calibration."""

import warnings

import numpy as np
import pytest
from sklearn.linear_model import LinearRegression
from sklearn.pipeline import Pipeline
from sklearn.preprocessing import StandardScaler
from sklearn.utils import Bunch

from sklearn_ifog import (
    ConformalRegressor,
    OutsideCalibrationWarning,
    RBFNetRegressor,
    ThermalFeatures,
    UnitwiseRegressor,
    make_compensation_pipeline,
)
from sklearn_ifog.datasets import make_thermal_campaign
from sklearn_ifog.report import (
    RunColumns,
    calibration_status,
    compensation_report,
    per_run_calibration,
)

pytest.importorskip("matplotlib", reason="the report and the plots draw with matplotlib")

from matplotlib.colors import to_rgb

from sklearn_ifog.plotting import outside_stretches, plot_compensation

CAMPAIGN = {"n_runs": 2, "azimuths": [0.0], "sampling_period": 120.0, "random_state": 0}
SHADE = "outside calibration"


@pytest.fixture(scope="module")
def calibration():
    """One unit's two runs between 10 and 40 degC (the coil between about 17 and 34)."""
    return make_thermal_campaign(n_units=1, temperature_range=(10.0, 40.0), **CAMPAIGN)


@pytest.fixture(scope="module")
def linear_model(calibration):
    return make_compensation_pipeline(LinearRegression()).fit(calibration.data, calibration.target)


@pytest.fixture(scope="module")
def partly_cold(calibration):
    """The calibration runs, the second half of run 1 made 30 degC colder.

    The rows before the change are calibration rows (inside by construction: the features
    are causal); the colder ones lie below every calibrated temperature (outside).
    """
    frame = calibration.frame.copy()
    run_1 = np.flatnonzero(frame["run"].to_numpy() == 1)
    colder = run_1[run_1.size // 2 :]
    frame.loc[colder, "temperature"] -= 30.0
    return frame


def _report(directory, model, frame, **kwargs):
    X = frame[["unit", "run", "azimuth", "time", "temperature"]]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", OutsideCalibrationWarning)
        drift = model.predict(X)
    columns = RunColumns(
        rate=frame["rate"],
        drift=drift,
        reference=frame["reference"],
        temperature=frame["temperature"],
        time=frame["time"],
        run=frame["run"],
    )
    result = compensation_report(directory, columns, model=model, X=X, **kwargs)
    return result, X


def _section(markdown, heading="### Calibration domain"):
    """The lines of a report section, blank lines dropped."""
    text = markdown.split(heading, 1)[1].split("\n#", 1)[0]
    return [line for line in text.splitlines() if line.strip()]


def test_per_run_shares_distances_and_degrees_are_the_models(linear_model, partly_cold, tmp_path):
    result, X = _report(tmp_path, linear_model, partly_cold)
    outside = linear_model.outside_calibration(X)
    distance = linear_model.calibration_distance(X)
    column = linear_model.fallback_.column
    coldest = linear_model.domain_.data_min_[column]
    warmest = linear_model.domain_.data_max_[column]
    temperature = X["temperature"].to_numpy()
    runs = X["run"].to_numpy()
    assert 0 < outside[runs == 1].mean() < 1  # the case this test is about
    table = result.calibration_table
    assert table.index.tolist() == [0, 1, "(all runs)"]
    for label, rows in [(0, runs == 0), (1, runs == 1), ("(all runs)", np.ones_like(outside))]:
        assert table.loc[label, "outside_share"] == outside[rows].mean()
        assert table.loc[label, "rows_outside"] == outside[rows].sum()
        assert table.loc[label, "max_distance"] == distance[rows].max()
        np.testing.assert_allclose(
            table.loc[label, "degC_below"], max(coldest - temperature[rows].min(), 0.0)
        )
        np.testing.assert_allclose(
            table.loc[label, "degC_above"], max(temperature[rows].max() - warmest, 0.0)
        )
    np.testing.assert_array_equal(result.calibration.outside, outside)
    # the policy never touches a row inside
    assert not (result.calibration.adjusted & ~outside).any()

    section = _section(result.paths["markdown"].read_text())
    n_out = outside.sum()
    assert section[0].startswith(
        f"{n_out} of {outside.size} rows ({n_out / outside.size:.1%}), in 1 of 2 run(s), lie "
        "outside the model's calibration domain"
    )
    assert f"its temperatures from {coldest:.4g} to {warmest:.4g} °C" in section[0]
    below = coldest - temperature.min()
    assert f"went down to {below:.3g} °C below the coldest calibrated temperature" in section[0]
    assert "(uncalibrated='blend')" in section[0]
    assert "| run | samples | rows_outside | outside_share |" in section[1]


@pytest.mark.parametrize("policy", ["blend", "clip", "none"])
@pytest.mark.parametrize("colder", [30.0, 0.5])
def test_the_paragraph_says_what_the_policy_did(calibration, tmp_path, policy, colder):
    model = make_compensation_pipeline(LinearRegression(), uncalibrated=policy)
    model.fit(calibration.data, calibration.target)
    # 30 degC colder: far out; 0.5 degC: just below the calibrated temperatures
    frame = calibration.frame.assign(temperature=calibration.frame["temperature"] - colder)
    result, _ = _report(tmp_path, model, frame)
    paragraph = _section(result.paths["markdown"].read_text())[0]
    adjusted, outside = result.calibration.adjusted, result.calibration.outside
    assert outside.any()
    assert f"uncalibrated='{policy}'" in paragraph
    # the text counts the rows outside that the policy left at the model's own prediction
    kept, total = int((outside & ~adjusted).sum()), int(outside.sum())
    if policy == "none":
        assert not adjusted.any()
        assert "There, the model extrapolated freely" in paragraph
        assert "kept the model's own prediction" not in paragraph
        return
    if policy == "blend" and kept == total:
        assert f"There, each of these {total} rows kept the model's own prediction" in paragraph
        return
    says = "the model fell back towards" if policy == "blend" else "the model was held at"
    assert f"There, {says}" in paragraph
    partly = f"for {total - kept} of these {total} rows; the other {kept} kept the model's own"
    assert (partly in paragraph) == (kept > 0)


def test_all_rows_inside_is_one_line(linear_model, calibration, tmp_path):
    result, X = _report(tmp_path, linear_model, calibration.frame)
    section = _section(result.paths["markdown"].read_text())
    assert section == [
        f"All {X.shape[0]} rows lie inside the model's calibration domain (calibrated from "
        f"{X['temperature'].min():.4g} to {X['temperature'].max():.4g} °C): every "
        "prediction is the model's own."
    ]
    assert (result.calibration_table["outside_share"] == 0).all()
    assert "shaded" not in result.paths["markdown"].read_text()


def _figures(monkeypatch):
    """Capture the axes the report saves, in order."""
    from sklearn_ifog import plotting

    saved = []
    original = plotting.save_figure

    def capture(figure, path, **kwargs):
        saved.append(figure)
        return original(figure, path, **kwargs)

    monkeypatch.setattr(plotting, "save_figure", capture)
    return saved


def _expected_extents(hours, mask):
    """Half-way to the neighbouring samples, stretch by stretch (computed plainly)."""
    extents = []
    start = None
    for i, flag in enumerate([*mask, False]):
        if flag and start is None:
            start = i
        elif not flag and start is not None:
            end = i - 1
            left = hours[0] if start == 0 else (hours[start - 1] + hours[start]) / 2
            right = hours[-1] if end == hours.size - 1 else (hours[end] + hours[end + 1]) / 2
            extents.append((left, right))
            start = None
    return extents


def _spans(ax, gid=SHADE):
    spans = [patch for patch in ax.patches if patch.get_gid() == gid]
    return sorted((span.get_x(), span.get_x() + span.get_width()) for span in spans)


def test_the_figure_of_a_partly_outside_run_shades_its_stretches(
    linear_model, partly_cold, tmp_path, monkeypatch
):
    saved = _figures(monkeypatch)
    result, X = _report(tmp_path, linear_model, partly_cold)
    axes_by_run = {0: saved[0], 1: saved[1]}
    outside = linear_model.outside_calibration(X)
    runs = X["run"].to_numpy()
    for run, ax in axes_by_run.items():
        rows = runs == run
        time = X["time"].to_numpy()[rows]
        hours = (time - time[0]) / 3600.0
        np.testing.assert_allclose(_spans(ax), _expected_extents(hours, outside[rows]))
        legend = [text.get_text() for text in ax.get_legend().get_texts()]
        assert legend.count(SHADE) == (1 if outside[rows].any() else 0)
    assert _spans(axes_by_run[1])  # run 1 is partly outside: shaded
    assert not _spans(axes_by_run[0])  # run 0 is the calibration: nothing shaded
    markdown = result.paths["markdown"].read_text()
    assert "Run 1: raw" in markdown
    assert markdown.count("shaded where the rows lie outside the calibration domain") == 2
    # (once in the figure's alt text, once in its caption: run 1 only)


def test_plot_compensation_shades_each_stretch_and_checks_the_mask():
    time = np.arange(0.0, 10 * 60.0, 60.0)
    rate = np.linspace(1.0, 2.0, time.size)
    mask = np.array([1, 1, 0, 0, 1, 0, 0, 0, 1, 1], dtype=bool)  # a single-row stretch
    first, last = outside_stretches(mask)
    assert first.tolist() == [0, 4, 8]
    assert last.tolist() == [1, 4, 9]
    ax, _ = plot_compensation(time, rate, rate - 1.0, outside=mask, time_unit="min")
    assert _spans(ax) == [(0.0, 1.5), (3.5, 4.5), (7.5, 9.0)]
    legend = [text.get_text() for text in ax.get_legend().get_texts()]
    assert legend == ["raw", "compensated", SHADE]

    # one mask per compensated series: in that series' colour, named after it
    series = {"traditional": rate - 0.9, "modified": rate - 1.0}
    masks = {"modified": mask, "traditional": np.zeros_like(mask)}
    ax, _ = plot_compensation(time, rate, series, outside=masks, time_unit="min")
    assert _spans(ax, f"{SHADE} (modified)") == [(0.0, 1.5), (3.5, 4.5), (7.5, 9.0)]
    assert not _spans(ax, f"{SHADE} (traditional)")
    lines = {line.get_label(): line for line in ax.get_lines()}
    shaded = [patch for patch in ax.patches if patch.get_gid() == f"{SHADE} (modified)"]
    assert shaded[0].get_facecolor()[:3] == pytest.approx(to_rgb(lines["modified"].get_color()))

    with pytest.raises(TypeError, match="outside must be a boolean mask"):
        plot_compensation(time, rate, rate, outside=mask.astype(int))
    with pytest.raises(ValueError, match=r"outside has shape \(9,\)"):
        plot_compensation(time, rate, rate, outside=mask[:-1])
    with pytest.raises(ValueError, match=r"outside names series \['rbf'\]"):
        plot_compensation(time, rate, series, outside={"rbf": mask})


def test_unitwise_and_conformal_rows_are_measured_by_the_model_that_predicts_them(tmp_path):
    lot = make_thermal_campaign(
        n_units=2, temperature_range=(10.0, 40.0), lot_spread=0.2, **CAMPAIGN
    )
    X, y = lot.data, lot.target
    cold = X.assign(
        temperature=np.where(X["unit"] == 1, X["temperature"] - 30.0, X["temperature"])
    )
    for pooling in ("none", "full"):
        model = UnitwiseRegressor(
            make_compensation_pipeline(LinearRegression()), pooling=pooling
        ).fit(X, y)
        status = calibration_status(model, cold)
        for unit in (0, 1):
            rows = (cold["unit"] == unit).to_numpy()
            own = model.estimators_[unit]
            inner = cold[rows].drop(columns="unit")
            np.testing.assert_array_equal(status.outside[rows], own.outside_calibration(inner))
            np.testing.assert_array_equal(status.distance[rows], own.calibration_distance(inner))
        assert not status.outside[(cold["unit"] == 0).to_numpy()].any()
        assert status.outside[(cold["unit"] == 1).to_numpy()].all()

    one_unit = X[X["unit"] == 0]
    conformal = ConformalRegressor(make_compensation_pipeline(LinearRegression()), cv=2)
    conformal.fit(one_unit, y[(X["unit"] == 0).to_numpy()])
    colder = one_unit.assign(temperature=one_unit["temperature"] - 30.0)
    status = calibration_status(conformal, colder)
    np.testing.assert_array_equal(status.outside, conformal.estimator_.outside_calibration(colder))
    assert status.outside.all()


def test_rbf_model_without_runs_and_a_model_without_a_domain(calibration, tmp_path):
    frame = calibration.frame
    one_run = frame[frame["run"] == 1].reset_index(drop=True)
    columns = ["temperature", "time"]
    model = make_compensation_pipeline(RBFNetRegressor(random_state=0), time="time", run=None).fit(
        frame[frame["run"] == 0][columns], calibration.target[frame["run"] == 0]
    )
    warmer = one_run.assign(temperature=one_run["temperature"] + 10.0)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", OutsideCalibrationWarning)
        drift = model.predict(warmer[columns])
    result = compensation_report(
        tmp_path,
        RunColumns(
            rate=warmer["rate"],
            drift=drift,
            reference=warmer["reference"],
            temperature=warmer["temperature"],
            time=warmer["time"],
        ),
        model=model,
        X=warmer[columns],
    )
    outside = model.outside_calibration(warmer[columns])
    (row,) = result.calibration_table.itertuples()
    assert row.Index == "(all runs)"
    assert row.outside_share == outside.mean() > 0
    warmest = model.domain_.data_max_[model.fallback_.column]
    np.testing.assert_allclose(row.degC_above, warmer["temperature"].max() - warmest)

    plain = Pipeline(
        [
            ("features", ThermalFeatures(temperature="temperature", time="time", run=None)),
            ("scale", StandardScaler()),
            ("regressor", LinearRegression()),
        ]
    ).fit(one_run[columns], calibration.target[frame["run"] == 1])
    assert calibration_status(plain, one_run[columns]) is None
    result = compensation_report(
        tmp_path,
        RunColumns(
            rate=one_run["rate"],
            drift=plain.predict(one_run[columns]),
            reference=one_run["reference"],
            temperature=one_run["temperature"],
        ),
        model=plain,
        X=one_run[columns],
    )
    assert result.calibration is None
    assert result.calibration_table is None
    assert _section(result.paths["markdown"].read_text())[0].startswith(
        "The model carries no calibration domain"
    )


def test_bad_model_and_rows_are_named(linear_model, calibration, tmp_path):
    frame = calibration.frame
    columns = RunColumns(
        rate=frame["rate"],
        drift=np.zeros(len(frame)),
        reference=frame["reference"],
        temperature=frame["temperature"],
    )
    with pytest.raises(ValueError, match="model was given without X"):
        compensation_report(tmp_path, columns, model=linear_model)
    with pytest.raises(ValueError, match="X was given without model"):
        compensation_report(tmp_path, columns, X=calibration.data)
    with pytest.raises(ValueError, match=f"X has 10 rows, rate has {len(frame)}"):
        compensation_report(tmp_path, columns, model=linear_model, X=calibration.data[:10])
    status = calibration_status(linear_model, calibration.data)
    with pytest.raises(ValueError, match=f"run has 3 labels; the status has {len(frame)} rows"):
        per_run_calibration(status, run=[0, 1, 2])


def test_rates_beyond_the_calibrated_ones_are_reported_per_run(tmp_path):
    # The paper's heating-only calibration, then runs that only cool through the same
    # temperatures: the temperature stays inside, the rate does not.
    unit = dict(n_units=1, n_runs=2, azimuths=[0.0, 90.0], sampling_period=120.0)
    heating = make_thermal_campaign(
        profile="paper", temperature_range=(10.0, 40.0), random_state=0, **unit
    )
    cooling = make_thermal_campaign(
        profile="cooling", temperature_range=(10.0, 40.0), random_state=0, **unit
    )
    model = make_compensation_pipeline(LinearRegression()).fit(heating.data, heating.target)
    X = cooling.data
    status = calibration_status(model, X)
    column = list(model.feature_names_out_).index("dT")
    rate = model[:1].transform(X)[:, column]
    slowest, fastest = model.domain_.data_min_[column], model.domain_.data_max_[column]
    expected = np.minimum(rate - slowest, 0.0) + np.maximum(rate - fastest, 0.0)
    np.testing.assert_allclose(status.rate_excess, expected, rtol=0, atol=1e-12)
    assert np.all(status.rate_min == slowest)
    assert np.all(status.rate_max == fastest)
    runs = X["run"].to_numpy()
    table = per_run_calibration(status, runs)
    for label in np.unique(runs):
        rows = runs == label
        assert table.loc[label, "rate_below"] == pytest.approx(max(slowest - rate[rows].min(), 0))
        assert table.loc[label, "rate_above"] == pytest.approx(max(rate[rows].max() - fastest, 0))
    assert table.loc["(all runs)", "rate_below"] > 0  # cooling, after heating only
    # A status without the rate (built by hand, or by an older version): NaN columns.
    legacy = {key: status[key] for key in ("distance", "outside", "temperature_excess")}
    assert np.isnan(per_run_calibration(Bunch(**legacy))["rate_below"]).all()
    # The report says it in words, with the calibrated temperatures kept.
    result, _ = _report(tmp_path, model, cooling.frame)
    text = " ".join(_section(result.paths["markdown"].read_text()))
    worst = table.loc["(all runs)", "rate_below"]
    assert f"Its rate dT went {worst:.3g} below the slowest calibrated rate" in text
