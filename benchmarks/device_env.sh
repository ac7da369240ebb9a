# Sourced by the scripts that run on the project's device machines (benchmarks/*_on_device.sh):
# installs the wheels carried in .whl/ (pyFFTW, netCDF4, cftime; see the device tool's notes)
# where the image lacks them, and puts them and src/ on PYTHONPATH.
if ! python3 -c "import pyfftw, netCDF4" 2>/dev/null; then
  python3 -m pip install -q --no-index --no-deps --no-compile --no-cache-dir --upgrade \
    --target /tmp/site .whl/*.whl || exit 1
  export PYTHONPATH=/tmp/site:$PWD/src
else
  export PYTHONPATH=$PWD/src
fi
