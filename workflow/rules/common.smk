# Config validation and job planning (runs before any job starts).

import json
import posixpath
import shlex
import sys
from pathlib import Path

from snakemake.exceptions import WorkflowError
from snakemake.utils import validate


SCHEMA = Path(workflow.basedir) / "workflow" / "schemas" / "config.schema.yaml"


def _validate_config(config):
    """JSON-schema validation with a message naming the key and the value.

    jsonschema's best match gives the path of the offending key. The schema's defaults are
    documentation only (tests/test_defaults.py keeps them equal to roughflow's): missing
    keys are filled by roughflow.scenes.study_defaults, the one source.
    """
    import yaml

    from roughflow.scenes.config_file import schema_error

    message = schema_error(config, yaml.safe_load(SCHEMA.read_text()))
    if message is not None:
        raise WorkflowError(f"invalid config: {message}")
    validate(config, "../schemas/config.schema.yaml", set_default=False)


def _results_dir(results):
    """The results folder without trailing or doubled slashes ('out/' -> 'out'): Snakemake
    warns about '//' in the paths built from it and matches such paths inconsistently."""
    norm = posixpath.normpath(results)
    if norm in ("/", "//"):
        raise WorkflowError(f"invalid config: key 'results' = {results!r}: the results "
                            "folder cannot be the file-system root")
    return norm


from roughflow.errors import InputError  # noqa: E402
from roughflow.fft import check_environment  # noqa: E402
from roughflow.scenes.config_file import check_config_file  # noqa: E402

try:
    for _configfile in workflow.configfiles:
        check_config_file(_configfile)
except InputError as exc:
    raise WorkflowError(f"invalid config: {exc}") from None
_validate_config(config)
try:  # every job reads them: a typo would fail each one (twice on SLURM), not the plan
    check_environment()
except InputError as exc:
    raise WorkflowError(f"invalid environment: {exc}") from None

from roughflow.defaults import FLOW_STUDIES, MEASURED_STUDY, THRESHOLD_STUDIES  # noqa: E402
from roughflow.figures import caption as figure_caption  # noqa: E402
from roughflow.resources import total_bytes, total_source  # noqa: E402
from roughflow.slurm import job_limits  # noqa: E402
from roughflow.scenes import expand_study, pool_jobs, study_defaults  # noqa: E402
from roughflow.scenes.expand import aggregated_config  # noqa: E402
from roughflow.scenes.requests import (  # noqa: E402
    KEEP_FAILED_LOG,
    RUNTIME_MARGIN,
    WRAPPER_MB,
    check_plan_memory,
    plan_cost,
    requested_mem_mb,
    requested_runtime_min,
)

RESULTS = config["results"] = _results_dir(config.get("results", "results"))
# the Python that runs snakemake and its roughflow (no PATH lookup needed)
PYTHON = shlex.quote(sys.executable)
RF = f"{PYTHON} -m roughflow"
STUDIES = config["studies"]


def study_config_text(study):
    """The study's config block, for the figure's caption in the report (a report of the
    test config looked like one of the paper's). Not the config files' names: a params
    value, it would rerun every figure when a file is renamed or an overlay added."""
    return f"studies.{study}: {json.dumps(STUDIES[study], sort_keys=True)}"
# A run whose jobs go to a SLURM cluster. Snakemake names the executor only after it has read
# this file (workflow.local_exec is still True here under --executor slurm), so such a run
# is told by the global mem_mb that profiles/slurm gives it, above this machine's memory:
# its jobs do not run here. Its partition is the profile's default slurm_partition.
_machine_bytes = total_bytes()
_global_mem_mb = getattr(workflow.global_resources.get("mem_mb"), "value", None)
RUNS_ON_CLUSTER = (workflow.is_main_process and _machine_bytes is not None
                   and isinstance(_global_mem_mb, int)
                   and _global_mem_mb * 10**6 > _machine_bytes)


def _default_resource(name):
    """A --default-resources value as given (a profile's default-resources), else None."""
    settings = getattr(workflow.resource_settings, "default_resources", None)
    for arg in getattr(settings, "args", None) or []:
        key, _, value = str(arg).partition("=")
        if key.strip() == name:
            return value.strip().strip("'\"")
    return None


# What a job may ask of the cluster (memory, time): a request above the limits of its
# partition, QOS or association would never run (roughflow.slurm), so every cluster job's
# request is capped at them. A rule sent to another partition, account or QOS
# (--set-resources RULE:slurm_partition=...) could be capped below what its jobs need
# there: then nothing is capped.
_OWN_LIMITS = [rule for rule, res in
               (getattr(workflow.resource_settings, "overwrite_resources", None) or {}).items()
               if {"slurm_partition", "slurm_account", "qos"} & set(res)]
try:  # a partition or account the cluster lacks: sbatch would refuse every job, twice
    SLURM_LIMITS = job_limits(_default_resource("slurm_partition"),
                              _default_resource("slurm_account"), _default_resource("qos")) \
        if RUNS_ON_CLUSTER and not _OWN_LIMITS else None
except InputError as exc:
    raise WorkflowError(f"invalid SLURM settings in the profile's default-resources "
                        f"(the config.yaml of the --profile folder, a copy of "
                        f"profiles/slurm): {exc}") from None
# The memory a job may need, checked at planning before any job runs: the config's
# max_mem_mb; on a SLURM cluster what a job may ask of it less the job's Snakemake
# (WRAPPER_MB), so that every planned first request runs; else the memory of this
# machine. Only the Snakemake that plans the run checks the plan: the one that runs a job
# inside a SLURM allocation (--mode remote, and under its srun --mode subprocess) parses
# this file again in a cgroup sized for that one job, where the plan's larger jobs would
# refuse it (each job's roughflow checks its own memory before allocating).
if not workflow.is_main_process:
    _MEM_LIMIT = (None, "")
elif config.get("max_mem_mb") is not None:
    _MEM_LIMIT = (int(config["max_mem_mb"]) * 10**6, f"max_mem_mb = {config['max_mem_mb']}")
elif SLURM_LIMITS is not None:
    _MEM_LIMIT = ((SLURM_LIMITS.mem_mib - WRAPPER_MB) * 10**6,
                  f"a job in SLURM partition {SLURM_LIMITS.partition} may ask for "
                  f"{SLURM_LIMITS.mem_mib} MB ({SLURM_LIMITS.mem_by}), less {WRAPPER_MB} MB "
                  "for the job's Snakemake; max_mem_mb in the config sets another limit")
else:
    _MEM_LIMIT = (_machine_bytes, f"{total_source()}; set max_mem_mb in the config for a "
                                 "cluster")
# A local run starts as many jobs as --cores allows, whatever their mem_mb, unless the run
# has a global mem_mb: give it this machine's memory (a --resources mem_mb=N of the user's
# stands), so that large jobs wait for each other instead of meeting the out-of-memory killer
# (16 cores would start 16 jobs of the paper's sizes at once). The job inside a cluster
# allocation needs none. A cluster run must not get it either: Snakemake lowers every job's
# mem_mb to the global one, so each job would ask the cluster for at most the login node's
# memory, at every attempt. profiles/slurm gives the run a global mem_mb of its own that
# never binds, and a cluster run without it is warned about once its executor is known.
LOCAL_MEM_MB = None
if (workflow.is_main_process and _machine_bytes is not None
        and "mem_mb" not in workflow.global_resources):
    LOCAL_MEM_MB = _machine_bytes // 10**6
    workflow.register_resource("mem_mb", LOCAL_MEM_MB)
_BUDGET_WARNED = []


def job_mem_mb(mb):
    """A job's mem_mb: at most the local run's LOCAL_MEM_MB (a job that needs the whole
    machine runs alone; above it Snakemake would refuse to schedule it); on a SLURM cluster
    at most what a job may ask for there (a retry's doubled request above it would never
    run; the plan's check keeps the first attempt's below it); else as given."""
    if SLURM_LIMITS is not None:
        return min(mb, SLURM_LIMITS.mem_mib)
    if LOCAL_MEM_MB is None:
        return mb
    if not workflow.local_exec and not _BUDGET_WARNED:
        from snakemake.logging import logger

        _BUDGET_WARNED.append(True)
        logger.warning(
            f"a cluster run without profiles/slurm: Snakemake lowers every job's mem_mb to "
            f"the memory of this machine ({LOCAL_MEM_MB} MB), and a job that needs more is "
            "refused in its allocation at every attempt; run with --profile profiles/slurm, "
            "or give a global --resources mem_mb above any job's, as that profile does")
    return min(mb, LOCAL_MEM_MB)


try:
    JOBS = {name: expand_study(name, block) for name, block in STUDIES.items()}
    # one pool of jobs per kind, keyed by job id: a job shared by several studies (same
    # parameters, e.g. elastic gamma = 2 at the default size) runs once
    _POOLED = pool_jobs(JOBS)
    if _MEM_LIMIT[0] is not None:
        check_plan_memory(JOBS, *_MEM_LIMIT)
except InputError as exc:
    raise WorkflowError(f"invalid config: {exc}") from None
POOL = {kind: {job_id: job for job_id, job in _POOLED.items() if job.kind == kind}
        for kind in ("threshold", "ladder")}
if workflow.is_main_process:  # a paper-sized plan runs for hours: say so before it starts
    from snakemake.logging import logger

    logger.info(plan_cost(_POOLED.values()))

# A sweep job whose request exceeds the time a job may ask for asks for that instead
# (job_runtime_min); say so before anything runs, since such a job may end TIMEOUT.
if SLURM_LIMITS is not None and SLURM_LIMITS.max_minutes is not None:
    _capped = sorted(request for request in
                     ((requested_runtime_min(job), job_id) for pool in POOL.values()
                      for job_id, job in pool.items())
                     if request[0] > SLURM_LIMITS.max_minutes)
    if _capped:
        from snakemake.logging import logger

        logger.warning(
            f"{len(_capped)} of {sum(map(len, POOL.values()))} jobs ask for more time than "
            f"SLURM partition {SLURM_LIMITS.partition} allows ({SLURM_LIMITS.time_by} "
            f"{SLURM_LIMITS.max_minutes} min; the longest asks for {_capped[-1][0]} min, "
            f"{RUNTIME_MARGIN:g} times its estimate: {_capped[-1][1]}): their requests are "
            f"capped at {SLURM_LIMITS.max_minutes} min, and a job that needs longer ends "
            "TIMEOUT; a partition or QOS with a longer limit avoids that")

THRESHOLD_NAMES = [s for s in STUDIES if s in THRESHOLD_STUDIES]
FLOW_NAMES = [s for s in STUDIES if s in FLOW_STUDIES]
MEASURED_NAMES = [s for s in STUDIES if s == MEASURED_STUDY]


def _alternatives(names):
    # a regex that matches none of the study names when the list is empty
    return "|".join(names) if names else "(?!x)x"


wildcard_constraints:
    study="|".join(STUDIES),
    kind="threshold|ladder",
    job=r"[A-Za-z0-9_.+\-]+",
    scan=r"[A-Za-z0-9_.\-]+",


def study_option(study, key):
    """A study's option with its default (roughflow.scenes.study_defaults)."""
    defaults = study_defaults(study)[key]
    given = STUDIES[study].get(key)
    if isinstance(defaults, dict):
        return {**defaults, **(given or {})}
    return defaults if given is None else given


def job_of(wildcards):
    try:
        return POOL[wildcards.kind][wildcards.job]
    except KeyError:
        raise WorkflowError(
            f"no {wildcards.kind} job {wildcards.job!r} in the config"
        ) from None


def job_args(wildcards):
    """The `roughflow scene` arguments of a job (also the rerun trigger of its rule)."""
    return " ".join(job_of(wildcards).cli_args())


# Both scale with Snakemake's attempt (1, then 2 for the profile's one retry): a job that
# SLURM ended for its time limit (TIMEOUT) or memory (OUT_OF_MEMORY) would only fail again
# with the same request.


def job_runtime_min(minutes):
    """A job's runtime (minutes): on a SLURM cluster at most the time a job may ask for
    (above it the job would wait forever), else as given."""
    if SLURM_LIMITS is not None and SLURM_LIMITS.max_minutes is not None:
        return min(minutes, SLURM_LIMITS.max_minutes)
    return minutes


def runtime_min(wildcards, attempt=1):
    # the cost model of roughflow.scenes.requests with its margin (minutes)
    return job_runtime_min(requested_runtime_min(job_of(wildcards), attempt))


def mem_mb(wildcards, attempt=1):
    # the library's memory estimate of the job (roughflow.resources, calibrated by
    # benchmarks/bench_memory.py; also the limit of the refusals) plus the Snakemake
    # process that wraps it on a cluster node
    return job_mem_mb(requested_mem_mb(job_of(wildcards), attempt))


def jobs_of(study):
    return [f"{RESULTS}/jobs/{job.kind}/{job_id}.nc"
            for job_id, job in sorted(JOBS[study].items())]


def study_targets():
    out = []
    for study in STUDIES:
        out += [f"{RESULTS}/{study}/dataset.nc", f"{RESULTS}/{study}/figure.png",
                f"{RESULTS}/{study}/figure.pdf"]
        if study == "threshold_vs_size":
            out.append(f"{RESULTS}/{study}/fit.nc")
    return out


def figure_inputs(wildcards):
    out = {"dataset": f"{RESULTS}/{wildcards.study}/dataset.nc"}
    if wildcards.study == "threshold_vs_size":
        out["fit"] = f"{RESULTS}/{wildcards.study}/fit.nc"
    return out
