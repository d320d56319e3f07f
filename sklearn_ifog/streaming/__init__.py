"""Online (sample-by-sample or chunked) drift compensation with a fitted Pipeline.

The only stateful step of a compensation Pipeline is :class:`~sklearn_ifog.ThermalFeatures`
(differences, lags and the smoothing are causal recursions); every later step acts row by row.
The compensator therefore carries, between calls, the last temperature of each sensor, the
last time stamp, the deficit of every first-order lag (per sensor and per time constant: the
lag terms and the smoothing, :class:`sklearn_ifog._lags.LagState`) and a first-row flag,
computes the features of a chunk with the same plain functions as the batch transformer,
started from that state, and hands the rows to the fitted steps after ThermalFeatures
unchanged. Its output is the batch Pipeline's, whatever the chunking. A
:class:`~sklearn_ifog.pipeline.CompensationPipeline` also brings its calibration domain:
the same distance of every feature row and the same ``uncalibrated`` policy as its ``predict``
(:class:`sklearn_ifog._compiled.CompiledDomain`), and a flag per row instead of a warning.

A package: the compensator (``_compensator``), its feature state machine (``_features``:
:func:`advance_features`), its state's schema and checks (``_state``), the recalibration
(``_recalibration``), the conformal band (``_band``) and the input checks (``_inputs``).
The public names, :class:`~sklearn_ifog.streaming.StreamingCompensator` and
:func:`~sklearn_ifog.streaming.advance_features`, are importable from
``sklearn_ifog.streaming``.
"""

from sklearn_ifog.streaming._compensator import StreamingCompensator
from sklearn_ifog.streaming._features import advance_features

__all__ = ["StreamingCompensator", "advance_features"]
