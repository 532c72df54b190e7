"""Run a job over many items in worker processes, results in input order (shared by
``gyrodrift batch`` and the Monte Carlo)."""

from __future__ import annotations

import signal

__all__ = ["map_processes"]

#: Seconds a worker is given to stop (and remove its temporary files) once terminated.
STOP_WAIT_S = 10.0


def _worker_start() -> None:
    """In each worker: SIGTERM raises :class:`KeyboardInterrupt`, so that a job stopped by
    :func:`map_processes` runs its clean-up (a partial output is removed, :mod:`gyrodrift._atomic`)."""
    signal.signal(signal.SIGTERM, signal.default_int_handler)


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
        futures = {pool.submit(job, item): i for i, item in enumerate(items)}
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
