#!/usr/bin/env bash
# Set everything up, then run table_sim (the paper's parameters) closed-loop with the demo
# PID controller. The table_sim status log (every 5 s) and the controller's target/actual
# lines show the table following a back-and-forth profile with reversals. Ctrl-C stops both.
# The run is recorded to out/demo_<date>_<time>/; at the end its plot (plot_run: 7 s of
# CPU for a 20 s run, longer on a busy machine) is written into that directory and its
# path printed.
#   bash scripts/run_demo.sh [--free-running] [--realistic] [--duration SECONDS]
#   (default)           lockstep: table_sim (lockstep:=true, paced at real-time factor 1)
#                       integrates each tick only once the controller answered the last
#                       joint_states, so the run is the same however busy the machine is,
#                       only slower when the machine cannot keep up
#   --free-running      table_sim runs at real time whether the controller keeps up or
#                       not (on a busy machine a late answer can upset the loop)
#   --realistic         the paper's table with bearing friction, encoders and a current
#                       loop (config/realistic.yaml); the plot shows measured over exact
#   --duration SECONDS  stop after SECONDS of simulated time (default: until Ctrl-C):
#                       the controller answers no joint_states from that stamp on, so in
#                       lockstep the run ends exactly there; free-running, table_sim runs
#                       on for the moment it takes to stop it
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
duration=""
sim_args=(-p lockstep:=true -p real_time_factor:=1.0)
params=(--params-file "$root/config/paper.yaml")
while [ $# -gt 0 ]; do
    case "$1" in
        --lockstep) shift ;;   # the default
        --free-running) sim_args=(-p lockstep:=false -p real_time_factor:=1.0); shift ;;
        --realistic) params+=(--params-file "$root/config/realistic.yaml"); shift ;;
        --duration) duration="${2:?--duration needs SECONDS}"; shift 2 ;;
        --duration=*) duration="${1#*=}"; shift ;;
        -h|--help) sed -n '2,20p' "$0"; exit 0 ;;
        *) echo "unknown argument: $1 (use --free-running, --realistic, --duration SECONDS)" >&2
           exit 2 ;;
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
    # TERM, not INT: a script's background jobs start with SIGINT ignored, so an INT
    # sent before a node installed its own handler would be lost and the wait endless
    for pid in "${pids[@]}"; do kill -TERM "$pid" 2>/dev/null || true; done
    for pid in "${pids[@]}"; do
        for _ in $(seq 1 60); do kill -0 "$pid" 2>/dev/null || break; sleep 0.5; done
        if kill -0 "$pid" 2>/dev/null; then
            echo "run_demo: process $pid did not stop within 30 s of SIGTERM: killed" >&2
            kill -KILL "$pid" 2>/dev/null || true
        fi
        wait "$pid" 2>/dev/null || true
    done
    if [ ! -e "$bag" ]; then
        echo "run_demo: stopped before table_sim recorded anything: no plot" >&2
        return
    fi
    echo "run_demo: drawing the plot of the run (plot_run: seconds, up to a minute on a busy machine)"
    local start=$SECONDS why
    if why="$(plot_run "$bag" -o "$bag/plot.png" 2>&1 >/dev/null 8>&-)"; then
        echo "run_demo: plot of the run ($((SECONDS - start)) s): $bag/plot.png"
    else
        # plot_run's one-line reason (e.g. no data: the run stopped before it started)
        echo "run_demo: no plot: ${why#plot_run: }" >&2
        echo "run_demo: the recording is kept in $bag" >&2
    fi
}
trap stop INT TERM EXIT

table_sim --ros-args "${params[@]}" -p "record:=$bag" \
    ${sim_args[@]+"${sim_args[@]}"} 8>&- &
pids+=($!)
controller_args=()
[ -z "$duration" ] || controller_args=(--duration "$duration")
demo_controller ${controller_args[@]+"${controller_args[@]}"} 8>&- &
pids+=($!)
# Either ends the demo: the controller at the stop time (--duration), or either process
# on its own (a crash, a Ctrl-C that reached only one).
wait -n "${pids[@]}" || true
