"""The compiled kernels' cache follows the package source (roughflow._jit): a kernel whose
callee in another module changed is compiled afresh, not loaded stale."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

import roughflow
from roughflow import _jit, files
from roughflow.files import STALE_TEMPORARY_S

PACKAGE = Path(roughflow.__file__).resolve().parent


def test_source_key_follows_every_file(tmp_path):
    pkg = tmp_path / "pkg"
    (pkg / "sub").mkdir(parents=True)
    (pkg / "a.py").write_text("x = 1\n")
    (pkg / "sub" / "b.py").write_text("y = 2\n")
    key = _jit.source_key(pkg)
    assert _jit.source_key(pkg) == key
    (pkg / "sub" / "b.py").write_text("y = 3\n")  # a constant a kernel may freeze
    changed = _jit.source_key(pkg)
    assert changed != key
    (pkg / "sub" / "b.py").rename(pkg / "sub" / "c.py")
    assert _jit.source_key(pkg) not in (key, changed)


def test_kernels_are_cached_under_the_keyed_directory_and_numba_setting_stays():
    import numba

    from roughflow.percolation import spanning

    here = _jit.cache_dir()
    assert here is not None and here.name == _jit.source_key()
    assert Path(spanning._spans_4._cache.cache_path).is_relative_to(here)
    assert numba.config.CACHE_DIR == os.environ.get("NUMBA_CACHE_DIR", "")


def test_an_editor_lock_file_does_not_stop_the_imports(tmp_path):
    # Emacs marks an unsaved file with a dangling link ".#name.py": reading it failed, and
    # with it every import of a solver
    pkg = tmp_path / "pkg"
    pkg.mkdir()
    (pkg / "a.py").write_text("x = 1\n")
    key = _jit.source_key(pkg)
    (pkg / ".#a.py").symlink_to("user@host.1234:1700000000")
    assert _jit.source_key(pkg) == key


def _run(code: str, env: dict) -> str:
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True,
                         text=True, timeout=300)
    assert out.returncode == 0, out.stderr
    return out.stdout.strip()


def test_old_versions_are_pruned_once_unused(tmp_path):
    parent = tmp_path / "cache" / "roughflow"
    day = _jit.PRUNE_AFTER_S
    ages = {f"old{i}": 2 * day * (i + 1) for i in range(_jit.KEEP + 2)}
    ages["recent"] = 60.0  # beyond KEEP by age order, but used a minute ago: kept
    for name, age in ages.items():
        (parent / name).mkdir(parents=True)
        os.utime(parent / name, (time.time() - age,) * 2)
    (tmp_path / "cache" / "roughflow-paper_0123").mkdir()  # numba's own folder of a user's
    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path / "cache")}
    here = Path(_run("from roughflow._jit import cache_dir; print(cache_dir())", env))
    assert here.parent == parent
    kept = sorted(p.name for p in parent.iterdir())
    newest = sorted(ages, key=ages.get)[:_jit.KEEP - 1]  # with the present one, KEEP
    assert kept == sorted({here.name, "recent", *newest})
    assert (tmp_path / "cache" / "roughflow-paper_0123").is_dir()


def test_an_unwritable_cache_falls_back_to_the_temporary_folder(tmp_path):
    # numba itself falls back to the per-file cache beside the source, the stale one
    blocker = tmp_path / "file"
    blocker.write_text("")
    env = {**os.environ, "NUMBA_CACHE_DIR": str(blocker / "sub"), "TMPDIR": str(tmp_path)}
    code = ("from roughflow._jit import cache_dir; from roughflow.percolation import "
            "spanning; print(cache_dir()); print(spanning._spans_4._cache.cache_path)")
    here, kernel = (Path(line) for line in _run(code, env).splitlines())
    assert here.is_relative_to(tmp_path) and not here.is_relative_to(blocker)
    assert kernel.is_relative_to(here)


def test_a_cache_that_cannot_be_used_is_reported_and_the_spare_made_only_then(tmp_path):
    # bob's NUMBA_CACHE_DIR, a group's folder whose version folder alice made under umask
    # 022, was passed over for /tmp without a word; and every process made its spare
    # folder in /tmp, used or not
    code = ("from roughflow._jit import cache_dir; from roughflow.percolation import "
            "spanning; print(cache_dir())")
    spare = tmp_path / "tmp"
    spare.mkdir()
    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path / "numba"), "TMPDIR": str(spare)}
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True,
                         text=True, timeout=300)
    assert out.returncode == 0, out.stderr
    assert Path(out.stdout.strip()).is_relative_to(tmp_path / "numba")
    assert "compiled kernels" not in out.stderr and not list(spare.iterdir())
    blocker = tmp_path / "file"
    blocker.write_text("")
    env["NUMBA_CACHE_DIR"] = str(blocker / "sub")
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True,
                         text=True, timeout=300)
    assert out.returncode == 0, out.stderr
    here = Path(out.stdout.strip())
    assert here.is_relative_to(spare)
    [warning] = [line for line in out.stderr.splitlines() if "compiled kernels" in line]
    assert str(blocker / "sub") in warning and f"cached in {here}" in warning


def test_a_changed_callee_in_another_module_is_not_served_stale(tmp_path):
    # percolation.spanning's kernels call percolation.sweep's union-find. numba checks a
    # cached kernel against its own file only: with the cache in one place (numba's
    # default, next to the source), breaking sweep._find left percolates_along answering
    # from the old machine code. A package copy is run, its sweep.py edited, run again.
    src = tmp_path / "src"
    shutil.copytree(PACKAGE, src / "roughflow",
                    ignore=shutil.ignore_patterns("__pycache__", "*.nbi", "*.nbc"))
    env = {**os.environ, "PYTHONPATH": str(src), "NUMBA_CACHE_DIR": str(tmp_path / "cache")}
    code = ("import numpy as np, roughflow; "
            f"assert roughflow.__file__.startswith({str(src)!r}); "
            "from roughflow.percolation import percolates_along; "
            "m = np.ones((6, 5), bool); m[:, 2] = False; "
            "print(sorted(percolates_along(m).items()))")
    assert _run(code, env) == "[(0, True), (1, False)]"  # a closed column blocks y only
    sweep = src / "roughflow" / "percolation" / "sweep.py"
    text = sweep.read_text()
    edited = text.replace("    while parent[x] != x:\n",
                          "    if x >= 0:\n        raise ValueError('edited')\n"
                          "    while parent[x] != x:\n", 1)
    assert edited != text
    sweep.write_text(edited)
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True,
                         text=True, timeout=300)
    assert out.returncode != 0 and "edited" in out.stderr, out.stdout  # compiled afresh


TOY = """from roughflow._jit import njit


@njit(cache=True)
def double(x):
    return 2 * x
"""


def _toy_module(folder: Path, name: str):
    import importlib.util

    path = folder / f"{name}.py"
    path.write_text(TOY)
    spec = importlib.util.spec_from_file_location(name, path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_a_kernel_numba_would_cache_beside_its_source_is_left_uncached(tmp_path, monkeypatch):
    # where numba cannot make the kernel's folder under the version (pruned meanwhile, a
    # full disk), it silently fell back to a cache beside the source file: the per-file
    # cache that served stale machine code
    from numba.core.caching import _CacheLocator

    where = tmp_path / "cache"
    blocked = where / _CacheLocator.get_suitable_cache_subpath(str(tmp_path / "toy_a.py"))
    blocked.parent.mkdir(parents=True)
    blocked.write_text("a file where numba wants its folder\n")
    monkeypatch.setattr(_jit, "cache_dir", lambda: where)
    toy = _toy_module(tmp_path, "toy_a")
    assert toy.double(3) == 6
    assert not list(tmp_path.rglob("*.nbi"))  # numba's index: no cache anywhere


def test_a_failed_save_leaves_the_kernel_uncached_not_the_computation_failed(
        tmp_path, monkeypatch, caplog):
    import errno

    from numba.core import caching

    def full(self, key, data):
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(caching.IndexDataCacheFile, "save", full)
    monkeypatch.setattr(_jit, "cache_dir", lambda: tmp_path / "cache")
    toy = _toy_module(tmp_path, "toy_b")
    with caplog.at_level("WARNING", logger="roughflow._jit"):
        assert toy.double(4) == 8
    assert "could not be cached" in caplog.text and "No space left" in caplog.text


def test_two_processes_saving_at_once_keep_both_signatures(tmp_path):
    # numba's save reads the index, picks the next data file and rewrites the index: two
    # processes compiling different signatures at once lost one entry in 16 of 20 tries
    # (and could pair one signature's index entry with the other's machine code). Left to
    # chance the two saves rarely overlap on a quiet machine, so each process here waits
    # for the other before it compiles (a barrier of files) and holds the index it read for
    # 0.3 s before rewriting it: without the lock every run loses an entry.
    import pickle

    (tmp_path / "toy_c.py").write_text(TOY)
    barrier = tmp_path / "ready"
    barrier.mkdir()
    code = ("import sys, time, pathlib; sys.path.insert(0, {folder!r}); import toy_c\n"
            "from numba.core import caching\n"
            "load = caching.IndexDataCacheFile._load_index\n"
            "def slow_load(self):\n"
            "    index = load(self)\n"
            "    time.sleep(0.3)\n"
            "    return index\n"
            "caching.IndexDataCacheFile._load_index = slow_load\n"
            "here = pathlib.Path({barrier!r})\n"
            "(here / {arg!r}).touch()\n"
            "end = time.time() + 120\n"
            "while len(list(here.iterdir())) < 2 and time.time() < end: time.sleep(0.005)\n"
            "print(toy_c.double({arg}))")
    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path / "numba"),
           "PYTHONPATH": str(PACKAGE.parent)}
    procs = [subprocess.Popen([sys.executable, "-c", code.format(
        folder=str(tmp_path), barrier=str(barrier), arg=arg)], env=env,
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True) for arg in ("1.5", "3")]
    outs = [p.communicate(timeout=300) for p in procs]
    assert [p.returncode for p in procs] == [0, 0], outs
    assert [o[0].strip() for o in outs] == ["3.0", "6"]
    [index] = (tmp_path / "numba").rglob("toy_c.double*.nbi")
    with index.open("rb") as f:
        pickle.load(f)  # numba's version
        _, overloads = pickle.loads(f.read())
    assert len(overloads) == 2, overloads


def test_the_spare_folder_in_the_temporary_folder_must_be_private(tmp_path):
    # its name can be guessed: a folder another user made first (or any folder others may
    # write, or a link) could hold planted pickles, which numba loads as machine code
    mine = tmp_path / "mine"
    assert _jit._private(mine) and (mine.stat().st_mode & 0o777) == 0o700
    # this user's own folder that others may write (made under umask 002): made private
    loose = tmp_path / "loose"
    loose.mkdir()
    loose.chmod(0o777)
    assert _jit._private(loose) and (loose.stat().st_mode & 0o777) == 0o700
    link = tmp_path / "link"
    link.symlink_to(mine)
    assert not _jit._private(link)
    if os.getuid() == 0:  # only root can give a folder to another user
        theirs = tmp_path / "theirs"
        theirs.mkdir(mode=0o777)
        os.chown(theirs, 65534, -1)
        assert not _jit._private(theirs)


def test_a_save_waits_for_another_process_then_gives_up(tmp_path, monkeypatch, caplog):
    # a holder that is stopped or hung (SIGSTOP, a suspended job) blocked every other job's
    # first save, and with it numba's compiler lock
    import fcntl

    where = tmp_path / "cache"
    where.mkdir()
    holder = os.open(where / ".save.lock", os.O_RDWR | os.O_CREAT)
    fcntl.flock(holder, fcntl.LOCK_EX)  # another open file: blocks like another process
    monkeypatch.setattr(_jit, "SAVE_LOCK_WAIT_S", 0.3)
    monkeypatch.setattr(_jit, "cache_dir", lambda: where)
    try:
        toy = _toy_module(tmp_path, "toy_d")
        with caplog.at_level("WARNING", logger="roughflow._jit"):
            assert toy.double(5) == 10
    finally:
        os.close(holder)
    assert "could not be cached" in caplog.text and "held" in caplog.text
    assert not list(where.rglob("*.nbi"))


def test_after_one_vain_wait_the_later_saves_do_not_wait(tmp_path, monkeypatch, caplog):
    # every kernel's save waited SAVE_LOCK_WAIT_S behind a stopped holder (a suspended job,
    # perhaps another user's, which this one cannot end): a threshold search that takes 10 s
    # had not finished after 5 minutes (4 kernels, a minute each)
    import fcntl

    where = tmp_path / "cache"
    where.mkdir()
    holder = os.open(where / ".save.lock", os.O_RDWR | os.O_CREAT)
    fcntl.flock(holder, fcntl.LOCK_EX)
    monkeypatch.setattr(_jit, "SAVE_LOCK_WAIT_S", 0.5)
    monkeypatch.setattr(_jit, "cache_dir", lambda: where)
    monkeypatch.setattr(files, "_WAITED_IN_VAIN", set())
    naps = []
    real_sleep = time.sleep
    monkeypatch.setattr(_jit.time, "sleep", lambda s: (naps.append(s), real_sleep(s)))
    toy = _toy_module(tmp_path, "toy_g")
    try:
        with caplog.at_level("WARNING", logger="roughflow._jit"):
            assert toy.double(5) == 10  # waits for the lock in vain
            first = len(naps)
            assert toy.double(2.5) == 5.0  # another signature, another save: no wait
            assert toy.double(np.float32(1.5)) == 3.0
        assert first > 0 and len(naps) == first
        assert caplog.text.count("could not be cached") == 1  # one warning, not one a kernel
    finally:
        os.close(holder)
    assert toy.double(True) == 2  # the lock is free again: this save takes it and caches
    assert files._WAITED_IN_VAIN == set()
    assert list(where.rglob("*.nbi"))


def test_a_damaged_index_is_a_cache_miss_and_is_replaced(tmp_path, monkeypatch):
    # numba does not fsync: an index cut short by a crash made every later run fail with an
    # UnpicklingError, on load and on save
    where = tmp_path / "cache"
    monkeypatch.setattr(_jit, "cache_dir", lambda: where)
    assert _toy_module(tmp_path, "toy_e").double(2) == 4
    [index] = where.rglob("toy_e.double*.nbi")
    index.write_bytes(index.read_bytes()[:40])
    assert _toy_module(tmp_path, "toy_e").double(2.5) == 5.0  # loads, then saves
    assert _toy_module(tmp_path, "toy_e").double(3) == 6
    import pickle

    with index.open("rb") as f:  # rebuilt whole
        pickle.load(f)
        _, overloads = pickle.loads(f.read())
    assert len(overloads) >= 1


def test_an_interrupted_prune_does_not_count_as_a_version(tmp_path, monkeypatch):
    parent = tmp_path / "versions"
    here = parent / "current"
    for name in ("current", "v1", "v2", "v_old", ".v9.removing-123"):
        (parent / name).mkdir(parents=True)
    old = time.time() - 2 * 86400
    os.utime(parent / "v_old", (old, old))
    monkeypatch.setattr(_jit, "KEEP", 4)
    _jit._prune(parent, here)
    # four versions, the leftover not among them: v_old is kept (it took a slot before)
    assert (parent / "v_old").exists()
    stale = time.time() - 2 * STALE_TEMPORARY_S
    os.utime(parent / ".v9.removing-123", (stale, stale))
    _jit._prune(parent, here)
    assert not (parent / ".v9.removing-123").exists()  # an hour old: removed
