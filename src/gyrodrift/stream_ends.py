"""The ends of ``gyrodrift stream``: the text coming in (a file descriptor, a serial port),
the text going out, and the signals that end the input (docs/streaming.md, sections
"Signals" and "Ends" of "gyrodrift stream")."""

from __future__ import annotations

import codecs
import os
import signal
import sys
from contextlib import contextmanager
from pathlib import Path
from typing import Iterator

from gyrodrift._atomic import atomic_output
from gyrodrift.errors import ConfigError, GyroDriftError
from gyrodrift.io.messages import check_input_path, message, read_error

__all__ = ["StreamInterrupted", "deferred_signals", "fd_blocks", "serial_blocks", "input_blocks", "output_writer",
           "SERIAL_ADVICE", "READ_BYTES"]

#: How to install the serial-port support.
SERIAL_ADVICE = "pip install 'gyrodrift[serial]'"
#: Bytes asked for in one read of a file descriptor (a read returns what is there, up to this).
READ_BYTES = 1 << 16


class StreamInterrupted(Exception):
    """A signal (SIGINT or SIGTERM) ended the input; ``signum`` says which."""

    def __init__(self, signum: int):
        super().__init__(signal.Signals(signum).name)
        self.signum = signum


class _Signals:
    """SIGINT/SIGTERM received while :func:`deferred_signals` runs."""

    def __init__(self) -> None:
        self.received: int | None = None
        self.waiting = False  # True while a source blocks for input: a signal then ends the read at once

    def handler(self, signum, frame) -> None:
        self.received = signum
        if self.waiting:
            raise StreamInterrupted(signum)

    def check(self) -> None:
        """Raise :class:`StreamInterrupted` if a signal came since the last read."""
        if self.received is not None:
            raise StreamInterrupted(self.received)

    @contextmanager
    def wait(self):
        """Around a blocking read: a signal raises :class:`StreamInterrupted` in it."""
        self.waiting = True  # before the check: a signal after it raises in the handler
        try:
            self.check()
            yield
        finally:
            self.waiting = False


@contextmanager
def deferred_signals(signums=(signal.SIGINT, signal.SIGTERM)):
    """Catch ``signums`` while the block runs, and restore the handlers after; yield the object
    :func:`fd_blocks` and :func:`serial_blocks` take as ``signals`` (a signal then ends their input)."""
    state = _Signals()
    previous = {}
    try:
        for signum in signums:
            previous[signum] = signal.signal(signum, state.handler)
    except (ValueError, OSError):  # not the main thread
        pass
    try:
        yield state
    finally:
        for signum, handler in previous.items():
            signal.signal(signum, signal.SIG_DFL if handler is None else handler)


def fd_blocks(fd: int, signals: _Signals | None = None, *, read_bytes: int = READ_BYTES) -> Iterator[str]:
    """The text of an open file descriptor as it arrives: what each read returned (up to
    ``read_bytes``), decoded as UTF-8 with replacement; ends at the end of the input, or with
    :class:`StreamInterrupted` when ``signals`` caught a signal."""
    decoder = codecs.getincrementaldecoder("utf-8")(errors="replace")
    while True:
        if signals is None:
            data = os.read(fd, read_bytes)
        else:
            with signals.wait():
                data = os.read(fd, read_bytes)
        if not data:
            tail = decoder.decode(b"", final=True)
            if tail:
                yield tail
            return
        yield decoder.decode(data)


def serial_blocks(port: str, baud: int, signals: _Signals | None = None) -> Iterator[str]:
    """The text a serial port sends, as it arrives (as :func:`fd_blocks`); needs pyserial. A missing
    pyserial or a port that cannot be opened is a :class:`ConfigError`."""
    try:
        import serial
    except ImportError:
        raise ConfigError(f"--serial {port}: reading a serial port needs pyserial; {SERIAL_ADVICE}") from None
    try:
        port_file = serial.Serial(port, baudrate=baud, timeout=None)
    except (serial.SerialException, ValueError, OSError) as exc:
        raise ConfigError(message(port, f"cannot open the serial port ({' '.join(str(exc).split())})",
                                  "check the device name, its permissions and --baud")) from exc
    decoder = codecs.getincrementaldecoder("utf-8")(errors="replace")
    with port_file:
        while True:
            if signals is None:
                data = port_file.read(max(1, port_file.in_waiting))
            else:
                with signals.wait():
                    data = port_file.read(max(1, port_file.in_waiting))
            if data:
                yield decoder.decode(data)


@contextmanager
def input_blocks(path: str = "-", signals: _Signals | None = None, *, serial_port: str | None = None,
                 baud: int = 115200):
    """Open the input of ``gyrodrift stream``; yield ``(blocks, name)``: the serial port
    ``serial_port`` (at ``baud``), else the file ``path``, or ``"-"`` for standard input."""
    if serial_port is not None:
        yield serial_blocks(serial_port, baud, signals), serial_port
        return
    if path == "-":
        yield fd_blocks(0, signals), "stdin"
        return
    check_input_path(Path(path))
    try:
        fd = os.open(path, os.O_RDONLY)
    except OSError as exc:
        raise read_error(path, exc) from exc
    try:
        yield fd_blocks(fd, signals), str(path)
    finally:
        os.close(fd)


@contextmanager
def output_writer(path: str = "-"):
    """Yield ``write(text)`` for :func:`stream_rows`, every call written and flushed: to standard
    output (``"-"``), or to a file written atomically (docs/streaming.md, section "Ends")."""
    if path == "-":
        out = sys.stdout
        out.flush()

        def write(text: str) -> None:
            try:
                out.buffer.write(text.encode("utf-8"))
                out.buffer.flush()
            except BrokenPipeError:  # e.g. "| head": what is still buffered goes nowhere, without a second error
                os.dup2(os.open(os.devnull, os.O_WRONLY), out.fileno())
                raise GyroDriftError("stdout: the program reading the output has closed it; the stream stopped "
                                     "(no profile is saved); keep the reader open, or write to a file with -o") from None

        yield write
        return
    with atomic_output(Path(path)) as fh:

        def write(text: str) -> None:
            fh.write(text.encode("utf-8"))
            fh.flush()

        yield write
