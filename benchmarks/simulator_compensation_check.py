"""Quick check that the simulator reproduces the reference paper's claims.

Per unit: train on the runs at one azimuth, test on the runs at another azimuth, with simple
hand-computed features (T, per-sample dT, T*dT; optionally EMA-smoothed before differencing).
Prints raw MSD and compensated MSD for several models ("vs drift": MSD of the prediction
against the noise-free true drift, i.e. the model error without the noise floor). Run:

    .venv/bin/python benchmarks/simulator_compensation_check.py
"""

import time

import numpy as np
from scipy.signal import lfilter
from sklearn.compose import ColumnTransformer
from sklearn.kernel_approximation import Nystroem
from sklearn.linear_model import LinearRegression, Ridge
from sklearn.pipeline import make_pipeline
from sklearn.preprocessing import PolynomialFeatures, StandardScaler

from sklearn_ifog.datasets import make_thermal_campaign


def features(frame, smoothing):
    out = []
    for _, run in frame.groupby("run", sort=False):
        T = run["temperature"].to_numpy()
        a = 1.0 / (1.0 + smoothing)
        s, _ = lfilter([a], [1.0, a - 1.0], T[1:], zi=[(1.0 - a) * T[0]])
        s = np.concatenate(([T[0]], s))
        dT = np.diff(s, prepend=s[0])
        out.append(np.column_stack([T, dT, T * dT]))
    return np.vstack(out)


def models():
    poly = lambda: make_pipeline(  # noqa: E731
        StandardScaler(), PolynomialFeatures(3), Ridge(alpha=1e-3)
    )
    additive = make_pipeline(
        StandardScaler(),
        ColumnTransformer(
            [
                ("T", PolynomialFeatures(3, include_bias=False), [0]),
                ("dT", PolynomialFeatures(3, include_bias=False), [1]),
            ]
        ),
        Ridge(alpha=1e-3),
    )
    rbf = lambda: make_pipeline(  # noqa: E731
        StandardScaler(), Nystroem(gamma=0.5, n_components=100, random_state=0), Ridge(1e-3)
    )
    return {
        "linear (T,dT)": ([0, 1], LinearRegression()),
        "linear (T,dT,TdT)": ([0, 1, 2], LinearRegression()),
        "additive poly3 g(T)+h(dT)": ([0, 1], additive),
        "poly3 (T,dT) [has T*dT cross]": ([0, 1], poly()),
        "poly3 (T,dT,TdT)": ([0, 1, 2], poly()),
        "gaussian-rbf (T,dT)": ([0, 1], rbf()),
        "gaussian-rbf (T,dT,TdT)": ([0, 1, 2], rbf()),
    }


def main():
    start = time.perf_counter()
    campaign = make_thermal_campaign(random_state=0)
    print(f"default campaign: {len(campaign.frame)} rows in {time.perf_counter() - start:.3f} s")
    frame = campaign.frame
    y_all = (frame["rate"] - frame["reference"]).to_numpy()
    drift = frame["drift"].to_numpy()
    for smoothing in (0.0, 6.0):
        print(f"\n--- dT from EMA-smoothed temperature, smoothing={smoothing} samples ---")
        print("train on one azimuth's 5 runs of a unit, test on another azimuth's 5 runs;")
        print("6 cases (3 units x (0->90, 45->135 deg)); MSD in (deg/h)^2")
        X_all = features(frame, smoothing)
        results, errors, raws = {}, {}, []
        for unit in sorted(frame["unit"].unique()):
            for train_az, test_az in [(0.0, 90.0), (45.0, 135.0)]:
                train = ((frame["unit"] == unit) & (frame["azimuth"] == train_az)).to_numpy()
                test = ((frame["unit"] == unit) & (frame["azimuth"] == test_az)).to_numpy()
                raws.append(np.mean(y_all[test] ** 2))
                predictions = {"oracle (true drift)": drift[test]}
                for name, (cols, model) in models().items():
                    model.fit(X_all[train][:, cols], y_all[train])
                    predictions[name] = model.predict(X_all[test][:, cols])
                for name, pred in predictions.items():
                    results.setdefault(name, []).append(np.mean((y_all[test] - pred) ** 2))
                    errors.setdefault(name, []).append(np.mean((drift[test] - pred) ** 2))
        raw = np.array(raws)
        header = f"{'model':36s} {'MSD':>9s} {'min ratio':>9s} {'med ratio':>9s} {'vs drift':>9s}"
        print(header)
        print(f"{'raw (no compensation)':36s} {raw.mean():9.2e}")
        for name, values in results.items():
            ratio = raw / np.array(values)
            print(
                f"{name:36s} {np.mean(values):9.2e} {ratio.min():9.1f} {np.median(ratio):9.1f}"
                f" {np.mean(errors[name]):9.2e}"
            )


if __name__ == "__main__":
    main()
