# roughflow sweep workflow: every study of Wang & Mueser (2021) from one config.
#   snakemake --cores all                                   # default config (reduced sizes)
#   snakemake --cores all --configfile config/paper.yaml    # paper sizes (see README: cluster)
#   snakemake results/threshold_vs_gamma/figure.png         # one study only
# The rules are in workflow/rules/*.smk; each calls one `roughflow` command.

import os

from snakemake.utils import min_version

# One BLAS/OpenMP thread per job: multi-threaded OpenBLAS spinning on a busy machine made
# the ladder scene 2.2x slower (docs/accuracy.md, profile); jobs inherit this environment.
for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

min_version("8.0")


# The default config unless a --configfile gives studies of its own (it would otherwise
# only extend the default, and the default's studies would leak into the run); one without
# studies changes settings of the default run (results, max_mem_mb, ...).
if "studies" not in config:

    configfile: "config/config.yaml"



report: "workflow/report/workflow.rst"


include: "workflow/rules/common.smk"
include: "workflow/rules/scenes.smk"
include: "workflow/rules/studies.smk"
include: "workflow/rules/measured.smk"
include: "workflow/rules/accuracy.smk"


# On a cluster (profiles/slurm) these run on the submitting host instead of through the
# queue: they read finished netCDF files (or convert a scan), take seconds and under 1 GB
# each, and a queued job would cost a scheduler round trip (and a queue wait) each.
localrules:
    all,
    aggregate,
    fit,
    figure,
    import_scan,
    accuracy,


rule all:
    input:
        study_targets(),
    default_target: True
