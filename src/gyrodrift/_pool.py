"""Run a job over many items in worker processes, results in input order (shared by
``gyrodrift batch`` and the Monte Carlo)."""

from __future__ import annotations

__all__ = ["map_processes"]


def map_processes(job, items, workers: int, progress=None, on_error=None) -> list:
    """``[job(item) for item in items]`` in up to ``workers`` spawned processes.

    Parameters
    ----------
    job : callable
        A picklable function of one item.
    items : sequence
    workers : int
        Largest number of processes (never more than there are items).
    progress : callable, optional
        ``progress(iterable, total)`` wrapping the completed futures (a progress bar).
    on_error : callable, optional
        ``on_error(item, exception)`` gives the result of an item whose worker failed
        (a process that died, an argument that could not be pickled); without it the
        exception propagates.
    """
    import multiprocessing
    from concurrent.futures import ProcessPoolExecutor, as_completed

    items = list(items)
    results: list = [None] * len(items)
    ctx = multiprocessing.get_context("spawn")  # no fork of a process that may hold threads
    with ProcessPoolExecutor(max_workers=min(workers, len(items)), mp_context=ctx) as pool:
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
    return results
