"""The calibration domain's tuned numbers, in one home (issue 43, point 4).

Private: none of them is a parameter a user sets (the public parameters that default to
them say so, e.g. ``fit_fallback(repeated_ratio=...)``). Each says where it was chosen and
which benchmark or test measures it. Several modules read them: the domain
(:mod:`sklearn_ifog.domain`), its fallback (:mod:`sklearn_ifog.fallback`), the pipeline,
the compiled path and the description both exports write (which repeat the formulas), and
the report and the command line (which word an excess).
"""

__all__ = [
    "CARRIED_SCALE",
    "HANDOVER_FOLDS",
    "INPUT_RATE_SLACK",
    "NOVELTY_RAMP",
    "PROJECTION_ROUNDS",
    "RATE_WEIGHT",
    "REPEATED_RATIO",
    "ROUNDOFF_SHARE",
]

# -- the domain's distance (sklearn_ifog.domain) -----------------------------------------------

#: Weight of a rate's excess in the distance: a rate feature (``rate`` of
#: :class:`~sklearn_ifog.CalibrationDomain`) that lies beyond its calibrated range adds its
#: excess, in standard deviations of that feature times this weight, to the distance as one
#: more axis. The decorrelated axes spread a rate excess over several of them and a
#: heating-only calibration covers its rates one-sidedly, so a cooling row of such a
#: calibration would otherwise stay within the margin while its network extrapolates to rates
#: it never saw. Chosen on the tuning seeds 0-7 of ``benchmarks/bench_extrapolation.py
#: --tune`` (its sweep): the largest weight that keeps the shared-profile rows inside the
#: calibrated temperatures flagged at most 2 % there; judged on seeds 8-12 (since retired, see
#: ``benchmarks/_cases.SEEDS``). The C export writes it (``boost_rate_ramp``, the rate scale).
RATE_WEIGHT = 2.0
#: The boost (``Box.boost``) is added in full from a novelty of this many standard
#: deviations of the rate or the temperature beyond its calibrated range: a short ramp,
#: only so that the distance stays continuous where a row leaves them (the exports repeat
#: it). Not tuned on a benchmark: ``tests/test_properties.py`` (the blend is continuous in
#: the distance) and ``tests/test_domain_mutants.py`` measure it.
NOVELTY_RAMP = 0.01
#: Rounds of alternating projection (box, then temperature ranges) of
#: :meth:`~sklearn_ifog.CalibrationDomain.project`, the ``"clip"`` policy (the exports repeat
#: them). Not tuned on a benchmark: ``tests/test_properties.py`` (``"clip"`` stays in the
#: widened box) and the C export's equality with Python (``tests/test_export_domain.py``)
#: measure it.
PROJECTION_ROUNDS = 8
#: A rate dT beyond its calibrated range by at most this share of that range is round-off,
#: not a rate the calibration never saw: the pipeline's warning, the report and the command
#: line do not word it (an excess as :meth:`~sklearn_ifog.CalibrationDomain.excess` reads
#: it; no flag or prediction depends on this share).
#: Why relative to the calibrated range: the excess is the difference of a rate recomputed
#: from a new log (a difference of temperatures over a time step, through the lags) and the
#: calibrated extreme, each carrying a few units in the last place of numbers of the size
#: of that range; so round-off scales with the range, in whatever unit dT is read (degC per
#: minute or per second: an absolute tolerance would be 60 times off in one of them). It
#: cannot be relative to the extreme itself: the slowest rate of a heating-only calibration
#: is a soak's, about 0, where any round-off (a 1.47e-14 below it) is infinitely many times
#: the value. 1e-9 of the range is ten million times a double's round-off and far below any
#: rate excess a calibration could be faulted for. Not tuned on a benchmark:
#: ``tests/test_stale_texts.py`` measures the wording on both sides of it.
ROUNDOFF_SHARE = 1e-9

# -- the fallback (sklearn_ifog.fallback) ------------------------------------------------------

#: Largest held-out-run error ratio of the plane in T and dT
#: (:func:`~sklearn_ifog.fallback.held_out_runs`, its squared error over a constant's) at
#: which :func:`~sklearn_ifog.fallback.fit_fallback` trusts it (its ``repeated_ratio``):
#: chosen on the tuning seeds 0-7 of ``benchmarks/bench_extrapolation.py --tune`` (its sweep
#: of 0.5-1.0), judged on seeds 8-12 (since retired, see ``benchmarks/_cases.SEEDS``).
REPEATED_RATIO = 0.75
#: Smallest held-out-run scale of the plane in T and dT
#: (:func:`~sklearn_ifog.fallback.held_out_runs` with ``return_scale=True``: the
#: least-squares factor by which the held-out runs' drift, about the other runs' mean,
#: follows the plane's prediction of it) at which
#: :func:`~sklearn_ifog.fallback.fit_fallback` also trusts a plane whose held-out-run ratio
#: lies between ``REPEATED_RATIO`` and 1 (its ``carried_scale``). A plane whose predictions
#: the held-out runs bear out in full (a scale near 1) is a thermal relation drowned in
#: run-to-run noise; one that overshoots them (a smaller scale) extrapolates worse than a
#: constant. Chosen on the tuning seeds 0-7 of ``benchmarks/bench_extrapolation.py --tune``
#: (its sweep), judged on seeds 8-12 (since retired, see ``benchmarks/_cases.SEEDS``).
CARRIED_SCALE = 0.9

# -- the held-out handover (sklearn_ifog.pipeline, handover=True) ------------------------------

#: Folds of whole runs (the runs dealt out in turn) of the held-out evidence per kind of
#: novelty: each fold costs one more fit of the steps. A cost, not a tuned accuracy:
#: ``benchmarks/bench_extrapolation.py`` measures the handover's flags, cost and fit time
#: beside the default.
HANDOVER_FOLDS = 3

# -- the scale factor (sklearn_ifog.pipeline, input_rate) ---------------------------------------

#: Share of the largest calibrated input-rate magnitude by which a row's input rate may lie
#: beyond the calibrated ones and still count as calibrated: a rate table's commanded steps
#: repeat to far better than this, and the Earth-rate component (at most 15 deg/h) is within
#: it at every calibrated rate from 1 deg/s up. Not tuned on accuracy.
INPUT_RATE_SLACK = 0.05
