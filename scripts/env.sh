# Sourced (bash): se3_sim's catkin workspace and its ROS environment. In a new shell, from the
# clone:   source scripts/env.sh
# The workspace is $SE3_SIM_WS when set, else the folder beside the clone named after it with
# _ws (a clone in ~/se3_sim builds in ~/se3_sim_ws). It lives outside the package folder: the
# workspace links back to the package, and rosrun and roslaunch search the package folder
# following links, so a workspace inside it would be a file-system loop.
# The shell's options (set -u, set -e, ...) are left as they were; nothing else is defined.
_se3_sim_opts=$(set +o)
set +u
_se3_sim_repo=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
export SE3_SIM_WS=${SE3_SIM_WS:-$(dirname "$_se3_sim_repo")/$(basename "$_se3_sim_repo")_ws}
if [[ -f "$SE3_SIM_WS/devel/setup.bash" ]]; then
  source "$SE3_SIM_WS/devel/setup.bash"
fi
# The meshes of the robots in data/robots (package://example-robot-data/...).
case ":${ROS_PACKAGE_PATH:-}:" in
  *":$_se3_sim_repo/data/meshes:"*) ;;
  *) export ROS_PACKAGE_PATH="$_se3_sim_repo/data/meshes${ROS_PACKAGE_PATH:+:$ROS_PACKAGE_PATH}" ;;
esac
export ROS_HOSTNAME=${ROS_HOSTNAME:-localhost}
export ROS_MASTER_URI=${ROS_MASTER_URI:-http://localhost:11311}
unset _se3_sim_repo
eval "$_se3_sim_opts"
unset _se3_sim_opts
