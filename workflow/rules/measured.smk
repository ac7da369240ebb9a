# The measured study: per scan, `roughflow import` (scan -> surface file) and `roughflow leak`
# (leak curve in physical units); the study's aggregation and figure are the shared rules.

import os  # noqa: E402

import netCDF4  # noqa: E402

from roughflow.boundary import cell_points  # noqa: E402

MEASURED = JOBS.get("measured", {})


def measured_job(wildcards):
    try:
        return MEASURED[wildcards.scan]
    except KeyError:
        raise WorkflowError(f"no scan {wildcards.scan!r} in config studies.measured") from None


def leak_mem_mb(wildcards, input, attempt):
    # the grid is the imported scan's: Snakemake evaluates this again once the import has
    # run (before the job is submitted); until then, the estimate of a 1024^2 scan
    shape = (1024, 1024)
    if os.path.exists(input[0]):
        with netCDF4.Dataset(input[0]) as ds:
            shape = (len(ds.dimensions["x"]), len(ds.dimensions["y"]))
    job = measured_job(wildcards)
    return requested_mem_mb(job, attempt, cell_points(shape, job.boundary))


rule import_scan:
    """A measured scan -> a roughflow surface file (crop, detrend, fill, units)."""
    input:
        lambda wc: measured_job(wc).file,
    output:
        f"{RESULTS}/measured/surfaces/{{scan}}.nc",
    params:
        args=lambda wc: " ".join(measured_job(wc).import_args()),
    log:
        f"{RESULTS}/logs/measured/import_{{scan}}.log",
    threads: 1
    resources:
        mem_mb=2000,
        runtime=10,
    shell:
        # the scan is a user-given path (spaces, shell characters): quoted, as are the
        # import options (MeasuredJob.import_args)
        "{RF} -v import {input:q} {params.args} -o {output} > {log} 2>&1" + KEEP_FAILED_LOG


rule leak:
    """Leak curve of one scan: contact, percolation, Reynolds flow, sealing pressure."""
    input:
        f"{RESULTS}/measured/surfaces/{{scan}}.nc",
    output:
        data=f"{RESULTS}/jobs/leak/{{scan}}.nc",
        table=f"{RESULTS}/measured/{{scan}}.txt",
    params:
        args=lambda wc: " ".join(measured_job(wc).cli_args()),
    log:
        f"{RESULTS}/logs/jobs/leak/{{scan}}.log",
    benchmark:
        f"{RESULTS}/benchmarks/workflow/jobs/leak/{{scan}}.tsv"
    threads: 1
    resources:
        mem_mb=leak_mem_mb,
        runtime=120,
    shell:
        # the table is written whole or not at all, as the dataset is
        "ROUGHFLOW_FFT_THREADS={threads} {RF} -v leak {input} {params.args} "
        "--threads {threads} -o {output.data} > {output.table}.part 2> {log} "
        "&& mv {output.table}.part {output.table} || {{ rc=$?; rm -f {output.table}.part; "
        "exit $rc; }}" + KEEP_FAILED_LOG
