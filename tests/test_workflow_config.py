"""Config handling of the Snakemake workflow at planning time (dry runs only, no job runs).

Each test runs ``snakemake -n`` in a subprocess in a temporary copy of the workflow
(tests/workflow_copy.py), on a small config built from config/test.yaml.
"""

from __future__ import annotations

import os
import shlex
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
import yaml
from workflow_copy import copy_workflow

SNAKEMAKE = Path(sys.executable).with_name("snakemake")

pytestmark = pytest.mark.skipif(not SNAKEMAKE.exists(), reason="snakemake not installed")


def dry_run(wd: Path, *args: str) -> subprocess.CompletedProcess:
    """``snakemake -n -p`` (shell commands printed) on config/case.yaml; targets in args."""
    env = {**os.environ, "ROUGHFLOW_FFT_THREADS": "1", "MPLBACKEND": "Agg"}
    return subprocess.run([str(SNAKEMAKE), *args, "-n", "-p", "--cores", "1",
                           "--configfile", "config/case.yaml"],
                          cwd=wd, env=env, capture_output=True, text=True, timeout=300)


def write_case(wd: Path, studies=("channels",), **top) -> None:
    """config/case.yaml: the given studies of config/test.yaml plus top-level keys."""
    cfg = yaml.safe_load((wd / "config" / "test.yaml").read_text())
    cfg["studies"] = {name: cfg["studies"][name] for name in studies}
    cfg.update(top)
    (wd / "config" / "case.yaml").write_text(yaml.safe_dump(cfg))


def shell_commands(output: str, word: str) -> list[list[str]]:
    """The printed shell commands that contain ``word``, split as the shell splits them."""
    return [shlex.split(line.split("Shell command:", 1)[1])
            for line in output.splitlines() if "Shell command:" in line and word in line]



def test_the_plan_states_its_cost(tmp_path):
    # a run of hours (config/paper.yaml: about 11 core-hours) says so before it starts
    wd = copy_workflow(tmp_path)
    write_case(wd, studies=("threshold_vs_gamma",))
    run = dry_run(wd)
    assert run.returncode == 0, run.stderr[-2000:]
    output = run.stdout + run.stderr
    lines = [line for line in output.splitlines() if "sweep jobs planned" in line]
    assert len(lines) == 1 and "core-hours by the cost model" in lines[0], lines

# (a) a scan path with a space and shell characters reaches `roughflow import` as one word
def test_scan_path_with_spaces_and_shell_characters_is_quoted(tmp_path):
    wd = copy_workflow(tmp_path)
    scan = "tests/data/afm 64 & co;$(x).npy"
    shutil.copy(wd / "tests" / "data" / "afm-64.npy", wd / scan)
    write_case(wd, studies=("measured",))
    cfg = yaml.safe_load((wd / "config" / "case.yaml").read_text())
    cfg["studies"]["measured"]["scans"][0]["file"] = scan
    (wd / "config" / "case.yaml").write_text(yaml.safe_dump(cfg))
    res = dry_run(wd)
    assert res.returncode == 0, res.stderr[-2000:]
    [cmd] = shell_commands(res.stdout, " import ")
    assert cmd[cmd.index("import") + 1] == scan


# (b) a key given twice in one mapping of a config file is refused, naming key and file
DUPLICATES = {
    "study block": ("studies:\n"
                    "  threshold_vs_gamma:\n    gamma: [1, 2]\n    seeds: [0, 1]\n"
                    "  threshold_vs_gamma:\n    gamma: [4]\n    seeds: [5]\n",
                    "studies.threshold_vs_gamma", "lines 2 and 5"),
    "key inside a series": ("studies:\n  threshold_vs_gamma:\n    seeds: [0, 1]\n    series:\n"
                            "      - {model: [elastic], eps_f: [0.125], eps_f: [0.5]}\n",
                            "studies.threshold_vs_gamma.series[0].eps_f", "lines 5 and 5"),
}


@pytest.mark.parametrize("case", sorted(DUPLICATES))
def test_duplicate_config_key_is_refused(tmp_path, case):
    wd = copy_workflow(tmp_path)
    text, key, lines = DUPLICATES[case]
    (wd / "config" / "case.yaml").write_text(text)
    res = dry_run(wd)
    out = res.stdout + res.stderr
    assert res.returncode != 0
    for needle in ("invalid config", "case.yaml", repr(key), "given twice", lines):
        assert needle in out, (needle, out[-2000:])
    assert not (wd / "results").exists()


# (c) the accuracy rules: `roughflow accuracy` of the Python that runs snakemake (as every
# rule calls roughflow), under the config's results folder
def test_accuracy_rules_use_this_python_and_the_results_folder(tmp_path):
    wd = copy_workflow(tmp_path)
    write_case(wd, results="acc_out")
    res = dry_run(wd, "accuracy")
    assert res.returncode == 0, res.stderr[-2000:]
    cmds = shell_commands(res.stdout, " accuracy ")
    assert len(cmds) == 3
    assert sorted(c[c.index("accuracy") + 1] for c in cmds) == ["report", "resolution", "tol"]
    for cmd in cmds:
        i = cmd.index("accuracy")
        assert cmd[i - 2:i] == ["-m", "roughflow"], cmd
        assert Path(cmd[i - 3]).parent == Path(sys.executable).parent, cmd  # this venv
        assert cmd[cmd.index("--out") + 1] == "acc_out/benchmarks", cmd
    assert "results/benchmarks" not in res.stdout + res.stderr
    assert "convergence.py" not in res.stdout + res.stderr
    # the report job declares every file the report writes (the anisotropic report's three
    # were written but not declared: snakemake neither tracked nor cleaned them)
    from roughflow.convergence.records import report_files

    for name in report_files():
        assert f"acc_out/benchmarks/{name}" in res.stdout, name


# (d) a results folder with a trailing or doubled slash is normalised ('out/' -> 'out')
@pytest.mark.parametrize("results", ["out/", "out//sub/"])
def test_results_folder_slashes_are_normalised(tmp_path, results):
    wd = copy_workflow(tmp_path)
    write_case(wd, results=results)
    res = dry_run(wd)
    out = res.stdout + res.stderr
    assert res.returncode == 0, res.stderr[-2000:]
    assert "double '/'" not in out and "out//" not in out
    norm = results.rstrip("/").replace("//", "/")
    assert f"output: {norm}/channels/dataset.nc" in out


def test_results_folder_root_is_refused(tmp_path):
    wd = copy_workflow(tmp_path)
    write_case(wd, results="/")
    res = dry_run(wd)
    out = res.stdout + res.stderr
    assert res.returncode != 0
    assert "invalid config" in out and "'results'" in out and "'/'" in out, out[-2000:]


def test_duplicate_keys_named_with_their_lines(tmp_path):
    from roughflow.errors import InputError
    from roughflow.scenes.config_file import check_config_file, duplicate_keys

    text = ("studies:\n"
            "  a: {seeds: [0]}\n"
            "  b:\n"
            "    series:\n"
            "      - {gamma: [1], gamma: [2]}\n"
            "  a: {seeds: [1]}\n")
    found = sorted(duplicate_keys(yaml.compose(text, Loader=yaml.SafeLoader)))
    assert found == [("studies.a", 2, 6), ("studies.b.series[0].gamma", 5, 5)]
    # an anchor used twice, or a merge key overridden, is not a duplicate
    ok = "base: &b {x: 1}\none: *b\ntwo: {<<: *b, x: 2}\n"
    assert duplicate_keys(yaml.compose(ok, Loader=yaml.SafeLoader)) == []
    (tmp_path / "c.yaml").write_text(text)
    # the first repetition in the file is named
    with pytest.raises(InputError, match=r"'studies.b.series\[0\].gamma' is given twice "
                                         r"\(lines 5 and 5\)"):
        check_config_file(tmp_path / "c.yaml")


@pytest.mark.parametrize(("var", "value"), [("ROUGHFLOW_FFTW_EFFORT", "FFTW_Measure"),
                                            ("ROUGHFLOW_FFTW_WISDOM", " ")])
def test_a_bad_fft_setting_stops_the_plan(tmp_path, monkeypatch, var, value):
    """Every job reads the FFT settings from the environment; a typo let the plan through
    and failed each job (twice on SLURM, with the profile's retry). It stops the plan."""
    wd = copy_workflow(tmp_path)
    write_case(wd)
    monkeypatch.setenv(var, value)
    res = dry_run(wd)
    out = res.stdout + res.stderr
    assert res.returncode != 0
    assert "invalid environment" in out and var in out and repr(value) in out, out[-2000:]


def test_a_failed_attempt_keeps_its_log(tmp_path):
    """Snakemake removes a job's log before each attempt, so the retry's log replaced the
    failed attempt's and the cause of the failure was lost. The rules' commands end in
    KEEP_FAILED_LOG: a failed attempt leaves a copy, and the exit status is the command's."""
    from roughflow.scenes.requests import KEEP_FAILED_LOG

    (tmp_path / "Snakefile").write_text(
        "rule a:\n"
        "    output: 'out.txt'\n"
        "    log: 'a.log'\n"
        "    shell: \"(if [ -e marker ]; then echo second; else touch marker; echo first; "
        f"exit 7; fi) > {{log}}\" + {KEEP_FAILED_LOG!r} + \" ; touch {{output}}\"\n")
    res = subprocess.run([str(SNAKEMAKE), "--cores", "1", "--retries", "1"], cwd=tmp_path,
                         capture_output=True, text=True, timeout=120)
    assert res.returncode == 0, res.stderr[-2000:]
    assert (tmp_path / "a.log").read_text() == "second\n"
    (kept,) = tmp_path.glob("a.log.failed-*")
    assert kept.read_text() == "first\n"
    # the status gets through: without a retry the run fails
    for p in (tmp_path / "marker", tmp_path / "out.txt", kept):
        p.unlink()
    res = subprocess.run([str(SNAKEMAKE), "--cores", "1", "--retries", "0"], cwd=tmp_path,
                         capture_output=True, text=True, timeout=120)
    assert res.returncode != 0 and not (tmp_path / "out.txt").exists()
    assert "exit status 7" in res.stderr + res.stdout


# (e) study options reach the commands: the fit's nu, the fit in the size figure
def test_fit_nu_and_the_fit_file_reach_their_commands(tmp_path):
    wd = copy_workflow(tmp_path)
    write_case(wd, studies=("threshold_vs_size",), results="out")
    cfg = yaml.safe_load((wd / "config" / "case.yaml").read_text())
    cfg["studies"]["threshold_vs_size"]["fit"]["nu"] = 1.2
    (wd / "config" / "case.yaml").write_text(yaml.safe_dump(cfg))
    res = dry_run(wd)
    assert res.returncode == 0, res.stderr[-2000:]
    [fit] = [c for c in shell_commands(res.stdout, " fit ") if "fit" in c and "-o" in c
             and c[c.index("-o") + 1] == "out/threshold_vs_size/fit.nc"]
    assert fit[fit.index("--nu") + 1] == "1.2", fit
    [figure] = shell_commands(res.stdout, " figure threshold_vs_size ")
    assert figure[figure.index("--fit") + 1] == "out/threshold_vs_size/fit.nc", figure


# (f) the accuracy seeds reach both convergence runs
def test_accuracy_seeds_reach_both_convergence_runs(tmp_path):
    wd = copy_workflow(tmp_path)
    write_case(wd, accuracy={"seeds": [7]})
    res = dry_run(wd, "accuracy")
    assert res.returncode == 0, res.stderr[-2000:]
    cmds = [c for c in shell_commands(res.stdout, " accuracy ")
            if "resolution" in c or "tol" in c]
    assert sorted(c[c.index("--out") - 1] for c in cmds) == ["resolution", "tol"], cmds
    for cmd in cmds:
        i = cmd.index("--seeds")
        assert cmd[i + 1] == "7" and not cmd[i + 2].isdigit(), cmd


# (g) a resolution below 2 points per lambda_s is refused by the schema, naming the key
def test_accuracy_resolution_below_two_is_refused(tmp_path):
    wd = copy_workflow(tmp_path)
    write_case(wd, accuracy={"points_per_lambda_s": [1, 2]})  # 1 divides 2: only the
    res = dry_run(wd, "accuracy")  # schema's minimum refuses it
    out = res.stdout + res.stderr
    assert res.returncode != 0
    assert "invalid config" in out and "accuracy.points_per_lambda_s" in out, out[-2000:]
    assert not (wd / "results").exists()


# (h) the accuracy jobs are held to max_mem_mb as the sweep's jobs are, but only where the
# accuracy target is planned: the default target never runs them
def test_accuracy_grid_above_max_mem_mb_is_refused_only_for_its_target(tmp_path):
    wd = copy_workflow(tmp_path)
    # the finest grid at 16 points per lambda_s is 1024^2: about 1.7 GB for a ladder, against
    # a 1 GB node; the test config's sweep jobs are far below it
    write_case(wd, max_mem_mb=1000, accuracy={"points_per_lambda_s": [4, 16]})
    res = dry_run(wd, "accuracy")
    out = res.stdout + res.stderr
    assert res.returncode != 0
    assert "invalid config" in out and "max_mem_mb = 1000" in out, out[-2000:]
    assert "the accuracy study's finest grid" in out, out[-2000:]
    assert not (wd / "results").exists()
    assert dry_run(wd).returncode == 0  # the default target plans as before
    write_case(wd, max_mem_mb=4000, accuracy={"points_per_lambda_s": [4, 16]})
    res = dry_run(wd, "accuracy")
    assert res.returncode == 0, (res.stdout + res.stderr)[-2000:]


# (i) only the Snakemake that plans a run checks the plan's memory. The one that runs a job
# inside a cluster allocation (--mode remote in the batch script, --mode subprocess under its
# srun) parses the Snakefile again in a cgroup sized for that one job, where checking the
# plan refused every job smaller than the plan's largest (tests/test_slurm.py runs it on a
# cluster). max_mem_mb stands in for that job's allocation here.
@pytest.mark.parametrize("mode", ["remote", "subprocess"])
def test_a_job_inside_an_allocation_is_not_refused_for_the_plans_larger_jobs(tmp_path, mode):
    wd = copy_workflow(tmp_path)
    write_case(wd, studies=("channels", "flow_isotropic"), max_mem_mb=700)
    cfg = yaml.safe_load((wd / "config" / "case.yaml").read_text())
    # both at 512^2: channels about 400 MB, the flow ladder about 734 MB (over 700)
    cfg["studies"]["channels"]["points_per_lambda_s"] = 16
    cfg["studies"]["flow_isotropic"].update(points_per_lambda_s=16, area_fraction=[0.3],
                                            series=[{"model": ["elastic"]}])
    (wd / "config" / "case.yaml").write_text(yaml.safe_dump(cfg))
    plan = dry_run(wd)
    out = plan.stdout + plan.stderr
    assert plan.returncode != 0 and "max_mem_mb = 700" in out, out[-2000:]
    assert "the ladder job" in out, out[-2000:]
    job = dry_run(wd, "--mode", mode, "--target-jobs", "channels:", "--allowed-rules",
                  "channels")
    assert job.returncode == 0, (job.stdout + job.stderr)[-2000:]


# (j) a run through profiles/slurm (its global mem_mb above this machine's memory) holds the
# plan to what the profile's partition allows a job (its largest node within MaxMemPerNode)
# less the 200 MB of the job's Snakemake, and caps every cluster job's memory and time
# requests at the partition's limits: above them a job, a retry's doubled request included,
# would never run (sbatch refuses it, or it waits forever: EnforcePartLimits=NO). Fake
# `scontrol` and `sinfo` stand in for the cluster (tests/test_slurm.py runs a real one).
def _fake_slurm(tmp_path: Path, partitions: str) -> None:
    """``scontrol show partition`` prints ``partitions``; ``sinfo`` gives partition "part"
    nodes of 700 and 800 MiB and any other one node of 64000."""
    bin_dir = tmp_path / "bin"
    bin_dir.mkdir(exist_ok=True)
    scripts = {"scontrol": f"printf '{partitions}'",
               "sinfo": 'case "$*" in *--partition=part\\ *) printf "700 2\\n800 2\\n";; '
                        '*) echo "64000 16";; esac',
               # the SLURM executor plugin (2.8) stops snakemake at start-up where `sinfo`
               # is on the PATH but neither `sacct` nor `squeue` is
               "sacct": "exit 0", "squeue": "exit 0"}
    for name, body in scripts.items():
        (bin_dir / name).write_text(f"#!/bin/sh\n{body}\n")
        (bin_dir / name).chmod(0o755)


def _resources(output: str, key: str) -> list[int]:
    """The integer values of resource ``key`` in the dry run's job blocks ("<TBD>" before an
    input exists is left out)."""
    return [int(word.split("=")[1].rstrip(","))
            for line in output.splitlines() if line.strip().startswith("resources:")
            for word in line.split() if word.startswith(f"{key}=")
            and word.split("=")[1].rstrip(",").isdigit()]


def test_a_cluster_run_plans_against_what_its_partition_allows(tmp_path, monkeypatch):
    wd = copy_workflow(tmp_path)
    write_case(wd, studies=("flow_isotropic",))
    cfg = yaml.safe_load((wd / "config" / "case.yaml").read_text())
    # 512^2: the flow ladder's estimate is 734 MB, its request 935 MB
    cfg["studies"]["flow_isotropic"].update(points_per_lambda_s=16, area_fraction=[0.3],
                                            series=[{"model": ["elastic"]}])
    (wd / "config" / "case.yaml").write_text(yaml.safe_dump(cfg))
    monkeypatch.setenv("PATH", f"{tmp_path / 'bin'}{os.pathsep}{os.environ['PATH']}")
    cluster = ("--resources", "mem_mb=1000000000", "--default-resources",
               "slurm_partition=part")
    other = "PartitionName=other Default=YES MaxTime=UNLIMITED MaxMemPerNode=UNLIMITED\\n"
    # partition part's largest node has 800 MB: 600 MB for the job itself
    _fake_slurm(tmp_path, other + "PartitionName=part Default=NO MaxTime=1-00:00:00 "
                "MaxMemPerNode=UNLIMITED\\n")
    plan = dry_run(wd, *cluster)
    out = plan.stdout + plan.stderr
    assert plan.returncode != 0, out[-2000:]
    assert "the ladder job" in out and "the limit is 600 MB" in out, out[-2000:]
    assert "SLURM partition part may ask for 800 MB" in out, out[-2000:]
    # MaxMemPerNode below the nodes' memory is the limit
    _fake_slurm(tmp_path, other + "PartitionName=part Default=NO MaxTime=UNLIMITED "
                "MaxMemPerNode=500\\n")
    plan = dry_run(wd, *cluster)
    out = plan.stdout + plan.stderr
    assert plan.returncode != 0 and "the limit is 300 MB" in out, out[-2000:]
    # a local run on the same machine plans against this machine's memory, not the cluster's
    local = dry_run(wd)
    assert local.returncode == 0, (local.stdout + local.stderr)[-2000:]
    assert 935 in _resources(local.stdout, "mem_mb")
    assert min(_resources(local.stdout, "runtime")) >= 2  # RUNTIME_FLOOR_MIN
    # the config's max_mem_mb overrides the partition's limit; the requests are still
    # capped at the partition's memory and its MaxTime of 1 minute, and the run says so
    write_case(wd, studies=("flow_isotropic",), max_mem_mb=4000)
    cfg_max = yaml.safe_load((wd / "config" / "case.yaml").read_text())
    cfg_max["studies"] = cfg["studies"]
    (wd / "config" / "case.yaml").write_text(yaml.safe_dump(cfg_max))
    _fake_slurm(tmp_path, other + "PartitionName=part Default=NO MaxTime=00:01:00 "
                "MaxMemPerNode=UNLIMITED\\n")
    capped = dry_run(wd, *cluster)
    out = capped.stdout + capped.stderr
    assert capped.returncode == 0, out[-2000:]
    requests = _resources(capped.stdout, "mem_mb")
    assert 935 not in requests and 800 in requests, requests  # the ladder's
    assert "1 of 1 jobs ask for more time than SLURM partition part allows" in out, out[-3000:]
    scene = [line for line in capped.stdout.split("rule scene:")[1].splitlines()
             if line.strip().startswith("resources:")][0]
    assert {"runtime=1", "mem_mb=800"} <= set(scene.replace(",", " ").split()), scene
    # a partition the cluster lacks (the profile's placeholder) is refused at planning
    wrong = dry_run(wd, "--resources", "mem_mb=1000000000", "--default-resources",
                    "slurm_partition=standard")
    out = wrong.stdout + wrong.stderr
    assert wrong.returncode != 0, out[-2000:]
    assert "SLURM partition 'standard' does not exist on this cluster (its partitions: other, " \
           "part)" in out, out[-2000:]
    # a rule sent to a partition of its own is not held to the profile's partition's limits
    moved = dry_run(wd, *cluster, "--set-resources", "scene:slurm_partition=big")
    assert moved.returncode == 0, (moved.stdout + moved.stderr)[-2000:]
    assert 935 in _resources(moved.stdout, "mem_mb") and "ask for more time" not in moved.stderr


def test_each_scan_of_the_measured_study_may_have_its_own_material(tmp_path):
    # faces of different materials (steel against SiC) took one config each: the scan
    # entries refused modulus, viscosity, pressures and boundary, which the study sets
    wd = copy_workflow(tmp_path)
    write_case(wd, studies=("measured",))
    cfg = yaml.safe_load((wd / "config" / "case.yaml").read_text())
    study = cfg["studies"]["measured"]
    first = study["scans"][0]
    study["scans"] = [first, {**first, "name": "sic", "modulus": "400GPa",
                              "viscosity": "2mPa.s", "pressures": "2MPa:200GPa:4",
                              "boundary": "mirror"}]
    (wd / "config" / "case.yaml").write_text(yaml.safe_dump(cfg))
    res = dry_run(wd)
    assert res.returncode == 0, res.stderr[-2000:]
    leaks = {cmd[cmd.index("-o") + 1]: cmd for cmd in shell_commands(res.stdout, " leak ")}
    steel, sic = (next(c for o, c in leaks.items() if o.endswith(f"{n}.nc"))
                  for n in (first["name"], "sic"))

    def option(cmd, flag):
        return cmd[cmd.index(flag) + 1]

    assert option(sic, "--boundary") == "mirror" and option(steel, "--boundary") == "window"
    assert option(sic, "--pressures") != option(steel, "--pressures")
    assert option(sic, "--modulus") != option(steel, "--modulus")
    assert option(sic, "--viscosity") != option(steel, "--viscosity")
