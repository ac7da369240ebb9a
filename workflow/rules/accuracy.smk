# Accuracy budget: convergence of a_c* and sigma against grid resolution, contact
# solver tolerance and bisection tolerance, with wall times; tables and error-vs-time plots
# under <results>/benchmarks/ (the config's results folder). Each rule is one
# `roughflow accuracy` call (roughflow.convergence). The two measuring jobs each write one
# netCDF dataset of their records (convergence_resolution.nc, convergence_tol.nc: written
# whole when the run completes), which the report reads. Their record logs (the .jsonl the
# command appends to as it measures, and resumes from) are declared as logs: kept after a
# failure to show what was measured, never an input, and removed before a job starts (a
# job starts afresh, not from a killed attempt's log). Not part of the default target:
# `snakemake --cores 1 accuracy` (about 2 minutes). Seeds and resolutions via
# config["accuracy"] (optional):
#   accuracy: {seeds: [0, 1, 2, 3, 4, 5], points_per_lambda_s: [2, 4, 8, 16]}

from roughflow.convergence.options import (  # noqa: E402
    ResolutionOptions,
    ToleranceOptions,
    check_resolutions,
    study_specs,
)
from roughflow.convergence.records import (  # noqa: E402
    report_files,
    resolution_file,
    tolerance_file,
)
from roughflow.scenes.requests import check_task_memory, task_mem_mb  # noqa: E402
from roughflow.surface import SurfaceSpec  # noqa: E402

_ACC = config.get("accuracy", {}) or {}
_ACC_SEEDS = " ".join(str(s) for s in _ACC.get("seeds", ResolutionOptions().seeds))
_ACC_PPL_LIST = [int(p) for p in _ACC.get("points_per_lambda_s", ResolutionOptions().ppl)]
# the finer grids are sampled down to the coarser ones (`roughflow accuracy resolution`):
# refused here, before the tolerance job runs, not in the resolution job after it
try:
    check_resolutions(_ACC_PPL_LIST)
except InputError as exc:
    raise WorkflowError(f"invalid config: key 'accuracy.points_per_lambda_s' = "
                        f"{_ACC_PPL_LIST}: {exc}") from None
_ACC_PPL = " ".join(str(p) for p in _ACC_PPL_LIST)
# contact and flow solves on the finest grid (resolution) and at 4 points (tolerances:
# the default --tol-ppl of `roughflow accuracy tol`), sized by the library's estimate of a
# ladder job
_ACC_TASK = "ladder"
_ACC_FINEST = study_specs(_ACC_PPL_LIST)[max(_ACC_PPL_LIST)]
_ACC_TOL_GRID = SurfaceSpec.from_sweep(points_per_lambda_s=ToleranceOptions().ppl)
_ACC_OUT = f"{RESULTS}/benchmarks"
_ACC_RESOLUTION = str(resolution_file(_ACC_OUT, 1.0, dataset=True))
_ACC_TOLERANCES = str(tolerance_file(_ACC_OUT, dataset=True))


def accuracy_fits(spec: SurfaceSpec, what: str):
    """An input function with no inputs that refuses the job, when the accuracy target is
    planned, if its grid does not fit the memory limit (max_mem_mb, else this machine's):
    as the sweep's jobs are refused, but only where the target is asked for (the default
    target never runs these jobs)."""

    def check(wildcards):
        if _MEM_LIMIT[0] is not None:
            try:
                check_task_memory(_ACC_TASK, (spec.nx, spec.ny), limit=_MEM_LIMIT[0],
                                  source=_MEM_LIMIT[1], what=what)
            except InputError as exc:
                raise WorkflowError(f"invalid config: key 'accuracy': {exc}") from None
        return []

    return check


rule accuracy_resolution:
    """a_c*, a_c and sigma at a_c = 0.2, 0.35 on one surface per seed at every resolution."""
    input:
        accuracy_fits(_ACC_FINEST, "the accuracy study's finest grid"),
    output:
        _ACC_RESOLUTION,
    log:
        run=f"{_ACC_OUT}/logs/convergence_resolution.log",
        records=str(resolution_file(_ACC_OUT, 1.0)),
    params:
        # params, not only the shell string: the profile reruns on params, and a run with
        # other seeds stood in for the default one ("Nothing to be done")
        seeds=_ACC_SEEDS,
        ppl=_ACC_PPL,
    threads: 1
    resources:
        # the default 16 points per lambda_s: 1024^2, 1.9 GB; the six seeds take a minute
        mem_mb=lambda wc, attempt: job_mem_mb(task_mem_mb(
            _ACC_TASK, _ACC_FINEST.nx * _ACC_FINEST.ny, attempt)),
        runtime=job_runtime_min(60),
    shell:
        "rm -f {output} {log.records} && ROUGHFLOW_FFT_THREADS={threads} {RF} accuracy "
        "resolution --out {_ACC_OUT} --seeds {params.seeds} --ppl {params.ppl} "
        "> {log.run} 2>&1"


rule accuracy_tolerances:
    """Contact-solver and bisection tolerances at the default resolution."""
    input:
        accuracy_fits(_ACC_TOL_GRID, "the accuracy study's tolerance grid"),
    output:
        _ACC_TOLERANCES,
    log:
        run=f"{_ACC_OUT}/logs/convergence_tol.log",
        records=str(tolerance_file(_ACC_OUT)),
    params:
        seeds=_ACC_SEEDS,
    threads: 1
    resources:
        mem_mb=lambda wc, attempt: job_mem_mb(task_mem_mb(
            _ACC_TASK, _ACC_TOL_GRID.nx * _ACC_TOL_GRID.ny, attempt)),
        runtime=job_runtime_min(60),
    shell:
        "rm -f {output} {log.records} && ROUGHFLOW_FFT_THREADS={threads} {RF} accuracy "
        "tol --out {_ACC_OUT} --seeds {params.seeds} > {log.run} 2>&1"


rule accuracy:
    """Tables (markdown, CSV) and error-versus-time (Pareto) plots of the accuracy budget,
    from the two record datasets."""
    input:
        _ACC_RESOLUTION,
        _ACC_TOLERANCES,
    output:
        # the isotropic and the anisotropic report (the resolution records carry the face
        # counts the latter needs): every file `roughflow accuracy report` writes
        [f"{_ACC_OUT}/{name}" for name in report_files()],
    log:
        f"{_ACC_OUT}/logs/convergence_report.log",
    shell:
        "{RF} accuracy report --out {_ACC_OUT} > {log} 2>&1"
