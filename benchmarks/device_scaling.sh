#!/usr/bin/env bash
# The 16-core scaling measurement (issue 31, item 5), as one short script for a
# lent machine with many cores and no network (set-up: device_setup.sh). Runs
# benchmarks/scaling.py (every path at each worker count, and Dask at the
# largest) and benchmarks/gil_share.py (py-spy, one worker). Results go to $OUT
# (or out/device/). From the repository's root:
#     bash benchmarks/device_scaling.sh [WORKERS...]      # default 1 2 4 8 16
set -u
source "$(dirname "$0")/device_setup.sh"
WORKERS=${*:-1 2 4 8 16}
timeout 330 $PY benchmarks/scaling.py --workers $WORKERS --dask "${WORKERS##* }" \
    --json "$OUT/scaling.json"
echo "scaling rc $?"
if command -v py-spy >/dev/null; then
    timeout 150 $PY benchmarks/gil_share.py --paths run grid wall_law \
        --starts warm --recordings 2 --json "$OUT/gil.json"
    echo "gil_share rc $?"
fi
