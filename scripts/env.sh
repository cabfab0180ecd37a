# Sourced by the scripts: ROS environment of the in-repository workspace.
repo=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
set +u
source "$repo/.build/ws/devel/setup.bash"
set -u
export ROS_HOSTNAME=${ROS_HOSTNAME:-localhost}
export ROS_MASTER_URI=${ROS_MASTER_URI:-http://localhost:11311}
