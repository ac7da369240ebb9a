# The measured study: per scan, `roughflow import` (scan -> surface file) and `roughflow leak`
# (leak curve in physical units); the study's aggregation and figure are the shared rules.

from roughflow.scenes.requests import leak_mem_mb  # noqa: E402

MEASURED = JOBS.get("measured", {})


def measured_job(wildcards):
    try:
        return MEASURED[wildcards.scan]
    except KeyError:
        raise WorkflowError(f"no scan {wildcards.scan!r} in config studies.measured") from None


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
        mem_mb=job_mem_mb(2000),
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
        # the imported scan's grid (the library's estimate; before the import, a default)
        mem_mb=lambda wc, input, attempt: job_mem_mb(
            leak_mem_mb(measured_job(wc), input[0], attempt)),
        runtime=job_runtime_min(120),
    shell:
        # the table is written whole or not at all, as the dataset is
        "ROUGHFLOW_FFT_THREADS={threads} {RF} -v leak {input} {params.args} "
        "--threads {threads} -o {output.data} > {output.table}.part 2> {log} "
        "&& mv {output.table}.part {output.table} || {{ rc=$?; rm -f {output.table}.part; "
        "(exit $rc); }}" + KEEP_FAILED_LOG  # (exit): the status, and the shell goes on to it
