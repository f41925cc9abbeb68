"""Many routines at once: ``gymtrack batch`` on Dask, from a laptop to a cluster.

Paper: the pipeline of Sections III-IV (tracking, the pose stage of III-D, the metrics of IV-A)
run over a folder of routines -- the paper's 140 performances, or a championship's thousands.
Layer: above :mod:`gymtrack.eval`, below :mod:`gymtrack.cli`.

* :mod:`.routines` the routines of a folder or list, the steps, the completeness marker
* :mod:`.steps`    one routine in a worker: track, pose, eval into ``<out>/<routine>/``, atomically
* :mod:`.engine`   Dask: LocalCluster or a scheduler, numba warm-up, one task per worker thread,
  dead workers and Ctrl-C; :func:`.engine.dask_runner` runs the benchmark's routines
* :mod:`.run`      :func:`run_batch`, batch.csv and batch.json

Dask (``distributed``) is the optional ``batch`` extra, imported when a batch starts.
"""

from .routines import MARKER, STEPS, BatchRoutine, find_routines, output_complete, parse_steps
from .run import BatchResult, run_batch

__all__ = ["run_batch", "BatchResult", "BatchRoutine", "find_routines", "parse_steps", "output_complete",
           "STEPS", "MARKER"]
