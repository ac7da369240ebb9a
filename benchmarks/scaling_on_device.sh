#!/bin/bash
# The hard-wall solve at a size that does not fit in 24 GiB, and the threshold pair's cost on
# dedicated cores, on a large machine (the project's GPU machines have 16 cores and 128 GiB;
# no GPU code runs here). Three processes side by side:
#   - bench_scaling.py --sizes BIG --l-over-lambda-r 4 on cores 2.., nproc-2 FFT threads, with
#     the solver's DEBUG progress (every 20 iterations) in $OUT/bigBIG.log;
#   - bench_scaling.py --threshold-seeds SEEDS --threshold-tol 0.002 at THR_A^2 on core 0 and
#     THR_B^2 on core 1, one thread each ($OUT/thrN.log, one JSON row per seed);
# each stopped after LIMIT_S seconds (the rows printed so far stay in its log). Tables:
# $OUT/tables.tgz (results/benchmarks). Where pyFFTW is missing, wheels in .whl/ are
# installed first (benchmarks/device_env.sh).
# Usage: bash benchmarks/scaling_on_device.sh [BIG] [THR_A] [THR_B] [SEEDS] [LIMIT_S]
#        (default 16384 1024 2048 10 520; BIGCORES / BIGTHREADS override the big run's cores)
set -u
BIG=${1:-16384}; TA=${2:-1024}; TB=${3:-2048}; SEEDS=${4:-10}; LIMIT=${5:-520}
OUT=${OUT:-/tmp/devout}; mkdir -p "$OUT"
. benchmarks/device_env.sh
export PYTHONUNBUFFERED=1 MPLBACKEND=Agg
{ python3 -c "import sys, numpy, numba, scipy, pyfftw; print(sys.version.split()[0], 'numpy', numpy.__version__, 'numba', numba.__version__, 'scipy', scipy.__version__, 'pyfftw', pyfftw.__version__)"
  nproc; lscpu | grep -E "Model name|^CPU\(s\)|L3"; free -g | head -2; } > "$OUT/env.txt" 2>&1
python3 -c "from roughflow.search import warm_up; warm_up()" || exit 1  # fill numba's cache once
ncpu=$(nproc)
thr() {  # threshold pair cost, one thread on one core
  ROUGHFLOW_FFT_THREADS=1 timeout "$LIMIT" taskset -c "$2" python3 benchmarks/bench_scaling.py \
    --sizes "$1" --l-over-lambda-r 4 --threshold-seeds "$SEEDS" --threshold-tol 0.002 \
    --variants cg --tag "_dev$1" > "$OUT/thr$1.log" 2>&1
  echo "thr $1 rc $?" >> "$OUT/env.txt"
}
thr "$TA" 0 &
thr "$TB" 1 &
ROUGHFLOW_FFT_THREADS=${BIGTHREADS:-$((ncpu - 2))} timeout "$LIMIT" taskset -c "${BIGCORES:-2-$((ncpu - 1))}" python3 -c "
import logging, runpy, sys
logging.basicConfig(level=logging.WARNING, format='%(asctime)s %(name)s %(message)s')
logging.getLogger('roughflow').setLevel(logging.DEBUG)
sys.argv = ['bench_scaling.py', '--sizes', '$BIG', '--l-over-lambda-r', '4', '--tag', '_dev$BIG']
runpy.run_path('benchmarks/bench_scaling.py', run_name='__main__')
" > "$OUT/big$BIG.log" 2>&1
echo "big $BIG rc $?" >> "$OUT/env.txt"
wait
tar czf "$OUT/tables.tgz" results/benchmarks 2>/dev/null
cat "$OUT/env.txt"; tail -n 4 "$OUT"/*.log
