"""Progress of long work (extraction, rendering) in notebooks and terminals.

The Rust library reports events from its worker threads: ``begin(stage,
total)``, ``add_total(n)``, ``advance(n)``, ``status(text)``, ``end(stage)``,
``info(line)`` and ``warn(line)``. :class:`ProgressBar` shows them with
tqdm (a widget in Jupyter, a bar in a terminal) when tqdm is installed, and
as a plain one-line bar on stderr otherwise. Pass your own object with
those methods as ``progress=`` to route them elsewhere.
"""

from __future__ import annotations

import os
import sys
import threading
import time
import traceback
import warnings


class EyereplayWarning(UserWarning):
    """Something the user should know that does not stop the job (a source
    clipped, a session short of data)."""


class ProgressBar:
    """One bar per stage; units are video frames."""

    def __init__(self, stream=None):
        self._stream = stream or sys.stderr
        self._lock = threading.Lock()
        self._bar = None
        self._stage = None
        self._done = 0
        self._total = 0
        self._shown_at = 0.0
        self._last_shown = -1
        # A terminal gets one line redrawn in place; a log file (no
        # terminal) a line now and then, '\r' would join them into one.
        isatty = getattr(self._stream, "isatty", None)
        self._in_place = bool(isatty and isatty())
        try:  # tqdm.auto picks the notebook widget inside Jupyter
            from tqdm.auto import tqdm

            self._tqdm = tqdm
        except ImportError:
            self._tqdm = None

    def begin(self, stage: str, total: int) -> None:
        with self._lock:
            self._close()
            self._stage, self._done, self._total = stage, 0, int(total)
            if self._tqdm is not None:
                self._bar = self._tqdm(total=self._total or None, desc=stage, unit="frame")

    def add_total(self, n: int) -> None:
        with self._lock:
            self._total += int(n)
            if self._bar is not None:
                self._bar.total = self._total
                self._bar.refresh()

    def advance(self, n: int) -> None:
        with self._lock:
            self._done += int(n)
            if self._bar is not None:
                self._bar.update(int(n))
            else:
                self._text_bar()

    def status(self, text: str) -> None:
        with self._lock:
            if self._bar is not None:
                self._bar.set_postfix_str(text)

    def end(self, stage: str) -> None:
        with self._lock:
            self._close()

    def info(self, line: str) -> None:
        with self._lock:
            self._clear_line()
            print(line, file=self._stream)

    def warn(self, line: str) -> None:
        _warn_at(getattr(self, "_site", None), line)

    # A bar of '=', redrawn in place with '\r' every 0.2 s at most in a
    # terminal; elsewhere a line every 10 s, and the last one.
    def _text_bar(self) -> None:
        now = time.monotonic()
        every = 0.2 if self._in_place else 10.0
        finished = 0 < self._total <= self._done
        if now - self._shown_at < every and not finished:
            return
        if self._done == self._last_shown:
            return
        self._shown_at, self._last_shown = now, self._done
        if self._total <= 0:
            # No total known yet: a count, not a bar that looks finished.
            line = f"{self._stage or '':>8} {self._done} frames"
        else:
            filled = int(30 * min(self._done, self._total) / self._total)
            line = (f"{self._stage or '':>8} [{'=' * filled}{' ' * (30 - filled)}] "
                    f"{self._done}/{self._total} frames")
        self._stream.write(f"\r{line}" if self._in_place else f"{line}\n")
        self._stream.flush()

    def _clear_line(self) -> None:
        if self._bar is None and self._shown_at and self._in_place:
            self._stream.write("\r" + " " * 70 + "\r")
            self._stream.flush()

    def _close(self) -> None:
        if self._bar is not None:
            self._bar.close()
            self._bar = None
        elif self._shown_at and self._in_place:
            self._stream.write("\n")
            self._stream.flush()
        self._shown_at, self._last_shown = 0.0, -1


_METHODS = ("begin", "add_total", "advance", "status", "end", "info", "warn")


def _ignore(*_args) -> None:
    pass


_PACKAGE_DIR = os.path.dirname(os.path.abspath(__file__))


def _user_site():
    """The first frame outside this package on the calling stack: where
    the user called eyereplay. The library warns from its worker threads,
    whose stack has no Python caller (``warnings.warn`` then names
    ``sys:1``), so the site is taken when the call starts."""
    f = sys._getframe(1)
    while f is not None and os.path.dirname(os.path.abspath(f.f_code.co_filename)) == _PACKAGE_DIR:
        f = f.f_back
    return None if f is None else (f.f_code.co_filename, f.f_lineno, f.f_globals)


def _warn_at(site, line: str) -> None:
    message = line.removeprefix("warning: ")
    if site is None:
        warnings.warn(message, EyereplayWarning, stacklevel=3)
        return
    filename, lineno, module_globals = site
    warnings.warn_explicit(
        message,
        EyereplayWarning,
        filename,
        lineno,
        module=module_globals.get("__name__", "<unknown>"),
        registry=module_globals.setdefault("__warningregistry__", {}),
        module_globals=module_globals,
    )


class _Partial:
    """A user's progress object with some of the methods: the ones it has
    are called, the rest do nothing (warnings still become
    :class:`EyereplayWarning`), so that a missing method is not an
    exception on a worker thread at every event."""

    def __init__(self, target, have):
        for name in _METHODS:
            fallback = self._warn if name == "warn" else _ignore
            setattr(self, name, getattr(target, name) if name in have else fallback)

    def _warn(self, line: str) -> None:
        _warn_at(getattr(self, "_site", None), line)


def resolve(progress):
    """``True`` -> a :class:`ProgressBar`, ``False``/``None`` -> no bar
(warnings still become :class:`EyereplayWarning`),
    an object with some of the methods above -> that object (the missing
    methods do nothing); anything else is a ``TypeError``, before any work
    starts."""
    if progress is True:
        resolved = ProgressBar()
    elif progress is False or progress is None:
        # No bar, but warnings still become EyereplayWarning: a script
        # that turns the bar off must still hear that a video was cut off.
        resolved = _Partial(None, [])
    else:
        have = [m for m in _METHODS if callable(getattr(progress, m, None))]
        if not have:
            raise TypeError(
                f"progress: expected True, False, None or an object with the methods "
                f"{', '.join(_METHODS)}; got {type(progress).__name__} {progress!r:.40}"
            )
        resolved = progress if len(have) == len(_METHODS) else _Partial(progress, have)
    # Where our own objects say the library's warnings (a user's object
    # says them as it likes).
    if isinstance(resolved, (ProgressBar, _Partial)):
        resolved._site = _user_site()
    return resolved


class _Guarded:
    """A progress object whose first exception is reported (as Python
    reports an exception it cannot raise) and which is not called again:
    what the native calls do with one, so that a broken bar neither stops
    the work nor prints a traceback at every event."""

    def __init__(self, target):
        self._target = target
        self._broken = False

    def __getattr__(self, name):
        method = getattr(self._target, name)

        def call(*args):
            if self._broken:
                return None
            try:
                return method(*args)
            except Exception as e:
                self._broken = True
                print(f"Exception ignored in the progress object's {name}():", file=sys.stderr)
                traceback.print_exception(type(e), e, e.__traceback__, file=sys.stderr)
                return None

        return call


def guarded(progress):
    """:class:`_Guarded` around a resolved progress object (``None`` stays)."""
    return None if progress is None else _Guarded(progress)
