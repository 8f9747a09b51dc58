"""The one executor for sweeps: independent tasks on Dask distributed, cached on disk.

:func:`run_tasks` maps a function over a list of tasks (cells of a grid):

- ``workers=None``: a Dask ``LocalCluster`` with one worker process per core;
- ``workers=N``: a ``LocalCluster`` of N worker processes (``workers=1``: serial,
  in this process, no cluster);
- ``scheduler="tcp://HOST:PORT"``: a cluster the user already runs.

Each task's result is cached under ``cache_dir`` by a hash of the function and
the task's inputs (:func:`task_key`), so a rerun or a wider grid computes only
the new cells. Results come back in task order and are the same whichever way
they ran (the chunks a function sees do not depend on the number of workers).

Example:
    >>> from manipcad.parallel import run_tasks
    >>> run_tasks(pow, [{"base": 2, "exp": k} for k in range(4)], workers=1, progress=False)
    [1, 2, 4, 8]
"""

from manipcad.parallel.executor import Pool, Split, TaskFailed, run_tasks, task_key

__all__ = ["run_tasks", "task_key", "TaskFailed", "Pool", "Split"]
