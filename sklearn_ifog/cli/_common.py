"""What the commands share: the program name, the exit statuses, the user's error, how a
table is printed and the check of a coverage option."""

import sys

PROGRAM = "sklearn-ifog"
EXIT_OK = 0
EXIT_INTERNAL = 1
EXIT_BAD_INPUT = 2
EXIT_INTERRUPTED = 130


class InputError(Exception):
    """Bad input the user can fix: reported as one line on stderr, exit status 2."""


def one_line(error):
    """The text of an exception (or warning) on one line; its type's name when empty."""
    return " ".join(str(error).split()) or type(error).__name__


def print_table(title, table, stream=None, float_format="{:.3g}"):
    """Print a DataFrame under a title (stdout by default)."""
    stream = sys.stdout if stream is None else stream
    print(f"\n{title}", file=stream)
    print(table.to_string(float_format=float_format.format), file=stream)


def check_coverage(value, option="--interval"):
    """An InputError unless ``value``, given with ``option``, is a coverage in (0, 1)."""
    if not 0.0 < value < 1.0:
        raise InputError(f"{option} must be a coverage in (0, 1), e.g. 0.9; got {value:g}")
