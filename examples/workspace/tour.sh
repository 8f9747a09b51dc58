#!/usr/bin/env bash
# The workspace tour of docs/workspace.md, from the command line (run from the repository root:
#   bash examples/workspace/tour.sh [FOLDER]   default FOLDER: /tmp/manipcad-tour).
# A UR5 with catalog drives, a motor of one's own, two trajectories, two regulators, four
# simulations (1 s each), a filtered listing, a comparison figure, a bit-for-bit re-run and
# an exported bundle. The regulators are synthesized (a PID baseline and the paper's ace_de).
set -euo pipefail
OUT=${1:-/tmp/manipcad-tour}
EX=$(cd "$(dirname "$0")/.." && pwd)
rm -rf "$OUT" && mkdir -p "$OUT" && cd "$OUT"
export MANIPCAD_WORKSPACE=$OUT/ws

manipcad ws init
manipcad ws add "$EX/ur5/ur5.yaml" --name ur5            # URDF + catalog drives
sed 's/^description:.*/description: my own RE40 (edited data)/' \
    "$(python -c 'import manipcad.model.load as l; print(l.CATALOG / "motors" / "maxon_re40_148877.yaml")')" \
    > my_re40.yaml
manipcad ws add my_re40.yaml                               # a motor of one's own
manipcad ws add "$EX/ur5/pick.yaml" --name pick
sed 's/move_time: 1.5/move_time: 2.5/' "$EX/ur5/pick.yaml" > pick_slow.yaml
manipcad ws add pick_slow.yaml
WS=$MANIPCAD_WORKSPACE
manipcad synthesize "$WS/robots/ur5.yaml" -m pid --all --spec bandwidth=40 --period 0.001 \
    --out pid.yaml > /dev/null
manipcad synthesize "$WS/robots/ur5.yaml" -m ace_de --all --spec bandwidth=40 --period 0.0001 \
    --out ace_de.yaml > /dev/null
manipcad ws add pid.yaml --robot ur5                       # checked against the robot
manipcad ws add ace_de.yaml --robot ur5

n=0
for traj in pick pick_slow; do
  for reg in pid ace_de; do
    n=$((n + 1))
    manipcad simulate "$WS/robots/ur5.yaml" -t "$WS/trajectories/$traj.yaml" \
        -r "$WS/regulators/$reg.yaml" --t-end 1.0 --every 10 --out "run$n" --json > /dev/null
    manipcad ws add "run$n" --name "run$n"                  # indexed with its provenance
  done
done

manipcad ws list result
manipcad ws list result --where "max_error<2.5e-3" --json
manipcad ws compare run1 run3 --plot compare.png
manipcad ws rerun run1
manipcad ws export run1 --to share
manipcad ws check
