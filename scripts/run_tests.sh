#!/usr/bin/env bash
# Set up everything and run the whole test suite (what .ci/run calls).
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
bash "$root/scripts/setup_venv.sh"
. "$root/scripts/env.sh"
cd "$root"
# Hold the venv's lock shared while the tests run (a set-up with something to reinstall
# waits for them); the tests' own processes do not inherit it.
exec 8>>"$VIRTUAL_ENV/.screwgear_ros/lock"
flock -s 8
python -P -m pytest -p no:cacheprovider "$@" test 8>&-
