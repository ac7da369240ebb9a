"""The compiled kernels' cache follows the package source (roughflow._jit): a kernel whose
callee in another module changed is compiled afresh, not loaded stale."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import time
from pathlib import Path

import roughflow
from roughflow import _jit

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
