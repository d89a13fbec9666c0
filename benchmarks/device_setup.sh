# Sourced by the device_*.sh scripts: makes this checkout runnable on a lent
# machine with no network. Installs the wheels carried in .whl/ (dask,
# distributed and what they need beside the machine's own packages, py-spy,
# tqdm) into /tmp/site, builds the compiled kernel for the machine's Python and
# records the CPU in $OUT/lscpu.txt. Sets PY, OUT and PYTHONPATH.
export PYTHONUNBUFFERED=1 OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 MKL_NUM_THREADS=1
OUT=${OUT:-out/device}
mkdir -p "$OUT"
PY=${PYTHON:-python3}
if ls .whl/*.whl >/dev/null 2>&1; then
    $PY -m pip install -q --no-index --no-deps --no-compile --no-cache-dir \
        --upgrade --target /tmp/site .whl/*.whl 2>&1 | grep -v "Running pip as" \
        || true
    export PYTHONPATH=/tmp/site PATH=/tmp/site/bin:$PATH
fi
export PYTHONPATH=$PWD/src${PYTHONPATH:+:$PYTHONPATH}
$PY setup.py build_ext --inplace >/tmp/microimpact-build.log 2>&1
$PY - <<'PY' || { tail -30 /tmp/microimpact-build.log; exit 3; }
from microimpact.engine import _compiled
if _compiled.ckernel is None:
    raise SystemExit(f"no compiled kernel: {_compiled.ERROR}")
import numpy, scipy, pandas, xarray, sys
print("python", sys.version.split()[0], "numpy", numpy.__version__, "scipy",
      scipy.__version__, "pandas", pandas.__version__, "xarray", xarray.__version__)
PY
(lscpu; echo; nproc; free -g) >"$OUT/lscpu.txt" 2>&1
grep -E "Model name|^CPU\(s\)|Thread|Core|Socket|NUMA node\(s\)|L2|L3" "$OUT/lscpu.txt"
