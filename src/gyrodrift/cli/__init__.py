"""The ``gyrodrift`` command line, on top of everything else (nothing below imports it).

:func:`main` runs it; its commands and their modules: docs/command-line.md.
"""

from gyrodrift.cli.commands import main

__all__ = ["main"]
