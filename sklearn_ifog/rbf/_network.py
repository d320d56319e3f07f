"""RBFNetRegressor: Gaussian RBF network, OLS centre selection, optional refinement."""

import warnings
from numbers import Integral, Real
from typing import ClassVar

import numpy as np
from sklearn.base import BaseEstimator, RegressorMixin
from sklearn.exceptions import ConvergenceWarning
from sklearn.utils import check_random_state
from sklearn.utils.validation import check_is_fitted, validate_data
from threadpoolctl import threadpool_limits

from sklearn_ifog._compat import Interval, StrOptions, _check_sample_weight, _fit_context
from sklearn_ifog.rbf._basis import (
    predict_network,
    solve_output_weights_chunked,
    squared_distances,
)
from sklearn_ifog.rbf._ols import (
    candidate_pool,
    contiguous_validation_mask,
    median_nn_distance,
    ols_forward_select,
    path_criterion,
    prefix_fits,
)

# Largest number of centres when ``n_centers="auto"``; the criterion picks along the path.
AUTO_MAX_CENTERS = 40
# Shared-width grid, in multiples of the candidates' median nearest-neighbour distance.
WIDTH_MULTIPLES = (1.0, 2.0, 4.0, 8.0, 16.0)
# Widths are kept inside this range (standardised units) so no design column is all zeros
# or all ones by construction.
WIDTH_BOUNDS = (1e-3, 1e3)
# Below this many held-out rows a validation error ranks nothing: no held-out blocks.
MIN_VALIDATION_ROWS = 10
# Held-out blocks per fit (fewer when there are few rows: at least 5 rows per block).
N_VALIDATION_BLOCKS = 5
MIN_BLOCK_ROWS = 5


def _weighted_mean_scale(A, sample_weight):
    """Weighted mean and standard deviation of each column; scale 1 for a constant column."""
    total = sample_weight.sum()
    mean = sample_weight @ A / total
    scale = np.sqrt(sample_weight @ np.square(A - mean) / total)
    positive = A[sample_weight > 0]
    constant = np.ptp(positive, axis=0) == 0
    # An exactly constant column: its mean is the value itself, so it standardises to 0.
    mean[constant] = positive[0, constant]
    scale[constant | ~(scale > 0)] = 1.0
    return mean, scale


class RBFNetRegressor(RegressorMixin, BaseEstimator):
    """Gaussian radial-basis-function network with OLS centre selection and refinement.

    The network, on inputs standardised internally to ``z = (x - x_mean_) / x_scale_``, is

    ``f(z) = Σ_j coef_j exp(-||z - c_j||² / (2 σ_j²)) + tail_coef · z + intercept``.

    Centres are chosen from the training rows by orthogonal least squares, their number and
    shared width by a criterion along the selection path (by default the error on held-out
    contiguous blocks of rows), then centres, widths and weights are optionally refined;
    the output weights are finally solved on all rows.

    Parameters
    ----------
    n_centers : "auto" or int, default="auto"
        Largest number of Gaussian units. The criterion picks the number along the
        selection path (0 is possible: then the model is the affine tail alone). ``"auto"``
        means at most 40 (fewer with few distinct rows). With ``criterion=None`` exactly
        this many are used (``"auto"``: 40). When fewer distinct training rows than an
        integer ``n_centers`` exist, a warning is given and all of them are candidates.
    width : "auto" or float, default="auto"
        Shared width σ of the Gaussian units, in standardised input units. ``"auto"`` picks
        it from multiples 1, 2, 4, 8 and 16 of the candidates' median nearest-neighbour
        distance by the same criterion as the number of centres.
    refine : {"varpro", "lm", "gd"} or None, default="varpro"
        Refinement of centres, widths (log-parametrised) and weights after selection:
        variable projection (weights solved inside), Levenberg–Marquardt on all parameters,
        the reference paper's gradient rules, or none. Refinement is stopped early on the
        held-out blocks, keeps its best iterate, and is discarded when it does not lower
        the held-out error; it needs held-out rows and is skipped without them.
    alpha : float, default=1e-4
        Ridge penalty on the Gaussian weights relative to the mean squared error: the
        output layer minimises ``Σ s_i ||y_i - f(z_i)||² / Σ s_i + alpha Σ ||coef||²`` on
        targets divided by their standard deviation (so ``alpha`` is free of units and of
        the number of rows). The tail and intercept are not penalised.
    criterion : {"holdout", "gcv", "bic", "aicc"} or None, default="holdout"
        How the number of centres and the width are chosen along the selection path.
        ``"holdout"``: weighted error on ``validation_fraction`` of the rows held out as
        contiguous blocks (weights re-solved for every prefix of the path); without enough
        rows for blocks (fewer than 10 held-out rows) it falls back to ``"gcv"``. ``"gcv"``,
        ``"bic"``, ``"aicc"``: generalised cross-validation, Bayesian and corrected Akaike
        information criteria on the training rows, which assume independent errors and so
        choose too many centres on autocorrelated series. ``None``: use ``n_centers`` units.
    goal : float, default=None
        Mean squared training error to reach, in target units (averaged over outputs), as
        in MATLAB's ``newrb``: the first prefix of the path that reaches it is kept (all
        ``n_centers`` if none does). Overrides ``criterion`` for the number of centres.
    tail : bool, default=True
        Whether the (standardised) inputs are regressors beside the Gaussian units, so the
        network extrapolates linearly instead of falling back to a constant.
    max_candidates : int, default=300
        Largest pool of candidate centres, drawn from the distinct selection rows by
        ``candidates`` when there are more.
    candidates : {"kmeans++", "random"}, default="kmeans++"
        How the candidate pool is drawn when it must be thinned: weighted k-means++ seeding
        (spread over the data, edges included) or uniformly at random.
    max_samples : int, default=4000
        Rows used for selection and refinement, drawn at random from the training rows when
        there are more (and, separately, at most as many held-out rows to score them).
        The output weights are always solved on all rows, in blocks, so fit time grows
        only through that solve.
    validation_fraction : float, default=0.1
        Fraction of rows held out, as up to 5 contiguous blocks, for the ``"holdout"``
        criterion and for early stopping of the refinement.
    max_iter : int, default=100
        Largest number of refinement iterations (epochs for ``"gd"``).
    tol : float, default=1e-6
        Relative tolerance of the refinement's convergence test.
    learning_rate : float, default=0.01
        Step size of the gradient rules (``refine="gd"`` only).
    random_state : int, RandomState instance or None, default=None
        Seeds the row subsample, the candidate pool and the refinement. The same seed gives
        the same model, bit for bit.

    Attributes
    ----------
    centers_ : ndarray of shape (n_centers_, n_features_in_)
        Centres, in standardised input units.
    widths_ : ndarray of shape (n_centers_,)
        Widths, in standardised input units.
    coef_ : ndarray of shape (n_outputs, n_centers_) or (n_centers_,)
        Weights of the Gaussian units (1-D when ``y`` was 1-D).
    tail_coef_ : ndarray of shape (n_outputs, n_features_in_) or (n_features_in_,)
        Weights of the standardised inputs (zeros when ``tail=False``).
    intercept_ : ndarray of shape (n_outputs,) or float
        Intercept.
    x_mean_ : ndarray of shape (n_features_in_,)
        Weighted mean of the training inputs.
    x_scale_ : ndarray of shape (n_features_in_,)
        Weighted standard deviation of the training inputs (1 for a constant feature).
    n_iter_ : int
        Refinement iterations run (0 when there was no refinement).
    selection_path_ : dict
        The selection path at the chosen width: ``"err"`` (error-reduction ratio of each
        chosen unit), ``"tail_err"``, ``"train_mse"``, ``"val_mse"`` (NaN without
        held-out rows), ``"dof"`` and ``"criterion"`` for every prefix ``k = 0 ..``,
        ``"criterion_name"``, ``"n_centers"`` (the chosen prefix), ``"widths_tried"``,
        ``"width_scores"`` (best criterion per width) and ``"refined"`` (whether
        refinement was kept).
    n_features_in_ : int
        Number of features seen during fit.
    feature_names_in_ : ndarray of shape (n_features_in_,)
        Names of features seen during fit, when they are all strings.

    See Also
    --------
    sklearn.kernel_ridge.KernelRidge : Kernel ridge regression (one centre per row).
    sklearn.neural_network.MLPRegressor : Multi-layer perceptron.

    Notes
    -----
    Selection: the Gaussian activations of every candidate centre form a candidate design;
    the intercept and the affine tail are projected out first and the target is centred;
    units are then added one by one by the largest regularised error-reduction ratio
    (Chen, Cowan & Grant, 1991; Chen, Chng & Alkadhimi, 1996), summed over outputs, with
    re-orthogonalisation and a relative tolerance so that a near-collinear candidate is
    never added. Each prefix of the path is re-solved as a ridge problem and scored; the
    best (width, number of centres) pair is kept. Held-out contiguous blocks are the default
    score because thermal-test series are autocorrelated: criteria for independent errors
    (GCV, BIC) choose too many units on them.

    Scale: selection and refinement see at most ``max_samples`` rows; the final output
    weights are solved on all rows by a blocked (tall-skinny) QR, so memory stays bounded
    and the fit time grows linearly with a small slope. Prediction is computed in blocks.

    The default refinement is variable projection: it moves centres and widths with the
    output weights solved exactly at every step, which converges in few iterations and was
    the most accurate per second of fit time in the package's benchmark.

    References
    ----------
    S. Chen, C. F. N. Cowan and P. M. Grant, "Orthogonal least squares learning algorithm
    for radial basis function networks", IEEE Trans. Neural Networks 2(2), 1991.
    S. Chen, E. S. Chng and K. Alkadhimi, "Regularized orthogonal least squares algorithm
    for constructing radial basis function networks", Int. J. Control 64(5), 1996.

    Examples
    --------
    >>> import numpy as np
    >>> from sklearn_ifog import RBFNetRegressor
    >>> rng = np.random.default_rng(0)
    >>> X = rng.uniform(-1, 1, size=(400, 2))
    >>> y = np.sin(3 * X[:, 0]) + X[:, 1] ** 2
    >>> model = RBFNetRegressor(refine=None, random_state=0).fit(X, y)
    >>> bool(model.score(X, y) > 0.99)
    True
    >>> model.predict(X[:2]).shape
    (2,)
    """

    _parameter_constraints: ClassVar[dict] = {
        "n_centers": [StrOptions({"auto"}), Interval(Integral, 1, None, closed="left")],
        "width": [StrOptions({"auto"}), Interval(Real, 0, None, closed="neither")],
        "refine": [StrOptions({"varpro", "lm", "gd"}), None],
        "alpha": [Interval(Real, 0, None, closed="left")],
        "criterion": [StrOptions({"holdout", "gcv", "bic", "aicc"}), None],
        "goal": [Interval(Real, 0, None, closed="left"), None],
        "tail": ["boolean"],
        "max_candidates": [Interval(Integral, 1, None, closed="left")],
        "candidates": [StrOptions({"kmeans++", "random"})],
        "max_samples": [Interval(Integral, 2, None, closed="left")],
        "validation_fraction": [Interval(Real, 0, 1, closed="neither")],
        "max_iter": [Interval(Integral, 1, None, closed="left")],
        "tol": [Interval(Real, 0, None, closed="left")],
        "learning_rate": [Interval(Real, 0, None, closed="neither")],
        "random_state": ["random_state"],
    }

    def __init__(
        self,
        n_centers="auto",
        width="auto",
        refine="varpro",
        alpha=1e-4,
        criterion="holdout",
        goal=None,
        tail=True,
        max_candidates=300,
        candidates="kmeans++",
        max_samples=4000,
        validation_fraction=0.1,
        max_iter=100,
        tol=1e-6,
        learning_rate=0.01,
        random_state=None,
    ):
        self.n_centers = n_centers
        self.width = width
        self.refine = refine
        self.alpha = alpha
        self.criterion = criterion
        self.goal = goal
        self.tail = tail
        self.max_candidates = max_candidates
        self.candidates = candidates
        self.max_samples = max_samples
        self.validation_fraction = validation_fraction
        self.max_iter = max_iter
        self.tol = tol
        self.learning_rate = learning_rate
        self.random_state = random_state

    @_fit_context(prefer_skip_nested_validation=True)
    def fit(self, X, y, sample_weight=None):
        """Select, refine and solve the network.

        Parameters
        ----------
        X : array-like of shape (n_samples, n_features)
            Training inputs. Row order matters for the held-out blocks: rows of one
            recording should be contiguous and in time order.
        y : array-like of shape (n_samples,) or (n_samples, n_outputs)
            Targets.
        sample_weight : array-like of shape (n_samples,), default=None
            Non-negative weights; an integer weight acts as that many copies of the row.

        Returns
        -------
        self : RBFNetRegressor
            Fitted estimator.
        """
        X, y = validate_data(
            self,
            X,
            y,
            multi_output=True,
            y_numeric=True,
            dtype=np.float64,
            ensure_min_samples=2,
        )
        sw = _check_sample_weight(sample_weight, X, dtype=np.float64, ensure_non_negative=True)
        Y = y.reshape(X.shape[0], -1)
        self.x_mean_, self.x_scale_ = _weighted_mean_scale(X, sw)
        y_mean, y_scale = _weighted_mean_scale(Y, sw)
        Z = (X - self.x_mean_) / self.x_scale_
        Ys = (Y - y_mean) / y_scale
        rng = check_random_state(self.random_state)

        train, val = self._split(sw)
        sel_rows = self._subsample(train, rng)
        val_rows = self._subsample(val, rng) if val is not None else None
        # Selection and refinement work on small matrices, where a multi-threaded BLAS
        # spends more time synchronising than computing (20x slower on a loaded machine).
        with threadpool_limits(limits=1, user_api="blas"):
            network, path = self._select(Z, Ys, sw, sel_rows, val_rows, y_scale, rng)
            centers, widths = network[:2]

            self.n_iter_ = 0
            refined = False
            if self.refine is not None and val_rows is not None and centers.shape[0]:
                result = self._refine(Z, Ys, sw, sel_rows, val_rows, network, rng)
                self.n_iter_ = int(result.n_iter)
                refined = bool(result.improved)
                centers, widths = result.centers, result.widths
                if not result.converged:
                    warnings.warn(
                        f"RBFNetRegressor: {self.refine!r} refinement stopped at "
                        f"max_iter={self.max_iter} before converging; the best iterate was kept.",
                        ConvergenceWarning,
                        stacklevel=2,
                    )
        path["refined"] = refined
        coef, tail_coef, intercept = solve_output_weights_chunked(
            Z,
            Ys,
            centers,
            widths,
            tail=self.tail,
            sample_weight=sw,
            alpha=self.alpha * sw.sum(),
        )
        coef = coef * y_scale[:, None]
        tail_coef = tail_coef * y_scale[:, None]
        intercept = intercept * y_scale + y_mean
        if not self.tail:
            tail_coef = np.zeros((Y.shape[1], X.shape[1]))
        self.centers_ = centers
        self.widths_ = widths
        self.selection_path_ = path
        if y.ndim == 1:
            self.coef_, self.tail_coef_, self.intercept_ = coef[0], tail_coef[0], intercept[0]
        else:
            self.coef_, self.tail_coef_, self.intercept_ = coef, tail_coef, intercept
        return self

    def _split(self, sw):
        """Training rows and held-out contiguous blocks (None when too few rows)."""
        n_samples = sw.shape[0]
        n_held = round(self.validation_fraction * n_samples)
        needs_blocks = self.criterion in ("holdout", None) or self.refine is not None
        if not needs_blocks or n_held < MIN_VALIDATION_ROWS:
            return np.arange(n_samples), None
        n_blocks = max(1, min(N_VALIDATION_BLOCKS, n_held // MIN_BLOCK_ROWS))
        mask = contiguous_validation_mask(n_samples, self.validation_fraction, n_blocks)
        if not (sw[mask].sum() > 0 and sw[~mask].sum() > 0):
            return np.arange(n_samples), None
        return np.flatnonzero(~mask), np.flatnonzero(mask)

    def _subsample(self, rows, rng):
        if rows.shape[0] <= self.max_samples:
            return rows
        return np.sort(rng.choice(rows, size=self.max_samples, replace=False))

    def _select(self, Z, Ys, sw, sel_rows, val_rows, y_scale, rng):
        """OLS paths over the width grid; returns the chosen network and its path record."""
        Z_sel, Y_sel, sw_sel = Z[sel_rows], Ys[sel_rows], sw[sel_rows]
        candidates = candidate_pool(
            Z_sel,
            sample_weight=sw_sel,
            max_candidates=self.max_candidates,
            method=self.candidates,
            random_state=rng,
        )
        n_candidates = candidates.shape[0]
        if self.n_centers == "auto":
            max_centers = min(AUTO_MAX_CENTERS, n_candidates)
        else:
            max_centers = min(self.n_centers, n_candidates)
            if self.n_centers > n_candidates:
                warnings.warn(
                    f"n_centers={self.n_centers} but only {n_candidates} distinct candidate "
                    f"rows are available; at most {n_candidates} centres will be used.",
                    UserWarning,
                    stacklevel=3,
                )
        if self.width == "auto":
            widths_tried = median_nn_distance(candidates) * np.asarray(WIDTH_MULTIPLES)
        else:
            widths_tried = np.array([float(self.width)])
        widths_tried = np.clip(widths_tried, *WIDTH_BOUNDS)

        has_val = val_rows is not None
        criterion = self.criterion
        if criterion is None:
            criterion = "holdout" if has_val else "gcv"
        elif criterion == "holdout" and not has_val:
            criterion = "gcv"
        alpha_sel = self.alpha * sw_sel.sum()
        T_sel = Z_sel if self.tail else None
        D2_sel = squared_distances(Z_sel, candidates)
        if has_val:
            Z_val, Y_val, sw_val = Z[val_rows], Ys[val_rows], sw[val_rows]
            D2_val = squared_distances(Z_val, candidates)
        best = None
        width_scores = []
        for width in widths_tried:
            P = np.exp(D2_sel * (-0.5 / width**2))
            path = ols_forward_select(
                P,
                Y_sel,
                T=T_sel,
                sample_weight=sw_sel,
                alpha=alpha_sel,
                max_selected=max_centers,
            )
            chosen = path.selected
            fits = prefix_fits(
                P[:, chosen],
                Y_sel,
                T=T_sel,
                sample_weight=sw_sel,
                alpha=alpha_sel,
                Phi_val=np.exp(D2_val[:, chosen] * (-0.5 / width**2)) if has_val else None,
                T_val=(Z_val if self.tail else None) if has_val else None,
                Y_val=Y_val if has_val else None,
                sample_weight_val=sw_val if has_val else None,
            )
            values = path_criterion(fits, criterion, sw_sel.sum())
            if self.criterion is None and self.goal is None:
                k = len(chosen)
            else:
                k = int(np.argmin(values))
            width_scores.append(values[k])
            if best is None or values[k] < best[0]:
                best = (values[k], width, path, fits, values, k)
        _, width, path, fits, values, k = best
        train_mse = (fits.train_mse * np.square(y_scale)).mean(axis=1)
        if self.goal is not None:
            reached = np.flatnonzero(train_mse <= self.goal)
            k = int(reached[0]) if reached.size else len(path.selected)
        n_tail = Z.shape[1] if self.tail else 0
        W = fits.weights[k]
        centers = candidates[path.selected[:k]]
        widths = np.full(k, width)
        network = (centers, widths, W[1 + n_tail :].T, W[1 : 1 + n_tail].T, W[0])
        val_mse = (
            (fits.val_mse * np.square(y_scale)).mean(axis=1)
            if has_val
            else np.full(len(values), np.nan)
        )
        record = {
            "err": path.err,
            "tail_err": path.tail_err,
            "train_mse": train_mse,
            "val_mse": val_mse,
            "dof": fits.dof,
            "criterion": values,
            "criterion_name": criterion,
            "n_centers": k,
            "widths_tried": widths_tried,
            "width_scores": np.asarray(width_scores),
        }
        return network, record

    def _refine(self, Z, Ys, sw, sel_rows, val_rows, network, rng):
        from sklearn_ifog.rbf._refine import refine_network

        centers, widths, coef, tail_coef, intercept = network
        sw_sel = sw[sel_rows]
        return refine_network(
            Z[sel_rows],
            Ys[sel_rows],
            centers,
            widths,
            coef,
            tail_coef,
            intercept,
            method=self.refine,
            sample_weight=sw_sel,
            alpha=self.alpha * sw_sel.sum(),
            Z_val=Z[val_rows],
            Y_val=Ys[val_rows],
            sample_weight_val=sw[val_rows],
            max_iter=self.max_iter,
            tol=self.tol,
            learning_rate=self.learning_rate,
            max_samples=None,
            random_state=rng.randint(np.iinfo(np.int32).max),
        )

    def predict(self, X):
        """Predict with the network, in row blocks.

        Parameters
        ----------
        X : array-like of shape (n_samples, n_features)
            Inputs.

        Returns
        -------
        y : ndarray of shape (n_samples,) or (n_samples, n_outputs)
            Predictions.
        """
        check_is_fitted(self)
        X = validate_data(self, X, reset=False)
        coef = self.coef_
        single = coef.ndim == 1
        Y = predict_network(
            (X - self.x_mean_) / self.x_scale_,
            self.centers_,
            self.widths_,
            coef[None] if single else coef,
            self.tail_coef_[None] if single else self.tail_coef_,
            np.atleast_1d(self.intercept_),
        )
        return Y[:, 0] if single else Y

    def __sklearn_tags__(self):
        tags = super().__sklearn_tags__()
        tags.target_tags.multi_output = True
        return tags
