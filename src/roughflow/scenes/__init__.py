"""Scene runners of the sweep workflow: one job -> one self-describing ``xr.Dataset``.

- :func:`run_threshold`: percolation thresholds for a group of seeds (no flow solve);
- :func:`run_ladder`: contact along an area ladder, Reynolds flow, theory predictions;
- :func:`run_channels`: the two surfaces of Fig. 1 and their fluid channels.

Jobs are frozen dataclasses (:mod:`roughflow.scenes.jobs`); a config study expands into
jobs with :func:`expand_study`; what a job asks of the scheduler (memory, runtime) is in
:mod:`roughflow.scenes.requests`. The runners are imported on first use, so planning jobs
(the workflow's job graph, cost estimates) does not load the solvers.
"""

from __future__ import annotations

from importlib import import_module
from typing import TYPE_CHECKING

from .expand import expand_studies, expand_study, pool_jobs, study_defaults
from .jobs import ChannelsJob, LadderJob, SurfaceParams, ThresholdJob, grid_points, job_methods
from .requests import check_job_memory, estimated_memory

if TYPE_CHECKING:
    import xarray as xr

    from .jobs import Job

_RUNNERS = {"run_threshold": "threshold", "run_ladder": "ladder", "run_channels": "channels"}

__all__ = ["ChannelsJob", "LadderJob", "SurfaceParams", "ThresholdJob", "check_job_memory",
           "estimated_memory", "expand_studies", "expand_study", "grid_points", "job_methods",
           "pool_jobs", "run", "study_defaults", *_RUNNERS]


def __getattr__(name: str):
    if name in _RUNNERS:
        return getattr(import_module(f"{__name__}.{_RUNNERS[name]}"), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def run(job: Job, *, threads: int | None = None) -> xr.Dataset:
    """Run any job and return its dataset (refused before any work if the job would need
    more memory than the machine has, :func:`roughflow.scenes.requests.check_job_memory`)."""
    from roughflow.fft import check_threads

    check_threads(threads)
    check_job_memory(job)
    ds = __getattr__(f"run_{job.kind}")(job, threads=threads)
    # provenance: the job's parameters (`roughflow scene` arguments)
    ds.attrs["job_parameters"] = " ".join(job.cli_args())
    if hasattr(job, "settings"):
        # what jobs stacked along seed must share (checked by roughflow.aggregate)
        ds.attrs["job_settings"] = " ".join(job.settings())
    return ds
