"""One BLAS thread for the fit's small and skinny matrices, without rescanning libraries.

``threadpoolctl.threadpool_limits`` inspects every loaded shared library on each call (4 to
12 ms, measured); a :class:`threadpoolctl.ThreadpoolController` made once does that once,
as scikit-learn does. The BLAS libraries are loaded with numpy and scipy, before the first
fit, so the one scan sees them.
"""

from threadpoolctl import ThreadpoolController

_CONTROLLER = None


def single_blas_thread():
    """Context manager limiting the BLAS libraries to one thread.

    Examples
    --------
    >>> with single_blas_thread():
    ...     pass
    """
    global _CONTROLLER
    if _CONTROLLER is None:
        _CONTROLLER = ThreadpoolController()
    return _CONTROLLER.limit(limits=1, user_api="blas")
