// The simulator node's command validation (se3_ros::check_torque_command, src/ros/convert.cpp)
// and what an accepted command does: a torque command built from the input (names from the
// model's, unknown, repeated or empty; efforts and base wrench with every kind of number), or a
// controller command (values for a position controller). Whatever passes is applied as the
// node applies it and the simulator steps: the state must stay finite (a step that diverges is
// rolled back), since the node must never publish NaN. The first byte picks a free Panda with
// locked fingers (torques) or a fixed one under arm_position_controller (controller commands).
#include <fuzzer/FuzzedDataProvider.h>

#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include "../test/source_paths.h"
#include "se3_sim/ros/convert.h"
#include "se3_sim/sim/sim.h"

namespace {

struct Rig {
  std::unique_ptr<se3::Simulator> sim;
  se3_ros::JointTable joints;
};

Rig make_rig(bool floating) {
  se3::Scene s = se3::load_scene(se3_sim_test::source_dir() + "/config/scenes/fixed_panda.yaml");
  s.floating = floating;
  Rig r;
  r.sim = se3::make_simulator(s);
  r.joints = se3_ros::joint_table(r.sim->model(), s.locked_joints);
  if (!floating) {
    r.sim->set_controllers(se3::parse_controllers_text(
        "arm: {type: effort_controllers/JointGroupPositionController, joints: [panda_joint1, "
        "panda_joint2, panda_joint3, panda_joint4, panda_joint5, panda_joint6, panda_joint7], "
        "gains: {panda_joint1: {p: 600, d: 30}, panda_joint2: {p: 600, d: 30}, panda_joint3: "
        "{p: 600, d: 30}, panda_joint4: {p: 600, d: 30}, panda_joint5: {p: 250, d: 10}, "
        "panda_joint6: {p: 150, d: 10}, panda_joint7: {p: 50, d: 5}}}"));
  }
  return r;
}

double number(FuzzedDataProvider& in) {
  switch (in.ConsumeIntegralInRange<int>(0, 7)) {
    case 0:
      return std::numeric_limits<double>::quiet_NaN();
    case 1:
      return std::numeric_limits<double>::infinity();
    case 2:
      return -1e300;
    case 3:
      return 1e4 * (in.ConsumeBool() ? 1 : -1);
    default:
      return in.ConsumeFloatingPoint<double>();
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static Rig free_rig = make_rig(true), fixed_rig = make_rig(false);
  FuzzedDataProvider in(data, size);
  const bool controller = in.ConsumeBool();
  Rig& rig = controller ? fixed_rig : free_rig;
  se3::Simulator& sim = *rig.sim;
  sim.reset();
  const int commands = in.ConsumeIntegralInRange<int>(1, 4);
  for (int c = 0; c < commands && in.remaining_bytes() > 0; ++c) {
    if (controller) {
      std::vector<double> values(in.ConsumeIntegralInRange<size_t>(0, 9));
      for (double& v : values) v = number(in);
      (void)sim.controllers()->set_command(0, values.data(), values.size());
    } else {
      se3_sim::JointTorques msg;
      const size_t n = in.ConsumeIntegralInRange<size_t>(0, 12);
      for (size_t k = 0; k < n; ++k) {
        const auto& names = rig.joints.names;
        msg.name.push_back(in.ConsumeBool()
                               ? names[in.ConsumeIntegralInRange<size_t>(0, names.size() - 1)]
                               : in.ConsumeRandomLengthString(16));
      }
      const size_t ne = in.ConsumeBool() ? n : in.ConsumeIntegralInRange<size_t>(0, 12);
      for (size_t k = 0; k < ne; ++k) msg.effort.push_back(number(in));
      msg.has_base_wrench = in.ConsumeBool();
      msg.base_wrench.torque.x = number(in);
      msg.base_wrench.torque.y = number(in);
      msg.base_wrench.torque.z = number(in);
      msg.base_wrench.force.x = number(in);
      msg.base_wrench.force.y = number(in);
      msg.base_wrench.force.z = number(in);
      se3_ros::TorqueCommand cmd;
      if (!se3_ros::check_torque_command(sim.model(), rig.joints, msg, 1e4, 1e4, cmd).empty()) {
        continue;
      }
      for (const auto& ie : cmd.efforts) {
        if (ie.first > 0) sim.set_joint_effort(ie.first, ie.second);
      }
      if (cmd.has_base_wrench) sim.set_base_wrench(cmd.base_wrench);
    }
    sim.step_n(in.ConsumeIntegralInRange<int>(1, 5));
    if (!sim.state().finite()) std::abort();  // the node would publish it
  }
  return 0;
}
