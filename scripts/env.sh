# Source this file (bash or zsh) to use the pip environment like a ROS 2 install:
#     . scripts/env.sh
# - activates .venv (made by scripts/setup_env.sh);
# - puts .venv on AMENT_PREFIX_PATH, where ament_index looks for packages: the pip install
#   of ema_phm (and the ROS wheels) registered themselves in .venv/share/ament_index, and
#   `ros2 run ema_phm <node>` (ros2cli comes from a ROS install; it has no wheel) and launch
#   files' get_package_share_directory('ema_phm') find them only through this variable;
# - keeps ROS traffic and sockets on 127.0.0.1: Fast DDS with config/fastdds_localhost.xml
#   and ROS_AUTOMATIC_DISCOVERY_RANGE=SYSTEM_DEFAULT (LOCALHOST would make rmw_fastrtps add a
#   UDP transport on every interface; see the profile).  To reach other machines instead:
#       unset FASTDDS_DEFAULT_PROFILES_FILE; export ROS_AUTOMATIC_DISCOVERY_RANGE=SUBNET
# Sourcing it twice changes nothing more.

_ema_phm_root="$(cd -- "$(dirname -- "${BASH_SOURCE[0]:-${(%):-%x}}")/.." && pwd)"
if [ ! -f "$_ema_phm_root/.venv/bin/activate" ]; then
    echo "env.sh: error: $_ema_phm_root/.venv is missing; run: bash scripts/setup_env.sh" >&2
else
    . "$_ema_phm_root/.venv/bin/activate"
    case ":${AMENT_PREFIX_PATH:-}:" in
        *":$_ema_phm_root/.venv:"*) ;;
        *) export AMENT_PREFIX_PATH="$_ema_phm_root/.venv${AMENT_PREFIX_PATH:+:$AMENT_PREFIX_PATH}" ;;
    esac
    export RMW_IMPLEMENTATION=rmw_fastrtps_cpp
    export FASTDDS_DEFAULT_PROFILES_FILE="$_ema_phm_root/config/fastdds_localhost.xml"
    export ROS_AUTOMATIC_DISCOVERY_RANGE=SYSTEM_DEFAULT
fi
unset _ema_phm_root
