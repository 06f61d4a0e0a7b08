"""tacmap: localize a tactile sensor's contact on a visual map (the compiled module's docstring
replaces this one once it is loaded).

The package is this file, _build_info.py (written by CMake: which interpreter the module was
built for) and the compiled module _tacmap (pybind11). A compiled module loads only in the
Python it was built for, with numpy; under any other interpreter the import fails with a
message that names both interpreters and what to do, instead of a bare "No module named" or
"numpy.core.multiarray failed to import".
"""

import importlib.machinery as _machinery
import os as _os
import sys as _sys

from ._build_info import BUILT_FOR as _BUILT_FOR


def _not_loadable(reason):
    this = (f"{_sys.executable} (Python {_sys.version.split()[0]}, extension suffix "
            f"{_machinery.EXTENSION_SUFFIXES[0]})")
    built = _BUILT_FOR
    return ImportError(
        f"tacmap: the compiled module cannot be loaded here: {reason}. It was built for "
        f"{built['executable']} (Python {built['version']}, extension suffix "
        f"{built['ext_suffix']}, numpy {built['numpy']}); this interpreter is {this}. Run your "
        f"program with {built['executable']}, or build tacmap for this interpreter from its "
        f"source folder: `{_sys.executable} -m pip install .` (in a venv made with "
        f"`python3 -m venv --system-site-packages`, with Debian's python3-numpy).")


_compiled = _os.path.join(_os.path.dirname(_os.path.abspath(__file__)),
                         "_tacmap" + _BUILT_FOR["ext_suffix"])
if not _os.path.exists(_compiled):
    raise ImportError(
        f"tacmap: {_compiled} is missing: the package's compiled part was not built (CMake "
        f"target tacmap_python) or not installed with it; `python3 -m pip install .` in tacmap's "
        f"source folder builds and installs both")
if _BUILT_FOR["ext_suffix"] not in _machinery.EXTENSION_SUFFIXES:
    raise _not_loadable("another Python version or ABI")
try:
    import numpy as _numpy  # noqa: F401  (the module's arrays are numpy arrays)
except ImportError as _error:
    raise _not_loadable(f"numpy is not importable ({_error}; Debian: python3-numpy)") from None
try:
    from . import _tacmap
except ImportError as _error:
    raise _not_loadable(str(_error)) from _error

from ._tacmap import *  # noqa: E402,F401,F403  (the whole API lives in the compiled module)

__doc__ = _tacmap.__doc__
__version__ = _tacmap.__version__

# The classes and functions say they are tacmap's (help(), tracebacks), not the private
# extension's.
for _name in dir(_tacmap):
    _object = getattr(_tacmap, _name)
    if getattr(_object, "__module__", None) == _tacmap.__name__:
        try:
            _object.__module__ = __name__
        except (AttributeError, TypeError):
            pass
del _name, _object
