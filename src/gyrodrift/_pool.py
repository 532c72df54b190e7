"""Run a job over many items in worker processes, results in input order (shared by
``gyrodrift batch`` and the Monte Carlo)."""

from __future__ import annotations

import os
import signal
import sys

from gyrodrift._signals import redeliver_sigterm

__all__ = ["map_processes"]

#: Seconds a worker is given to stop (and remove its temporary files) once terminated.
STOP_WAIT_S = 10.0

#: Exit status of a worker stopped by SIGTERM (128 + the signal's number, as a shell says it).
TERMINATED_STATUS = 128 + signal.SIGTERM

#: In a worker process: whether a job is running (set by :func:`_run`, read by the signal handler).
_in_job = False


class _Stopped(KeyboardInterrupt):
    """A worker's SIGTERM inside a job (:func:`_on_sigterm`)."""


def _on_sigterm(signum, frame) -> None:
    """A worker's SIGTERM: inside a job, :class:`_Stopped` (its clean-up runs); between jobs
    (waiting for or unpickling the next item) there is nothing to clean, and the worker exits at
    once, without the traceback multiprocessing would print."""
    if _in_job:
        raise _Stopped
    os._exit(TERMINATED_STATUS)


def _worker_start() -> None:
    """In each worker: SIGTERM stops it (:func:`_on_sigterm`; one raised inside a finalizer,
    where it cannot propagate, is sent again rather than printed and lost); SIGINT is ignored,
    because Ctrl-C reaches the whole process group and the parent then stops its workers with
    SIGTERM."""
    signal.signal(signal.SIGTERM, _on_sigterm)
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    sys.unraisablehook = redeliver_sigterm(sys.unraisablehook, _Stopped)


def _run(job, item):
    """``job(item)`` in a worker; a job stopped by SIGTERM ends the worker once its clean-up ran
    (a partial output is removed, :mod:`gyrodrift._atomic`), so that it takes no queued item."""
    global _in_job
    _in_job = True
    try:
        return job(item)
    except KeyboardInterrupt:
        os._exit(TERMINATED_STATUS)
    finally:
        _in_job = False


def _stop(pool) -> None:
    """Cancel the items not started, terminate the workers running one, and wait for them."""
    # the standard library's own record of the workers, which shutdown() drops
    workers = list((getattr(pool, "_processes", None) or {}).values())
    pool.shutdown(wait=False, cancel_futures=True)
    for proc in workers:
        if proc.is_alive():
            proc.terminate()
    for proc in workers:
        proc.join(STOP_WAIT_S)
        if proc.is_alive():
            proc.kill()
            proc.join()


def map_processes(job, items, workers: int, progress=None, on_error=None) -> list:
    """``[job(item) for item in items]`` in up to ``workers`` spawned processes, in input order.

    ``job`` is a picklable function of one item; ``progress(iterable, total)`` wraps the
    completed futures (a progress bar); ``on_error(item, exception)`` gives the result of an
    item whose worker failed (else the exception propagates). An interruption stops every
    worker and propagates (``docs/output_files.md``, worker processes).
    """
    import multiprocessing
    from concurrent.futures import ProcessPoolExecutor, as_completed

    items = list(items)
    results: list = [None] * len(items)
    ctx = multiprocessing.get_context("spawn")  # no fork of a process that may hold threads
    pool = ProcessPoolExecutor(max_workers=min(workers, len(items)), mp_context=ctx, initializer=_worker_start)
    try:
        futures = {pool.submit(_run, job, item): i for i, item in enumerate(items)}
        done = as_completed(futures)
        if progress is not None:
            done = progress(done, len(futures))
        for fut in done:
            i = futures[fut]
            try:
                results[i] = fut.result()
            except Exception as err:  # a worker process died (BrokenProcessPool) or could not pickle
                if on_error is None:
                    raise
                results[i] = on_error(items[i], err)
    except BaseException:
        _stop(pool)
        raise
    pool.shutdown(wait=True)
    return results
