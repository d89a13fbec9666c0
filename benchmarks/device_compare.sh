#!/usr/bin/env bash
# One prepared run on a lent many-core machine (set-up: device_setup.sh): the
# scaling table of this tree (benchmarks/scaling.py, every path, Dask at the
# largest count), then this tree against a baseline checkout in .base/ (its
# src/, setup.py and pyproject.toml, e.g. `git archive <commit> src setup.py
# pyproject.toml | tar -x -C .base`), alternated twice on run, grid and wall
# law at 1 and the largest count, then the timeline of this tree. Results go
# to $OUT (or out/device/): 7 files, inside what a lent machine sends back (8).
#     bash benchmarks/device_compare.sh [WORKERS...]     # default 1 2 4 8 16
set -u
source "$(dirname "$0")/device_setup.sh"
WORKERS=${*:-1 2 4 8 16}
MAX=${WORKERS##* }
SITE=${PYTHONPATH#*:}
timeout 200 $PY benchmarks/scaling.py --workers $WORKERS --dask "$MAX" \
    --json "$OUT/scaling.json"
echo "scaling rc $?"
if [ -d .base/src ]; then
    (cd .base && $PY setup.py build_ext --inplace >/tmp/microimpact-build-base.log 2>&1)
    for round in 1 2; do
        for tree in base new; do
            src=$PWD/src; [ $tree = base ] && src=$PWD/.base/src
            echo "== $tree, round $round"
            PYTHONPATH=$src:$SITE timeout 90 $PY benchmarks/scaling.py \
                --paths run grid wall_law --workers 1 "$MAX" --repeats 3 \
                --json "$OUT/${tree}_$round.json"
        done
    done
fi
timeout 90 $PY benchmarks/timeline.py --workers 1 "$MAX" --json "$OUT/timeline.json"
echo "timeline rc $?"
