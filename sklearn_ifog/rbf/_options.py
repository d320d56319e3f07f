"""The settings of one fit of a Gaussian RBF network, as one record.

:class:`~sklearn_ifog.RBFNetRegressor` builds a :class:`FitOptions` from its parameters once
they are validated; the numerics (``_fit.fit_network``, ``_select.select_network`` and the
cross-validation) read the fields they need by name. The estimator's docstring is the one
place where each setting is explained and where the defaults are given.
"""

from dataclasses import dataclass


@dataclass(frozen=True)
class FitOptions:
    """The settings of :func:`~sklearn_ifog.rbf._fit.fit_network`, already validated.

    Each field has the name, meaning and allowed values of the
    :class:`~sklearn_ifog.RBFNetRegressor` parameter of that name; there are no defaults
    here, so that the estimator stays the one place that gives them.

    Attributes
    ----------
    n_centers : "auto" or int
        Largest number of Gaussian units.
    width : "auto" or float
        Shared width of the units, standardised units.
    refine : {"varpro", "lm", "gd"} or None
        Refinement method.
    alpha : float
        Relative ridge penalty on the Gaussian weights.
    tail_alpha : "auto" or float
        Relative ridge penalty on the tail weights.
    tail_penalty : {"spread", "ridge"}
        The tail penalty's shape.
    criterion : {"cv", "holdout", "gcv", "bic", "aicc"} or None
        How the number of centres and the width are chosen.
    goal : float or None
        Mean squared training error to reach.
    tail : {"linear", "quadratic", "auto"} or bool
        Polynomial tail.
    max_candidates : int
        Largest pool of candidate centres.
    candidates : {"kmeans++", "random"}
        How the candidate pool is drawn.
    max_samples : int
        Rows used for selection and refinement.
    validation_fraction : float
        Fraction of the rows held out (and the number of folds of ``"cv"``).
    max_iter : int
        Largest number of refinement iterations.
    tol : float
        Relative tolerance of the refinement.
    learning_rate : float
        Step size of ``refine="gd"``.
    random_state : int, RandomState instance or None
        Seeds the row subsample, the candidate pool and the refinement.

    Examples
    --------
    >>> options = FitOptions(
    ...     n_centers="auto",
    ...     width="auto",
    ...     refine=None,
    ...     alpha=1e-4,
    ...     tail_alpha=0.0,
    ...     tail_penalty="spread",
    ...     criterion="holdout",
    ...     goal=None,
    ...     tail="linear",
    ...     max_candidates=300,
    ...     candidates="kmeans++",
    ...     max_samples=3000,
    ...     validation_fraction=0.2,
    ...     max_iter=100,
    ...     tol=1e-6,
    ...     learning_rate=0.1,
    ...     random_state=0,
    ... )
    >>> options.criterion, options.refine
    ('holdout', None)
    """

    n_centers: object
    width: object
    refine: str | None
    alpha: float
    tail_alpha: object
    tail_penalty: str
    criterion: str | None
    goal: float | None
    tail: object
    max_candidates: int
    candidates: str
    max_samples: int
    validation_fraction: float
    max_iter: int
    tol: float
    learning_rate: float
    random_state: object
