#!/usr/bin/env bash
# Set everything up, then run table_sim (the paper's parameters) closed-loop with the demo
# PID controller. The table_sim status log (every 5 s) and the controller's target/actual
# lines show the table following a back-and-forth profile with reversals. Ctrl-C stops both.
#   bash scripts/run_demo.sh [--duration SECONDS]
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
duration=""
while [ $# -gt 0 ]; do
    case "$1" in
        --duration) duration="$2"; shift 2 ;;
        --duration=*) duration="${1#*=}"; shift ;;
        -h|--help) sed -n '2,5p' "$0"; exit 0 ;;
        *) echo "unknown argument: $1 (use --duration SECONDS)" >&2; exit 2 ;;
    esac
done
bash "$root/scripts/setup_venv.sh"
. "$root/scripts/env.sh"

pids=()
stop() {
    trap - INT TERM EXIT
    for pid in "${pids[@]}"; do kill -INT "$pid" 2>/dev/null || true; done
    for pid in "${pids[@]}"; do wait "$pid" 2>/dev/null || true; done
}
trap stop INT TERM EXIT

table_sim --ros-args --params-file "$root/config/paper.yaml" &
pids+=($!)
demo_controller &
pids+=($!)
if [ -n "$duration" ]; then
    sleep "$duration"
else
    wait -n "${pids[@]}" || true
fi
