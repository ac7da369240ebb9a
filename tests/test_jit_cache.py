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
    assert here.name == f"roughflow-{_jit.source_key()}"
    assert Path(spanning._spans_4._cache.cache_path).is_relative_to(here)
    assert numba.config.CACHE_DIR == os.environ.get("NUMBA_CACHE_DIR", "")


def _run(code: str, env: dict) -> str:
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True,
                         text=True, timeout=300)
    assert out.returncode == 0, out.stderr
    return out.stdout.strip()


def test_old_versions_are_pruned(tmp_path):
    parent = tmp_path / "cache"
    for i in range(_jit.KEEP + 2):
        old = parent / f"roughflow-old{i}"
        old.mkdir(parents=True)
        os.utime(old, (time.time() - 1000 * (i + 1),) * 2)
    (parent / "someone-else").mkdir()  # not roughflow's: left alone
    env = {**os.environ, "NUMBA_CACHE_DIR": str(parent)}
    here = _run("from roughflow._jit import cache_dir; print(cache_dir())", env)
    kept = sorted(p.name for p in parent.iterdir())
    assert Path(here).name in kept
    assert kept == sorted([Path(here).name, "someone-else"]
                          + [f"roughflow-old{i}" for i in range(_jit.KEEP - 1)])


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
