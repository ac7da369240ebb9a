"""Test-wide settings: one thread for FFTs and BLAS (the test machines have 2 shared cores;
multi-threaded OpenBLAS on tiny vectors was measured 100x slower than numpy's sum under load),
a non-interactive matplotlib backend, and private folders for every cache a test writes."""

import atexit
import os
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

import pytest
from workflow_copy import copy_workflow

for var, value in (("ROUGHFLOW_FFT_THREADS", "1"), ("OPENBLAS_NUM_THREADS", "1"),
                   ("OMP_NUM_THREADS", "1"), ("MPLBACKEND", "Agg")):
    os.environ.setdefault(var, value)

# Caches in folders of this session's own, shared by the processes it starts (so that the
# workflow runs it compares use the same FFT algorithms), not in the working directory (the
# repository in CI) or the user's home: FFTW wisdom; Hypothesis's folder, which it fills
# with constants from the package whatever its database setting (40 files in the working
# directory from three property-test files, a test audit); roughflow's numba kernels
# (271 versions, 595 MB in ~/.cache after a development's test runs; compiling them in a
# fresh folder took no measurable time of a 6-minute suite); matplotlib's and IPython's.
for var, name in (("ROUGHFLOW_FFTW_WISDOM", "fftw"), ("HYPOTHESIS_STORAGE_DIRECTORY",
                                                    "hypothesis"),
                  ("NUMBA_CACHE_DIR", "numba"), ("MPLCONFIGDIR", "matplotlib"),
                  ("IPYTHONDIR", "ipython")):
    if var not in os.environ:
        os.environ[var] = tempfile.mkdtemp(prefix=f"roughflow-{name}-")
        atexit.register(shutil.rmtree, os.environ[var], ignore_errors=True)


@pytest.fixture(scope="session")
def local_test_run(tmp_path_factory):
    """config/test.yaml run once per session on this machine (default profile, 2 cores) in a
    temporary copy of the workflow: the results tests/test_workflow.py checks and
    tests/test_slurm.py compares the SLURM run with. Returns (workdir, CompletedProcess)."""
    snakemake = Path(sys.executable).with_name("snakemake")
    if not snakemake.exists():
        pytest.skip("snakemake not installed")
    wd = copy_workflow(tmp_path_factory.mktemp("wf"))
    env = {**os.environ, "ROUGHFLOW_FFT_THREADS": "1", "MPLBACKEND": "Agg"}
    run = subprocess.run([str(snakemake), "--configfile", "config/test.yaml", "--cores", "2"],
                         cwd=wd, env=env, capture_output=True, text=True, timeout=600)
    assert run.returncode == 0, run.stdout[-3000:] + run.stderr[-3000:]
    return wd, run


@pytest.fixture(scope="session")
def cli_surface_file(tmp_path_factory):
    """A small surface written by ``roughflow surface`` (2 points per lambda_s, seed 1),
    shared read-only by the command-line tests of a session."""
    from roughflow.cli import main

    path = tmp_path_factory.mktemp("cli_surface") / "s.nc"
    assert main(["surface", "--points-per-lambda-s", "2", "--seed", "1", "-o", str(path)]) in (
        0, None)
    return path


@pytest.fixture(scope="session")
def afm_scan_file(tmp_path_factory):
    """The AFM test scan tests/data/afm-64.npy imported by ``roughflow import`` (64^2 over
    500 nm, heights in nm), shared read-only by the hardness tests of a session."""
    from roughflow.cli import main

    out = tmp_path_factory.mktemp("afm_scan") / "afm.nc"
    data = Path(__file__).resolve().parent / "data" / "afm-64.npy"
    assert main(["-q", "import", str(data), "--size", "500nm", "--unit", "nm", "-o",
                 str(out)]) == 0
    return out


@pytest.fixture(autouse=True)
def _library_logging_restored():
    """A test that runs the command line in-process (``main([...])``) leaves its progress
    handler on the "roughflow" logger, which then stops propagating: a later test's
    ``caplog`` saw nothing, and its outcome depended on the order the tests ran in."""
    yield
    from roughflow.progress import log_progress

    log_progress(None)


@pytest.fixture(autouse=True)
def _global_random_stream_restored():
    """Tests that check a solver leaves numpy's legacy global stream alone seed it; the
    tests after them get it back as it was (it stayed seeded, a test audit)."""
    import numpy as np

    state = np.random.get_state()  # noqa: NPY002
    yield
    np.random.set_state(state)  # noqa: NPY002
