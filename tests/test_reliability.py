"""Library-level guards of issue 13: job and config checks at planning time, the memory
estimate and its refusals, dataset kinds, atomic writes with the right permissions.

Each test names the defect it would catch; the command-line side of the same defects is
in tests/test_adversarial.py, the workflow side in tests/test_workflow.py.
"""

from __future__ import annotations

import math
import os

import numpy as np
import pytest
import xarray as xr

from roughflow import fft, resources
from roughflow.errors import MAX_SEED, InputError, ResourceError
from roughflow.scenes import (
    ChannelsJob,
    LadderJob,
    SurfaceParams,
    ThresholdJob,
    estimated_memory,
    expand_study,
)
from roughflow.scenes.expand import check_collisions
from roughflow.scenes.requests import check_plan_memory
from roughflow.surface import SurfaceSpec, generate

SMALL = SurfaceParams(l_over_lambda_r=4, eps_f=0.25, points_per_lambda_s=2)


# --- jobs and configs, refused at planning time ------------------------------------------

@pytest.mark.parametrize("kw", [{"gamma": 0.0}, {"gamma": -1.0}, {"hurst": 1.5},
                                {"eps_f": 2.0}, {"points_per_lambda_s": 1.0},
                                {"points_per_lambda_s": math.nan}, {"aspect": 0.0},
                                {"l_over_lambda_r": -4.0}])
def test_surface_params_refuse_bad_numbers(kw):
    # item 10: gamma = 0 used to fail as ZeroDivisionError, -1 as a math domain error
    name = next(iter(kw))
    with pytest.raises(InputError, match=name):
        SurfaceParams(**kw)


def test_jobs_refuse_duplicate_and_invalid_seeds():
    # item 11: --seeds 0 0 wrote a duplicate seed coordinate; item 12: huge seeds
    with pytest.raises(InputError, match="distinct"):
        ThresholdJob(surface=SMALL, seeds=(0, 0))
    with pytest.raises(InputError, match="distinct"):
        LadderJob(surface=SMALL, seeds=(3, 1, 3))
    for bad in ((), (-1,), (MAX_SEED + 1,), (1.5,)):
        with pytest.raises(InputError, match="seed"):
            ThresholdJob(surface=SMALL, seeds=bad)
    with pytest.raises(InputError, match="seed"):
        SurfaceSpec.from_sweep(seed=MAX_SEED + 1)
    assert SurfaceSpec.from_sweep(seed=MAX_SEED).seed == MAX_SEED


def test_jobs_refuse_tolerances_beyond_their_maximum():
    with pytest.raises(InputError, match="tol"):
        ThresholdJob(surface=SMALL, tol=0.5)
    with pytest.raises(InputError, match="contact_tol"):
        ThresholdJob(surface=SMALL, contact_tol=1.0)
    with pytest.raises(InputError, match="area_fraction"):
        ChannelsJob(area_fraction=1.0)


@pytest.mark.parametrize("areas", [(0.0,), (1.0,), (math.nan,), (0.3, 0.1), (0.2, 0.2)])
def test_ladder_areas_are_named(areas):
    # item 11: an area of 1 or NaN was reported as "pressure must be finite"
    with pytest.raises(InputError, match="area_fractions"):
        LadderJob(surface=SMALL, area_fractions=areas)


def test_threshold_study_refuses_the_adhesive_model_naming_the_study():
    # item 5: every job of such a study failed at run time
    with pytest.raises(InputError, match=r"studies\.threshold_vs_gamma.*adhesive"):
        expand_study("threshold_vs_gamma", {"model": ["adhesive"], "seeds": [0]})


def test_series_differing_only_in_resolution_collide():
    # item 1: two series that differ only in points_per_lambda_s fill the same cells
    block = {"seeds": [0, 1], "eps_f": [0.25], "l_over_lambda_r": [4],
             "series": [{"points_per_lambda_s": 2}, {"points_per_lambda_s": 3}]}
    with pytest.raises(InputError, match="points-per-lambda-s 2.0 vs 3.0"):
        expand_study("threshold_vs_size", block)


def test_overlapping_seeds_of_two_series_collide():
    # item 1: overlapping seeds across series gave a seed index [0 1 1 2]
    block = {"eps_f": [0.25], "l_over_lambda_r": [4], "points_per_lambda_s": 2,
             "seeds_per_job": 2, "series": [{"seeds": [0, 1]}, {"seeds": [1, 2]}]}
    with pytest.raises(InputError, match=r"seeds \[1\]"):
        expand_study("threshold_vs_size", block)
    # disjoint seed groups of one parameter set are fine (stacked along seed)
    ok = {**block, "series": [{"seeds": [0, 1]}, {"seeds": [2, 3]}]}
    assert len(expand_study("threshold_vs_size", ok)) == 2
    # and different models do not collide
    check_collisions("x", [ThresholdJob(surface=SMALL, model=m) for m in ("elastic", "bearing")])


def test_job_settings_leave_out_only_the_seeds():
    a = LadderJob(surface=SMALL, seeds=(0, 1), area_fractions=(0.1, 0.2))
    b = LadderJob(surface=SMALL, seeds=(5,), area_fractions=(0.1, 0.2))
    c = LadderJob(surface=SMALL, seeds=(5,), area_fractions=(0.1, 0.3))
    assert a.settings() == b.settings() != c.settings()
    assert "--seeds" not in a.settings() and a.key == c.key


# --- memory ---------------------------------------------------------------------------

def test_memory_model_grows_with_the_grid_and_orders_the_tasks():
    n = 1024**2
    est = {t: resources.estimate_bytes(t, n) for t in resources.TASKS}
    assert est["flow"] > est["contact"] > est["surface"]
    assert resources.estimate_bytes("contact", 4 * n) > est["contact"]
    with pytest.raises(KeyError):
        resources.estimate_bytes("nonsense", n)


def test_threshold_search_checks_the_model_of_its_states(monkeypatch):
    # the elastic search keeps 4 bytes a point per state, the adhesive one whole states:
    # each is checked against its own model before anything is solved (a limit between the
    # two estimates refuses the adhesive search only)
    from roughflow.contact import Adhesion
    from roughflow.search import critical, threshold
    from roughflow.surface import Surface

    shape = (1024, 1024)
    elastic = resources.estimate_bytes("threshold", shape[0] * shape[1])
    adhesive = resources.estimate_bytes("threshold_adhesive", shape[0] * shape[1])
    assert adhesive > elastic
    monkeypatch.setattr(resources, "available_bytes", lambda: (elastic + adhesive) // 2)

    class Reached(Exception):
        pass

    def refine(*args, **kwargs):
        raise Reached

    monkeypatch.setattr(critical, "_refine", refine)
    surface = Surface(heights=np.zeros(shape), lx=1.0, ly=1.0)
    with pytest.raises(ResourceError, match="an adhesive threshold search on a 1024 x 1024"):
        threshold(surface, model="adhesive", adhesion=Adhesion(surface_energy=1e-4, range=0.01))
    with pytest.raises(Reached):  # passed the check
        threshold(surface)


@pytest.mark.parametrize(("cgroup", "files", "limit"), [
    # a SLURM job's allocation (cgroup v1): its own cgroup below the root, which read
    # alone (unlimited) had given the node's memory, not the job's
    ("4:memory:/slurm/uid_0/job_7/step_batch\n1:cpu:/slurm/uid_0/job_7",
     {"memory/slurm/uid_0/job_7/memory.limit_in_bytes": "3000000000",
      "memory/slurm/uid_0/job_7/step_batch/memory.limit_in_bytes": "9223372036854771712",
      "memory/memory.limit_in_bytes": "9223372036854771712"}, 3_000_000_000),
    # cgroup v2 (systemd's scope of a SLURM step): the lowest of the own and ancestors' limits
    ("0::/system.slice/slurmstepd.scope/job_9/step_0/user",
     {"system.slice/slurmstepd.scope/job_9/memory.max": "2000000000",
      "system.slice/slurmstepd.scope/job_9/step_0/user/memory.max": "max",
      "system.slice/slurmstepd.scope/job_9/step_0/memory.max": "5000000000"}, 2_000_000_000),
    # a container's namespace shows its cgroup as the root
    ("0::/", {"memory.max": "4000000000"}, 4_000_000_000),
    ("0::/", {"memory.max": "max"}, None),
])
def test_the_memory_limit_is_that_of_the_own_cgroup(tmp_path, monkeypatch, cgroup, files,
                                                     limit):
    (tmp_path / "cgroup").write_text(cgroup + "\n")
    for name, text in files.items():
        (tmp_path / "fs" / name).parent.mkdir(parents=True, exist_ok=True)
        (tmp_path / "fs" / name).write_text(text + "\n")
    monkeypatch.setattr(resources, "PROC_CGROUP", tmp_path / "cgroup")
    monkeypatch.setattr(resources, "CGROUP_ROOT", tmp_path / "fs")
    assert resources._cgroup_limit() == limit
    monkeypatch.setattr(resources, "_meminfo", lambda key: 24 * 10**9)
    assert resources.total_bytes() == (limit or 24 * 10**9)
    # the workflow's plan check names it: "the memory of this machine" pointed at the
    # node's 24 GB where a job's allocation was the limit
    assert ("cgroup" in resources.total_source()) == (limit is not None)


@pytest.mark.parametrize(("cgroup", "files"), [
    # cgroup v1 (a SLURM allocation): usage counts the page cache, whose file part
    # (memory.stat's total_active_file and total_inactive_file, the cgroups below included)
    # the kernel reclaims before it kills; shared memory (tmpfs) is not reclaimed
    ("4:memory:/slurm/uid_0/job_7/step_batch",
     {"memory/slurm/uid_0/job_7/memory.limit_in_bytes": "3000000000",
      "memory/slurm/uid_0/job_7/memory.usage_in_bytes": "2300000000",
      "memory/slurm/uid_0/job_7/memory.stat": "cache 500000000\nshmem 200000000\n"
                                               "inactive_file 0\nactive_file 0\n"
                                               "total_inactive_file 100000000\n"
                                               "total_active_file 200000000",
      "memory/slurm/uid_0/job_7/step_batch/memory.limit_in_bytes": "9223372036854771712",
      "memory/slurm/uid_0/job_7/step_batch/memory.usage_in_bytes": "2300000000"}),
    # cgroup v2
    ("0::/system.slice/slurmstepd.scope/job_9",
     {"system.slice/slurmstepd.scope/job_9/memory.max": "3000000000",
      "system.slice/slurmstepd.scope/job_9/memory.current": "2300000000",
      "system.slice/slurmstepd.scope/job_9/memory.stat": "anon 1800000000\n"
                                                          "file 500000000\n"
                                                          "shmem 200000000\n"
                                                          "active_file 200000000\n"
                                                          "inactive_file 100000000"}),
])
def test_available_memory_leaves_out_what_the_cgroups_other_processes_hold(
        tmp_path, monkeypatch, cgroup, files):
    # two roughflow processes in one 2 GB cgroup each saw the whole limit: the second
    # passed its check and the kernel killed the first (2026-12-06)
    (tmp_path / "cgroup").write_text(cgroup + "\n")
    for name, text in files.items():
        (tmp_path / "fs" / name).parent.mkdir(parents=True, exist_ok=True)
        (tmp_path / "fs" / name).write_text(text + "\n")
    # /proc: this process (started by a shell, pid 40, itself started by pid 1) holds
    # 0.2 GB; the shell is in another cgroup until the second part of the test
    proc = tmp_path / "proc"
    for pid, parent, rss in (("self", 40, 200_000_000), ("40", 1, 500_000_000)):
        (proc / pid).mkdir(parents=True)
        (proc / pid / "stat").write_text(f"{pid} (a (b) c) S {parent} 1 1 0\n")
        (proc / pid / "statm").write_text(f"1 {rss // os.sysconf('SC_PAGE_SIZE')} 0\n")
    (proc / "40" / "cgroup").write_text("0::/elsewhere\n")
    monkeypatch.setattr(resources, "PROC_CGROUP", tmp_path / "cgroup")
    monkeypatch.setattr(resources, "CGROUP_ROOT", tmp_path / "fs")
    monkeypatch.setattr(resources, "PROC", proc)
    monkeypatch.setattr(resources, "_meminfo", lambda key: 24 * 10**9)
    monkeypatch.setattr(resources, "_own_rss", lambda: 200_000_000)
    # 2.0 GB held in the cgroup (2.3 less 0.3 of file cache), 0.2 of it by this
    # process: 1.8 GB by others, so this one can reach 3.0 - 1.8 = 1.2 GB
    assert resources.total_bytes() == 3_000_000_000
    assert resources.available_bytes() == 1_200_000_000
    assert resources.headroom_bytes() == 1_000_000_000
    resources.check_memory("contact", (2048, 2048))  # 0.97 GB
    with pytest.raises(ResourceError, match=r"1.66 GB .* can reach 1.2 GB \(the memory limit "
                       r"of its cgroup.* is 3 GB, other processes in it hold 1.8 GB\)"):
        resources.check_memory("threshold", (2048, 2048))
    # the process that started this one (Snakemake, locally or in a cluster job) is covered
    # by the job's request: its 0.5 GB (rounded to pages) is not counted against it
    (proc / "40" / "cgroup").write_text(cgroup + "\n")
    assert abs(resources.available_bytes() - 1_700_000_000) < 10**5
    resources.check_memory("threshold", (2048, 2048))


def test_check_memory_refuses_with_grid_and_sizes():
    with pytest.raises(ResourceError, match=r"60000 x 60000 grid.*GB.*limit is 1 GB"):
        resources.check_memory("surface", (60000, 60000), limit=10**9)
    # small grids are never refused, whatever the limit
    assert resources.check_memory("flow", (64, 64), limit=1) > 0


def test_generate_refuses_before_allocating():
    # item 2: --nx 60000 --ny 60000 took the whole host; 2e5^2 needs terabytes anywhere
    spec = SurfaceSpec(nx=200_000, ny=200_000, lx=1, ly=1, hurst=0.8, gamma=1, lambda_r=0.25,
                       lambda_s=1e-4, seed=0)
    with pytest.raises(ResourceError, match="TB"):
        generate(spec)
    from roughflow.theory import discrete_spectrum

    with pytest.raises(ResourceError, match="spectrum"):
        discrete_spectrum(spec)


def test_plan_memory_refuses_the_54_terabyte_config():
    # item 2: points_per_lambda_s 64, L/lambda_r 64, eps_f 0.01 passed validation (mem_mb 5e7)
    jobs = {"threshold_vs_size": expand_study("threshold_vs_size", {
        "seeds": [0], "points_per_lambda_s": 64, "l_over_lambda_r": [64], "eps_f": [0.01]})}
    (job,) = jobs["threshold_vs_size"].values()
    assert estimated_memory(job) > 1e13
    with pytest.raises(ResourceError, match=r"studies\.threshold_vs_size.*TB"):
        check_plan_memory(jobs, 24 * 10**9, "test")


def test_job_memory_is_the_snakemake_request():
    # the workflow requests the estimate plus the Snakemake wrapper, doubled on the retry
    # (workflow/rules/common.smk: mem_mb)
    from roughflow.scenes.requests import WRAPPER_MB, requested_mem_mb, task_mem_mb

    job = ThresholdJob(surface=SMALL)
    assert estimated_memory(job) == resources.estimate_bytes("threshold", 32 * 32)
    mb = WRAPPER_MB + math.ceil(estimated_memory(job) / 1e6)
    assert requested_mem_mb(job) == mb and requested_mem_mb(job, attempt=2) == 2 * mb
    # the accuracy study's jobs (no sweep jobs) by the same rule, from a task and a grid
    assert task_mem_mb("threshold", 32 * 32) == mb and task_mem_mb("threshold", 1024, 2) == 2 * mb


def test_threads_must_be_positive():
    # item 10: --threads -3 raised OverflowError inside FFTW, 0 was accepted
    for bad in (0, -3, 2.5, True):
        with pytest.raises(InputError, match="threads"):
            fft.plan((8, 8), bad)
    assert fft.check_threads(None) is None and fft.check_threads(2) == 2


# --- files ----------------------------------------------------------------------------

def test_read_dataset_names_the_kind_it_found(tmp_path):
    from roughflow.io import read_dataset, surface_to_dataset, write_dataset

    surface = generate(SMALL.spec(0))
    path = write_dataset(surface_to_dataset(surface), tmp_path / "s.nc")
    assert "heights" in read_dataset(path, "surface")
    with pytest.raises(InputError, match="not a contact file.*looks like a surface file"):
        read_dataset(path, "contact", what="contact file")


def test_surface_spec_must_match_the_heights(tmp_path):
    from roughflow.io import surface_from_dataset, surface_to_dataset

    ds = surface_to_dataset(generate(SMALL.spec(0)))
    with pytest.raises(InputError, match="spec_"):
        surface_from_dataset(ds.assign_attrs(spec_nx=7))
    with pytest.raises(InputError, match="incomplete"):
        surface_from_dataset(ds.drop_attrs().assign_attrs(lx=1.0, ly=1.0, spec_nx=32))


def test_write_is_atomic_and_leaves_no_partial_file(tmp_path, monkeypatch):
    from roughflow.io import write_dataset

    def boom(self, path, *a, **k):
        open(path, "wb").write(b"half a file")
        raise OSError("disk full")

    monkeypatch.setattr(xr.Dataset, "to_netcdf", boom)
    with pytest.raises(OSError, match="disk full"):
        write_dataset(xr.Dataset({"a": ("x", np.arange(3))}), tmp_path / "a.nc")
    assert list(tmp_path.iterdir()) == []


# --- outputs of one command appear together; write failures name the file ------------------

def test_a_figures_png_and_pdf_appear_together_or_not_at_all(tmp_path):
    # the PNG used to be published before the PDF was rendered: a failed or killed PDF
    # render left a new PNG beside no PDF (or beside the PDF of an earlier figure)
    from matplotlib.figure import Figure

    from roughflow.io import save_figure

    class PdfFails(Figure):
        def savefig(self, fname, format=None, **kw):
            if format == "pdf":
                raise RuntimeError("pdf backend died")
            return super().savefig(fname, format=format, **kw)

    (tmp_path / "fig.pdf").write_bytes(b"an earlier figure's PDF")
    with pytest.raises(RuntimeError, match="pdf backend died"):
        save_figure(PdfFails(), tmp_path / "fig.png", tmp_path / "fig.pdf")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["fig.pdf"]
    assert (tmp_path / "fig.pdf").read_bytes() == b"an earlier figure's PDF"
    save_figure(Figure(), tmp_path / "fig.png", tmp_path / "fig.pdf")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["fig.pdf", "fig.png"]


@pytest.mark.parametrize("failure", ["enospc", "hdf_error_on_a_full_disk"])
def test_a_full_disk_is_an_output_error_naming_the_file(tmp_path, monkeypatch, failure):
    # netCDF reports a full disk as "NetCDF: HDF error" (a RuntimeError), mkstemp as a
    # PermissionError, matplotlib as an AttributeError: each ended in a traceback (exit 1)
    import errno
    import shutil

    from roughflow.errors import OutputError
    from roughflow.io import write_dataset

    if failure == "enospc":
        def write(self, path, *a, **k):
            raise OSError(errno.ENOSPC, "No space left on device")
    else:
        def write(self, path, *a, **k):
            raise RuntimeError("NetCDF: HDF error")

        usage = shutil.disk_usage(tmp_path)
        monkeypatch.setattr(shutil, "disk_usage",
                            lambda p: usage._replace(free=4096))
    monkeypatch.setattr(xr.Dataset, "to_netcdf", write)
    with pytest.raises(OutputError, match=r"cannot write '.*a\.nc': no space left"):
        write_dataset(xr.Dataset({"a": ("x", np.arange(3))}), tmp_path / "a.nc")
    assert list(tmp_path.iterdir()) == []


def test_a_writer_bug_on_a_disk_with_room_stays_a_bug(tmp_path, monkeypatch):
    # only the file system's failures become OutputError; a writer's own error propagates
    from roughflow.io import write_dataset

    def write(self, path, *a, **k):
        raise RuntimeError("NetCDF: HDF error")

    monkeypatch.setattr(xr.Dataset, "to_netcdf", write)
    with pytest.raises(RuntimeError, match="HDF error"):
        write_dataset(xr.Dataset({"a": ("x", np.arange(3))}), tmp_path / "a.nc")
    assert list(tmp_path.iterdir()) == []


def test_a_rename_that_fails_midway_takes_back_the_outputs_already_published(tmp_path,
                                                                             monkeypatch):
    # the PNG was renamed into place and the PDF's rename failed: the new PNG stayed beside
    # the old PDF, and exit 5 said no output was left
    import errno
    import os

    from matplotlib.figure import Figure

    from roughflow import io
    from roughflow.errors import OutputError

    real = os.replace
    calls = []

    def second_fails(src, dst):
        calls.append(dst)
        if len(calls) == 2:
            raise OSError(errno.EIO, "I/O error")
        return real(src, dst)

    monkeypatch.setattr(io.os, "replace", second_fails)
    with pytest.raises(OutputError, match="fig.pdf"):
        io.save_figure(Figure(), tmp_path / "fig.png", tmp_path / "fig.pdf")
    assert list(tmp_path.iterdir()) == []
