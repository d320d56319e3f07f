"""Heat model of a wound fibre coil: a linear thermal network solved by modal decomposition.

The network has one housing node and ``n_layers`` radial coil layers (index 0 the outermost)::

    chamber air --G_air--> housing --G_contact--> layer 0 --G_layer--> layer 1 ... layer N-1

with heat capacities ``C_housing`` and ``C_coil / n_layers`` per layer and an adiabatic inner
face (the spool's bore). In state form ``dx/dt = A x + b u`` with ``x = (housing, layers)``
and ``u`` the chamber air temperature, ``A = -C⁻¹ K`` where ``K`` is the symmetric conduction
(Laplacian-plus-ground) matrix and ``C`` the diagonal capacity matrix. The network is
similar to the symmetric matrix ``C^(-1/2) K C^(-1/2)``, so its modes are real and
negative; each mode is a first-order lag of the chamber temperature and every node is a
fixed mixture of those lags::

    x_i(t) = sum_k W[i, k] * lag_{tau_k}(u)(t),      sum_k W[i, k] = 1

(``sum = 1``: at a steady chamber temperature every node reaches it). Each lag runs through
:func:`scipy.signal.lfilter` (first-order hold, exact for an input linear between samples);
no Python loop over samples.
"""

import numpy as np

from sklearn_ifog.datasets._gyro import first_order_lag

__all__ = [
    "block_average",
    "conduction_network",
    "modal_response",
    "simulate_network",
]


def conduction_network(n_layers, tau_housing, tau_contact, tau_diffusion, coil_capacity_ratio):
    """State matrix ``A`` and input vector ``b`` of the housing-and-layers network.

    Parameters
    ----------
    n_layers : int
        Number of radial coil layers (index 0 the outermost, coupled to the housing).
    tau_housing : float
        Time constant of the housing alone against the chamber air, seconds
        (``C_housing / G_air``).
    tau_contact : float
        Time constant of the whole coil, as one lump, against the housing, seconds
        (``C_coil / G_contact``).
    tau_diffusion : float
        Slowest internal time constant of the layer chain with its outer face held at a
        fixed temperature, seconds: radial diffusion through the winding.
    coil_capacity_ratio : float
        ``C_coil / C_housing``: how much the coil loads the housing.

    Returns
    -------
    A : ndarray of shape (n_layers + 1, n_layers + 1)
        State matrix, 1/s; state 0 is the housing, states 1.. the layers, outermost first.
    b : ndarray of shape (n_layers + 1,)
        Input vector (chamber air temperature), 1/s.
    capacity : ndarray of shape (n_layers + 1,)
        Heat capacities relative to the housing's.

    Examples
    --------
    >>> A, b, capacity = conduction_network(3, 1200.0, 900.0, 300.0, 0.3)
    >>> A.shape, b.shape
    ((4, 4), (4,))
    >>> bool(abs((A.sum(axis=1) + b).max()) < 1e-15)  # a uniform temperature is steady
    True
    """
    n = n_layers + 1
    capacity = np.empty(n)
    capacity[0] = 1.0
    capacity[1:] = coil_capacity_ratio / n_layers
    g_air = 1.0 / tau_housing
    g_contact = coil_capacity_ratio / tau_contact
    # Slowest mode of a chain of N equal nodes, Dirichlet on the outer face and Neumann on
    # the inner one: lambda_1 = (g / c) * 4 sin²(pi / (2 (2N + 1))).
    c_layer = capacity[1]
    g_layer = c_layer / tau_diffusion / (4.0 * np.sin(np.pi / (2.0 * (2 * n_layers + 1))) ** 2)
    # Conductances between neighbours: housing-layer0 (contact), then layer-layer. The
    # contact conductance enters the first layer in series with half a layer's conductance.
    edges = np.concatenate(([1.0 / (1.0 / g_contact + 0.5 / g_layer)], np.full(n - 2, g_layer)))
    K = np.zeros((n, n))
    index = np.arange(n - 1)
    K[index, index] += edges
    K[index + 1, index + 1] += edges
    K[index, index + 1] -= edges
    K[index + 1, index] -= edges
    K[0, 0] += g_air
    A = -K / capacity[:, None]
    b = np.zeros(n)
    b[0] = g_air / capacity[0]
    return A, b, capacity


def modal_response(A, b, capacity):
    """Time constants and mixing weights of the network's modes.

    Parameters
    ----------
    A : ndarray of shape (n, n)
        State matrix from :func:`conduction_network`.
    b : ndarray of shape (n,)
        Input vector.
    capacity : ndarray of shape (n,)
        Heat capacities (make ``A`` similar to a symmetric matrix).

    Returns
    -------
    time_constants : ndarray of shape (n,)
        ``tau_k = -1 / lambda_k``, seconds, increasing.
    weights : ndarray of shape (n, n)
        ``W[i, k]``: node ``i`` is ``sum_k W[i, k] * lag_{tau_k}(u)``; rows sum to 1.

    Examples
    --------
    >>> A, b, capacity = conduction_network(3, 1200.0, 900.0, 300.0, 0.3)
    >>> taus, W = modal_response(A, b, capacity)
    >>> bool(abs(W.sum(axis=1) - 1.0).max() < 1e-12)
    True
    """
    scale = np.sqrt(capacity)
    # S = C^(1/2) A C^(-1/2) = -C^(-1/2) K C^(-1/2) is symmetric.
    symmetric = scale[:, None] * A / scale[None, :]
    symmetric = 0.5 * (symmetric + symmetric.T)
    eigenvalues, vectors = np.linalg.eigh(symmetric)  # ascending: most negative first
    order = np.argsort(-eigenvalues)  # slowest mode first
    eigenvalues, vectors = eigenvalues[order], vectors[:, order]
    modes = vectors / scale[:, None]  # eigenvectors of A
    # Modal coordinates z = modes^-1 x obey dz_k/dt = lambda_k z_k + beta_k u.
    beta = np.linalg.solve(modes, b)
    weights = modes * (beta / -eigenvalues)[None, :]
    return -1.0 / eigenvalues, weights


def simulate_network(chamber, step, time_constants, weights):
    """Node temperatures and their exact time derivatives on a uniform grid.

    The network starts in equilibrium with ``chamber[0]``.

    Parameters
    ----------
    chamber : ndarray of shape (n_samples,)
        Chamber air temperature, degC, on a grid of spacing ``step`` (taken as linear between
        samples).
    step : float
        Grid spacing, seconds.
    time_constants : ndarray of shape (n_modes,)
        From :func:`modal_response`.
    weights : ndarray of shape (n_nodes, n_modes)
        From :func:`modal_response`.

    Returns
    -------
    temperatures : ndarray of shape (n_nodes, n_samples)
        Node temperatures, degC.
    rates : ndarray of shape (n_nodes, n_samples)
        Their time derivatives, degC/s (``dy_k/dt = (u - y_k) / tau_k`` for each mode).

    Examples
    --------
    >>> import numpy as np
    >>> A, b, capacity = conduction_network(3, 1200.0, 900.0, 300.0, 0.3)
    >>> taus, W = modal_response(A, b, capacity)
    >>> T, dT = simulate_network(np.full(50, 20.0), 10.0, taus, W)
    >>> bool(np.allclose(T, 20.0)), bool(np.allclose(dT, 0.0))
    (True, True)
    """
    lags = np.stack([first_order_lag(chamber, step, tau, chamber[0]) for tau in time_constants])
    lag_rates = (chamber[None, :] - lags) / np.asarray(time_constants)[:, None]
    return weights @ lags, weights @ lag_rates


def block_average(values, per_block):
    """Trapezoidal mean of each block of ``per_block`` steps on a fine grid.

    ``values`` has ``n_blocks * per_block + 1`` points along its last axis; block ``n``
    spans points ``n * per_block`` to ``(n + 1) * per_block`` (both ends shared with the
    neighbours). The mean over ``m`` consecutive blocks equals the trapezoidal mean over
    their union, so block averages nest exactly.

    Parameters
    ----------
    values : ndarray of shape (..., n_blocks * per_block + 1)
        Samples on the fine grid.
    per_block : int
        Fine steps per block.

    Returns
    -------
    means : ndarray of shape (..., n_blocks)
        Block means.

    Examples
    --------
    >>> import numpy as np
    >>> block_average(np.arange(7.0), 3)
    array([1.5, 4.5])
    """
    values = np.asarray(values, dtype=np.float64)
    n_blocks = (values.shape[-1] - 1) // per_block
    if n_blocks * per_block + 1 != values.shape[-1]:
        raise ValueError(
            f"values must have n_blocks * per_block + 1 = k * {per_block} + 1 points, "
            f"got {values.shape[-1]}."
        )
    blocks = values[..., :-1].reshape((*values.shape[:-1], n_blocks, per_block))
    ends = values[..., per_block::per_block]
    total = blocks.sum(axis=-1) - 0.5 * blocks[..., 0] + 0.5 * ends
    return total / per_block
