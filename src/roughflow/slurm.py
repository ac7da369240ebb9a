"""What a SLURM cluster lets one job ask for: memory and time.

A request above these limits never runs. sbatch refuses memory above every node of the
partition ("Requested node configuration is not available"). Above the partition's own
limits, its QOS's or the association's, the job is accepted and waits forever
("MaxMemPerLimit", "PartitionTimeLimit", "QOSMaxWallDurationPerJobLimit",
"QOSMaxMemoryPerJob", "AssocMaxWallDurationPerJobLimit", ...) wherever the cluster does not
check them at submission (``EnforcePartLimits=NO``, SLURM's default; a QOS without the
``DenyOnLimit`` flag), and Snakemake waits with it. The workflow caps every cluster job's
requests at :func:`job_limits` (workflow/rules/common.smk).

Each limit is taken where SLURM takes it (its "Resource Limits" page): the first level of
partition QOS, job QOS (the two swapped where the job QOS has ``OverPartQOS``), then the
association (``sacctmgr`` shows a user's association with the limits it inherits from its
accounts) that defines it; time is bounded by the partition's ``MaxTime`` as well, unless
the QOS that sets it has ``PartitionTimeLimit``, and memory by the partition's largest node
within its ``MaxMemPerNode`` (or its ``MaxMemPerCPU`` times the node's CPUs: SLURM gives a
job more CPUs to fit its memory, up to the node's). QOS and association limits count only
where the cluster enforces them (``AccountingStorageEnforce`` with ``limits``). Aggregate
limits (``Grp*``, per user or account) are not read: they bound what runs at once, not one
job.

Where these limits cannot be read (no SLURM commands, as on a workstation; a controller or
``sacctmgr`` that does not answer), :func:`job_limits` logs one warning saying what was not
checked, so that a dry run away from the cluster does not pass for a checked plan.
"""

from __future__ import annotations

import getpass
import logging
import subprocess
from dataclasses import dataclass

from roughflow.errors import InputError

__all__ = ["JobLimits", "slurm_minutes", "tres_mem_mib", "job_limits"]

#: what SLURM's memory suffixes mean (its "MB" is a MiB, the unit of ``sbatch --mem``)
_MEM_UNITS = {"K": 1 / 1024, "M": 1, "G": 1024, "T": 1024**2, "P": 1024**3}

log = logging.getLogger(__name__)


def _not_checked(what: str, why: str) -> None:
    """One warning line: a limit the plan could not check."""
    log.warning("SLURM limits not read (%s): %s not checked; run the dry run on the "
                "cluster's login node to check them", why, what)


@dataclass(frozen=True)
class JobLimits:
    """The most one job may ask for in ``partition``, and which limit says so."""

    partition: str
    #: memory in MiB (SLURM's "MB", the unit of ``sbatch --mem``)
    mem_mib: int
    #: time in whole minutes; None where unlimited
    max_minutes: int | None
    #: the limit that sets ``mem_mib``, e.g. "its largest node, within its MaxMemPerNode"
    mem_by: str
    #: the limit that sets ``max_minutes``, e.g. "MaxTime", "the MaxWall of QOS short"
    time_by: str


@dataclass(frozen=True)
class _Level:
    """One level of SLURM's hierarchy of per-job limits: a QOS or an association."""

    name: str
    max_minutes: int | None
    mem_per_job: int | None
    mem_per_node: int | None
    flags: frozenset[str] = frozenset()


def _slurm(*argv: str) -> str | None:
    try:
        return subprocess.run(argv, capture_output=True, text=True, timeout=30,
                              check=True).stdout
    except (OSError, subprocess.SubprocessError):
        return None


def slurm_minutes(text: str) -> int | None:
    """Whole minutes of a SLURM time limit as ``scontrol`` and ``sacctmgr`` show it
    (``[D-]HH:MM:SS``, ``MM:SS``); None for ``UNLIMITED`` or empty."""
    if text.upper() in ("", "UNLIMITED", "INFINITE"):
        return None
    days, _, clock = text.rpartition("-")
    parts = [int(part) for part in clock.split(":")]
    hours, minutes, seconds = [0] * (3 - len(parts)) + parts
    total = (int(days or 0) * 24 + hours) * 60 * 60 + minutes * 60 + seconds
    return max(total // 60, 1)  # SLURM counts time limits in minutes


def tres_mem_mib(tres: str) -> int | None:
    """The ``mem`` of a TRES list as ``sacctmgr`` shows it (``cpu=4,mem=10G``), in MiB;
    None where it has none."""
    for item in tres.split(","):
        key, _, value = item.partition("=")
        if key.strip() == "mem" and value:
            value = value.strip()
            unit = value[-1].upper() if value[-1].isalpha() else "M"
            number = value[:-1] if value[-1].isalpha() else value
            return int(float(number) * _MEM_UNITS[unit])
    return None


def _fields(line: str) -> dict[str, str]:
    return dict(word.split("=", 1) for word in line.split() if "=" in word)


def _partition(name: str | None) -> tuple[dict[str, str], list[tuple[int, int]]] | None:
    """``scontrol`` fields of partition ``name`` (None: the default one) and its nodes'
    memory (MiB) and CPUs."""
    shown = _slurm("scontrol", "--all", "--oneliner", "show", "partition")
    where = f"partition {name!r}" if name is not None else "the default partition"
    if shown is None:
        _not_checked(f"{where}, the account, the QOS and the per-job memory and time limits",
                     "`scontrol show partition` is missing or did not answer")
        return None
    names = []
    for line in shown.splitlines():
        fields = _fields(line)
        found = fields.get("PartitionName")
        names += [found] if found else []
        if found and (found == name if name is not None else fields.get("Default") == "YES"):
            break
    else:
        if name is not None and names:
            raise InputError(f"SLURM partition {name!r} does not exist on this cluster (its "
                             f"partitions: {', '.join(names)})")
        _not_checked("the account, the QOS and the per-job memory and time limits",
                     "scontrol lists no partitions" if not names else
                     "the cluster has no default partition and the profile names none")
        return None
    nodes = _slurm("sinfo", "--noheader", "--Node", f"--partition={found}", "--format=%m %c")
    sizes = [(int(words[0]), int(words[1])) for words in
             (line.split() for line in (nodes or "").splitlines())
             if len(words) == 2 and words[0].isdigit() and words[1].isdigit()]
    if not sizes:
        _not_checked("the account, the QOS and the per-job memory and time limits",
                     f"`sinfo` lists no node of partition {found}")
        return None
    return fields, sizes


def _rows(text: str | None, names: tuple[str, ...]) -> list[dict[str, str]]:
    return [dict(zip(names, line.split("|"), strict=False))
            for line in (text or "").splitlines() if line.strip()]


def _accounting() -> tuple[str, str] | None:
    """The cluster's name and the user, where the cluster enforces association and QOS
    limits (``AccountingStorageEnforce`` with ``limits``, or ``safe``/``all`` that imply
    it); else None: such limits are not applied to jobs."""
    config = _slurm("scontrol", "show", "config")
    if config is None:
        _not_checked("the account and the limits of its QOS and association",
                     "`scontrol show config` did not answer")
    settings = {}
    for line in (config or "").splitlines():
        key, sep, value = line.partition("=")
        if sep:
            settings[key.strip()] = value.strip()
    enforce = set(settings.get("AccountingStorageEnforce", "").lower().split(","))
    if not enforce & {"limits", "safe", "all"} or not settings.get("ClusterName"):
        return None
    return settings["ClusterName"], getpass.getuser()


_ASSOC = ("Partition", "DefaultQOS", "QOS", "MaxWall", "MaxTRES", "MaxTRESPerNode")
_QOS = ("Name", "Flags", "MaxWall", "MaxTRES", "MaxTRESPerNode")


def _association(cluster: str, user: str, account: str | None,
                 partition: str) -> tuple[str, dict[str, str]] | None:
    """The account and the user's association with it in ``partition`` (or for every
    partition); None where sacctmgr does not answer. Raises
    :class:`~roughflow.errors.InputError` where the user has no association with
    ``account`` (SLURM rejects every job under it)."""
    if account is None:
        users = _rows(_slurm("sacctmgr", "--noheader", "--parsable2", "show", "user", user,
                             "format=DefaultAccount"), ("DefaultAccount",))
        account = users[0]["DefaultAccount"] if users else None
        if not account:
            return None
    text = _slurm("sacctmgr", "--noheader", "--parsable2", "show", "assoc",
                  "where", f"cluster={cluster}", f"user={user}",
                  "format=Account," + ",".join(_ASSOC))
    if text is None:
        return None
    rows = _rows(text, ("Account", *_ASSOC))
    mine = [row for row in rows if row["Account"] == account]
    for wanted in (partition, ""):
        for row in mine:
            if row["Partition"] == wanted:
                return account, row
    yours = sorted({row["Account"] for row in rows})
    raise InputError(f"SLURM account {account!r} has no association for user {user!r} on "
                     f"cluster {cluster!r}{f' in partition {partition}' if mine else ''} "
                     f"(yours: {', '.join(yours) or 'none'}; `sacctmgr show associations "
                     f"user={user}`)")


def _job_qos(requested: str | None, association: dict[str, str]) -> str:
    """The QOS SLURM gives a job: the one asked for, else the association's default, else
    the one QOS it may use, else "normal"."""
    allowed = [name for name in association.get("QOS", "").split(",") if name]
    if requested:
        return requested
    if association.get("DefaultQOS"):
        return association["DefaultQOS"]
    return allowed[0] if len(allowed) == 1 else "normal"


def _level(name: str, row: dict[str, str], flags: str = "") -> _Level:
    """The per-job limits of a ``sacctmgr`` row; a value in a form these parsers do not
    know is left to the cluster (no cap), as the partition's MaxTime is."""
    def parsed(parse, key):
        try:
            return parse(row.get(key, ""))
        except (ValueError, KeyError):
            return None

    return _Level(name, parsed(slurm_minutes, "MaxWall"), parsed(tres_mem_mib, "MaxTRES"),
                  parsed(tres_mem_mib, "MaxTRESPerNode"),
                  frozenset(flag for flag in flags.split(",") if flag))


def _qos_level(name: str, row: dict[str, str] | None) -> _Level | None:
    return None if row is None else _level(f"QOS {name}", row, row.get("Flags", ""))


def _levels(fields: dict[str, str], account: str | None, qos: str | None) -> list[_Level]:
    """The QOS and association levels of a job in partition ``fields``, in SLURM's order
    of precedence; empty where the cluster does not enforce them or sacctmgr does not
    answer (the latter with a warning)."""
    accounting = _accounting()
    if accounting is None:
        return []
    cluster, user = accounting
    found = _association(cluster, user, account, fields["PartitionName"])
    table = _slurm("sacctmgr", "--noheader", "--parsable2", "show", "qos",
                   "format=" + ",".join(_QOS))
    if found is None or table is None:
        _not_checked("the account and the limits of its QOS and association",
                     "`sacctmgr` is missing, did not answer or gave no default account")
        return []
    account, association = found
    qos_rows = {row["Name"]: row for row in _rows(table, _QOS)}
    job_qos = _job_qos(qos, association)
    part_qos = fields.get("QoS", "N/A")
    part_qos = None if part_qos in ("N/A", "(null)", "") else part_qos
    job = _qos_level(job_qos, qos_rows.get(job_qos))
    part = _qos_level(part_qos, qos_rows.get(part_qos)) if part_qos else None
    order = [job, part] if job is not None and "OverPartQOS" in job.flags else [part, job]
    assoc = _level(f"the association of account {account} and user {user}", association)
    return [level for level in (*order, assoc) if level is not None]


def _first(levels: list[_Level], key: str) -> tuple[int, _Level] | None:
    for level in levels:
        value = getattr(level, key)
        if value is not None:
            return value, level
    return None


def job_limits(partition: str | None = None, account: str | None = None,
               qos: str | None = None) -> JobLimits | None:
    """The most one job in SLURM partition ``partition`` (None: the cluster's default) under
    ``account`` (None: the user's default account) and ``qos`` (None: the association's
    default QOS) may ask for, from ``scontrol``, ``sinfo`` and ``sacctmgr``. None where
    these are missing or do not answer within 30 s (not a SLURM login node), or there is no
    default partition or no node is listed; QOS and association limits are left out where
    the cluster does not enforce them or sacctmgr does not answer. Each of these, except a
    cluster that does not enforce the limits, logs one warning (logger ``roughflow.slurm``)
    naming what was not checked. Raises
    :class:`~roughflow.errors.InputError` where the cluster answers and has no partition
    ``partition``, or the user has no association with ``account`` (sbatch would refuse
    every job)."""
    found = _partition(partition)
    if found is None:
        return None
    fields, nodes = found
    name = fields["PartitionName"]
    mem, mem_by = max(node_mib for node_mib, _ in nodes), "its largest node"
    if fields.get("MaxMemPerNode", "").isdigit():
        mem = min(mem, int(fields["MaxMemPerNode"]))
        mem_by = "its largest node, within its MaxMemPerNode"
    elif fields.get("MaxMemPerCPU", "").isdigit():
        # SLURM gives a job more CPUs to fit its memory, and sbatch refuses one that would
        # need more than a node has ("CPU count per node can not be satisfied")
        per_cpu = int(fields["MaxMemPerCPU"])
        mem = max(min(node_mib, per_cpu * cpus) for node_mib, cpus in nodes)
        mem_by = "its largest node, within its MaxMemPerCPU times the node's CPUs"
    try:
        minutes = slurm_minutes(fields.get("MaxTime", "UNLIMITED"))
    except ValueError:
        minutes = None  # a form this parser does not know: leave time to the cluster
    time_by = "MaxTime"
    levels = _levels(fields, account, qos)
    for key in ("mem_per_job", "mem_per_node"):
        first = _first(levels, key)
        if first is not None and first[0] < mem:
            word = "MaxTRES" if key == "mem_per_job" else "MaxTRESPerNode"
            mem, mem_by = first[0], f"the {word} mem of {first[1].name}"
    first = _first(levels, "max_minutes")
    if first is not None:
        wall, level = first
        if minutes is None or wall < minutes or "PartitionTimeLimit" in level.flags:
            minutes, time_by = wall, f"the MaxWall of {level.name}"
    return JobLimits(name, mem, minutes, mem_by, time_by)
