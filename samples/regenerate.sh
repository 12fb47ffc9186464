#!/usr/bin/env bash
# Regenerate the bundled sample log and its ground truth with the simulator.
#   usage: samples/regenerate.sh VENV_BIN      (e.g. samples/regenerate.sh .venv/bin)
# The simulator is deterministic: the same command writes byte-identical files.
set -euo pipefail
BIN="${1:?usage: samples/regenerate.sh VENV_BIN (e.g. .venv/bin)}"
HERE="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"

# Five workdays (Mon 2026-01-05 .. Fri) in the paper's office, six people, a robot that patrols
# every hour from 07:00 to 20:00 and waits at its dock in the hallway otherwise. Scene graphs
# once a minute while it drives and hourly while parked keep the log at a few MB; TF and empty
# detection messages every 10 s while it is parked (aion takes a longer TF gap as time the
# robot's pose was unknown, and simulate refuses one).
"$BIN/aion" simulate -o "$HERE/office.mcap" --force --quiet \
    --days 5 --seed 1 --start 2026-01-05 --agents 6 \
    --tour-every 60 --patrol-hours 7-20 \
    --dsg-period 60 --dsg-idle-period 3600 --tf-idle-period 10
