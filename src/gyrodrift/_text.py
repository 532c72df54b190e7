"""User text made safe to show on one line: in terminal lines, parameter files and reports.

:func:`printable` writes line ends, control characters and bidirectional controls as their
Python escapes, so the text stays one line and is shown, not obeyed (``docs/output_files.md``).
"""

from __future__ import annotations

import re
import sys

__all__ = ["printable", "say", "warn"]

#: C0 and C1 control characters, DEL, the Unicode line and paragraph separators and the
#: bidirectional controls that reorder what a terminal or an editor shows.
_UNSAFE = re.compile("[\x00-\x1f\x7f-\x9f\u2028\u2029\u200e\u200f\u202a-\u202e\u2066-\u2069]")


def _escape(match: re.Match) -> str:
    return match.group().encode("unicode_escape").decode("ascii")


def printable(text) -> str:
    """``str(text)`` with every control character, line or paragraph separator and
    bidirectional control written as its escape (module notes).

    Examples
    --------
    >>> printable("log\\n1.csv\\x1b[31m")
    'log\\\\n1.csv\\\\x1b[31m'
    """
    return _UNSAFE.sub(_escape, str(text))


def say(*lines, file=None) -> None:
    """Print each of ``lines`` as one line, flushed, its user text made :func:`printable` (a line
    end or an escape code in a file name is shown, not obeyed); ``file`` default stdout."""
    print("\n".join(printable(line) for line in lines), file=file or sys.stdout, flush=True)


def warn(source, notes) -> None:
    """Print each note as one warning line on stderr, naming its ``source`` file."""
    for note in notes:
        say(f"gyrodrift: warning: {source}: {note}", file=sys.stderr)
