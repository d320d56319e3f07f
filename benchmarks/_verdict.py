"""Verdicts shared by the benchmarks: targets, comparisons with a tie margin, exit codes.

Every benchmark prints, at the end of its output, one line per target and per comparison:

- ``PASS: <target> (<measured>)`` or ``FAIL: <target> (<measured>)``;
- ``WIN: ...``, ``TIE: ...`` or ``LOSS: ...`` for a comparison of our model with one peer on
  a lower-is-better score: WIN when ours is below the peer's by more than ``TIE_MARGIN`` of
  the larger of the two magnitudes, LOSS when above it by more than that, TIE otherwise. A
  tie is never a win: a target "beats X" needs WIN. The band is on the difference, so the
  verdict is right for every sign (an excess over a noise floor can be negative, where a
  band built as ``theirs * (1 +- margin)`` would swap its ends).

and exits 1 when any target fails (0 otherwise). A target that cannot be judged at the size
of a ``--quick`` run (a timing on a toy lot, a margin a one-seed campaign cannot resolve) is
printed as ``INFO: <target> ...`` instead (``info_line``): never a verdict, never in the exit
code. A quick run's PASS/FAIL lines are the regression guards a broken default would fail, so
``tests/test_benchmarks.py`` requires every quick run to exit 0; it checks these lines'
format and that the exit code agrees with them.
"""

import re

# Two scores within 2% of each other tie: about the spread of a held-out MSD between
# neighbouring seeds of the same model, and the "no worse than 1.02x".
TIE_MARGIN = 0.02
LINE = re.compile(r"^(PASS|FAIL|WIN|TIE|LOSS|INFO): \S.*$")


def relative_difference(ours, theirs):
    """``(ours - theirs) / max(|ours|, |theirs|)``, in [-2, 2]; 0 when both are 0."""
    scale = max(abs(ours), abs(theirs))
    return 0.0 if scale == 0 else (ours - theirs) / scale


def compare(ours, theirs, margin=TIE_MARGIN):
    """WIN, TIE or LOSS of a lower-is-better score ``ours`` against ``theirs``.

    The tie band is ``margin`` times the larger magnitude, on either side of ``theirs``:
    right for negative, zero and mixed-sign scores alike.
    """
    difference = relative_difference(ours, theirs)
    if difference < -margin:
        return "WIN"
    if difference > margin:
        return "LOSS"
    return "TIE"


def comparison_line(ours_name, theirs_name, ours, theirs, what, margin=TIE_MARGIN):
    """One ``WIN/TIE/LOSS`` line, with both scores, their ratio and relative difference."""
    outcome = compare(ours, theirs, margin)
    ratio = ours / theirs if theirs else float("inf")
    return (
        f"{outcome}: {ours_name} vs {theirs_name}, {what}: {ours:.4g} vs {theirs:.4g} "
        f"(ratio {ratio:.4f}; difference {relative_difference(ours, theirs):+.4f} of the "
        f"larger; tie within {margin:.0%})"
    )


def target_line(passed, text):
    """One ``PASS/FAIL`` line."""
    return f"{'PASS' if passed else 'FAIL'}: {text}"


def info_line(passed, text):
    """One ``INFO`` line: a target not judged at this size, with whether it held."""
    return f"INFO: {text}; not judged at this size ({'held' if passed else 'did not hold'})"


def verdict_line(passed, text, judged=True):
    """``target_line`` when the target is ``judged`` at this size, else ``info_line``."""
    return target_line(passed, text) if judged else info_line(passed, text)


def exit_code(passed):
    """0 when every target passed, 1 otherwise (``passed``: iterable of booleans)."""
    return 0 if all(passed) else 1
