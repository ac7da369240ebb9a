#!/bin/bash
# The GPU backend's checks on a machine with CuPy and a CUDA GPU (the project's device
# machines: their image has CuPy, numba, scipy and xarray; pyFFTW, netCDF4 and cftime are
# carried as wheels in .whl/, see the device tool's notes): tests/test_gpu.py,
# then benchmarks/bench_gpu.py with the arguments given (default: hard-wall solves from 1024^2
# to 16384^2, the fused kernels and their twins on the GPU, the CPU at 1 and nproc FFT threads
# up to 4096^2; threshold pairs from 512^2 to 4096^2, the CPU up to 2048^2). Logs and the
# tables in $OUT (TEST_LIMIT / BENCH_LIMIT: seconds for each part, default 200 / 420).
# Usage: bash benchmarks/gpu_on_device.sh [bench_gpu.py arguments]
set -u
OUT=${OUT:-/tmp/devout}; mkdir -p "$OUT"
if [ $# -eq 0 ]; then
  set -- --sizes 1024 2048 4096 8192 16384 --variants cuda twins --cpu-max-n 4096 \
    --threshold-sizes 512 1024 2048 4096 --threshold-cpu-max-n 2048 --repeats 2
fi
. benchmarks/device_env.sh
export PYTHONUNBUFFERED=1 MPLBACKEND=Agg ROUGHFLOW_FFT_THREADS=$(nproc)
{ python3 -c "import sys, numpy, numba, scipy, pyfftw, cupy; print(sys.version.split()[0], 'numpy', numpy.__version__, 'numba', numba.__version__, 'scipy', scipy.__version__, 'pyfftw', pyfftw.__version__, 'cupy', cupy.__version__)"
  nvidia-smi --query-gpu=name,memory.total,driver_version --format=csv,noheader
  nproc; lscpu | grep -E "Model name"; } > "$OUT/env.txt" 2>&1
cat "$OUT/env.txt"
timeout ${TEST_LIMIT:-200} python3 -m pytest -q -p no:cacheprovider tests/test_gpu.py > "$OUT/tests.log" 2>&1
echo "tests rc $?" | tee -a "$OUT/env.txt"; tail -n 15 "$OUT/tests.log"
timeout ${BENCH_LIMIT:-420} python3 benchmarks/bench_gpu.py --cpu-threads 1 "$(nproc)" "$@" > "$OUT/bench.log" 2>&1
echo "bench rc $?" | tee -a "$OUT/env.txt"; tail -n 30 "$OUT/bench.log"
cp results/benchmarks/bench_gpu* "$OUT/" 2>/dev/null
exit 0
