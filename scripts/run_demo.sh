#!/usr/bin/env bash
# Set everything up, then run table_sim (the paper's parameters) closed-loop with the demo
# PID controller. The table_sim status log (every 5 s) and the controller's target/actual
# lines show the table following a back-and-forth profile with reversals. Ctrl-C stops both.
# The run is recorded to out/demo_<date>_<time>/; at the end its plot (plot_run) is written
# into that directory and its path printed.
#   bash scripts/run_demo.sh [--lockstep] [--duration SECONDS]
#   --lockstep          table_sim (lockstep:=true, still at real-time factor 1) integrates
#                       each tick only once the controller answered the last joint_states:
#                       the run is bit-identical however busy the machine is, only slower
#                       when the machine cannot keep up
#   --duration SECONDS  stop both after SECONDS of wall time (default: until Ctrl-C)
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
duration=""
sim_args=()
while [ $# -gt 0 ]; do
    case "$1" in
        --lockstep) sim_args+=(-p lockstep:=true -p real_time_factor:=1.0); shift ;;
        --duration) duration="${2:?--duration needs SECONDS}"; shift 2 ;;
        --duration=*) duration="${1#*=}"; shift ;;
        -h|--help) sed -n '2,12p' "$0"; exit 0 ;;
        *) echo "unknown argument: $1 (use --lockstep, --duration SECONDS)" >&2; exit 2 ;;
    esac
done
bash "$root/scripts/setup_venv.sh"
. "$root/scripts/env.sh"
# Hold the venv's lock shared while the demo runs (a set-up with something to reinstall
# waits for it); the demo's processes do not inherit it.
exec 8>>"$VIRTUAL_ENV/.screwgear_ros/lock"
flock -s 8

bag="$root/out/demo_$(date +%Y%m%d_%H%M%S)"
mkdir -p "$root/out"
pids=()
stop() {
    trap - INT TERM EXIT
    for pid in "${pids[@]}"; do kill -INT "$pid" 2>/dev/null || true; done
    for pid in "${pids[@]}"; do wait "$pid" 2>/dev/null || true; done
    if [ -f "$bag/metadata.yaml" ]; then
        plot_run "$bag" -o "$bag/plot.png" 8>&- || echo "run_demo: no plot of $bag (see above)" >&2
    fi
}
trap stop INT TERM EXIT

table_sim --ros-args --params-file "$root/config/paper.yaml" -p "record:=$bag" \
    ${sim_args[@]+"${sim_args[@]}"} 8>&- &
pids+=($!)
demo_controller 8>&- &
pids+=($!)
if [ -n "$duration" ]; then
    sleep "$duration"
else
    wait -n "${pids[@]}" || true
fi
