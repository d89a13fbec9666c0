#!/usr/bin/env bash
# Where a threaded run's time goes on a lent many-core machine (set-up:
# device_setup.sh): benchmarks/timeline.py over run, grid and the wall law at
# each worker count, then the grid at 1 and the largest count with the task
# count per worker varied. Results go to $OUT (or out/device/).
#     bash benchmarks/device_timeline.sh [WORKERS...]     # default 1 2 4 8 16
set -u
source "$(dirname "$0")/device_setup.sh"
WORKERS=${*:-1 2 4 8 16}
timeout 200 $PY benchmarks/timeline.py --workers $WORKERS --json "$OUT/timeline.json"
echo "timeline rc $?"
timeout 120 $PY benchmarks/timeline.py --workers 1 "${WORKERS##* }" --paths grid \
    --knob TASKS_PER_WORKER=2,8,16 --json "$OUT/timeline_knob.json"
echo "knob rc $?"
