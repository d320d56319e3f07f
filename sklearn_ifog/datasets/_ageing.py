"""An aged copy of a simulated campaign: the calibration a gyro drifts away from.

Between calibration and use, a gyro's turn-on bias shifts and its thermal sensitivity
changes (storage, shocks, ageing of the coil's potting: the potting's stiffness, hence the
stress-induced and Shupe terms, creeps with time). :func:`age_campaign` applies both to the
runs of a campaign recorded after the ageing, deterministically, so that the same thermal
histories can be compensated before and after it.
"""

from numbers import Real

import numpy as np
import pandas as pd
from sklearn.utils import Bunch

from sklearn_ifog._compat import Interval, validate_params

__all__ = ["age_campaign"]


@validate_params(
    {
        "campaign": [Bunch],
        "bias_shift": [Real],
        "sensitivity_change": [Interval(Real, -1.0, None, closed="right")],
        "runs": ["array-like", None],
    },
    prefer_skip_nested_validation=True,
)
def age_campaign(campaign, *, bias_shift=0.0, sensitivity_change=0.0, runs=None):
    """An aged copy of a simulated campaign: bias shift and thermal-sensitivity change.

    On the selected runs, the true thermal drift becomes
    ``drift_aged = (1 + sensitivity_change) * drift + bias_shift``, and the gyro output
    changes by the same amount (``rate += drift_aged - drift``); the noise
    (``rate - reference - drift``) and the temperatures are unchanged, so
    :func:`~sklearn_ifog.datasets.noise_floor` still holds.

    Parameters
    ----------
    campaign : Bunch
        From :func:`~sklearn_ifog.datasets.make_thermal_campaign` with ``as_frame=True``.
    bias_shift : float, default=0.0
        Change of the bias, deg/h.
    sensitivity_change : float, default=0.0
        Relative change of the thermal drift (0.2: 20 % more), > -1.
    runs : array-like of int, default=None
        Run ids recorded after the ageing; None: every run.

    Returns
    -------
    aged : Bunch
        The campaign's fields, with ``frame``, ``data``, ``target`` and ``components``
        (a new column ``ageing``: the added drift, deg/h) changed on the aged runs, and
        ``ageing``: a dict of the three parameters (``runs`` as a list).

    Raises
    ------
    ValueError
        If ``campaign`` has no frame (``as_frame=False``), or a run id is not in it.

    Examples
    --------
    >>> from sklearn_ifog.datasets import age_campaign, make_thermal_campaign
    >>> campaign = make_thermal_campaign(n_units=1, n_runs=2, azimuths=[0.0], random_state=0)
    >>> aged = age_campaign(campaign, bias_shift=0.05, sensitivity_change=0.2, runs=[1])
    >>> new, old = aged.frame, campaign.frame
    >>> bool(((new["drift"] - old["drift"])[old["run"] == 0] == 0).all())
    True
    >>> late = old["run"] == 1
    >>> bool(((new["drift"] - (1.2 * old["drift"] + 0.05))[late].abs() < 1e-15).all())
    True
    """
    frame = campaign.get("frame")
    if not isinstance(frame, pd.DataFrame):
        raise ValueError(
            "age_campaign needs a campaign made with as_frame=True (its 'frame' is a "
            f"DataFrame), got frame of type {type(frame).__name__}."
        )
    known = pd.unique(frame["run"])
    if runs is None:
        selected = np.ones(len(frame), dtype=bool)
        run_list = [int(run) for run in known]
    else:
        run_list = [int(run) for run in np.atleast_1d(np.asarray(runs))]
        missing = sorted(set(run_list) - set(int(run) for run in known))
        if missing:
            raise ValueError(
                f"runs {missing} are not in the campaign (its runs: {sorted(known.tolist())})."
            )
        selected = frame["run"].isin(run_list).to_numpy()
    drift = frame["drift"].to_numpy()
    added = np.where(selected, float(sensitivity_change) * drift + float(bias_shift), 0.0)
    aged_frame = frame.copy()
    aged_frame["drift"] = drift + added
    aged_frame["rate"] = frame["rate"].to_numpy() + added
    target = (aged_frame["rate"] - aged_frame["reference"]).rename(campaign.target.name)
    components = campaign.components.copy()
    components["ageing"] = added
    return Bunch(
        **{
            **campaign,
            "frame": aged_frame,
            "data": aged_frame[list(campaign.feature_names)],
            "target": target,
            "components": components,
            "ageing": {
                "bias_shift": float(bias_shift),
                "sensitivity_change": float(sensitivity_change),
                "runs": run_list,
            },
        }
    )
