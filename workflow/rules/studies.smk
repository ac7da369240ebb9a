# Aggregation, fits and figures of each study.


rule aggregate:
    """Combine the study's per-job datasets (outer join on the coordinates)."""
    input:
        lambda wc: jobs_of(wc.study),
    output:
        f"{RESULTS}/{{study}}/dataset.nc",
    params:
        # the study's config block, recorded as the dataset's study_config (provenance);
        # without the fit options and labels, which do not change the dataset
        config=lambda wc: aggregated_config(STUDIES[wc.study]),
    log:
        f"{RESULTS}/logs/{{study}}/aggregate.log",
    benchmark:
        f"{RESULTS}/benchmarks/workflow/{{study}}/aggregate.tsv"
    wildcard_constraints:
        study=_alternatives(THRESHOLD_NAMES + FLOW_NAMES + MEASURED_NAMES),
    threads: 1
    resources:
        mem_mb=1000,
        runtime=5,
    shell:
        "{RF} -v aggregate {input} --study {wildcards.study} --study-config {params.config:q} "
        "-o {output} 2> {log}"


rule fit:
    """Finite-size-scaling fits (nu = 4/3 and free; per direction and joint; bootstrap)."""
    input:
        f"{RESULTS}/{{study}}/dataset.nc",
    output:
        f"{RESULTS}/{{study}}/fit.nc",
    params:
        bootstrap=lambda wc: study_option(wc.study, "fit")["bootstrap"],
        nu=lambda wc: study_option(wc.study, "fit")["nu"],
    log:
        f"{RESULTS}/logs/{{study}}/fit.log",
    benchmark:
        f"{RESULTS}/benchmarks/workflow/{{study}}/fit.tsv"
    wildcard_constraints:
        study="threshold_vs_size",
    threads: 1
    resources:
        mem_mb=1000,
        runtime=5,
    shell:
        "{RF} -v fit {input} --bootstrap {params.bootstrap} --nu {params.nu} "
        "-o {output} 2> {log}"


rule figure:
    """The study's figure (PNG and PDF) with its caption (figure.md, and in the report)."""
    input:
        unpack(figure_inputs),
    output:
        png=report(
            f"{RESULTS}/{{study}}/figure.png",
            caption="../report/figure.rst",
            category="Figures",
            labels={"study": "{study}"},
        ),
        pdf=f"{RESULTS}/{{study}}/figure.pdf",
        caption=f"{RESULTS}/{{study}}/figure.md",
    params:
        fit=lambda wc, input: f"--fit {input.fit}" if "fit" in input.keys() else "",
        # for the report (report/figure.rst): the library's caption, the one `figure
        # --caption` prints
        caption=lambda wc: figure_caption(wc.study),
        settings=lambda wc: study_config_text(wc.study),
    log:
        f"{RESULTS}/logs/{{study}}/figure.log",
    benchmark:
        f"{RESULTS}/benchmarks/workflow/{{study}}/figure.tsv"
    threads: 1
    resources:
        mem_mb=1000,
        runtime=5,
    shell:
        "MPLBACKEND=Agg {RF} -v figure {wildcards.study} {input.dataset} {params.fit} "
        "-o {output.png} 2> {log}"
