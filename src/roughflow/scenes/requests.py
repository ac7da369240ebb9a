"""What a job asks of the scheduler: its memory and runtime estimates (Snakemake's
``mem_mb`` and ``runtime``), the refusal of a plan that cannot fit, and the shell suffix
that keeps a failed attempt's log. The estimates come from :mod:`roughflow.resources`'
memory models and a runtime model fitted to measured jobs."""

from __future__ import annotations

import math
from collections.abc import Iterable
from pathlib import Path

from .jobs import ChannelsJob, Job, LeakJob, ThresholdJob, _grid, grid_points

#: The task of :mod:`roughflow.resources` whose memory model covers each job kind (a leak
#: job is a pressure ladder on the imported scan).
MEMORY_TASKS = {"threshold": "threshold", "ladder": "ladder", "channels": "channels",
                "leak": "ladder"}
#: Shell suffix of a rule's command: Snakemake removes a job's log before each attempt, so
#: a retry erased the failed attempt's log (the cause of the failure with it). A failed
#: attempt leaves a copy beside the log, named by when it failed; the exit status is kept.
#: (For a rule's ``shell:``: Snakemake fills in ``{log}`` and reads ``{{`` as ``{``.)
KEEP_FAILED_LOG = (' || {{ rc=$?; cp {log} "{log}.failed-$(date -u +%Y%m%dT%H%M%SZ)" '
                   '|| true; exit $rc; }}')

#: Memory of the Snakemake process that runs a job inside its cluster allocation (it shares
#: the job's memory cgroup: 375 MB peak measured for a whole config/test.yaml job under
#: SLURM, whose roughflow process the estimate puts at about 315 MB).
WRAPPER_MB = 200


def estimated_memory(job: Job, points: int | None = None) -> int:
    """Estimated peak memory of ``job`` in bytes (:func:`roughflow.resources.estimate_bytes`
    of its grid, or of ``points`` grid points: a leak job's grid is known after the import);
    the limit of the refusals."""
    from roughflow.resources import estimate_bytes

    return estimate_bytes(MEMORY_TASKS[job.kind], grid_points(job) if points is None
                          else points)


def requested_mem_mb(job: Job, attempt: int = 1, points: int | None = None) -> int:
    """Snakemake ``mem_mb`` of ``job``: its estimate plus :data:`WRAPPER_MB`, times the
    attempt (a job that a cluster ended for its memory would only fail again with the
    same request)."""
    return _mem_mb(estimated_memory(job, points), attempt)


def task_mem_mb(task: str, points: int, attempt: int = 1) -> int:
    """:func:`requested_mem_mb` of a job that is no sweep job (the accuracy study's): the
    estimate of :mod:`roughflow.resources`' ``task`` on ``points`` grid points."""
    from roughflow.resources import estimate_bytes

    return _mem_mb(estimate_bytes(task, points), attempt)


def _mem_mb(estimate: float, attempt: int) -> int:
    return attempt * (WRAPPER_MB + math.ceil(estimate / 1e6))


#: The scan grid a leak job's ``mem_mb`` assumes until its scan is imported: Snakemake
#: evaluates ``mem_mb`` again once the import has run, before the job is submitted.
LEAK_GRID_BEFORE_IMPORT = (1024, 1024)


def leak_mem_mb(job: LeakJob, surface_file: str | Path, attempt: int = 1) -> int:
    """:func:`requested_mem_mb` of a leak job on the grid of its imported surface file
    (embedded as its boundary treatment does); :data:`LEAK_GRID_BEFORE_IMPORT` while the
    file does not exist yet."""
    import netCDF4

    from roughflow.boundary import cell_points
    from roughflow.errors import InputError
    from roughflow.io import DAMAGED_OUTPUT_ADVICE

    shape = LEAK_GRID_BEFORE_IMPORT
    if Path(surface_file).exists():
        try:
            with netCDF4.Dataset(surface_file) as ds:
                shape = (len(ds.dimensions["x"]), len(ds.dimensions["y"]))
        except (OSError, KeyError) as exc:  # planning stopped on a raw HDF error (an audit)
            raise InputError(f"cannot read the grid of the imported scan {str(surface_file)!r} "
                             f"({type(exc).__name__}: {exc}) {DAMAGED_OUTPUT_ADVICE}") from None
    return requested_mem_mb(job, attempt, cell_points(shape, job.boundary))


def check_job_memory(job: Job, *, limit: int | None = None) -> int:
    """Raise :class:`~roughflow.errors.ResourceError` if ``job`` needs more memory than
    ``limit`` bytes (default: what this process can reach); returns the estimate."""
    from roughflow.resources import check_memory

    return check_memory(MEMORY_TASKS[job.kind], _grid(job), limit=limit,
                        what=f"the {job.kind} job {job.job_id}")


def check_plan_memory(jobs: dict[str, dict[str, Job]], limit: int, source: str) -> None:
    """Refuse a plan (study name -> jobs) with a job that needs more than ``limit`` bytes
    (``source`` says where the limit comes from), naming the study and the job."""
    from roughflow.errors import ResourceError

    for study, study_jobs in jobs.items():
        for job in study_jobs.values():
            if isinstance(job, LeakJob):
                continue  # its grid is the scan's; ``roughflow leak`` checks it itself
            try:
                check_job_memory(job, limit=limit)
            except ResourceError as exc:
                raise ResourceError(f"config studies.{study}: {exc} ({source})") from None


def check_task_memory(task: str, shape: tuple[int, int], *, limit: int, source: str,
                      what: str) -> None:
    """Refuse ``what``, a job that is no sweep job (the accuracy study's), if the estimate of
    :mod:`roughflow.resources`' ``task`` on a grid of ``shape`` exceeds ``limit`` bytes
    (``source`` says where the limit comes from), as :func:`check_plan_memory` refuses a
    sweep job."""
    from roughflow.errors import ResourceError
    from roughflow.resources import check_memory

    try:
        check_memory(task, shape, limit=limit, what=what)
    except ResourceError as exc:
        raise ResourceError(f"{exc} ({source})") from None


# Cost model: CPU seconds on one core of the 2-core development machine, fitted to single
# `roughflow scene` runs (one thread) of config/paper.yaml's jobs, 0.26 M to 33.5 M points
# (docs/workflow.md "Cost", all on 2026-11-27: threshold searches with FFTW_MEASURE plans,
# ladders with one Gauss-Seidel sweep each side of the AMG V-cycle;
# benchmarks/bench_cost_model.py repeats them). A guide for the workflow's runtime requests
# and core-hour estimates, not a benchmark.
#: Start-up of one ``roughflow scene`` process (imports, surface generation, writing).
COST_START_S = 3.0
#: An isotropic elastic threshold search (both axes), per N log2(N): 4.3-8.7e-8 s measured
#: (the wider band eps_f = 1/64 at the low end; it needed more iterations under ESTIMATE
#: plans, 1.4-1.9x at gamma 4 and 8, and no longer does: 0.9-1.45x).
COST_THRESHOLD_S = 8e-8
#: Anisotropic searches bracket a_c*(x) and a_c*(y) apart (9 solves where isotropic
#: searches on large grids share 4-7): measured 1.2-1.8 times the isotropic cost per point
#: at gamma 2, 2.0 at gamma 4, 1.8-2.7 at gamma 8.
COST_ANISOTROPIC_FACTOR = 2.0
#: One Reynolds solve (one axis, AMG-CG), per grid point: 3.1-3.55e-6 s measured in the
#: three 2048^2 ladders (6.5e-6 fitted to runs of 2026-11-26, before the lighter smoothing
#: and on a slower day of the shared machine).
COST_FLOW_S = 3.5e-6
#: The contact solves of a ladder step (warm-started load search), per N log2(N), by model.
#: Adhesive: 1.6e-7 until FIRE's force pass was compiled (2026-12-07), whose solves then took
#: 0.64x the time at 512^2 and 0.54x at 1024^2 (docs/contact.md "Adhesive force pass").
COST_LADDER_CONTACT_S = {"elastic": 7e-8, "adhesive": 1.0e-7, "bearing": 0.0}
#: The bearing model's exact threshold (one sort and sweep), per grid point and seed.
COST_BEARING_THRESHOLD_S = 8e-7


def _threshold_seconds(job: ThresholdJob, n: int) -> float:
    """CPU seconds of one seed's elastic threshold search (both axes)."""
    factor = 1.0 if job.surface.gamma == 1 else COST_ANISOTROPIC_FACTOR
    return COST_THRESHOLD_S * n * math.log2(n) * factor


def estimated_seconds(job: Job) -> float:
    """Estimated CPU seconds of ``job`` (:data:`COST_START_S` included)."""
    n = grid_points(job)
    if isinstance(job, ChannelsJob):  # two load searches to the area, two labellings
        return COST_START_S + 4 * COST_LADDER_CONTACT_S["elastic"] * n * math.log2(n)
    seeds = len(job.seeds)
    if isinstance(job, ThresholdJob):
        per = COST_BEARING_THRESHOLD_S * n if job.model == "bearing" \
            else _threshold_seconds(job, n)
        return COST_START_S + seeds * per
    flow = COST_FLOW_S * n
    contact = COST_LADDER_CONTACT_S[job.model] * n * math.log2(n)
    steps = len(job.area_fractions)  # each: contact, flow along x and y; plus the reference
    return COST_START_S + seeds * (steps * (2 * flow + contact) + 2 * flow)


def plan_cost(jobs: Iterable[Job]) -> str:
    """One line on the cost of a plan: its number of sweep jobs and their estimated
    core-hours (:func:`estimated_seconds`), and the longest job; said at planning, before a
    run of hours starts (``workflow/scripts/estimate_cost.py`` itemises it by kind and
    model). Measured-scan (leak) jobs are counted apart: their cost is known only after the
    import."""
    jobs = list(jobs)
    scans = sum(job.kind == "leak" for job in jobs)
    # a measured-only config still runs its scans' jobs: "no sweep jobs" must not read as
    # "nothing to run"
    measured = (f"; {scans} measured scan{'s' if scans != 1 else ''}, costed once imported"
                if scans else "")
    seconds = sorted((estimated_seconds(job), job.job_id) for job in jobs if job.kind != "leak")
    if not seconds:
        return "no sweep jobs planned" + measured
    total = sum(s for s, _ in seconds)
    return (f"{len(seconds)} sweep jobs planned, about {total / 3600:.2g} core-hours by the "
            f"cost model (the longest, {seconds[-1][1]}, about {seconds[-1][0] / 60:.2g} min)"
            + measured)


#: Snakemake ``runtime`` of a job: this many times its estimate (the model is fitted to
#: single runs; seeds differ by up to 2x in solves and a busy node slows a job) ...
RUNTIME_MARGIN = 3.0
#: ... and never under this many minutes (start-up of a cluster job, small grids).
RUNTIME_FLOOR_MIN = 2


def requested_runtime_min(job: Job, attempt: int = 1) -> int:
    """Snakemake ``runtime`` (minutes) of ``job``: :data:`RUNTIME_MARGIN` times
    :func:`estimated_seconds`, at least :data:`RUNTIME_FLOOR_MIN`, times the attempt (a job
    that a cluster ended for its time limit would only fail again with the same request)."""
    minutes = math.ceil(RUNTIME_MARGIN * estimated_seconds(job) / 60)
    return attempt * max(RUNTIME_FLOOR_MIN, minutes)
