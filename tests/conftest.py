"""Test-wide settings: one thread for FFTs and BLAS (the test machines have 2 shared cores;
multi-threaded OpenBLAS on tiny vectors was measured 100x slower than numpy's sum under load),
and a non-interactive matplotlib backend."""

import os

for var, value in (("ROUGHFLOW_FFT_THREADS", "1"), ("OPENBLAS_NUM_THREADS", "1"),
                   ("OMP_NUM_THREADS", "1"), ("MPLBACKEND", "Agg")):
    os.environ.setdefault(var, value)
