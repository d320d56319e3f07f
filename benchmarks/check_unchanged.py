"""Check that a refactor changed no behaviour: the same numbers before and after, bit for bit.

What it checks
--------------
One *snapshot* runs a fixed workload with whatever ``sklearn_ifog`` Python imports and stores
every result as a named array in an ``.npz`` file; two snapshots are then compared array by
array. The workload, on the simulator's default campaign ``make_thermal_campaign(
random_state=0)`` (training on units 0-1, predicting unit 2) and on the shipped real recording
``load_psim_tvc()`` (run column ``burst``, training on bursts 0-14, predicting 15-24, the three
gyro axes as three outputs):

1. ``features.*``: ``ThermalFeatures.fit_transform`` and ``get_feature_names_out`` for the
   default parameters, for ``terms=("T", "dT")``, each term alone, all terms with two sensors
   (``temperature`` and ``chamber_temperature``, so ``"gradient"`` is defined), smoothing (a
   time constant in seconds, so only with a time column), ``time=None`` (per-sample
   difference), every ``rate_unit``, numpy
   input with column positions, polars input, pandas output, rows of all runs interleaved
   (shuffled), and string run ids.
2. ``model.*``: predictions of the hand-built default Pipeline ``ThermalFeatures(temperature=,
   time=, run=) -> StandardScaler -> RBFNetRegressor(random_state=0)`` and of each refine
   mode (``"varpro"``, ``"lm"``, ``"gd"``, None), both with the default model selection and
   with ``n_centers=20, criterion=None`` (the default selection keeps no Gaussian unit on
   these data, where the refiners have nothing to move); with the fitted ``centers_``,
   ``widths_``, ``coef_``, ``tail_coef_``, ``intercept_`` and ``n_iter_``. Plus a Ridge
   Pipeline on two sensors with ``time=None`` (so no smoothing), for the streaming and C
   front ends.
3. ``stream.*``: ``StreamingCompensator`` drift and compensated rate, sample by sample
   (``step``) and in chunks of 1 to 1000 rows (``update``), and its final ``get_state``.
4. ``c.*`` / ``json.*``: ``export.to_c`` in ``"double"`` and ``"float"``, compiled with
   ``cc -std=c99 -O0`` and run on the test rows by a driver that prints ``%.17g`` (streaming
   ``step`` with a reset at each run start, and ``batch`` per run); the generated header and
   source text; ``to_json`` parsed (every number array by its JSON path, every string exactly).
5. ``demo.*``: ``run_demo(out, quick=True)``: ``campaign.csv`` (every column), the tables of
   ``report.md`` (numbers as arrays, text exactly), the report's other lines, every table the
   demo hands to ``Report.add_table`` at full precision (captured by wrapping that method),
   the predictions of the saved ``model.joblib`` on ``campaign.csv``, and the names of the
   files ``run_demo`` returns.

Ignored, because they differ from one run to the next whatever the code: the ``fit_time`` and
``score_time`` columns (timings); dates and times (the report's "report made ... UTC" and the
model's "saved" stamp, replaced by ``<timestamp>``); the output directory (only file names are
kept); the demo's stdout (its tables are the report's, printed with fewer digits and a timing
column whose width moves the others) and its progress on stderr; the figures and
``report.html`` (the same tables plus embedded images). Everything else is compared.

Run
---
From the repository root (``.venv/bin/python`` or any Python with the dependencies)::

    python benchmarks/check_unchanged.py                      # against 844783f
    python benchmarks/check_unchanged.py --baseline REV --out benchmarks/results/check_unchanged.md
    python benchmarks/check_unchanged.py --snapshot before.npz   # one snapshot, current tree
    python benchmarks/check_unchanged.py --compare before.npz after.npz
    python benchmarks/check_unchanged.py --quick --out /tmp/check.md   # CI smoke run

``--quick`` (CI, seconds): the features part only (no models, streaming, C or demo), on the
simulator's default campaign with one run per (unit, azimuth) instead of five
(``QUICK_CAMPAIGN``), the working tree against ``HEAD`` (unless ``--baseline`` is given): it
checks that the machinery (``git archive``, the two snapshot processes, the comparison, the
exit code) still works, and that the features are reproducible.

``--baseline REV`` extracts REV with ``git archive`` into a temporary directory (no worktree
state), runs this script there in ``--snapshot`` mode with ``PYTHONPATH`` set to it (the
snapshot checks that ``sklearn_ifog`` really comes from there and aborts otherwise), does the
same with the current working tree (uncommitted edits included), both at once, and compares.
A C compiler ``cc`` is needed for the C part (without one, the snapshot stops with an error
rather than leave the C unchecked). Cost: about 80 s of CPU per snapshot, the demo half of it
(as measured by ``time`` and the per-part times each snapshot prints), so one to two minutes
on an idle two-core machine; several times more when other jobs share the cores.

What "identical" means
----------------------
For each quantity the table gives the shape, the largest absolute difference, the largest
relative difference (the largest absolute difference divided by the largest magnitude of the
baseline's values) and a verdict:

- ``identical``: same dtype, same shape, same bytes (text: the same strings);
- ``within 1e-15 (summation order)``: same dtype, shape and NaN positions, relative difference
  at most 1e-15 (a few units in the last place: what moving a sum into another order gives);
- ``DIFFERENT``: anything else, including a quantity missing on one side.

The script exits 1 if any quantity is ``DIFFERENT`` or missing, 0 otherwise (2 on a setup
error such as a baseline that does not import from where it should).
"""

import argparse
import contextlib
import importlib
import io
import json
import os
import re
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from _verdict import target_line  # isort: skip

DEFAULT_BASELINE = "844783f"
REPOSITORY = Path(__file__).resolve().parents[1]
RELATIVE_TOLERANCE = 1e-15
SEED = 0
QUICK_CAMPAIGN = {"n_runs": 1}  # --quick: the simulated campaign's runs per (unit, azimuth)
TERMS = ("T", "dT", "TdT", "T2", "gradient")  # every term of the baseline's ThermalFeatures
REFINE_MODES = ("varpro", "lm", "gd", None)
TIMING_COLUMNS = ("fit_time", "score_time")
VERDICTS = ("identical", "within 1e-15 (summation order)", "DIFFERENT")
PARTS = {
    "features": "features (ThermalFeatures)",
    "model": "predictions and fitted networks",
    "stream": "StreamingCompensator",
    "c": "exported C (text and outputs)",
    "json": "exported JSON",
    "demo": "demo tables",
}
TIMESTAMP = re.compile(
    r"\d{4}-\d{2}-\d{2}[T ]\d{2}:\d{2}(:\d{2}(\.\d+)?)?(Z|[+-]\d{2}:?\d{2}| ?UTC)?"
)

# Reads rows (run-start flag, time, temperatures...) as float64; prints, one line per sample,
# the streamed drift (step, reset at each run start) then the batched drift (batch per run).
C_DRIVER = r"""
#include <stdio.h>
#include <stdlib.h>
#include "ifog.h"

#define WIDTH (2 + IFOG_N_SENSORS)

int main(int argc, char **argv)
{
    long n, i, k, start = 0;
    double *rows, *time, *temperature;
    ifog_real *streamed, *batched;
    ifog_state state;
    FILE *in;
    if (argc != 3) return 1;
    n = atol(argv[1]);
    rows = malloc((size_t)(n * WIDTH) * sizeof(double));
    time = malloc((size_t)n * sizeof(double));
    temperature = malloc((size_t)(n * IFOG_N_SENSORS) * sizeof(double));
    streamed = malloc((size_t)(n * IFOG_N_OUTPUTS) * sizeof(ifog_real));
    batched = malloc((size_t)(n * IFOG_N_OUTPUTS) * sizeof(ifog_real));
    in = fopen(argv[2], "rb");
    if (!rows || !time || !temperature || !streamed || !batched || !in) return 2;
    if (fread(rows, sizeof(double), (size_t)(n * WIDTH), in) != (size_t)(n * WIDTH)) return 3;
    fclose(in);
    ifog_init(&state);
    for (i = 0; i < n; ++i) {
        const double *row = rows + i * WIDTH;
        time[i] = row[1];
        for (k = 0; k < IFOG_N_SENSORS; ++k) temperature[i * IFOG_N_SENSORS + k] = row[2 + k];
        if (row[0] != 0.0) ifog_reset(&state);
        ifog_step(&state, time[i], temperature + i * IFOG_N_SENSORS,
                  streamed + i * IFOG_N_OUTPUTS);
    }
    for (i = 1; i <= n; ++i) {
        if (i == n || rows[i * WIDTH] != 0.0) {
            ifog_batch(i - start, time + start, temperature + start * IFOG_N_SENSORS,
                       batched + start * IFOG_N_OUTPUTS);
            start = i;
        }
    }
    for (i = 0; i < n; ++i) {
        for (k = 0; k < IFOG_N_OUTPUTS; ++k) {
            printf("%.17g ", (double)streamed[i * IFOG_N_OUTPUTS + k]);
        }
        for (k = 0; k < IFOG_N_OUTPUTS; ++k) {
            printf("%.17g ", (double)batched[i * IFOG_N_OUTPUTS + k]);
        }
        printf("\n");
    }
    return 0;
}
"""


# ---------------------------------------------------------------------------------------------
# Writing
# ---------------------------------------------------------------------------------------------


@contextlib.contextmanager
def _atomic_path(path):
    """The package's ``_io.atomic_path`` when importable, else a temporary sibling + rename."""
    try:
        from sklearn_ifog._io import atomic_path
    except ImportError:
        atomic_path = None
    if atomic_path is not None:
        with atomic_path(path) as temporary:
            yield Path(temporary)
        return
    path = Path(path)
    descriptor, temporary = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.")
    os.close(descriptor)
    try:
        yield Path(temporary)
        os.replace(temporary, path)
    except BaseException:
        with contextlib.suppress(FileNotFoundError):
            os.remove(temporary)
        raise


def _write_npz(path, arrays):
    with _atomic_path(path) as temporary, open(temporary, "wb") as stream:
        np.savez(stream, **arrays)


def _write_text(path, text):
    with _atomic_path(path) as temporary:
        Path(temporary).write_text(text, encoding="utf-8")


# ---------------------------------------------------------------------------------------------
# Snapshot helpers (run with the package under test)
# ---------------------------------------------------------------------------------------------


def _import_first(candidates, name):
    """``name`` from the first module of ``candidates`` that has it."""
    errors = []
    for module_name in candidates:
        try:
            module = importlib.import_module(module_name)
        except ImportError as exc:
            errors.append(f"{module_name}: {exc}")
            continue
        if hasattr(module, name):
            return getattr(module, name)
        errors.append(f"{module_name}: no {name}")
    raise ImportError(f"{name} not found in {candidates}: {errors}")


def _text(values):
    """A str array of ``values`` (masking dates and times)."""
    return np.array([TIMESTAMP.sub("<timestamp>", str(value)) for value in values], dtype=str)


def _columns(prefix, table):
    """Every column of a DataFrame (index included) as an array: numbers as they are, text
    as str (timings dropped)."""
    import pandas as pd

    if not isinstance(table, pd.DataFrame):
        table = pd.DataFrame(table)
    if any(name is not None for name in table.index.names):
        table = table.reset_index()
    out = {f"{prefix}:columns": _text(table.columns)}
    for position, name in enumerate(table.columns):
        if str(name) in TIMING_COLUMNS:
            continue
        values = table.iloc[:, position]
        key = f"{prefix}:{position}:{name}"
        if values.dtype.kind in "biuf":
            out[key] = values.to_numpy()
        else:
            out[key] = _text(values.tolist())
    return out


def _json_arrays(prefix, value):
    """Every leaf of parsed JSON by its path: number lists as arrays, strings exactly."""
    out = {}
    if isinstance(value, dict):
        out[f"{prefix}:keys"] = _text(value)
        for key, item in value.items():
            out.update(_json_arrays(f"{prefix}.{key}", item))
        return out
    if isinstance(value, list):
        try:
            array = np.asarray(value)
        except ValueError:  # ragged
            array = None
        if array is not None and array.dtype.kind in "biuf":
            return {prefix: array}
        if array is not None and array.dtype.kind == "U":
            return {prefix: array}
        out[f"{prefix}:length"] = np.array(len(value))
        for position, item in enumerate(value):
            out.update(_json_arrays(f"{prefix}[{position}]", item))
        return out
    if value is None:
        return {prefix: _text(["null"])}
    if isinstance(value, bool):
        return {prefix: np.array(value)}
    if isinstance(value, int | float):
        return {prefix: np.array(value)}
    return {prefix: _text([value])}


def _markdown(prefix, text):
    """Tables of a Markdown document as columns; its other lines as text."""
    out, lines, table, count = {}, [], [], 0

    def flush():
        nonlocal count
        if table:
            header = [cell.strip() for cell in table[0].strip("|").split("|")]
            rows = [[cell.strip() for cell in row.strip("|").split("|")] for row in table[2:]]
            out[f"{prefix}.table{count}:header"] = _text(header)
            for position, name in enumerate(header):
                if name in TIMING_COLUMNS:
                    continue
                cells = [row[position] for row in rows]
                try:
                    values = np.array([float(cell) for cell in cells])
                except ValueError:
                    values = _text(cells)
                out[f"{prefix}.table{count}:{position}:{name}"] = values
            count += 1
            table.clear()

    for line in text.splitlines():
        if line.startswith("|"):
            table.append(line)
        else:
            flush()
            lines.append(line)
    flush()
    out[f"{prefix}:lines"] = _text(lines)
    return out


def _simulated(quick=False):
    from sklearn_ifog.datasets import make_thermal_campaign

    frame = make_thermal_campaign(random_state=SEED, **(QUICK_CAMPAIGN if quick else {})).frame
    train = (frame["unit"] < 2).to_numpy()
    target = (frame["rate"] - frame["reference"]).to_numpy()
    return frame, train, target


def _real():
    from sklearn_ifog.datasets import load_psim_tvc

    frame = load_psim_tvc().frame
    train = (frame["burst"] < 15).to_numpy()
    target = frame[["gyro_x", "gyro_y", "gyro_z"]].to_numpy()
    return frame, train, target


def _snapshot_features(frame, real):
    import polars as pl

    from sklearn_ifog import ThermalFeatures

    out = {}

    def record(name, features, X):
        values = features.fit_transform(X)
        if hasattr(values, "to_numpy"):
            out[f"features.{name}:pandas_columns"] = _text(values.columns)
            values = values.to_numpy()
        out[f"features.{name}"] = np.asarray(values)
        out[f"features.{name}:names"] = _text(features.get_feature_names_out())

    if real is not None:
        for name, params in {
            "default-columns": {},
            "all-terms-smoothed": {"terms": TERMS[:4], "smoothing": 4.0},
            # Smoothing is a time constant in seconds: without a time column, none.
            "per-sample": {"time": None, "smoothing": 0.0},
        }.items():
            params = {"temperature": "temperature", "time": "time", "run": "burst", **params}
            record(f"real.{name}", ThermalFeatures(**params), real)

    columns = {"temperature": "temperature", "time": "time", "run": "run"}
    two = ["temperature", "chamber_temperature"]
    settings = {
        "default": {},
        "default-columns": columns,
        "traditional": {**columns, "terms": ("T", "dT")},
        **{f"term-{term}": {**columns, "terms": (term,)} for term in TERMS[:4]},
        "reversed-terms": {**columns, "terms": TERMS[3::-1]},
        "two-sensors-all-terms": {**columns, "temperature": two, "terms": TERMS},
        "two-sensors-gradient-smoothed": {
            **columns,
            "temperature": two,
            "terms": ("gradient", "dT"),
            "smoothing": 2.0,
        },
        "smoothed": {**columns, "smoothing": 3.0},
        "per-sample": {**columns, "time": None},
        "per-sample-smoothed": {**columns, "smoothing": 5.0},
        "rate-unit-s": {**columns, "rate_unit": "s"},
        "rate-unit-h": {**columns, "rate_unit": "h"},
        "rate-unit-30": {**columns, "rate_unit": 30.0},
    }
    for name, params in settings.items():
        record(f"sim.{name}", ThermalFeatures(**params), frame)

    everything = {**columns, "temperature": two, "terms": TERMS, "smoothing": 2.0}
    array = frame[["unit", "run", "time", "temperature", "chamber_temperature"]].to_numpy(float)
    record(
        "sim.numpy-positions",
        ThermalFeatures(temperature=[3, 4], time=2, run=1, terms=TERMS, smoothing=2.0),
        array,
    )
    record("sim.polars", ThermalFeatures(**everything), pl.from_pandas(frame))
    record(
        "sim.pandas-output",
        ThermalFeatures(**everything).set_output(transform="pandas"),
        frame,
    )
    # All runs interleaved (each keeps its time order): by time, ties in a random run order.
    run_key = np.random.default_rng(SEED).permutation(frame["run"].max() + 1)
    shuffled_order = np.lexsort((run_key[frame["run"].to_numpy()], frame["time"].to_numpy()))
    shuffled = frame.iloc[shuffled_order]
    record("sim.interleaved", ThermalFeatures(**everything), shuffled)
    named = frame.assign(run="u" + frame["unit"].astype(str) + "-r" + frame["run"].astype(str))
    record("sim.string-runs", ThermalFeatures(**everything), named.iloc[shuffled_order])
    return out


def _network_attributes(prefix, network):
    out = {}
    for name in ("centers_", "widths_", "coef_", "tail_coef_", "intercept_", "n_iter_"):
        out[f"{prefix}:{name}"] = np.asarray(getattr(network, name))
    return out


def _rbf_pipeline(run, **params):
    from sklearn.pipeline import make_pipeline
    from sklearn.preprocessing import StandardScaler

    from sklearn_ifog import RBFNetRegressor, ThermalFeatures

    return make_pipeline(
        ThermalFeatures(temperature="temperature", time="time", run=run),
        StandardScaler(),
        RBFNetRegressor(random_state=SEED, **params),
    )


def _snapshot_models(sim, real):
    from sklearn.linear_model import Ridge
    from sklearn.pipeline import make_pipeline
    from sklearn.preprocessing import StandardScaler

    from sklearn_ifog import ThermalFeatures

    out, models = {}, {}
    frame, train, target = sim
    fixed = {"n_centers": 20, "criterion": None}
    specifications = {"default": {}}
    for mode in REFINE_MODES:
        # Every mode, the default's included: what the default is may differ between the
        # revisions compared.
        specifications[f"refine-{mode}"] = {"refine": mode}
        specifications[f"fixed20-refine-{mode}"] = {**fixed, "refine": mode}
    for name, params in specifications.items():
        model = _rbf_pipeline("run", **params).fit(frame[train], target[train])
        out[f"model.sim.{name}:predict"] = model.predict(frame[~train])
        out.update(_network_attributes(f"model.sim.{name}", model[-1]))
        models[f"sim.{name}"] = model

    columns = ["temperature", "chamber_temperature", "run"]
    ridge = make_pipeline(
        ThermalFeatures(
            temperature=["temperature", "chamber_temperature"],
            run="run",
            terms=TERMS,
            smoothing=0.0,  # a time constant in seconds: none without a time column
        ),
        StandardScaler(),
        Ridge(alpha=1e-3),
    ).fit(frame.loc[train, columns], target[train])
    out["model.sim.ridge-two-sensors-per-sample:predict"] = ridge.predict(
        frame.loc[~train, columns]
    )
    models["sim.ridge-two-sensors-per-sample"] = ridge

    frame, train, target = real
    for name, params in {
        "default": {},
        "fixed20-refine-varpro": {**fixed, "refine": "varpro"},
        "fixed20-refine-lm": {**fixed, "refine": "lm"},
        "fixed20-refine-gd": {**fixed, "refine": "gd"},
        "fixed20-refine-None": {**fixed, "refine": None},
    }.items():
        model = _rbf_pipeline("burst", **params).fit(frame[train], target[train])
        out[f"model.real.{name}:predict"] = model.predict(frame[~train])
        out.update(_network_attributes(f"model.real.{name}", model[-1]))
        models[f"real.{name}"] = model
    return out, models


def _snapshot_streaming(models, sim, real):
    from sklearn_ifog.streaming import StreamingCompensator

    out = {}
    chunks = (1, 2, 17, 64, 250, 1000)
    cases = {
        "sim.default": (sim, "run", ["temperature"], 600),
        "sim.fixed20-refine-varpro": (sim, "run", ["temperature"], 600),
        "sim.ridge-two-sensors-per-sample": (
            sim,
            "run",
            ["temperature", "chamber_temperature"],
            600,
        ),
        "real.default": (real, "burst", ["temperature"], 500),
    }
    for name, ((frame, train, target), run, sensors, n_steps) in cases.items():
        model = models[name]
        test = frame[~train]
        rate = np.asarray(target)[~train] + 10.0  # any rate: compensated = rate - drift
        X = test[list(model[0].feature_names_in_)]
        compensator = StreamingCompensator(model)
        drifts, compensated = [], []
        start, position = 0, 0
        while start < len(X):
            stop = min(start + chunks[position % len(chunks)], len(X))
            done, drift = compensator.update(X.iloc[start:stop], rate=rate[start:stop])
            drifts.append(drift)
            compensated.append(done)
            start, position = stop, position + 1
        out[f"stream.{name}:update-drift"] = np.concatenate(drifts)
        out[f"stream.{name}:update-compensated"] = np.concatenate(compensated)
        out[f"stream.{name}:state"] = _text([json.dumps(compensator.get_state(), sort_keys=True)])

        compensator = StreamingCompensator(model)
        uses_time = model[0].time is not None
        drifts, compensated = [], []
        times = test["time"].to_numpy()
        temperatures = test[sensors].to_numpy()
        runs = test[run].to_numpy()
        for row in range(n_steps):
            done, drift = compensator.step(
                time=float(times[row]) if uses_time else None,
                temperature=temperatures[row],
                rate=rate[row],
                run=runs[row].item(),
            )
            drifts.append(drift)
            compensated.append(done)
        out[f"stream.{name}:step-drift"] = np.array(drifts)
        out[f"stream.{name}:step-compensated"] = np.array(compensated)
    return out


def _snapshot_export(models, sim, real):
    from sklearn_ifog.export import to_c, to_json

    compiler = shutil.which("cc")
    if compiler is None:
        raise RuntimeError("no C compiler 'cc' on this machine: the C export cannot be checked")
    out = {}
    cases = {
        "sim.default": (sim, "run", ["temperature"]),
        "sim.fixed20-refine-varpro": (sim, "run", ["temperature"]),
        "sim.ridge-two-sensors-per-sample": (sim, "run", ["temperature", "chamber_temperature"]),
        "real.fixed20-refine-lm": (real, "burst", ["temperature"]),
    }
    with tempfile.TemporaryDirectory(prefix="check-unchanged-c-") as directory:
        directory = Path(directory)
        for name, ((frame, train, _), run, sensors) in cases.items():
            model = models[name]
            test = frame[~train]
            runs = test[run].to_numpy()
            starts = np.r_[True, runs[1:] != runs[:-1]]
            rows = np.column_stack([starts.astype(float), test["time"], test[sensors]])
            parsed = json.loads(Path(to_json(model, directory / "model.json")).read_text())
            out.update(_json_arrays(f"json.{name}", parsed))
            for precision in ("double", "float"):
                build = directory / f"{name}-{precision}"
                build.mkdir()
                to_c(model, build, precision=precision)
                out[f"c.{name}.{precision}:ifog.h"] = _text([(build / "ifog.h").read_text()])
                out[f"c.{name}.{precision}:ifog.c"] = _text([(build / "ifog.c").read_text()])
                (build / "driver.c").write_text(C_DRIVER)
                rows.astype(np.float64).tofile(build / "in.bin")
                subprocess.run(
                    [compiler, "-std=c99", "-O0", "driver.c", "ifog.c", "-lm", "-o", "driver"],
                    cwd=build,
                    check=True,
                    capture_output=True,
                )
                result = subprocess.run(
                    [str(build / "driver"), str(len(rows)), "in.bin"],
                    cwd=build,
                    check=True,
                    capture_output=True,
                    text=True,
                )
                values = np.array(result.stdout.split(), dtype=np.float64)
                values = values.reshape(len(rows), 2, -1)
                out[f"c.{name}.{precision}:step"] = values[:, 0]
                out[f"c.{name}.{precision}:batch"] = values[:, 1]
    return out


def _snapshot_demo():
    import pandas as pd

    from sklearn_ifog import load_model
    from sklearn_ifog.report import Report

    run_demo = _import_first(
        [
            "sklearn_ifog.cli",
            "sklearn_ifog.cli.demo",
            "sklearn_ifog.cli._demo",
            "sklearn_ifog.demo",
        ],
        "run_demo",
    )
    captured = []
    add_table = Report.add_table

    def recording_add_table(self, table, *args, **kwargs):
        captured.append(table)
        return add_table(self, table, *args, **kwargs)

    out = {}
    with tempfile.TemporaryDirectory(prefix="check-unchanged-demo-") as directory:
        target = Path(directory) / "demo"
        Report.add_table = recording_add_table
        try:
            with (
                contextlib.redirect_stdout(io.StringIO()),
                contextlib.redirect_stderr(io.StringIO()),
            ):
                written = run_demo(target, quick=True)
        finally:
            Report.add_table = add_table
        for role in sorted(written):
            paths = written[role]
            paths = paths if isinstance(paths, list) else [paths]
            out[f"demo.written.{role}"] = _text([Path(path).name for path in paths])
        out["demo.files"] = _text(sorted(path.name for path in target.iterdir()))
        campaign = pd.read_csv(target / "campaign.csv")
        out.update(_columns("demo.campaign.csv", campaign))
        out.update(_markdown("demo.report.md", (target / "report.md").read_text()))
        model = load_model(target / "model.joblib")
        columns = list(model[0].feature_names_in_)
        out["demo.model.joblib:predict"] = model.predict(campaign[columns])
    for position, table in enumerate(captured):
        out.update(_columns(f"demo.add_table{position}", table))
    return out


def snapshot(path, expect_root=None, parts=None, quick=False):
    """Run the workload with the ``sklearn_ifog`` that Python imports; save every result.

    ``parts``: None for the whole workload, ``("features",)`` for the features only;
    ``quick``: the smaller simulated campaign (``QUICK_CAMPAIGN``).
    """
    import sklearn_ifog

    location = Path(sklearn_ifog.__file__).resolve()
    if expect_root is not None and not location.is_relative_to(Path(expect_root).resolve()):
        print(
            f"error: sklearn_ifog was imported from {location}, not from under {expect_root}",
            file=sys.stderr,
        )
        raise SystemExit(2)
    print(f"snapshot of {location.parent}", file=sys.stderr)
    started = time.perf_counter()

    def done(part):
        print(f"  {part}: {time.perf_counter() - started:.0f} s", file=sys.stderr)

    sim, real = _simulated(quick), _real()
    arrays = {}
    arrays.update(_snapshot_features(sim[0], real[0]))
    done("features")
    if parts is not None and tuple(parts) == ("features",):
        _write_npz(path, arrays)
        print(f"wrote {len(arrays)} quantities to {path}", file=sys.stderr)
        return
    model_arrays, models = _snapshot_models(sim, real)
    arrays.update(model_arrays)
    done("models")
    arrays.update(_snapshot_streaming(models, sim, real))
    done("streaming")
    arrays.update(_snapshot_export(models, sim, real))
    done("export")
    arrays.update(_snapshot_demo())
    done("demo")
    _write_npz(path, arrays)
    print(f"wrote {len(arrays)} quantities to {path}", file=sys.stderr)


# ---------------------------------------------------------------------------------------------
# Comparison (needs only numpy)
# ---------------------------------------------------------------------------------------------


def _compare_one(a, b):
    """(shape, max |diff|, max relative diff, verdict) of two stored arrays."""
    if a is None or b is None:
        present = a if a is not None else b
        side = "baseline" if a is None else "current"
        return str(present.shape), "", "", f"DIFFERENT (missing in {side})"
    shape = str(a.shape) if a.shape == b.shape else f"{a.shape} vs {b.shape}"
    if a.dtype.kind in "US" or b.dtype.kind in "US":
        same = a.dtype.kind == b.dtype.kind and a.shape == b.shape and np.array_equal(a, b)
        return shape, "", "", "identical" if same else "DIFFERENT (text)"
    if a.shape != b.shape:
        return shape, "", "", "DIFFERENT (shape)"
    if a.dtype == b.dtype and a.tobytes() == b.tobytes():
        return shape, "0", "0", "identical"
    x, y = a.astype(np.float64), b.astype(np.float64)
    if not np.array_equal(np.isnan(x), np.isnan(y)) or not np.array_equal(
        x[np.isinf(x)], y[np.isinf(x)]
    ):
        return shape, "", "", "DIFFERENT (NaN or inf)"
    finite = np.isfinite(x)
    difference = float(np.max(np.abs(x[finite] - y[finite]), initial=0.0))
    scale = float(np.max(np.abs(x[finite]), initial=0.0))
    relative = difference / scale if scale > 0 else (0.0 if difference == 0 else np.inf)
    if a.dtype != b.dtype:
        verdict = f"DIFFERENT (dtype {a.dtype} vs {b.dtype})"
    elif relative <= RELATIVE_TOLERANCE:
        verdict = "within 1e-15 (summation order)"
    else:
        verdict = "DIFFERENT"
    return shape, f"{difference:.3g}", f"{relative:.3g}", verdict


def _first_text_difference(a, b):
    """Where two text arrays first differ, for the notes under the table."""
    if a.shape != b.shape:
        return f"{a.size} vs {b.size} strings"
    for position, (left, right) in enumerate(zip(a.ravel(), b.ravel(), strict=True)):
        if left != right:
            left_lines, right_lines = str(left).splitlines(), str(right).splitlines()
            for line, (one, two) in enumerate(zip(left_lines, right_lines, strict=False)):
                if one != two:
                    return f"item {position}, line {line + 1}: {one[:80]!r} vs {two[:80]!r}"
            return f"item {position}: {len(left_lines)} vs {len(right_lines)} lines"
    return "dtype"


def compare(baseline_path, current_path, *, labels=("baseline", "current")):
    """Markdown table comparing two snapshots, and whether everything matched."""
    with np.load(baseline_path) as a_file, np.load(current_path) as b_file:
        a = {key: a_file[key] for key in a_file.files}
        b = {key: b_file[key] for key in b_file.files}
    keys = list(a) + [key for key in b if key not in a]
    rows, notes, counts, parts = [], [], {}, {}
    for key in keys:
        shape, difference, relative, verdict = _compare_one(a.get(key), b.get(key))
        rows.append(f"| `{key}` | {shape} | {difference} | {relative} | {verdict} |")
        kind = "DIFFERENT" if verdict.startswith("DIFFERENT") else verdict
        counts[kind] = counts.get(kind, 0) + 1
        part = parts.setdefault(key.split(".")[0], dict.fromkeys(VERDICTS, 0))
        part[kind] += 1
        if verdict == "DIFFERENT (text)":
            notes.append(f"- `{key}`: {_first_text_difference(a[key], b[key])}")
    ok = counts.get("DIFFERENT", 0) == 0
    lines = [
        f"Snapshots compared: {labels[0]} ({len(a)} quantities) against {labels[1]} "
        f"({len(b)} quantities).",
        "",
        "| part | quantities | " + " | ".join(VERDICTS) + " |",
        "| --- | --- | " + " | ".join("---" for _ in VERDICTS) + " |",
    ]
    for part, part_counts in parts.items():
        cells = " | ".join(str(part_counts[verdict]) for verdict in VERDICTS)
        lines.append(f"| {PARTS.get(part, part)} | {sum(part_counts.values())} | {cells} |")
    summary = ", ".join(f"{counts.get(verdict, 0)} {verdict}" for verdict in VERDICTS)
    lines += [
        f"| all | {len(keys)} | " + " | ".join(str(counts.get(v, 0)) for v in VERDICTS) + " |",
        "",
        f"Verdict: {'UNCHANGED' if ok else 'CHANGED'} ({summary}).",
        "",
        "| quantity | shape | max abs diff | max rel diff | verdict |",
        "| --- | --- | --- | --- | --- |",
        *rows,
    ]
    if notes:
        lines += ["", "Text differences (first differing line):", *notes]
    return "\n".join(lines) + "\n", ok


# ---------------------------------------------------------------------------------------------
# Baseline run
# ---------------------------------------------------------------------------------------------


def _start_snapshot(package_root, output, parts=None, quick=False):
    """Start ``--snapshot output`` in a subprocess that imports the package under
    ``package_root``; its stderr goes to ``output.log``."""
    environment = {**os.environ, "PYTHONPATH": str(package_root)}
    log = open(output.with_suffix(".log"), "w")  # noqa: SIM115 - closed in _finish_snapshot
    command = [
        sys.executable,
        str(Path(__file__).resolve()),
        "--snapshot",
        str(output),
        "--expect-root",
        str(package_root),
    ]
    if parts:
        command += ["--parts", *parts]
    if quick:
        command.append("--quick")
    process = subprocess.Popen(
        command, env=environment, cwd=output.parent, stdout=log, stderr=subprocess.STDOUT
    )
    return process, log


def _finish_snapshot(process, log, package_root):
    returncode = process.wait()
    log.close()
    text = Path(log.name).read_text()
    print(text, end="", file=sys.stderr)
    if returncode != 0:
        print(f"error: the snapshot of {package_root} failed", file=sys.stderr)
        raise SystemExit(2)


def _git(*args):
    """Output of one git command in this repository, stripped."""
    return subprocess.run(
        ["git", "-C", str(REPOSITORY), *args], check=True, capture_output=True, text=True
    ).stdout.strip()


def against_baseline(revision, parts=None, quick=False):
    with tempfile.TemporaryDirectory(prefix="check-unchanged-") as directory:
        directory = Path(directory)
        tree = directory / "baseline"
        tree.mkdir()
        archive = subprocess.run(
            ["git", "-C", str(REPOSITORY), "archive", "--format=tar", revision],
            check=True,
            capture_output=True,
        )
        subprocess.run(["tar", "-x", "-C", str(tree)], input=archive.stdout, check=True)
        commit = _git("rev-parse", "--short", f"{revision}^{{commit}}")
        head = _git("rev-parse", "--short", "HEAD")
        dirty = _git("status", "--porcelain", "--untracked-files=no")
        before, after = directory / "baseline.npz", directory / "current.npz"
        # Both at once: each is mostly single-threaded.
        running = [
            (*_start_snapshot(root, path, parts, quick), root)
            for root, path in [(tree, before), (REPOSITORY, after)]
        ]
        for process, log, root in running:
            _finish_snapshot(process, log, root)
        labels = (
            f"baseline {commit}",
            f"working tree at {head}" + (" (modified)" if dirty else ""),
        )
        text, ok = compare(before, after, labels=labels)
    command = f"python benchmarks/check_unchanged.py --baseline {revision}" + (
        " --quick" if parts else ""
    )
    text = f"# check_unchanged: {labels[0]} against {labels[1]}\n\nCommand: `{command}`\n\n" + text
    return text, ok


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n", 1)[0])
    mode = parser.add_mutually_exclusive_group()
    mode.add_argument(
        "--baseline",
        metavar="REV",
        help=f"git revision to compare the working tree with (default {DEFAULT_BASELINE})",
    )
    mode.add_argument("--snapshot", metavar="PATH", help="write one snapshot (.npz) and stop")
    mode.add_argument("--compare", nargs=2, metavar=("A", "B"), help="compare two snapshots")
    parser.add_argument("--expect-root", help=argparse.SUPPRESS)
    parser.add_argument("--parts", nargs="+", help=argparse.SUPPRESS)
    parser.add_argument(
        "--quick", action="store_true", help="CI: features only, against HEAD by default"
    )
    parser.add_argument("--out", metavar="PATH", help="also write the Markdown table here")
    args = parser.parse_args(argv)

    if args.snapshot:
        snapshot(
            Path(args.snapshot).resolve(),
            expect_root=args.expect_root,
            parts=args.parts,
            quick=args.quick,
        )
        return 0
    if args.compare:
        text, ok = compare(*args.compare, labels=tuple(args.compare))
    else:
        default = "HEAD" if args.quick else DEFAULT_BASELINE
        parts = ("features",) if args.quick else None
        text, ok = against_baseline(args.baseline or default, parts, args.quick)
    print(text, end="")
    print(target_line(ok, f"every quantity identical or within {RELATIVE_TOLERANCE:g}"))
    if args.out:
        _write_text(args.out, text)
    return 0 if ok else 1


if __name__ == "__main__":
    raise SystemExit(main())
