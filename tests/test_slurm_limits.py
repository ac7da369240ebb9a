"""What a SLURM cluster lets one job ask for (roughflow.slurm), against fake ``scontrol``,
``sinfo`` and ``sacctmgr`` that print what SLURM 22.05 printed on the one-node test cluster
(tests/cluster/local_slurm.sh). Each case of the limits' precedence repeats a measurement
there: jobs just above a limit stayed PENDING with the reason quoted, jobs at the predicted
limit ran (tests/test_slurm.py runs one such job end to end)."""

from __future__ import annotations

import getpass
import os
import subprocess
import sys
from pathlib import Path

import pytest
from workflow_copy import copy_workflow

from roughflow.errors import InputError
from roughflow.slurm import JobLimits, job_limits, slurm_minutes, tres_mem_mib

USER = getpass.getuser()
PARTITIONS = ("PartitionName=big Default=YES QoS=N/A MaxTime=UNLIMITED "
              "MaxMemPerNode=UNLIMITED\n"
              "PartitionName=small Default=NO QoS={part_qos} MaxTime={max_time} "
              "MaxMemPerNode=2500\n"
              "PartitionName=empty Default=NO QoS=N/A MaxTime=01:30:00 "
              "MaxMemPerNode=UNLIMITED\n"
              "PartitionName=percpu Default=NO QoS=N/A MaxTime=UNLIMITED MaxMemPerCPU=1000\n")


def fake(tmp_path: Path, *, part_qos: str = "N/A", max_time: str = "2-03:00:30",
         enforce: str = "associations,limits", assoc: str = "", qos: str = "normal||||\n",
         default_account: str = "acct", sacctmgr_fails: bool = False) -> None:
    """Fake SLURM commands on PATH. ``assoc``: the lines of ``sacctmgr show assoc``
    (Account|Partition|DefaultQOS|QOS|MaxWall|MaxTRES|MaxTRESPerNode), ``qos`` those of
    ``sacctmgr show qos`` (Name|Flags|MaxWall|MaxTRES|MaxTRESPerNode)."""
    partitions = PARTITIONS.format(part_qos=part_qos, max_time=max_time)
    config = f"ClusterName             = test\nAccountingStorageEnforce = {enforce}\n"
    scripts = {
        "scontrol": f'case "$*" in *partition*) printf "{partitions}";; '
                    f'*config*) printf "{config}";; esac',
        "sinfo": 'case "$*" in *=small\\ *) printf "1000 4\\n3000 8\\n2000 2\\n";; '
                 '*=big\\ *) echo "512000 64";; *=percpu\\ *) printf "3000 2\\n1500 4\\n";; '
                 'esac',
        "sacctmgr": "exit 1" if sacctmgr_fails else
                    f'case "$*" in *" user {USER} "*) echo "{default_account}";; '
                    f'*cluster=test*user={USER}*) printf "{assoc}";; '
                    f'*" qos "*) printf "{qos}";; *) exit 1;; esac',
    }
    for name, body in scripts.items():
        (tmp_path / name).write_text(f"#!/bin/sh\n{body}\n")
        (tmp_path / name).chmod(0o755)


@pytest.fixture
def slurm_path(tmp_path, monkeypatch):
    monkeypatch.setenv("PATH", f"{tmp_path}{os.pathsep}{os.environ['PATH']}")
    return tmp_path


def test_parsing_of_times_and_memory():
    assert [slurm_minutes(t) for t in ("00:05:00", "01:30:00", "1-01:00:00", "00:00:30",
                                       "45:00", "2-00:00:00", "UNLIMITED", "")] == \
        [5, 90, 1500, 1, 45, 2880, None, None]
    assert [tres_mem_mib(t) for t in ("mem=1000M", "cpu=4,mem=10G", "mem=1T,node=1",
                                      "mem=2000", "cpu=4", "")] == \
        [1000, 10240, 1024**2, 2000, None, None]


def test_partition_limits(slurm_path):
    # the largest node (3000) within MaxMemPerNode (2500); MaxTime in whole minutes; a
    # cluster that does not enforce association or QOS limits leaves them out
    fake(slurm_path, enforce="associations")
    assert job_limits("small") == JobLimits("small", 2500, 3060, "its largest node, within "
                                            "its MaxMemPerNode", "MaxTime")
    assert job_limits() == JobLimits("big", 512000, None, "its largest node", "MaxTime")
    assert job_limits("empty") is None  # no node listed
    # measured: MaxMemPerCPU 1000 on a 2-CPU node: a job of 1900 MB ran on 2 CPUs, one of
    # 2500 MB was refused by sbatch ("CPU count per node can not be satisfied"); here the
    # nodes allow 2 x 1000 and min(1500, 4 x 1000)
    assert job_limits("percpu") == JobLimits(
        "percpu", 2000, None, "its largest node, within its MaxMemPerCPU times the node's "
        "CPUs", "MaxTime")
    with pytest.raises(InputError, match=r"'missing' does not exist .*: big, small, empty, "
                                         r"percpu\)"):
        job_limits("missing")  # sbatch would refuse every job
    # where sacctmgr does not answer, the partition's limits alone
    fake(slurm_path, assoc="acct||rshort|normal,rshort|00:10:00||\n", sacctmgr_fails=True)
    assert job_limits("small", "acct").max_minutes == 3060
    fake(slurm_path)
    (slurm_path / "scontrol").write_text("#!/bin/sh\necho 'Unable to contact slurm "
                                         "controller' >&2; exit 1\n")
    assert job_limits("small") is None  # not a SLURM login node


def test_no_slurm_commands_at_all(tmp_path, monkeypatch, caplog):
    monkeypatch.setenv("PATH", str(tmp_path))
    with caplog.at_level("WARNING", logger="roughflow.slurm"):
        assert job_limits("small") is None
    # a dry run away from the cluster says what it did not check, in one line
    assert [r.getMessage() for r in caplog.records] == [
        "SLURM limits not read (`scontrol show partition` is missing or did not answer): "
        "partition 'small', the account, the QOS and the per-job memory and time limits not "
        "checked; run the dry run on the cluster's login node to check them"]


def test_what_could_not_be_checked_is_warned_about(slurm_path, caplog):
    def warned(*args):
        caplog.clear()
        with caplog.at_level("WARNING", logger="roughflow.slurm"):
            job_limits(*args)
        return [r.getMessage() for r in caplog.records]

    fake(slurm_path, assoc=ASSOC, qos=QOS)
    assert warned("small", "acct") == []  # everything read
    fake(slurm_path, assoc=ASSOC, qos=QOS, enforce="associations")
    assert warned("small", "acct") == []  # limits not enforced: nothing to check
    fake(slurm_path, assoc=ASSOC, qos=QOS, sacctmgr_fails=True)  # sacctmgr blocked
    [line] = warned("small", "acct")
    assert "`sacctmgr` is missing, did not answer" in line
    assert "the account and the limits of its QOS and association not checked" in line
    [line] = warned("empty")
    assert "`sinfo` lists no node of partition empty" in line


def test_a_dry_run_without_slurm_says_the_checks_were_skipped(tmp_path):
    """The README's cluster check (`snakemake -n --profile profiles/slurm`) on a machine
    whose SLURM commands do not answer: the plan goes on, with the warning in its output."""
    snakemake = Path(sys.executable).with_name("snakemake")
    if not snakemake.exists():
        pytest.skip("snakemake not installed")
    (tmp_path / "wd").mkdir()
    wd = copy_workflow(tmp_path / "wd")
    bin_dir = tmp_path / "bin"
    bin_dir.mkdir()
    # sacct and squeue too: the SLURM executor plugin (2.8) refuses to start without
    # either on the PATH, as on a cluster whose tools are installed but whose controller
    # does not answer
    for name in ("scontrol", "sinfo", "sacctmgr", "sacct", "squeue"):
        (bin_dir / name).write_text("#!/bin/sh\necho 'Unable to contact slurm controller' "
                                    ">&2; exit 1\n")
        (bin_dir / name).chmod(0o755)
    env = {**os.environ, "PATH": f"{bin_dir}{os.pathsep}{os.environ['PATH']}",
           "ROUGHFLOW_FFT_THREADS": "1"}
    res = subprocess.run([str(snakemake), "-n", "--profile", "profiles/slurm",
                          "--configfile", "config/test.yaml"], cwd=wd, env=env,
                         capture_output=True, text=True, timeout=300)
    log = res.stdout + res.stderr
    assert res.returncode == 0, log[-3000:]
    assert log.count("SLURM limits not read") == 1, log[-3000:]
    assert "partition 'standard', the account" in log, log[-3000:]


# a default QOS with MaxWall 30 min and MaxTRES mem=3G; the association (inherited from
# its account) 1 h and mem=2000M
ASSOC = "acct||rshort|normal,rshort|01:00:00|mem=2000M|\nother|||normal|||\n"
QOS = "normal||||\nrshort||00:30:00|mem=3G|\nrpart||00:20:00||\n"


def test_the_job_qos_comes_before_the_association(slurm_path):
    fake(slurm_path, assoc=ASSOC, qos=QOS, max_time="UNLIMITED")
    # measured: a job of 2500M ran under rshort, 3500M waited (QOSMaxMemoryPerJob)
    limits = job_limits("small", "acct")
    assert (limits.mem_mib, limits.max_minutes) == (2500, 30)  # MaxMemPerNode 2500 < 3G
    assert limits.time_by == "the MaxWall of QOS rshort"
    fake(slurm_path, assoc=ASSOC.replace("mem=2000M", "mem=2000M|mem=1500"), qos=QOS)
    limits = job_limits("small", "acct")  # the association's MaxTRESPerNode is the next
    assert (limits.mem_mib, limits.mem_by) == (  # level's: the QOS sets none
        1500, "the MaxTRESPerNode mem of the association of account acct and user " + USER)
    # the user's default account, when the profile names none
    fake(slurm_path, assoc=ASSOC, qos=QOS, max_time="UNLIMITED")
    assert job_limits("small") == limits.__class__(
        "small", 2500, 30, "its largest node, within its MaxMemPerNode",
        "the MaxWall of QOS rshort")


def test_a_qos_without_limits_leaves_the_associations(slurm_path):
    # measured under --qos=normal: 2500M waited (AssocMaxMemPerJob); 50 min against a
    # partition MaxTime of 45 waited (PartitionTimeLimit), 44 min and 1900M ran
    fake(slurm_path, assoc=ASSOC, qos=QOS, max_time="00:45:00")
    limits = job_limits("small", "acct", "normal")
    assert (limits.mem_mib, limits.max_minutes, limits.time_by) == (2000, 45, "MaxTime")
    assert limits.mem_by == "the MaxTRES mem of the association of account acct and user " \
        + USER
    fake(slurm_path, assoc=ASSOC, qos=QOS, max_time="02:00:00")
    limits = job_limits("small", "acct", "normal")
    assert (limits.max_minutes, limits.time_by) == (
        60, "the MaxWall of the association of account acct and user " + USER)


def test_partition_time_limit_flag_lifts_the_partitions_max_time(slurm_path):
    # measured: QOS MaxWall 2 days with PartitionTimeLimit, partition MaxTime 45 min: a
    # 50 min job ran, one of 3000 min waited (QOSMaxWallDurationPerJobLimit)
    qos = QOS.replace("rshort||00:30:00", "rshort|PartitionTimeLimit|2-00:00:00")
    fake(slurm_path, assoc=ASSOC, qos=qos, max_time="00:45:00")
    assert job_limits("small", "acct").max_minutes == 2880
    fake(slurm_path, assoc=ASSOC, qos=QOS.replace("00:30:00", "2-00:00:00"),
         max_time="00:45:00")
    assert job_limits("small", "acct").max_minutes == 45  # no flag: the partition bounds it


def test_the_partition_qos_comes_first_unless_over_part_qos(slurm_path):
    # measured: partition QOS MaxWall 20 min, job QOS 2 days: 25 min waited
    # (QOSMaxWallDurationPerJobLimit); with OverPartQOS on the job QOS it ran
    qos = QOS.replace("rshort||00:30:00", "rshort|PartitionTimeLimit|2-00:00:00")
    fake(slurm_path, assoc=ASSOC, qos=qos, part_qos="rpart", max_time="UNLIMITED")
    limits = job_limits("small", "acct")
    assert (limits.max_minutes, limits.time_by) == (20, "the MaxWall of QOS rpart")
    # the partition QOS sets no memory: the job QOS's (3G) is next, above MaxMemPerNode
    assert limits.mem_mib == 2500
    fake(slurm_path, assoc=ASSOC, qos=qos.replace("PartitionTimeLimit",
                                                  "PartitionTimeLimit,OverPartQOS"),
         part_qos="rpart", max_time="UNLIMITED")
    assert job_limits("small", "acct").max_minutes == 2880


def test_the_job_qos_when_none_is_named(slurm_path):
    # SLURM's choice: the association's default QOS, else its only QOS, else "normal"
    fake(slurm_path, assoc="acct||||00:10:00||\n", qos=QOS)
    assert job_limits("small", "acct").max_minutes == 10  # "normal": no limits of its own
    fake(slurm_path, assoc="acct|||rpart|||\n", qos=QOS)
    assert job_limits("small", "acct").max_minutes == 20


def test_a_limit_in_an_unknown_form_is_left_to_the_cluster(slurm_path):
    # a planning that crashed on a value it cannot parse would stop every cluster run
    fake(slurm_path, assoc="acct||rshort|normal,rshort|soon|mem=lots|\n", qos=QOS,
         max_time="UNLIMITED")
    limits = job_limits("small", "acct")
    assert (limits.mem_mib, limits.max_minutes) == (2500, 30)  # the QOS's, then the node's


def test_a_partition_specific_association_comes_first(slurm_path):
    fake(slurm_path, assoc="acct|||normal|01:00:00||\nacct|small||normal|00:05:00||\n",
         qos=QOS)
    assert job_limits("small", "acct").max_minutes == 5
    assert job_limits("big", "acct").max_minutes == 60


def test_an_account_without_association_is_refused(slurm_path):
    # the profile's placeholder: SLURM rejects every job under it ("Invalid account")
    fake(slurm_path, assoc=ASSOC, qos=QOS)
    with pytest.raises(InputError, match=r"account 'your_account' has no association for "
                                         rf"user '{USER}' on cluster 'test' \(yours: acct, "
                                         "other;"):
        job_limits("small", "your_account")
    # an association only in another partition does not admit the job to this one
    fake(slurm_path, assoc="acct|big||normal|||\n", qos=QOS)
    with pytest.raises(InputError, match="in partition small"):
        job_limits("small", "acct")
    # a cluster that does not enforce associations accepts any account: nothing to check
    fake(slurm_path, assoc=ASSOC, qos=QOS, enforce="none")
    assert job_limits("small", "your_account").max_minutes == 3060
