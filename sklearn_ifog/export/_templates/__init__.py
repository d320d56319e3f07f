"""C99 templates of the exported compensator (``string.Template``: ``$name`` placeholders).

Every fixed piece of C text the generator writes is here, in three modules: the header and
the source with the front end's pieces (``_source``), the calibration domain's functions and
header text (``_domain``), and the online recalibration's (``_adapt``); the generator
(:mod:`sklearn_ifog.export._c` and its parts) fills in names, sizes and parameters. Kept as
Python strings rather than package-data files so an installed wheel always has them.
"""
