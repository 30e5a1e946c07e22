#!/usr/bin/env bash
# Re-record the checked-in test bags under test/data/ with the project's own node.
#
# Each scenario in test/data/scenarios/<name>.yaml (start parameters, timed commands,
# parameter changes, resets) is played into a fresh table_sim by replay_run, which
# starts the node with record:=test/data/<name> in lockstep, answers each of its ticks
# after sending the actions due then (so every action takes effect exactly at its
# scenario time, whatever the machine's load) and stops it with SIGINT; check_run then
# checks every new bag against the reference solution.
#
# realtime_demo is recorded the way users record: table_sim with config/paper.yaml at
# real_time_factor 1 and demo_controller driving it for 0.5 s of wall time from its first command
# (test/test_replay_realtime.py does it), again until some tick applied several commands,
# which a real-time recording has whenever the controller's answers bunch up.
#
#   SCREWGEAR_VENV=... bash scripts/record_test_bags.sh [name ...]   # default: all
#
# DDS stays on loopback; pick a ROS_DOMAIN_ID nobody else uses (default 42).
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
bash "$root/scripts/setup_venv.sh" >/dev/null
. "$root/scripts/env.sh"
export ROS_DOMAIN_ID="${ROS_DOMAIN_ID:-42}"
cd "$root/test/data"
names=("$@")
[ ${#names[@]} -gt 0 ] || names=($(cd scenarios && ls *.yaml | sed 's/\.yaml$//') realtime_demo)
for name in "${names[@]}"; do
    rm -rf "$name"
    if [ "$name" = realtime_demo ]; then
        for attempt in 1 2 3 4 5; do
            rm -rf "$name"
            python "$root/test/test_replay_realtime.py" "$name" 0.5 && break
        done
    else
        replay_run --script "scenarios/$name.yaml" --record "$name"
    fi
    check_run --no-progress "$name" | tail -n 1
    du -sh "$name"
done
