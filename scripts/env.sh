# Source me: the project's venv and the ROS environment it needs (DDS on loopback only).
_root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
. "${SCREWGEAR_VENV:-$_root/.venv}/bin/activate"
export AMENT_PREFIX_PATH="$VIRTUAL_ENV${AMENT_PREFIX_PATH:+:$AMENT_PREFIX_PATH}"
export ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST
export RMW_IMPLEMENTATION="${RMW_IMPLEMENTATION:-rmw_fastrtps_cpp}"
unset _root
