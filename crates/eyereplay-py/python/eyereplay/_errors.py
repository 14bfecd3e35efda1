"""Where the package's exception classes meet Python's own.

The native module makes each class with one base, ``EyereplayError``;
here :class:`ConfigError` also becomes a ``ValueError`` (a bad option or
config value is what ``except ValueError`` is written for), and an input
that is not there raises its class's error that is also a
``FileNotFoundError``, so code written for Python's own exceptions
catches ours.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Dict, Type, Union

from ._native import ConfigError, EyereplayError

if not issubclass(ConfigError, ValueError):
    ConfigError.__bases__ = (EyereplayError, ValueError)

_NOT_FOUND: Dict[type, type] = {}


def not_found(cls: Type[EyereplayError], path: Union[str, "os.PathLike[str]"], what: str) -> Exception:
    """``cls``'s error, also a ``FileNotFoundError``, for ``path``."""
    sub = _NOT_FOUND.get(cls)
    if sub is None:
        # Named as its class, so a traceback reads "VideoError: ...".
        sub = type(cls.__name__, (cls, FileNotFoundError), {
            "__module__": cls.__module__,
            "__doc__": f"{cls.__name__} for an input that is not there (also a FileNotFoundError).",
        })
        _NOT_FOUND[cls] = sub
    return sub(f"{os.fspath(path)}: {what}")


def require(path: Union[str, "os.PathLike[str]"], cls: Type[EyereplayError], what: str) -> None:
    """Raises :func:`not_found` when nothing is at ``path``."""
    if not Path(path).exists():
        raise not_found(cls, path, what)
