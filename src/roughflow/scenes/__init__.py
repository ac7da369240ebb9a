"""Scene runners of the sweep workflow: one job -> one self-describing ``xr.Dataset``.

- :func:`run_threshold`: percolation thresholds for a group of seeds (no flow solve);
- :func:`run_ladder`: contact along an area ladder, Reynolds flow, theory predictions;
- :func:`run_channels`: the two surfaces of Fig. 1 and their fluid channels.

Jobs are frozen dataclasses (:mod:`roughflow.scenes.jobs`); a config study expands into
jobs with :func:`expand_study`. The stage modules (contact, percolation, flow, theory) are
imported inside the runners, so planning jobs needs none of them.
"""

from .channels import run_channels
from .jobs import (
    FLOW_STUDIES,
    PARAM_DIMS,
    STUDIES,
    THRESHOLD_STUDIES,
    ChannelsJob,
    LadderJob,
    SurfaceParams,
    ThresholdJob,
    expand_study,
    grid_points,
)
from .ladder import run_ladder
from .threshold import run_threshold

__all__ = [
    "FLOW_STUDIES", "PARAM_DIMS", "STUDIES", "THRESHOLD_STUDIES", "ChannelsJob", "LadderJob",
    "SurfaceParams", "ThresholdJob", "expand_study", "grid_points", "run_channels",
    "run_ladder", "run_threshold",
]


def run(job, *, threads: int | None = None):
    """Run any job and return its dataset."""
    return {"threshold": run_threshold, "ladder": run_ladder,
            "channels": run_channels}[job.kind](job, threads=threads)
