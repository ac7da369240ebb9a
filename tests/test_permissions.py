"""What a user who is not root meets: files and folders of another user, shared caches and
locks held by another user's process. CI runs as root, for whom the permission bits do not
hold: there the checks run with the effective user 'nobody' (:func:`unprivileged`)."""

from __future__ import annotations

import contextlib
import os
from pathlib import Path

import numpy as np
import pytest

from roughflow.errors import InputError

NOBODY = 65534


@contextlib.contextmanager
def unprivileged():
    """Inside the block the permission bits hold for this process: as root, its effective
    user and group are 'nobody' (what it imports there must be imported before: root's own
    folders are closed to nobody); as any other user nothing changes."""
    if os.geteuid() != 0:
        yield
        return
    os.setegid(NOBODY)
    os.seteuid(NOBODY)
    try:
        yield
    finally:
        os.seteuid(0)
        os.setegid(0)


@pytest.fixture
def closed(tmp_path) -> Path:
    """A folder that no one but root may enter, holding a file ``s.nc`` that no one but root
    may read."""
    from roughflow.io import surface_to_dataset, write_dataset
    from roughflow.surface import SurfaceSpec, generate

    folder = tmp_path / "closed"
    folder.mkdir()
    spec = SurfaceSpec(nx=16, ny=16, lx=1.0, ly=1.0, hurst=0.8, gamma=1.0, lambda_r=0.5,
                       lambda_s=0.125, seed=1)
    surface = generate(spec)
    write_dataset(surface_to_dataset(surface), folder / "s.nc")
    (folder / "s.nc").chmod(0)
    folder.chmod(0)
    yield folder
    folder.chmod(0o700)


def test_an_input_another_user_may_not_read_is_an_input_error(closed):
    # a traceback (PermissionError, exit 1) before: the file of a colleague made under a
    # private umask, or one in a folder this user may not enter
    import roughflow.datasets.kinds  # noqa: F401  (imported by read_dataset)
    from roughflow.io import read_dataset

    with unprivileged(), pytest.raises(InputError) as err:
        read_dataset(closed / "s.nc", "surface")
    assert str(closed / "s.nc") in str(err.value) and "cannot be read" in str(err.value)
    assert "Permission denied" in str(err.value)
    closed.chmod(0o700)  # the folder may be entered, the file not read
    with unprivileged(), pytest.raises(InputError, match="cannot be read"):
        read_dataset(closed / "s.nc", "surface")


def test_an_output_in_a_folder_this_user_may_not_enter_is_an_input_error(closed):
    from roughflow.io import check_output

    with unprivileged(), pytest.raises(InputError) as err:
        check_output(closed / "sub" / "out.nc", option="--output")
    assert "--output" in str(err.value) and "cannot be written" in str(err.value)


def test_a_scan_another_user_may_not_read_is_an_input_error(tmp_path):
    # SurfaceTopography's readers turned the refusal into "not a topography it can read"
    from roughflow.scan import read_scan

    scan = tmp_path / "scan.npy"
    np.save(scan, np.zeros((8, 8)))
    scan.chmod(0)
    with unprivileged(), pytest.raises(InputError) as err:
        read_scan(scan, size="1um")
    assert "cannot be read" in str(err.value) and "Permission denied" in str(err.value)


def test_a_checkout_git_refuses_as_another_users_is_reported(tmp_path, monkeypatch, caplog):
    # a lab's shared checkout, owned by its maintainer: git refuses it to everyone else
    # ("dubious ownership"), and the results lost their roughflow_commit without a word
    import shutil
    import subprocess

    from roughflow.provenance import source_commit

    if shutil.which("git") is None:
        pytest.skip("git is not installed")
    pkg = tmp_path / "repo" / "src" / "pkg"
    pkg.mkdir(parents=True)
    (pkg / "__init__.py").write_text("x = 1\n")
    for args in (["init", "-q"], ["add", "."],
                 ["-c", "user.name=t", "-c", "user.email=t@t", "commit", "-qm", "c"]):
        subprocess.run(["git", *args], cwd=tmp_path / "repo", check=True, capture_output=True)
    # git's own switch for its ownership check (no second user needed), and no safe.directory
    # of this machine's configuration
    monkeypatch.setenv("GIT_TEST_ASSUME_DIFFERENT_OWNER", "1")
    monkeypatch.setenv("GIT_CONFIG_GLOBAL", os.devnull)
    monkeypatch.setenv("GIT_CONFIG_NOSYSTEM", "1")
    if subprocess.run(["git", "-C", str(pkg), "rev-parse", "HEAD"],
                      capture_output=True).returncode == 0:
        pytest.skip("this git does not check the owner of a repository (before 2.35.2)")
    with caplog.at_level("WARNING", logger="roughflow.provenance"):
        assert source_commit.__wrapped__(pkg) == ""
    assert "belongs to another user" in caplog.text and "safe.directory" in caplog.text


def test_a_scan_another_user_may_not_read_stops_the_plan(tmp_path, monkeypatch):
    # it passed planning and failed in the import job, after the other studies' jobs ran
    from roughflow.scenes.expand import expand_study

    np.save(tmp_path / "scan.npy", np.zeros((8, 8)))
    (tmp_path / "scan.npy").chmod(0)
    monkeypatch.chdir(tmp_path)
    block = {"modulus": "1GPa", "pressures": "1MPa:10MPa:3", "fluid_pressure": "1MPa",
             "viscosity": "1mPa.s", "seal_width": "2mm", "seal_length": "60mm",
             "scans": [{"file": "scan.npy", "size": "500nm", "unit": "nm"}]}
    expand_study("measured", {**block, "scans": []})  # imports what the check needs
    with unprivileged(), pytest.raises(InputError) as err:
        expand_study("measured", block)
    assert "scan 'scan'" in str(err.value) and "cannot be read" in str(err.value)


def test_another_users_output_in_a_sticky_folder_is_refused_before_the_work(tmp_path,
                                                                            monkeypatch):
    # /tmp or a shared scratch folder: the rename that publishes the output is refused for
    # another user's file there (EPERM), which came after the work (exit 5): a threshold
    # search's result was lost. A user id that owns neither the file nor the folder stands
    # in for the other user (no second user needed).
    from roughflow.io import check_output

    scratch = tmp_path / "scratch"
    scratch.mkdir()
    scratch.chmod(0o1777)
    (scratch / "t.nc").write_bytes(b"")
    check_output(scratch / "t.nc")  # one's own file: replaced
    monkeypatch.setattr(os, "geteuid", lambda: 4242)
    with pytest.raises(InputError) as err:
        check_output(scratch / "t.nc", option="-o")
    assert "sticky" in str(err.value) and "give another name" in str(err.value)
    check_output(scratch / "new.nc")  # a new file there is fine
    # a file of that name in the nearest folder that exists is not the output's
    check_output(scratch / "sub" / "t.nc")
    scratch.chmod(0o777)  # without the sticky bit anyone who may write the folder replaces it
    check_output(scratch / "t.nc")


def test_a_prune_leaves_another_users_kernel_version_it_may_not_empty(monkeypatch):
    # A group's shared kernel cache: its folder is writable by the group, a version made by
    # another user under umask 022 is not. Moving that version aside succeeded and emptying
    # it failed, so it stayed behind as ".<version>.removing-<pid>" (and its owner's next
    # process compiled afresh). Root's folders stand in for the other user's.
    import shutil
    import tempfile
    import time

    from roughflow import _jit

    if os.geteuid() != 0:
        pytest.skip("root's folders stand in for another user's")
    shared = Path(tempfile.mkdtemp(dir="/tmp"))  # nobody can reach it, unlike tmp_path
    try:
        shared.chmod(0o777)
        old = time.time() - 2 * _jit.PRUNE_AFTER_S
        (shared / "theirs").mkdir(mode=0o755)
        (shared / "theirs" / "kernel.nbi").write_bytes(b"")
        os.utime(shared / "theirs", (old, old))
        monkeypatch.setattr(_jit, "KEEP", 1)
        with unprivileged():
            for name in ("here", "mine"):
                (shared / name).mkdir()
                (shared / name / "kernel.nbi").write_bytes(b"")
            os.utime(shared / "mine", (old, old))
            _jit._prune(shared, shared / "here")
        assert sorted(p.name for p in shared.iterdir()) == ["here", "theirs"]
        assert (shared / "theirs" / "kernel.nbi").exists()
    finally:
        shutil.rmtree(shared)
