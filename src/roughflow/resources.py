"""Memory: how much a computation on a grid needs, and the check against what there is.

One estimate per task, ``estimate_bytes(task, points) = BASE[task] + PER_POINT[task] * points``:
the peak resident memory of a ``roughflow`` process (interpreter, imported libraries, the
task's arrays), calibrated with ``benchmarks/bench_memory.py`` (peak RSS of fresh
processes at 128^2 ... 2048^2 points; docs/workflow.md "Memory") and rounded up. The same
numbers refuse work that cannot fit (the library entry points call :func:`check_memory`
before allocating: ``surface.generate``, ``contact.solve``, ``flow.solve``,
``search.threshold``, the Persson spectrum, ``theory.gap_theory``, every scene job) and set
the Snakemake ``mem_mb`` of a job (:func:`roughflow.scenes.requests.estimated_memory`).

Tasks: ``surface`` (generate a surface), ``contact`` (one elastic or adhesive solve, GFMD or
CG), ``bearing``, ``threshold`` (an elastic threshold search: each warm-start state is kept
as 4 bytes a point; the estimate covers about 35 solves), ``threshold_adhesive`` (an
adhesive threshold search, or one through an observed window: every state is kept whole,
17 bytes a point; about 17 solves at 2048^2),
``flow`` (Reynolds flow with AMG, the largest per point), ``ladder`` (contact + flow +
theory per step), ``channels`` (two contacts), ``spectrum`` (Persson theory from a spec),
``theory`` (Bruggeman and closed forms of a gap field), ``gpu_contact`` (the GPU memory of an
elastic gfmd solve with ``backend="cupy"``, also each solve of a threshold search there:
the peak of CuPy's memory pool, 184-256 B per point from 1024^2 to 16384^2 on an H200,
docs/contact.md "GPU backend"; checked against the GPU's free memory,
``roughflow.gpu.available_bytes``).

What there is: the memory the kernel reports available (``MemAvailable``), within what the
process's cgroups leave (a SLURM job's allocation: its limit less what the other processes
in it hold), plus what this process already holds, since the estimate counts the whole
process. This module imports nothing heavy.
"""

from __future__ import annotations

import os
from pathlib import Path

from roughflow.errors import ResourceError

__all__ = ["BASE", "PER_POINT", "TASKS", "FLOW_LDL_BYTES_PER_UNKNOWN", "SMALL", "estimate_bytes",
           "total_bytes", "total_source", "available_bytes", "headroom_bytes", "describe",
           "check_memory"]

MB = 1024**2

#: Fixed cost of a process in bytes: interpreter and libraries (numba's compiler for the
#: GFMD kernels, scipy.sparse and pyamg for the flow).
BASE = {"surface": 150 * MB, "contact": 300 * MB, "bearing": 150 * MB, "threshold": 300 * MB,
        "threshold_adhesive": 300 * MB, "flow": 350 * MB, "ladder": 400 * MB,
        "channels": 300 * MB, "spectrum": 150 * MB, "theory": 200 * MB,
        "gpu_contact": 64 * MB}
#: Bytes per grid point at the peak (float64 fields, FFT buffers, AMG hierarchy, ...). The
#: ladder's comes from the paper config's own ladders (12 steps at 2048^2 and 2048 x 4096:
#: 840-920 B a point between 1024^2 and 2048^2; 1200 since the direct flow solver for thin
#: clusters, whose 2048 x 4096 bearing ladder peaked at 8635 MB), not from the short ladders
#: of bench_memory.py (579 B), docs/workflow.md "Memory".
PER_POINT = {"surface": 80, "contact": 160, "bearing": 64, "threshold": 320,
             "threshold_adhesive": 480, "flow": 560, "ladder": 1200, "channels": 320,
             "spectrum": 32, "theory": 200, "gpu_contact": 256}
TASKS = tuple(PER_POINT)
#: Bytes per unknown of the direct Reynolds solve (QDLDL's LDL^T, minimum degree ordering),
#: checked against the memory this process can still allocate before
#: ``roughflow.flow.linsolve`` takes that solver beyond small systems or falls back to it.
#: Measured peaks of a flow solve in a fresh process: 655-700 B per unknown, the whole process
#: included, at 2048 x 4096 where at most 3/4 of the cells flow (900 B with 89 % flowing);
#: above the process's start at 1024^2, 700-1160 B (the most with every cell open); rounded
#: up from the largest (docs/flow.md "Direct solver").
FLOW_LDL_BYTES_PER_UNKNOWN = 1200
#: Grids whose arrays need less than this are never refused (the check is for grids that
#: cannot fit, not for a machine that is momentarily short of memory).
SMALL = 64 * MB


def estimate_bytes(task: str, points: int) -> int:
    """Estimated peak memory in bytes of ``task`` on ``points`` grid points."""
    if task not in PER_POINT:
        raise KeyError(f"unknown task {task!r}; known: {', '.join(PER_POINT)}")
    return int(BASE[task] + PER_POINT[task] * int(points))


def _meminfo(key: str) -> int | None:
    try:
        for line in Path("/proc/meminfo").read_text().splitlines():
            if line.startswith(key + ":"):
                return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    return None


#: Where the kernel lists this process's cgroups, where cgroup file systems are mounted, and
#: the processes (module constants so that tests can point them at a tree of their own).
PROC_CGROUP = Path("/proc/self/cgroup")
CGROUP_ROOT = Path("/sys/fs/cgroup")
PROC = Path("/proc")


def _cgroup_dirs() -> list[Path]:
    """The folders of this process's memory cgroup and of all its ancestors: the v2 one
    (``0::/path``, under :data:`CGROUP_ROOT`) and the v1 ``memory`` controller's (under
    ``memory/``). A SLURM job's allocation is such a cgroup below the root (``/slurm/
    uid_0/job_7/...``), which only /proc/self/cgroup names; a container's namespace shows
    its own cgroup as ``/``."""
    try:
        lines = PROC_CGROUP.read_text().splitlines()
    except OSError:
        lines = []
    dirs = []
    for line in lines:
        hierarchy, controllers, path = (line.split(":", 2) + ["", ""])[:3]
        if hierarchy == "0" and not controllers:
            base = CGROUP_ROOT
        elif "memory" in controllers.split(","):
            base = CGROUP_ROOT / "memory"
        else:
            continue
        own = Path(path.lstrip("/"))
        dirs += [base / d for d in (own, *own.parents)]
    return dirs or [CGROUP_ROOT, CGROUP_ROOT / "memory"]


#: The files of a memory cgroup: its limit, what its processes use (page cache included),
#: and the keys of ``memory.stat`` that give the file page cache within that use, which the
#: kernel reclaims before it kills, as ``MemAvailable`` counts it for a machine (v2, then
#: v1; v1's ``total_`` keys count the cgroups below too, as its usage does; tmpfs and
#: shared memory are not among them: they cannot be dropped, only swapped).
_CGROUP_FILES = (("memory.max", "memory.current", ("active_file", "inactive_file")),
                 ("memory.limit_in_bytes", "memory.usage_in_bytes",
                  ("total_active_file", "total_inactive_file")))


def _read_int(path: Path) -> int | None:
    try:
        raw = path.read_text().strip()
    except OSError:
        return None
    return int(raw) if raw.isdigit() else None


def _stat(path: Path, keys: tuple[str, ...]) -> int:
    """The sum of ``keys`` in the ``memory.stat`` file ``path`` (0 for those missing)."""
    total = 0
    try:
        for line in path.read_text().splitlines():
            name, _, value = line.partition(" ")
            if name in keys:
                total += int(value)
    except (OSError, ValueError):
        return 0
    return total


def _cgroup_limits() -> list[tuple[int, int | None]]:
    """(limit, used) of each of this process's memory cgroups and their ancestors that has a
    limit (v2 ``memory.max`` or v1 ``memory.limit_in_bytes``; each applies to everything
    below it). ``used`` is what all the processes of that cgroup hold, less its file page
    cache; None if unknown."""
    out = []
    for folder in _cgroup_dirs():
        for limit_name, usage_name, cache in _CGROUP_FILES:
            limit = _read_int(folder / limit_name)
            if limit is None or limit >= 2**60:
                continue
            usage = _read_int(folder / usage_name)
            used = None if usage is None else max(
                usage - _stat(folder / "memory.stat", cache), 0)
            out.append((limit, used))
    return out


def _cgroup_limit() -> int | None:
    """The lowest memory limit of this process's cgroup and its ancestors, None if
    unlimited or unknown."""
    limits = [limit for limit, _ in _cgroup_limits()]
    return min(limits) if limits else None


def _parent(stat: Path) -> int:
    # /proc/PID/stat: "pid (name) state ppid ...", the name may hold spaces and brackets
    return int(stat.read_text().rsplit(")", 1)[1].split()[1])


def _launchers_rss() -> int:
    """Resident memory of the processes that started this one and share its cgroups (the
    Snakemake process that runs a job, locally or inside a cluster allocation, and its
    shell): a job's request (``mem_mb``) and the local run's budget cover them, so a job is
    not refused for the memory of its own Snakemake."""
    page = os.sysconf("SC_PAGE_SIZE")
    total = 0
    try:
        own = PROC_CGROUP.read_text()
        pid = _parent(PROC / "self" / "stat")
        for _ in range(64):
            if pid <= 1 or (PROC / str(pid) / "cgroup").read_text() != own:
                break
            total += int((PROC / str(pid) / "statm").read_text().split()[1]) * page
            pid = _parent(PROC / str(pid) / "stat")
    except (OSError, ValueError, IndexError):
        pass
    return total


def _own_rss() -> int:
    try:
        pages = int(Path("/proc/self/statm").read_text().split()[1])
        return pages * os.sysconf("SC_PAGE_SIZE")
    except (OSError, ValueError, IndexError):
        return 0


def total_bytes() -> int | None:
    """Physical memory of the machine (within the cgroup limit); None if unknown."""
    values = [v for v in (_meminfo("MemTotal"), _cgroup_limit()) if v is not None]
    return min(values) if values else None


def _limited_by_cgroup() -> int | None:
    """The cgroup limit where it is below the machine's memory (a SLURM allocation, a
    container), else None: there "this machine" would name the node's memory."""
    cgroup = _cgroup_limit()
    return cgroup if cgroup is not None and cgroup < (_meminfo("MemTotal") or cgroup + 1) \
        else None


def total_source() -> str:
    """What :func:`total_bytes` is, for messages."""
    if _limited_by_cgroup() is not None:
        return "the memory limit of this process's cgroup (a SLURM allocation or container)"
    return "the memory of this machine"


def available_bytes() -> int | None:
    """Memory this process can reach: what it holds plus what the machine has available,
    within what each of its cgroups leaves: its limit less what the cgroup's other processes
    hold (another job of the same SLURM allocation or local run), those that started it
    excepted (:func:`_launchers_rss`). None if unknown (then nothing is refused)."""
    avail = _meminfo("MemAvailable")
    if avail is None:
        return None
    own = _own_rss()
    have = avail + own
    limits = _cgroup_limits()
    ours = own + (_launchers_rss() if limits else 0)
    for limit, used in limits:
        others = 0 if used is None else max(used - ours, 0)
        have = min(have, limit - others)
    return have


def headroom_bytes() -> int | None:
    """Memory this process can still allocate beside what it holds (within the cgroup
    limit); None if unknown."""
    have = available_bytes()
    return None if have is None else max(have - _own_rss(), 0)


def describe(nbytes: float) -> str:
    """``1.5 GB`` (decimal units, as SLURM's ``--mem`` and Snakemake's ``mem_mb``)."""
    for unit, size in (("TB", 1e12), ("GB", 1e9), ("MB", 1e6)):
        if nbytes >= size:
            return f"{nbytes / size:.3g} {unit}"
    return f"{nbytes / 1e3:.3g} kB"


def check_memory(task: str, shape: tuple[int, ...] | int, *, limit: int | None = None,
                 what: str = "") -> int:
    """Raise :class:`ResourceError` before any allocation if ``task`` on a grid of
    ``shape`` (or a number of points) needs more than ``limit`` bytes (default: what this
    process can reach, :func:`available_bytes`); returns the estimate. ``what`` names the
    work in the message (default "a <task> computation")."""
    if isinstance(shape, int):
        points, grid = shape, f"{shape} points"
    else:
        points = 1
        for n in shape:
            points *= int(n)
        grid = " x ".join(str(int(n)) for n in shape) + f" grid ({points:.3g} points)"
    need = estimate_bytes(task, points)
    if need - BASE[task] < SMALL:
        return need
    have = available_bytes() if limit is None else limit
    if have is not None and need > have:
        on_gpu = task.startswith("gpu")
        if on_gpu:
            source = f"the GPU has {describe(have)} free"
        elif limit is not None:
            source = f"the limit is {describe(have)}"
        else:
            source = f"this machine has {describe(have)} available"
            cgroup = _limited_by_cgroup()
            if cgroup is not None:
                held = (f", other processes in it hold {describe(cgroup - have)}"
                        if cgroup - have > SMALL else "")
                source = (f"this process can reach {describe(have)} (the memory limit of its "
                          f"cgroup, a SLURM allocation or container, is {describe(cgroup)}"
                          f"{held})")
        raise ResourceError(
            f"{what or f'a {task} computation'} on a {grid} needs about {describe(need)} of "
            f"{'GPU ' if on_gpu else ''}memory, but {source}; use a coarser grid (fewer points "
            "per lambda_s, a larger eps_f or a smaller L/lambda_r)")
    return need
