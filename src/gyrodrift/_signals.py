"""A SIGTERM raised as an exception that a finalizer swallowed is sent again (shared by the
command line and the worker processes of :mod:`gyrodrift._pool`).

A signal handler runs between two bytecodes of the main thread, also inside a finalizer (a
``__del__``, a weak reference's callback); an exception raised there cannot propagate, Python
gives it to ``sys.unraisablehook`` (which would print a traceback) and the signal is lost.
"""

from __future__ import annotations

import os
import signal

__all__ = ["REDELIVER_S", "redeliver_sigterm"]

#: Delay before a SIGTERM that landed in a finalizer is sent again, s.
REDELIVER_S = 0.05


def redeliver_sigterm(hook, exc_type):
    """A ``sys.unraisablehook`` that, for an ``exc_type`` (the exception a SIGTERM handler
    raises) that could not propagate, sends SIGTERM to this process again after
    :data:`REDELIVER_S` and prints nothing; anything else goes to ``hook``."""

    def unraisable(info) -> None:
        if isinstance(info.exc_value, exc_type):
            import threading

            threading.Timer(REDELIVER_S, os.kill, (os.getpid(), signal.SIGTERM)).start()
            return
        hook(info)

    return unraisable
