// A Gazebo user's URDF (issue 37): <mimic> joints held by joint_coupling constraint rows
// (constraints.h, Model::mimics): the Panda's fingers and a parallel gripper move together under
// a command and under contact, a mimic of a mimic follows, a loop of mimics is one error.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "error_of.h"
#include "se3_sim/controllers.h"
#include "se3_sim/sim.h"

using namespace se3;

namespace {

const std::string kSource = SE3_SIM_SOURCE_DIR;

// A fixed palm with two prismatic fingers along y: `right` mimics `left` mirrored
// (multiplier -1, offset 0.01), and a tip sliding up and down (z) on the right finger mimics
// `right` (a mimic of a mimic, multiplier 0.5, offset -0.002).
std::string gripper_urdf(const std::string& extra_joint = "") {
  auto link = [](const std::string& name, double mass, const std::string& xyz) {
    return "<link name='" + name + "'><inertial><origin xyz='" + xyz + "'/><mass value='" +
           std::to_string(mass) +
           "'/><inertia ixx='1e-4' iyy='1e-4' izz='1e-4' ixy='0' ixz='0' iyz='0'/></inertial>"
           "<collision><origin xyz='" +
           xyz + "'/><geometry><box size='0.02 0.02 0.06'/></geometry></collision></link>";
  };
  auto joint = [](const std::string& name, const std::string& parent, const std::string& child,
                  const std::string& xyz, const std::string& mimic,
                  const std::string& axis = "0 1 0") {
    return "<joint name='" + name + "' type='prismatic'><parent link='" + parent +
           "'/><child link='" + child + "'/><origin xyz='" + xyz + "'/><axis xyz='" + axis +
           "'/><limit lower='-0.1' upper='0.1' effort='50' velocity='1'/>" + mimic + "</joint>";
  };
  return "<robot name='gripper'>" + link("palm", 1.0, "0 0 0") +
         link("left_finger", 0.1, "0 0 -0.03") + link("right_finger", 0.12, "0 0 -0.03") +
         link("right_tip", 0.02, "0 0 -0.01") +
         joint("left", "palm", "left_finger", "0 0.05 0", "") +
         joint("right", "palm", "right_finger", "0 -0.05 0",
               "<mimic joint='left' multiplier='-1' offset='0.01'/>") +
         joint("tip", "right_finger", "right_tip", "0 0 -0.06",
               "<mimic joint='right' multiplier='0.5' offset='-0.002'/>", "0 0 1") +
         extra_joint + "</robot>";
}

std::vector<ControllerSpec> position_controller(const std::string& joint, double p, double d) {
  return parse_controllers_text(
      "hand:\n  type: effort_controllers/JointPositionController\n"
      "  joint: " +
      joint + "\n  pid: {p: " + std::to_string(p) + ", d: " + std::to_string(d) + "}\n");
}

double q_of(const Simulator& sim, const std::string& joint) {
  const Model& m = sim.model();
  return sim.state().q[m.idx_q(m.joint_index(joint))];
}

}  // namespace

// The Panda's panda_finger_joint2 mimics panda_finger_joint1: under a position controller on
// joint1 alone (the arm falling under gravity meanwhile) both fingers reach the target together,
// equal to 1e-9 at every step.
TEST(Mimic, PandaFingersMoveTogether) {
  Model m = model_from_urdf_file(kSource + "/data/robots/panda.urdf");
  ASSERT_EQ(m.mimics.size(), 1u);
  EXPECT_EQ(m.joint_name[m.mimics[0].joint], "panda_finger_joint2");
  EXPECT_EQ(m.joint_name[m.mimics[0].leader], "panda_finger_joint1");
  State x(m);
  x.q[m.idx_q(m.joint_index("panda_finger_joint2"))] = 0.02;  // apart: the mimic starts at 0
  Simulator sim(std::move(m), x, SimConfig{});
  EXPECT_EQ(q_of(sim, "panda_finger_joint2"), q_of(sim, "panda_finger_joint1"));
  sim.set_controllers(position_controller("panda_finger_joint1", 2000, 20));
  double worst = 0;
  for (double target : {0.03, 0.01}) {
    sim.controllers()->set_command(0, &target, 1);
    for (int k = 0; k < 600; ++k) {
      ASSERT_TRUE(sim.step()) << sim.failure();
      worst = std::max(
          worst, std::abs(q_of(sim, "panda_finger_joint2") - q_of(sim, "panda_finger_joint1")));
    }
    EXPECT_NEAR(q_of(sim, "panda_finger_joint1"), target, 2e-3);
  }
  EXPECT_LT(worst, 1e-9);
  std::printf("  largest |q2 - q1|: %.2e m\n", worst);
}

// A parallel gripper: right = -left + 0.01, tip = 0.5 right - 0.002 (a mimic of a mimic, in
// order leader first), under a command; then with the tip resting on the ground (velocity-level
// rows with contact), lifted by one command and pressed down by the next, which the ground
// stops through the chain of mimics: every relation holds to 1e-9.
TEST(Mimic, ParallelGripperUnderCommandAndContact) {
  const Model m = model_from_urdf_string(gripper_urdf());
  ASSERT_EQ(m.mimics.size(), 2u);
  EXPECT_EQ(m.joint_name[m.mimics[0].joint], "right");
  EXPECT_EQ(m.joint_name[m.mimics[1].joint], "tip");
  EXPECT_EQ(m.mimics[1].multiplier, 0.5);
  for (bool contact : {false, true}) {
    SCOPED_TRACE(contact ? "ground contact" : "free");
    Simulator sim(m, State(m), SimConfig{});
    if (contact) {  // the tip's sphere touches the ground at the start (q_tip = 0.003)
      ConstraintSpec spec;
      spec.ground = true;
      spec.ground_offset = -0.102;
      spec.contacts.push_back({"tip", "right_tip", Vec3(0, 0, -0.04), 0.005});
      sim.set_constraints(spec);
    }
    auto error = [&] {
      const double l = q_of(sim, "left"), r = q_of(sim, "right"), t = q_of(sim, "tip");
      return std::max(std::abs(r - (-l + 0.01)), std::abs(t - (0.5 * r - 0.002)));
    };
    EXPECT_LT(error(), 1e-12);  // the initial state is put on the relations
    sim.set_controllers(position_controller("left", 500, 10));
    double worst = 0;
    for (double target : {-0.02, 0.01}) {
      sim.controllers()->set_command(0, &target, 1);
      for (int k = 0; k < 800; ++k) {
        ASSERT_TRUE(sim.step()) << sim.failure();
        worst = std::max(worst, error());
      }
      // 0.01 would put the tip 5 mm into the ground: it stops the fingers at left = 0.
      const double reached = contact && target > 0 ? 0.0 : target;
      EXPECT_NEAR(q_of(sim, "left"), reached, 2e-3);
    }
    EXPECT_LT(worst, 1e-9);
    if (contact) {
      EXPECT_GT(sim.constraints()->report().velocity_steps, 0u);
      EXPECT_GT(sim.constraints()->report().active_contacts, 0);
    }
    std::printf("  largest relation error: %.2e m\n", worst);
  }
}

// Without mimic_joints the follower moves on its own: the relation is the constraint's doing.
TEST(Mimic, OffMovesAsJointsOfTheirOwn) {
  const Model m = model_from_urdf_string(gripper_urdf());
  SimConfig cfg;
  cfg.mimic_joints = false;
  Simulator sim(m, State(m), cfg);
  EXPECT_EQ(sim.constraints(), nullptr);
  EXPECT_EQ(q_of(sim, "right"), 0.0);
}

// A loop of mimics (left follows tip, which follows right, which follows left) is one error
// naming the joints in order; a mimic of a joint that does not move is one warning.
TEST(Mimic, LoopIsOneError) {
  std::string urdf = gripper_urdf();
  const std::string left = "<joint name='left' type='prismatic'>";
  urdf.replace(urdf.find(left), left.size(), left + "<mimic joint='tip'/>");
  const std::string e = se3_test::error_of<ModelError>([&] { model_from_urdf_string(urdf); });
  EXPECT_NE(e.find("'left' -> 'tip' -> 'right' -> 'left' form a loop"), std::string::npos) << e;
  EXPECT_EQ(e.find('\n'), std::string::npos);
  // A joint mimicking itself is the shortest loop.
  std::string self = gripper_urdf();
  self.replace(self.find(left), left.size(), left + "<mimic joint='left'/>");
  EXPECT_NE(se3_test::error_of<ModelError>([&] {
              model_from_urdf_string(self);
            }).find("'left' -> 'left' form a loop"),
            std::string::npos);

  const Model m = model_from_urdf_string(gripper_urdf(
      "<link name='cam'/><joint name='cam_joint' type='fixed'><parent link='palm'/>"
      "<child link='cam'/></joint><link name='wheel'><inertial><mass value='0.1'/>"
      "<inertia ixx='1e-4' iyy='1e-4' izz='1e-4' ixy='0' ixz='0' iyz='0'/></inertial></link>"
      "<joint name='wheel_joint' type='continuous'><parent link='palm'/><child link='wheel'/>"
      "<axis xyz='0 0 1'/><mimic joint='cam_joint'/></joint>"));
  EXPECT_EQ(m.mimics.size(), 2u);
  int said = 0;
  for (const std::string& w : m.warnings) {
    if (w.find("'wheel_joint' (of 'cam_joint')") != std::string::npos) ++said;
  }
  EXPECT_EQ(said, 1);
}

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
