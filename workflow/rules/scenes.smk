# Simulation jobs: one `roughflow scene` call each, one netCDF per job. Jobs live in a
# pool shared by the studies (results/jobs/<kind>/<job id>.nc), so a job that several
# studies need runs once.


rule scene:
    """threshold: a_c*(x), a_c*(y) of a group of seeds (contact bisection, no flow);
    ladder: contact along an area ladder + Reynolds flow along x, y + theory lines."""
    output:
        f"{RESULTS}/jobs/{{kind}}/{{job}}.nc",
    params:
        args=job_args,
    log:
        f"{RESULTS}/logs/jobs/{{kind}}/{{job}}.log",
    benchmark:
        f"{RESULTS}/benchmarks/workflow/jobs/{{kind}}/{{job}}.tsv"
    threads: 1
    resources:
        mem_mb=mem_mb,
        runtime=runtime_min,
    shell:
        "ROUGHFLOW_FFT_THREADS={threads} {RF} -v scene {params.args} "
        "--threads {threads} -o {output} 2> {log}" + KEEP_FAILED_LOG


rule channels:
    """Fig. 1: isotropic 0.5 x 2 cell and the gamma-stretched square cell at a_c ~ 0.4."""
    output:
        f"{RESULTS}/channels/dataset.nc",
    params:
        args=lambda wc: " ".join(JOBS["channels"]["channels"].cli_args()),
    log:
        f"{RESULTS}/logs/channels/channels.log",
    benchmark:
        f"{RESULTS}/benchmarks/workflow/channels/channels.tsv"
    threads: 1
    resources:
        mem_mb=lambda wc, attempt: job_mem_mb(
            requested_mem_mb(JOBS["channels"]["channels"], attempt)),
        runtime=job_runtime_min(10),
    shell:
        "ROUGHFLOW_FFT_THREADS={threads} {RF} -v scene {params.args} "
        "--threads {threads} -o {output} 2> {log}" + KEEP_FAILED_LOG
