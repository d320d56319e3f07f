"""Reading order of the example gallery: from a first compensation to the real recording."""

from pathlib import Path

from sphinx_gallery.sorting import FileNameSortKey

READING_ORDER = (
    "plot_compensate_campaign.py",
    "plot_traditional_vs_modified.py",
    "plot_grid_search_azimuths.py",
    "plot_baselines.py",
    "plot_allan_deviation.py",
    "plot_conformal_intervals.py",
    "plot_production_lot.py",
    "plot_outside_calibration.py",
    "plot_paper_experiments.py",
    "plot_recalibration.py",
    "plot_transition_terms.py",
    "plot_scale_factor.py",
    "plot_real_recording.py",
)


class ReadingOrder(FileNameSortKey):
    """Sort key: the examples of ``READING_ORDER`` first, in that order, then any other."""

    def __call__(self, filename):
        name = Path(filename).name
        if name in READING_ORDER:
            return f"{READING_ORDER.index(name):03d}"
        return f"999{name}"
