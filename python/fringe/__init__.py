"""fringe: fringe-projection (phase-shifting structured-light) 3D measurement.

Python bindings of the fringe C++ library: numpy arrays in and out, options as keyword
arguments with the C++ defaults, summaries as dicts, errors raised as fringe.Error with the
library's message. See help(fringe.reconstruct) and the README's "Python" section.
"""

import sys as _sys

from . import _fringe
from ._fringe import *  # noqa: F401,F403  (the public API is the extension module's)
from ._fringe import evaluate

# `import fringe.evaluate` works like the attribute access.
_sys.modules[__name__ + ".evaluate"] = evaluate

__all__ = [name for name in dir(_fringe) if not name.startswith("_")]
