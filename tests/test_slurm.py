"""The cluster path for real: config/test.yaml through `--profile profiles/slurm` on a one-node
SLURM cluster started for the test (tests/cluster/local_slurm.sh: munged, mariadbd, slurmdbd,
slurmctld, slurmd, all on 127.0.0.1), compared with a local run of the same config.

INSTALLS DEBIAN PACKAGES: run as root with apt-get, the cluster fixture installs slurmctld,
slurmd, slurm-client, slurmdbd, munge and mariadb-server-core if they are missing. Where that
is impossible (not root, no apt-get, no package access, a SLURM installation of the machine's
own) the tests are skipped with the reason; with ROUGHFLOW_REQUIRE_SLURM=1 (set by .ci/run)
they fail instead, so that CI cannot pass without having run them. `pytest -m "not slurm"`
leaves them out. Every daemon is stopped at the end, also after a failure.

The only settings added to the real profile are the test cluster's account and partition (an
overlay profile replaces the two placeholders) and a 5 s status-polling interval instead of
the plugin's 40 s (it only changes how soon a finished job is noticed).
"""

from __future__ import annotations

import contextlib
import fcntl
import getpass
import os
import re
import shutil
import signal
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest
import xarray as xr
import yaml
from workflow_copy import copy_workflow

from roughflow import provenance
from roughflow.scenes.requests import WRAPPER_MB

ROOT = Path(__file__).resolve().parents[1]
SCRIPT = ROOT / "tests" / "cluster" / "local_slurm.sh"
SNAKEMAKE = Path(sys.executable).with_name("snakemake")
ACCOUNT, PARTITION = "rftest", "rfdebug"
# the rules that must not go through the queue (localrules in the Snakefile)
LOCAL_RULES = {"all", "aggregate", "fit", "figure", "import_scan"}
# per-run bookkeeping, not results: a SLURM run and a local run legitimately differ here
IGNORED_VARIABLES = {"wall_time"}
PROVENANCE_ATTRS = re.compile(r"^(provenance|history|created|date|host|user|command|version"
                              r"|roughflow_version|git|slurm)", re.I)
# and the attributes roughflow.provenance writes (wall time, threads, ...)
PROVENANCE_NAMES = set(provenance.PROVENANCE_ATTRS)
# one test cluster per machine (fixed ports, /etc/slurm/slurm.conf): concurrent test sessions
# on a shared machine take turns
LOCK = Path(tempfile.gettempdir()) / "roughflow-slurm-test.lock"
LOCK_WAIT_S = 1800
SACCT_FIELDS = ("JobIDRaw", "JobName", "Comment", "Account", "Partition", "ReqMem",
                "Timelimit", "ReqCPUS", "State", "ExitCode")

pytestmark = [
    pytest.mark.slurm,
    pytest.mark.slow,
    pytest.mark.skipif(not SNAKEMAKE.exists(), reason="snakemake not installed"),
    pytest.mark.skipif(sys.platform != "linux", reason="the test cluster needs Debian's SLURM"),
]


@dataclass
class Cluster:
    state: Path
    env: dict

    def sacct(self, *args: str) -> list[dict[str, str]]:
        out = subprocess.run(
            ["sacct", "-X", "--parsable2", "--noheader", "--allusers",
             "--starttime", "now-1days", f"--format={','.join(SACCT_FIELDS)}", *args],
            env=self.env, capture_output=True, text=True, check=True, timeout=60).stdout
        return [dict(zip(SACCT_FIELDS, line.split("|"), strict=True))
                for line in out.splitlines() if line.strip()]

    @property
    def enforces_memory(self) -> bool:
        """Whether slurmd holds jobs to their --mem with cgroups (local_slurm.sh writes a
        cgroup.conf where a writable cgroup v1 memory hierarchy exists)."""
        return (self.state / "etc" / "cgroup.conf").exists()

    def scancel(self, job_id: str) -> None:
        subprocess.run(["scancel", job_id], env=self.env, check=True, timeout=60)

    def sacctmgr(self, *args: str) -> None:
        subprocess.run(["sacctmgr", "--immediate", *args], env=self.env, check=True,
                       capture_output=True, timeout=60)

    def update_partition(self, **limits: str) -> None:
        subprocess.run(["scontrol", "update", f"PartitionName={PARTITION}",
                        *(f"{key}={value}" for key, value in limits.items())],
                       env=self.env, check=True, timeout=60)


def _daemon_pids(state: Path) -> dict[str, int]:
    return {p.stem: int(p.read_text().split()[0]) for p in (state / "run").glob("*.pid")
            if p.read_text().strip()}


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    return True


def _lock() -> int:
    # read-only: flock needs no write access, so any user may wait on root's lock file
    fd = os.open(LOCK, os.O_RDONLY | os.O_CREAT, 0o644)
    deadline = time.monotonic() + LOCK_WAIT_S
    while True:
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            return fd
        except BlockingIOError:
            if time.monotonic() > deadline:
                os.close(fd)
                pytest.fail(f"another test session held {LOCK} for {LOCK_WAIT_S} s")
            time.sleep(2)


@pytest.fixture(scope="module")
def cluster():
    lock = _lock()
    # a short path: it holds the unix sockets of munged and mariadbd (107 bytes at most)
    state = Path(tempfile.mkdtemp(prefix="rfslurm.", dir="/tmp"))
    # holding the lock, a cluster still running is one whose test session died: take it over
    env = {**os.environ, "RF_SLURM_ACCOUNT": ACCOUNT, "RF_SLURM_PARTITION": PARTITION,
           "RF_SLURM_TAKEOVER": "1"}
    pids: dict[str, int] = {}
    try:
        start = subprocess.run(["bash", str(SCRIPT), "start", str(state)], env=env,
                               capture_output=True, text=True, timeout=900)
        pids = _daemon_pids(state)
        if start.returncode == 77:
            reason = start.stderr.strip().splitlines()[-1]
            if os.environ.get("ROUGHFLOW_REQUIRE_SLURM") == "1":
                pytest.fail(f"ROUGHFLOW_REQUIRE_SLURM=1 but {reason}")
            pytest.skip(reason)
        assert start.returncode == 0, start.stdout + start.stderr
        print(start.stderr)
        yield Cluster(state, {**env, "SLURM_CONF": str(state / "etc" / "slurm.conf"),
                              "ROUGHFLOW_FFT_THREADS": "1", "MPLBACKEND": "Agg"})
    finally:
        pids = pids or _daemon_pids(state)
        stop = subprocess.run(["bash", str(SCRIPT), "stop", str(state)], env=env,
                              capture_output=True, text=True, timeout=300)
        left = {name: pid for name, pid in pids.items() if _alive(pid)}
        if not left:
            shutil.rmtree(state, ignore_errors=True)
        os.close(lock)
        assert stop.returncode == 0 and not left, (left, stop.stderr)


def write_overlay(wd: Path) -> list[str]:
    """The profile arguments: the real SLURM profile plus an overlay with the test cluster's
    account and partition (a profile key replaces the whole key, so the overlay repeats the
    profile's default-resources with exactly those two values changed)."""
    real = yaml.safe_load((wd / "profiles" / "slurm" / "config.yaml").read_text())
    resources = real["default-resources"]
    # the two values the README tells users to edit, still placeholders in the repository
    assert resources["slurm_account"] == "your_account"
    assert resources["slurm_partition"] == "standard"
    overlay = {
        "default-resources": {**resources, "slurm_account": ACCOUNT,
                              "slurm_partition": PARTITION},
        "slurm-init-seconds-before-status-checks": 5,
    }
    (wd / "testcluster").mkdir()
    (wd / "testcluster" / "config.yaml").write_text(yaml.safe_dump(overlay))
    return ["--profile", "profiles/slurm", "--profile", "testcluster"]


def run_snakemake(wd: Path, env: dict, *args: str, timeout: int = 900):
    return subprocess.run([str(SNAKEMAKE), *args], cwd=wd, env=env, capture_output=True,
                          text=True, timeout=timeout)


def job_blocks(log: str) -> dict[str, dict]:
    """Snakemake's job blocks by Snakemake job id: rule, local or not, first output,
    resources and threads, and the SLURM job id where the job was submitted."""
    blocks = {}
    for m in re.finditer(r"^(localrule|rule) (\w+):\n((?:    .*\n)+)", log, re.M):
        fields = dict(re.findall(r"^    (\w+): (.*)$", m.group(3), re.M))
        resources = dict(re.findall(r"(\w+)=([^,\s]+)", fields.get("resources", "")))
        blocks[fields["jobid"]] = {
            "rule": m.group(2), "local": m.group(1) == "localrule",
            "output": fields.get("output", "").split(", ")[0],
            "mem_mb": int(resources["mem_mb"]) if "mem_mb" in resources else None,
            "runtime": int(resources["runtime"]) if "runtime" in resources else None,
            "threads": int(fields.get("threads", 1)),
        }
    for jobid, slurm_id in re.findall(r"^Job (\d+) has been submitted with SLURM jobid (\d+)",
                                      log, re.M):
        blocks[jobid].setdefault("slurm", []).append(slurm_id)
    return blocks


def minutes(timelimit: str) -> int:
    days, _, hms = timelimit.rpartition("-")
    h, m, s = (int(x) for x in hms.split(":"))
    return (int(days or 0) * 24 + h) * 60 + m + (s > 0)


def _leak_request(wd: Path, output: str) -> int:
    """The mem_mb of a leak job: Snakemake evaluates it again once the scan is imported
    (the dry run, before the import, shows the placeholder of a 1024^2 grid)."""
    import netCDF4

    from roughflow.boundary import cell_points
    from roughflow.scenes import expand_study
    from roughflow.scenes.requests import requested_mem_mb

    name = Path(output).stem
    cfg = yaml.safe_load((wd / "config" / "test.yaml").read_text())["studies"]["measured"]
    with contextlib.chdir(wd):  # scan paths are relative to the workflow
        job = expand_study("measured", cfg)[name]
    with netCDF4.Dataset(wd / "results" / "measured" / "surfaces" / f"{name}.nc") as ds:
        shape = (len(ds.dimensions["x"]), len(ds.dimensions["y"]))
    return requested_mem_mb(job, points=cell_points(shape, job.boundary))


def megabytes(reqmem: str) -> int:
    m = re.fullmatch(r"(\d+)([KMGT])[nc]?", reqmem)
    assert m, reqmem
    return int(m.group(1)) * {"K": 1 / 1024, "M": 1, "G": 1024, "T": 1024**2}[m.group(2)]


@pytest.fixture(scope="module")
def runs(cluster, request, tmp_path_factory):
    """config/test.yaml through SLURM, the session's local run of it (tests/conftest.py) and
    the plan of a local dry run (the resources the Snakefile computes for each job)."""
    # asked for once the cluster is up: a session fixture named as an argument would run
    # first, also where the cluster test is then skipped
    local, _ = request.getfixturevalue("local_test_run")
    dry = copy_workflow(tmp_path_factory.mktemp("plan"))
    plan = run_snakemake(dry, cluster.env, "--configfile", "config/test.yaml", "-n")
    assert plan.returncode == 0, plan.stderr[-3000:]

    slurm = copy_workflow(tmp_path_factory.mktemp("slurm"))
    profile = write_overlay(slurm)
    res = run_snakemake(slurm, cluster.env, *profile, "--configfile", "config/test.yaml")
    log = res.stdout + res.stderr
    assert res.returncode == 0, log[-5000:]
    run_id = re.search(r"SLURM run ID: (\S+)", log).group(1)
    jobs = cluster.sacct("--name", run_id)
    print(f"SLURM run ID {run_id}; sacct:\n" + "|".join(SACCT_FIELDS))
    for row in jobs:
        print("|".join(row[f] for f in SACCT_FIELDS))
    return {"local": local, "slurm": slurm, "plan": job_blocks(plan.stdout + plan.stderr),
            "blocks": job_blocks(log), "log": log, "sacct": jobs}


def test_every_cluster_job_went_through_sbatch_with_its_resources(runs):
    plan = {b["output"]: b for b in runs["plan"].values()}
    blocks = runs["blocks"]
    sacct = {row["JobIDRaw"]: row for row in runs["sacct"]}
    remote = [b for b in blocks.values() if not b["local"]]
    # the SLURM run planned the same jobs as the local dry run
    assert sorted(b["output"] for b in blocks.values()) == sorted(plan)
    assert {b["rule"] for b in remote} == {"scene", "channels", "leak"}
    assert len(remote) == sum(1 for b in plan.values() if b["rule"] not in LOCAL_RULES)
    for b in remote:
        # one sbatch each (no retry needed), recorded by slurmdbd under the test account
        assert len(b.get("slurm", [])) == 1, b
        row = sacct[b["slurm"][0]]
        expected = plan[b["output"]]
        if b["rule"] == "leak":
            expected = {**expected, "mem_mb": _leak_request(runs["slurm"], b["output"])}
        assert row["State"] == "COMPLETED" and row["ExitCode"] == "0:0", row
        assert (row["Account"], row["Partition"]) == (ACCOUNT, PARTITION), row
        assert row["Comment"].startswith(f"rule_{b['rule']}"), row
        # memory, time and CPUs are the Snakefile's (workflow/rules/common.smk, rules)
        assert megabytes(row["ReqMem"]) == expected["mem_mb"], (row, expected)
        assert minutes(row["Timelimit"]) == expected["runtime"], (row, expected)
        assert int(row["ReqCPUS"]) == expected["threads"], (row, expected)
    # nothing else of this run was queued
    assert set(sacct) == {b["slurm"][0] for b in remote}


def test_aggregation_fits_and_figures_run_locally(runs):
    blocks = runs["blocks"].values()
    assert {b["rule"] for b in blocks if b["local"]} == LOCAL_RULES
    assert all(b["local"] for b in blocks if b["rule"] in LOCAL_RULES)
    assert not [b for b in blocks if b["local"] and b.get("slurm")]
    assert not [row for row in runs["sacct"]
                if re.match(r"rule_(aggregate|fit|figure|all|import_scan)\b", row["Comment"])]
    for study in ("channels", "threshold_vs_gamma", "flow_isotropic"):
        assert (runs["slurm"] / "results" / study / "figure.png").stat().st_size > 5000


def test_a_partition_the_cluster_lacks_is_refused_at_planning(cluster, tmp_path):
    """profiles/slurm as it is in the repository, its placeholder partition unedited: sbatch
    would refuse each of the run's jobs at both attempts ("invalid partition specified"); the
    planning refuses the run once, naming the cluster's partitions (hidden ones included);
    likewise the placeholder account, naming the user's accounts."""
    wd = copy_workflow(tmp_path)
    res = run_snakemake(wd, cluster.env, "-n", "--profile", "profiles/slurm", "--configfile",
                        "config/test.yaml", timeout=300)
    log = res.stdout + res.stderr
    assert res.returncode != 0, log[-3000:]
    assert (f"SLURM partition 'standard' does not exist on this cluster (its partitions: "
            f"{PARTITION})") in log, log[-3000:]
    # the partition edited, the account not: SLURM would reject every job ("Invalid account")
    resources = yaml.safe_load((wd / "profiles" / "slurm" / "config.yaml").read_text())[
        "default-resources"]
    (wd / "partition_only").mkdir()
    (wd / "partition_only" / "config.yaml").write_text(yaml.safe_dump(
        {"default-resources": {**resources, "slurm_partition": PARTITION}}))
    res = run_snakemake(wd, cluster.env, "-n", "--profile", "profiles/slurm", "--profile",
                        "partition_only", "--configfile", "config/test.yaml", timeout=300)
    log = res.stdout + res.stderr
    assert res.returncode != 0, log[-3000:]
    assert "SLURM account 'your_account' has no association for user" in log, log[-3000:]
    assert ACCOUNT in log.split("has no association")[1].split(")")[0], log[-3000:]


def test_jobs_of_different_sizes_each_run_once_in_their_allocation(cluster, tmp_path):
    """Each job's Snakemake parses the Snakefile again inside its allocation, where the cgroup
    limit is that job's memory: a plan check there refused every job smaller than the plan's
    largest, and only the retry at twice the memory ran it (config/test.yaml's jobs are all
    too small to be checked, so the runs above could not show it)."""
    if not cluster.enforces_memory:
        pytest.skip("this test cluster does not enforce memory with cgroups (no writable "
                    "cgroup v1 memory hierarchy)")
    wd = copy_workflow(tmp_path)
    profile = write_overlay(wd)
    cfg = yaml.safe_load((wd / "config" / "test.yaml").read_text())
    studies = {name: cfg["studies"][name] for name in ("channels", "flow_isotropic")}
    # both at 512^2: channels about 400 MB, the flow ladder about 734 MB, a few s each
    studies["channels"]["points_per_lambda_s"] = 16
    studies["flow_isotropic"].update(points_per_lambda_s=16, area_fraction=[0.3],
                                     series=[{"model": ["elastic"]}])
    (wd / "config" / "sizes.yaml").write_text(yaml.safe_dump({"studies": studies}))
    res = run_snakemake(wd, cluster.env, *profile, "--configfile", "config/sizes.yaml")
    log = res.stdout + res.stderr
    assert res.returncode == 0, log[-5000:]
    remote = [b for b in job_blocks(log).values() if not b["local"]]
    assert {b["rule"] for b in remote} == {"channels", "scene"}
    # the test can fail: the smaller job's allocation (MiB) is below the larger one's estimate
    smaller, larger = sorted(b["mem_mb"] for b in remote)
    assert smaller * 2**20 < (larger - WRAPPER_MB) * 10**6
    assert "Error in rule" not in log, log[-5000:]
    for b in remote:
        assert len(b.get("slurm", [])) == 1, b  # no retry
        (row,) = cluster.sacct("--jobs", b["slurm"][0])
        assert row["State"] == "COMPLETED" and megabytes(row["ReqMem"]) == b["mem_mb"], row


def test_a_login_node_with_little_memory_leaves_the_requests_alone(cluster, tmp_path):
    """Snakemake on a login node with a per-user memory limit (a 1 GiB cgroup here). The
    Snakefile gives a local run the memory of its machine as a global mem_mb, and Snakemake
    lowers each job's request to it, also under the SLURM executor: this 2048^2 threshold job
    asked for 1073 MB instead of 1857 MB at both attempts and was refused in its allocation.
    profiles/slurm now gives the run a global mem_mb of its own. Without max_mem_mb in the
    config the plan was refused, checked against the login session's 1 GiB; it is now held
    to the partition's largest node (sinfo)."""
    memory = Path("/sys/fs/cgroup/memory")
    if not cluster.enforces_memory or not os.access(memory, os.W_OK):
        pytest.skip("no writable cgroup v1 memory hierarchy for a login node's limit")
    wd = copy_workflow(tmp_path)
    profile = write_overlay(wd)
    cfg = {"studies": {"threshold_vs_gamma": {
        "gamma": [1], "l_over_lambda_r": [4], "eps_f": [0.0625], "seeds": [0],
        "seeds_per_job": 1, "points_per_lambda_s": 32, "tol": 0.01}}}
    (wd / "config" / "login.yaml").write_text(yaml.safe_dump(cfg))
    login = memory / f"rftest-login-{os.getpid()}"
    login.mkdir()
    limit = 2**30
    (login / "memory.limit_in_bytes").write_text(str(limit))

    def enter():  # in the child, before snakemake starts
        (login / "cgroup.procs").write_text(str(os.getpid()))

    try:
        res = subprocess.run([str(SNAKEMAKE), *profile, "--configfile", "config/login.yaml"],
                             cwd=wd, env=cluster.env, capture_output=True, text=True,
                             timeout=900, preexec_fn=enter)
    finally:
        with contextlib.suppress(OSError):  # a process left in it: an empty folder stays
            login.rmdir()
    log = res.stdout + res.stderr
    assert res.returncode == 0, log[-5000:]
    (job,) = [b for b in job_blocks(log).values() if not b["local"]]
    assert job["mem_mb"] * 10**6 > limit  # the request the login node's memory capped
    assert len(job["slurm"]) == 1, job
    (row,) = cluster.sacct("--jobs", job["slurm"][0])
    assert row["State"] == "COMPLETED" and megabytes(row["ReqMem"]) == job["mem_mb"], row


def _same_attrs(a: dict, b: dict) -> bool:
    return a.keys() == b.keys() and all(np.array_equal(a[k], b[k]) for k in a)


def _compare(local: xr.Dataset, slurm: xr.Dataset, name: str) -> None:
    assert set(local.data_vars) == set(slurm.data_vars), name
    assert set(local.coords) == set(slurm.coords), name
    for var in local.coords:
        np.testing.assert_array_equal(local[var].values, slurm[var].values, err_msg=name)
    compared = 0
    for var in sorted(set(local.data_vars) - IGNORED_VARIABLES):
        a, b = local[var], slurm[var]
        assert a.dims == b.dims, (name, var)
        # bit-identical: same code, same inputs, one FFT/BLAS thread in both runs
        np.testing.assert_array_equal(a.values, b.values, err_msg=f"{name}: {var}")
        assert _same_attrs(a.attrs, b.attrs), (name, var)
        compared += 1
    assert compared > 0, name
    kept = [{k: v for k, v in ds.attrs.items()
             if not PROVENANCE_ATTRS.match(k) and k not in PROVENANCE_NAMES}
            for ds in (local, slurm)]
    assert _same_attrs(*kept), name


def test_datasets_equal_those_of_a_local_run(runs):
    local_files = sorted(p.relative_to(runs["local"]) for p in
                         (runs["local"] / "results").rglob("*.nc"))
    slurm_files = sorted(p.relative_to(runs["slurm"]) for p in
                         (runs["slurm"] / "results").rglob("*.nc"))
    assert local_files == slurm_files
    # every job's file and every study's dataset and fit
    assert len(local_files) == sum(1 for b in runs["plan"].values()
                                   if b["output"].endswith(".nc"))
    for rel in local_files:
        with xr.open_dataset(runs["local"] / rel) as a, xr.open_dataset(runs["slurm"] / rel) as b:
            _compare(a, b, str(rel))


def _wait(predicate, what: str, proc: subprocess.Popen, timeout: float = 240):
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        value = predicate()
        if value:
            return value
        if proc.poll() is not None:
            pytest.fail(f"snakemake exited ({proc.returncode}) while waiting for {what}")
        time.sleep(0.2)
    pytest.fail(f"timed out waiting for {what}")


def test_cancelled_job_is_reported_retried_and_rerun(cluster, tmp_path):
    wd = copy_workflow(tmp_path)
    profile = write_overlay(wd)
    cfg = {"studies": {"threshold_vs_gamma": {
        # one job of 6 seeds at 512^2 (about 10 s of solves on one core): still running
        # whenever it is cancelled right after its first seed started
        "gamma": [1], "l_over_lambda_r": [8], "eps_f": [0.0625], "seeds": [0, 1, 2, 3, 4, 5],
        "seeds_per_job": 6, "points_per_lambda_s": 4, "tol": 0.002}}}
    (wd / "config" / "cancel.yaml").write_text(yaml.safe_dump(cfg))
    args = [str(SNAKEMAKE), *profile, "--configfile", "config/cancel.yaml"]
    out = wd / "snakemake.log"
    job_logs = wd / "results" / "logs" / "jobs" / "threshold"
    outputs = wd / "results" / "jobs" / "threshold"

    def submitted() -> list[str]:
        return re.findall(r"submitted with SLURM jobid (\d+)", out.read_text())

    def solving(previous_first_line: str | None):
        # the job's own log: roughflow started its first seed (a rerun rewrites the log,
        # with new timestamps, so a first line unlike the previous attempt's is a new one)
        def check():
            for p in job_logs.glob("*.log") if job_logs.exists() else []:
                text = p.read_text()
                if "seed 0" in text and text.splitlines()[0] != previous_first_line:
                    return text.splitlines()[0]
            return None
        return check

    with out.open("w") as fh:
        proc = subprocess.Popen(args, cwd=wd, env=cluster.env, stdout=fh, stderr=subprocess.STDOUT,
                                start_new_session=True)
    try:
        first = _wait(lambda: submitted()[:1], "the first sbatch", proc)[0]
        line = _wait(solving(None), "the first attempt to start solving", proc)
        cluster.scancel(first)
        # retries: 1 in the profile: the cancelled job is submitted again
        second = _wait(lambda: submitted()[1:2], "the retry's sbatch", proc)[0]
        _wait(solving(line), "the retry to start solving", proc)
        cluster.scancel(second)
        rc = proc.wait(timeout=300)
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
            proc.wait()
    log = out.read_text()
    print(log[-3000:])
    assert rc != 0, "a run whose job was cancelled twice reported success"
    for job_id in (first, second):
        assert f"SLURM-job '{job_id}' failed, SLURM status is: 'CANCELLED'" in log, job_id
    # the cancelled attempts left no output that a later run could take for a result
    assert not (outputs.exists() and list(outputs.glob("*.nc")))
    rows = {row["JobIDRaw"]: row for row in cluster.sacct("--jobs", f"{first},{second}")}
    for row in rows.values():
        print("|".join(row[f] for f in SACCT_FIELDS))
    assert rows[first]["State"].startswith("CANCELLED")
    assert rows[second]["State"].startswith("CANCELLED")
    # the retry asked for twice the memory and time (attempt 2, workflow/rules/common.smk)
    assert megabytes(rows[second]["ReqMem"]) == 2 * megabytes(rows[first]["ReqMem"])
    assert minutes(rows[second]["Timelimit"]) == 2 * minutes(rows[first]["Timelimit"])

    rerun = run_snakemake(wd, cluster.env, *profile, "--configfile", "config/cancel.yaml")
    rerun_log = rerun.stdout + rerun.stderr
    assert rerun.returncode == 0, rerun_log[-5000:]
    third = re.findall(r"submitted with SLURM jobid (\d+)", rerun_log)
    assert len(third) == 1 and third[0] not in (first, second), rerun_log[-3000:]
    (row,) = cluster.sacct("--jobs", third[0])
    print("|".join(row[f] for f in SACCT_FIELDS))
    assert row["State"] == "COMPLETED" and row["ExitCode"] == "0:0", row
    assert megabytes(row["ReqMem"]) == megabytes(rows[first]["ReqMem"])
    (result,) = outputs.glob("*.nc")
    with xr.open_dataset(result) as ds:
        assert ds.sizes["seed"] == 6 and np.isfinite(ds["a_c_star"].values).all()
    with xr.open_dataset(wd / "results" / "threshold_vs_gamma" / "dataset.nc") as ds:
        assert np.isfinite(ds["a_c_star"].values).all()


@pytest.mark.parametrize("limited_by", ["partition", "qos"])
def test_a_retry_asks_for_no_more_than_the_cluster_allows(cluster, tmp_path, limited_by):
    """A retry doubles a job's memory and time requests. Above the partition's MaxMemPerNode
    or MaxTime, a cluster that does not check partition limits at submission
    (EnforcePartLimits=NO, SLURM's default and the test cluster's) accepts the job and
    leaves it pending forever ("MaxMemPerLimit", "PartitionTimeLimit"), and Snakemake waits
    with it; so it does above the per-job limits of its QOS ("QOSMaxMemoryPerJob", where
    the QOS lacks DenyOnLimit) or its association ("AssocMaxWallDurationPerJobLimit"). The
    requests are now capped at what the partition (scontrol, sinfo), or the QOS and
    association (sacctmgr), allow."""
    from roughflow.scenes import expand_study
    from roughflow.scenes.requests import requested_mem_mb, requested_runtime_min

    wd = copy_workflow(tmp_path)
    profile = write_overlay(wd)
    block = {  # the cancel test's job: about 10 s of solves, still running after seed 0
        "gamma": [1], "l_over_lambda_r": [8], "eps_f": [0.0625], "seeds": [0, 1, 2, 3, 4, 5],
        "seeds_per_job": 6, "points_per_lambda_s": 4, "tol": 0.002}
    (wd / "config" / "retry.yaml").write_text(
        yaml.safe_dump({"studies": {"threshold_vs_gamma": block}}))
    (job,) = expand_study("threshold_vs_gamma", block).values()
    mem, time_min = requested_mem_mb(job), requested_runtime_min(job)
    # room for the first attempt, not for the doubled retry
    limit_mb, limit_min = mem + 100, time_min + 1
    assert limit_mb < 2 * mem and limit_min < 2 * time_min
    out = wd / "snakemake.log"
    job_logs = wd / "results" / "logs" / "jobs" / "threshold"

    def submitted() -> list[str]:
        return re.findall(r"submitted with SLURM jobid (\d+)", out.read_text())

    def started(count: int):
        # the job's log has a first seed once per attempt (a rerun rewrites the log)
        def check():
            logs = list(job_logs.glob("*.log")) if job_logs.exists() else []
            return len(submitted()) >= count and any("seed 0" in p.read_text() for p in logs)
        return check

    user, qos = getpass.getuser(), "rfretry"
    where = ["where", f"account={ACCOUNT}", f"user={user}"]
    if limited_by == "partition":
        cluster.update_partition(MaxMemPerNode=limit_mb, MaxTime=limit_min)
    else:  # memory from the job's QOS (its association's default), time from the association
        cluster.sacctmgr("add", "qos", qos, f"MaxTRESPerJob=mem={limit_mb}")
        cluster.sacctmgr("modify", "user", *where, "set", f"qos+={qos}", f"defaultqos={qos}",
                         f"maxwall={limit_min}")
    try:
        with out.open("w") as fh:
            proc = subprocess.Popen([str(SNAKEMAKE), *profile, "--configfile",
                                     "config/retry.yaml"], cwd=wd, env=cluster.env, stdout=fh,
                                    stderr=subprocess.STDOUT, start_new_session=True)
        try:
            _wait(started(1), "the first attempt to start solving", proc)
            for p in job_logs.glob("*.log"):
                p.unlink()
            cluster.scancel(submitted()[0])
            # on the old code the retry waited here forever (MaxMemPerLimit,
            # QOSMaxMemoryPerJob)
            _wait(started(2), "the retry to start solving", proc, timeout=120)
            rc = proc.wait(timeout=300)
        finally:
            if proc.poll() is None:
                os.killpg(proc.pid, signal.SIGKILL)
                proc.wait()
    finally:
        if limited_by == "partition":
            cluster.update_partition(MaxMemPerNode=0, MaxTime="INFINITE")  # 0: unlimited
        else:
            cluster.sacctmgr("modify", "user", *where, "set", "qos=normal", "defaultqos=-1",
                             "maxwall=-1")
            cluster.sacctmgr("delete", "qos", qos)
    log = out.read_text()
    assert rc == 0, log[-3000:]
    first, second = submitted()
    rows = {row["JobIDRaw"]: row for row in cluster.sacct("--jobs", f"{first},{second}")}
    assert rows[first]["State"].startswith("CANCELLED")
    assert megabytes(rows[first]["ReqMem"]) == mem
    assert minutes(rows[first]["Timelimit"]) == time_min
    assert rows[second]["State"] == "COMPLETED", rows[second]
    assert megabytes(rows[second]["ReqMem"]) == limit_mb
    assert minutes(rows[second]["Timelimit"]) == limit_min
