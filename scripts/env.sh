# Sourced by the scripts: ROS environment of the in-repository workspace.
repo=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
set +u
source "$repo/.build/ws/devel/setup.bash"
set -u
# The meshes of the robots in data/robots (package://example-robot-data/...).
case ":${ROS_PACKAGE_PATH:-}:" in
  *":$repo/data/meshes:"*) ;;
  *) export ROS_PACKAGE_PATH="$repo/data/meshes${ROS_PACKAGE_PATH:+:$ROS_PACKAGE_PATH}" ;;
esac
export ROS_HOSTNAME=${ROS_HOSTNAME:-localhost}
export ROS_MASTER_URI=${ROS_MASTER_URI:-http://localhost:11311}
