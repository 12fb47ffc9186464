#!/usr/bin/env bash
# The main job on the bundled sample: build a map, predict at two times of day, plan, export.
#   usage: samples/demo.sh VENV_BIN OUT_DIR     (make demo runs it with .venv/bin demo-out)
set -euo pipefail
BIN="${1:?usage: samples/demo.sh VENV_BIN OUT_DIR}"
OUT="${2:?usage: samples/demo.sh VENV_BIN OUT_DIR}"
HERE="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
LOG="$HERE/office.mcap"
MAP="$OUT/office.aion"
mkdir -p "$OUT"
rm -f "$MAP"
rm -rf "$OUT/export"  # the demo writes it afresh (an export replaces only its own files)

step() { printf '\n\033[1m$ %s\033[0m\n' "$*"; "$@"; }

# The sample covers Mon 2026-01-05 .. Fri 2026-01-09 (UTC); predict the following Monday.
step "$BIN/aion" info "$LOG"
step "$BIN/aion" build "$LOG" -o "$MAP"
step "$BIN/aion" predict "$MAP" --time "2026-01-12 08:40" --tz UTC --top 8
step "$BIN/aion" predict "$MAP" --time "2026-01-12 17:30" --tz UTC --layer rooms
step "$BIN/aion" predict "$MAP" --layer rooms --from "2026-01-12 06:00" --to "2026-01-12 20:00" \
    --step 2h --tz UTC
step "$BIN/aion" plan "$MAP" --from p103 --to p2 --time "2026-01-12 08:40" --tz UTC \
    --png "$OUT/plan.png"
step "$BIN/aion" plan "$MAP" --from kitchen --to "office 1" --leave "2026-01-12 07:00..2026-01-12 10:00" \
    --step 30m --tz UTC
step "$BIN/aion" export "$MAP" --time "2026-01-12 08:40" --tz UTC -o "$OUT/export" \
    --path-from p103 --path-to p2
step "$BIN/aion" export "$MAP" --from "2026-01-12 06:00" --to "2026-01-12 20:00" --step 2h --tz UTC \
    --format png -o "$OUT/map.png"
step "$BIN/aion" export "$MAP" --time "2026-01-12 08:40" --tz UTC --format dsg \
    -o "$OUT/office-4d.json"
step "$BIN/aion" report "$MAP" --time "2026-01-12 08:40" --tz UTC -o "$OUT/report"
step "$BIN/aion" export "$MAP" --from "2026-01-12 06:00" --to "2026-01-12 20:00" --step 1h --tz UTC \
    --format mcap -o "$OUT/scene.mcap" --path-from p103 --path-to p2
printf '\nDone. Open the PLY files in %s/export with any viewer (MeshLab, CloudCompare, Open3D),\nthe report in %s/report/index.html with a browser, and %s/scene.mcap in Foxglove\n(https://app.foxglove.dev: open the file, add a 3D panel, scrub the timeline through the day).\nThe pictures: %s/map.png (the day from above) and %s/plan.png (both paths); the 4D scene graph\nfor spark_dsg: %s/office-4d.json (each node'"'"'s dynamics in its metadata).\n' "$OUT" "$OUT" "$OUT" "$OUT" "$OUT" "$OUT"
