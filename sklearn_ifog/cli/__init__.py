"""The ``sklearn-ifog`` command line.

Subcommands::

    sklearn-ifog demo [--out DIR] [--quick]
    sklearn-ifog fit DATA.csv --temperature COL [--time COL] [--run COL]
                 [--rate COL] [--reference COL | --latitude DEG --azimuth COL]
                 [--groups COL] [--cv unit|azimuth|run] -o MODEL
    sklearn-ifog compensate MODEL DATA.csv -o OUT.csv
    sklearn-ifog report MODEL DATA.csv --out DIR
    sklearn-ifog export MODEL (--c DIR | --json FILE)

Exit status: 0 on success; 2 on bad input (a missing file or column, text in a number
column, time not increasing within a run, an empty file, ...) with one line on stderr naming
the problem; 1 on an unexpected internal error (``--debug`` shows its traceback); 130 when
interrupted (Ctrl-C). Every output is written to a temporary file (or staging directory)
first and renamed into place only when complete, so a failure leaves no partial output
behind: see ``sklearn_ifog._io`` for the exact guarantee of the multi-file outputs (the
demo's directory, the report, the C export).

Layout: ``_main`` parses and dispatches; ``_fit`` holds ``fit``; ``_compensate`` holds
``compensate`` and ``report``; ``_export`` holds ``export``; ``_demo`` the demo
(``run_demo``); ``_files`` loads the saved model and checks the output paths; ``_input``
reads and validates the CSV files; ``_progress`` draws the progress; ``_common`` holds the
exit statuses and the user's error.
"""

from sklearn_ifog.cli._main import main

__all__ = ["main"]
