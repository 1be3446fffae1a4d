"""The SIFT detector's kernels compiled ahead of time into a plain extension module.

``kernels_compiled`` compiles the functions of ``kernels`` with numba when a process first
needs them. Loading them from numba's disk cache still costs a new process ~0.5 s of CPU
(importing numba, then its typing and target registries and, through its BLAS check,
``scipy.linalg``): most of the front-end workers' start-up, which a short run like the demo's
59 images cannot amortise. numba's
ahead-of-time compiler (``numba.pycc``) turns the same functions, with fixed argument types,
into an extension module that imports in milliseconds and needs neither numba nor scipy at run
time.

``build`` compiles it (numba and a C compiler needed; ~10 s) into the package's ``__pycache__``,
named by a key of everything its machine code depends on: ``kernels.py``'s source, the Python ABI,
numpy's version (its C API) and this CPU (the code is compiled for the host's instruction set).
``make`` builds it (``python -m omnislam.frontend.kernels_aot``); ``load`` returns it when one was
built for this key, else None (``kernels_compiled`` then compiles them with numba). The module runs
the same LLVM code as numba's just-in-time functions, without fast-math: the same bits, which
``tests/frontend/test_sift_kernels.py`` checks for both against the numpy path. Unlike the
just-in-time functions (``nogil``), the exported ones hold the GIL while they run (``numba.pycc``
has no such option); the front end prepares its images in processes, where that does not matter.
"""

from __future__ import annotations

import argparse
import functools
import hashlib
import importlib.machinery
import importlib.util
import os
import platform
import sys
import sysconfig
import tempfile
import warnings
from pathlib import Path
from types import ModuleType

import numpy as np

from omnislam.frontend import kernels

#: the extension's module name (its ``PyInit_`` symbol); its file is named by ``key()``
MODULE = "omnislam_kernels_aot"
#: the exported functions and their argument types (those ``scale_space`` passes)
SIGNATURES = {
    "extrema": "int64[:, :](float32[:, :, ::1], int64, float32, uint8[:, ::1])",
    "refine": ("Tuple((int64[:], float64[:, :]))(float32[:, :, ::1], int64, int64, int64[:], "
               "int64[:], int64[:], float64, float64)"),
    "window_gradients": ("Tuple((float32[:], float32[:], boolean[:]))(float32[:, :, ::1], "
                         "int64[:], int64[:], int64[:], int64[:], int64)"),
    "orientation_histograms": "float64[:, :](float32[:], float32[:], float32[:], int64, int64)",
}
_SOURCE = Path(kernels.__file__)


def _cpu() -> str:
    """This CPU's model and instruction-set flags (Linux), else what ``platform`` says."""
    try:
        with open("/proc/cpuinfo", encoding="utf-8", errors="replace") as info:
            lines = [line for line in info if line.startswith(("model name", "flags"))]
        return "".join(sorted(set(lines)))
    except OSError:
        return f"{platform.machine()} {platform.processor()}"


@functools.cache
def key() -> str:
    """What the compiled module depends on, hashed: the kernels' source, the Python ABI,
    numpy's version and this CPU."""
    digest = hashlib.sha256(_SOURCE.read_bytes())
    for part in (sysconfig.get_config_var("EXT_SUFFIX") or "", sys.implementation.cache_tag,
                 np.__version__, platform.machine(), _cpu()):
        digest.update(b"\0" + str(part).encode())
    return digest.hexdigest()[:16]


def path(directory: Path | None = None) -> Path:
    """Where the module for this key is (or would be) built."""
    folder = directory if directory is not None else _SOURCE.parent / "__pycache__"
    suffix = sysconfig.get_config_var("EXT_SUFFIX") or ".so"
    return folder / f"kernels-aot-{key()}{suffix}"


def load(directory: Path | None = None) -> ModuleType | None:
    """The module built for this key, or None when there is none or it cannot be loaded
    (then numba's just-in-time path runs, with a warning)."""
    file = path(directory)
    if not file.is_file():
        return None
    loader = importlib.machinery.ExtensionFileLoader(MODULE, str(file))
    spec = importlib.util.spec_from_file_location(MODULE, file, loader=loader)
    assert spec is not None
    try:
        module = importlib.util.module_from_spec(spec)
        loader.exec_module(module)
    except ImportError as exc:
        warnings.warn(f"{file}: cannot load the SIFT kernels compiled ahead of time ({exc}); "
                      "numba compiles them instead", RuntimeWarning, stacklevel=2)
        return None
    return module


def build(directory: Path | None = None) -> Path:
    """Compile the kernels for this key into ``directory`` (default: the package's
    ``__pycache__``) and return the file; the file is replaced atomically, so concurrent
    builds are harmless.

    Raises:
        ImportError: numba is not installed.
        OSError, RuntimeError...: what ``numba.pycc`` raises when it cannot compile or link
            (no C compiler).
    """
    import numba

    with warnings.catch_warnings():  # pycc is pending deprecation in numba; still shipped
        warnings.simplefilter("ignore")
        from numba.pycc import CC

    namespace = vars(kernels)
    for helper in kernels.HELPERS:  # the kernels call them: compiled first
        if not isinstance(namespace[helper], numba.core.dispatcher.Dispatcher):
            namespace[helper] = numba.njit(nogil=True)(namespace[helper])
    target = path(directory)
    target.parent.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory(dir=target.parent) as scratch:
        compiler = CC(MODULE)
        compiler.output_dir = scratch
        compiler.output_file = target.name
        compiler.target_cpu = "host"
        compiler.verbose = False
        for name, signature in SIGNATURES.items():
            compiler.export(name, signature)(getattr(kernels, name))
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            compiler.compile()
        os.replace(Path(scratch) / target.name, target)
    return target


def main(argv: list[str] | None = None) -> int:
    """``python -m omnislam.frontend.kernels_aot``: build the module unless it is built."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--force", action="store_true", help="build even if it is built")
    args = parser.parse_args(argv)
    target = path()
    if target.is_file() and not args.force:
        return 0
    if importlib.util.find_spec("numba") is None:
        print("omnislam: numba is not installed (extra `fast`): the SIFT kernels stay on the "
              "numpy path", file=sys.stderr)
        return 0
    print(f"omnislam: compiling the SIFT kernels ahead of time into {target} (~10 s)",
          file=sys.stderr)
    try:
        build()
    except Exception as exc:  # any failure leaves numba's just-in-time path
        print(f"omnislam: could not compile them ahead of time ({type(exc).__name__}: {exc}); "
              "numba compiles them when a process first needs them", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
