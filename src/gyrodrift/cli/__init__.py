"""The ``gyrodrift`` command line, on top of everything else (nothing below imports it).

:func:`main` runs it (the ``gyrodrift`` script and ``python -m gyrodrift``).
:mod:`~gyrodrift.cli.commands` builds the parser and holds the commands that are a few
lines over the library; :mod:`~gyrodrift.cli.report`, :mod:`~gyrodrift.cli.batch`,
:mod:`~gyrodrift.cli.calibrate` and :mod:`~gyrodrift.cli.stream` the commands of those
names; :mod:`~gyrodrift.cli.options` is the one option layer (how to read a log, the
method's settings) and :mod:`~gyrodrift.cli.parser` the parser that suggests the closest
option.
"""

from gyrodrift.cli.commands import main

__all__ = ["main"]
