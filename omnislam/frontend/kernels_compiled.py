"""The SIFT detector's kernels as the detector calls them: compiled ahead of time when built for
this machine, else by numba just in time, else none (the numpy path).

Importing this module loads the kernels (``kernels``) compiled ahead of time when ``make`` has
built them for this machine (``kernels_aot``: an extension module that needs no numba at run
time and loads in milliseconds), else compiles them with numba (cached on disk by numba, yet
~0.5 s of CPU per new process); ``pipeline``'s fork server imports it once, so its workers start
with them loaded. ``COMPILED`` is None without numba and without a built module.
"""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np

from omnislam.frontend import kernels, kernels_aot


def _compile() -> SimpleNamespace | None:
    """The kernels compiled with ``numba.njit`` (cached on disk), or None without numba."""
    try:
        import numba
    except ImportError:
        return None
    jit = numba.njit(cache=True, nogil=True)
    # the helpers the kernels call must be compiled first (numba resolves globals then); a
    # second call finds them compiled already
    namespace = vars(kernels)
    for helper in kernels.HELPERS:
        if not isinstance(namespace[helper], numba.core.dispatcher.Dispatcher):
            namespace[helper] = jit(namespace[helper])
    compiled = SimpleNamespace(**{name: jit(namespace[name]) for name in kernels_aot.SIGNATURES})
    # compile now, for the argument types ``scale_space`` passes (numba compiles on first call)
    dog = np.zeros((3, 12, 12), dtype=np.float32)
    dog[1, 6, 6] = 1.0
    found = compiled.extrema(dog, 1, np.float32(0.5), np.full((12, 12), 255, dtype=np.uint8))
    compiled.refine(
        dog, 1, 5, found[:, 0].copy(), found[:, 1].copy(), found[:, 2].copy(), 0.01, 10.0
    )
    one = np.ones(1, dtype=np.int64)
    dx, dy, _ = compiled.window_gradients(dog, one, 6 * one, 6 * one, 2 * one, 2)
    compiled.orientation_histograms(dx, dx, dy, 1, 36)
    return compiled


def _load() -> SimpleNamespace | None:
    """The kernels compiled ahead of time for this machine when they were built
    (``kernels_aot``: no numba at run time, milliseconds to load), else ``_compile``'s."""
    module = kernels_aot.load()
    if module is None:
        return _compile()
    return SimpleNamespace(**{name: getattr(module, name) for name in kernels_aot.SIGNATURES})


#: the compiled kernels, or None when numba is not installed and none were built ahead of time
COMPILED: SimpleNamespace | None = _load()
