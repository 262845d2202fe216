"""Batch analysis of many recordings on Dask distributed (``walkmon batch``, ``walkmon.batch(...)``).

:mod:`~walkmon.batching.pairing` finds the recordings (video + IMU file + calibration),
:mod:`~walkmon.batching.worker` analyses one on a worker, :mod:`~walkmon.batching.tables` holds the summary,
bout and manifest formats and :mod:`~walkmon.batching.run` schedules them. Dask, pandas and pyarrow (the
``batch`` extra) are imported only when a batch runs. Like walkmon.live, this package talks to sockets and
starts threads (Dask's); the analysis packages it calls do neither.
"""

from __future__ import annotations

from walkmon.batching.pairing import Recording, find_recordings
from walkmon.batching.run import batch

__all__ = ["Recording", "batch", "find_recordings"]
