// A Gazebo user's URDF (issue 37, docs/gazebo.md): <mimic> joints held by joint_coupling
// constraint rows (constraints.h, Model::mimics): the Panda's fingers and a parallel gripper move
// together under a command and under contact, a mimic of a mimic follows, a loop of mimics is one
// error; the <gazebo> tags (gazebo_tags.h) read, warned about once, and mapped: material colours,
// static, selfCollide, mu1/mu2 against Coulomb's sliding distance.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <string>
#include <utility>
#include <vector>

#include "error_of.h"
#include "se3_sim/geometry/geometry.h"
#include "se3_sim/sim/controllers.h"
#include "se3_sim/sim/scene_collision.h"
#include "se3_sim/sim/sim.h"
#include "source_paths.h"

using namespace se3;

namespace {

const std::string kSource = se3_sim_test::source_dir();

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

// ------------------------------------------------------------------ <gazebo> tags

namespace {

// A two-link arm with every tag Gazebo users write (docs/gazebo.md's table), two it does not use
// (fdir1 twice, a made-up one), a bad value, and a reference to nothing.
const char* kTagged = R"(<robot name="tagged">
  <link name="base"><inertial><mass value="1"/><inertia ixx="0.01" iyy="0.01" izz="0.01" ixy="0" ixz="0" iyz="0"/></inertial>
    <visual><geometry><box size="0.1 0.1 0.1"/></geometry><material name="grey"><color rgba="0.5 0.5 0.5 1"/></material></visual>
    <collision><geometry><box size="0.1 0.1 0.1"/></geometry></collision></link>
  <link name="upper"><inertial><origin xyz="0 0 0.2"/><mass value="1"/><inertia ixx="0.01" iyy="0.01" izz="0.01" ixy="0" ixz="0" iyz="0"/></inertial>
    <visual><origin xyz="0 0 0.2"/><geometry><box size="0.05 0.05 0.4"/></geometry></visual>
    <collision><origin xyz="0 0 0.2"/><geometry><box size="0.05 0.05 0.4"/></geometry></collision></link>
  <link name="lower"><inertial><origin xyz="0 0 0.2"/><mass value="1"/><inertia ixx="0.01" iyy="0.01" izz="0.01" ixy="0" ixz="0" iyz="0"/></inertial>
    <visual><origin xyz="0 0 0.2"/><geometry><box size="0.05 0.05 0.4"/></geometry></visual>
    <collision><origin xyz="0 0 0.2"/><geometry><box size="0.05 0.05 0.4"/></geometry></collision></link>
  <joint name="shoulder" type="revolute"><parent link="base"/><child link="upper"/><origin xyz="0 0 0.05"/>
    <axis xyz="0 1 0"/><limit lower="-3" upper="3" effort="50" velocity="5"/></joint>
  <joint name="elbow" type="revolute"><parent link="upper"/><child link="lower"/><origin xyz="0 0 0.4"/>
    <axis xyz="0 1 0"/><limit lower="-3" upper="3" effort="50" velocity="5"/></joint>
  <gazebo reference="base"><material>Gazebo/Orange</material><mu1>0.3</mu1><mu2>0.5</mu2>
    <kp>1e6</kp><kd>100</kd><minDepth>0.001</minDepth><maxVel>0.1</maxVel><fdir1>1 0 0</fdir1></gazebo>
  <gazebo reference="lower"><selfCollide>true</selfCollide><gravity>false</gravity><fdir1>0 1 0</fdir1>
    <material>Gazebo/NoSuchColour</material></gazebo>
  <gazebo reference="upper"><mu1>plenty</mu1><sparkle>yes</sparkle></gazebo>
  <gazebo reference="elbow"><provideFeedback>true</provideFeedback><implicitSpringDamper>1</implicitSpringDamper></gazebo>
  <gazebo reference="nowhere"><mu1>1</mu1></gazebo>
  <gazebo><static>true</static>
    <plugin name="gazebo_ros_control" filename="libgazebo_ros_control.so">
      <robotNamespace>/tagged</robotNamespace><controlPeriod>0.002</controlPeriod></plugin></gazebo>
</robot>)";

int lines_with(const std::vector<std::string>& lines, const std::string& s) {
  return static_cast<int>(std::count_if(lines.begin(), lines.end(), [&](const std::string& l) {
    return l.find(s) != std::string::npos;
  }));
}

}  // namespace

// Every mapped tag is read; the unknown ones are one warning naming them with their lines; a bad
// value and a reference to nothing are a warning each; nothing is refused.
TEST(GazeboTags, ReadsEveryTagAndWarnsOnce) {
  const UrdfDocument doc = parse_urdf_document(kTagged);
  const GazeboTags& g = doc.gazebo;
  const GazeboLink* base = g.link("base");
  ASSERT_NE(base, nullptr);
  EXPECT_EQ(base->mu1, 0.3);
  EXPECT_EQ(base->mu2, 0.5);
  EXPECT_EQ(base->mu(), 0.3);
  EXPECT_EQ(base->kp, 1e6);
  EXPECT_EQ(base->kd, 100);
  EXPECT_EQ(base->min_depth, 0.001);
  EXPECT_EQ(base->max_vel, 0.1);
  EXPECT_EQ(base->material, "Gazebo/Orange");
  const GazeboLink* lower = g.link("lower");
  ASSERT_NE(lower, nullptr);
  EXPECT_EQ(lower->self_collide, 1);
  EXPECT_EQ(lower->gravity, 0);
  EXPECT_TRUE(std::isnan(g.link("upper")->mu1));
  const GazeboJoint* elbow = g.joint("elbow");
  ASSERT_NE(elbow, nullptr);
  EXPECT_EQ(elbow->provide_feedback, 1);
  EXPECT_EQ(elbow->implicit_spring_damper, 1);
  EXPECT_EQ(g.is_static, 1);
  EXPECT_TRUE(g.control_plugin);
  EXPECT_EQ(g.robot_namespace, "/tagged");
  EXPECT_EQ(g.control_period, 0.002);
  const std::vector<std::string>& w = doc.warnings;
  EXPECT_EQ(lines_with(w, "<gazebo> tags se3_sim does not use"), 1);
  EXPECT_EQ(lines_with(w, "fdir1 (lines 16, 17), sparkle (line 19)"), 1);
  EXPECT_EQ(lines_with(w, "<mu1> 'plenty' is not a number >= 0"), 1);
  EXPECT_EQ(lines_with(w, "reference=\"nowhere\"> names no link or joint"), 1);
  EXPECT_EQ(lines_with(w, "'Gazebo/NoSuchColour' is not one of Gazebo's stock colours"), 1);
  for (const std::string& l : w) EXPECT_EQ(l.find('\n'), std::string::npos) << l;
  // The model carries the warnings (the node prints them).
  const Model m = model_from_urdf(doc);
  EXPECT_EQ(lines_with(m.warnings, "<gazebo> tags se3_sim does not use"), 1);
}

// <material>Gazebo/Orange</material> replaces the URDF's grey on the base's visual; the other
// links keep theirs.
TEST(GazeboTags, MaterialIsDrawnInGazebosColour) {
  const Model m = model_from_urdf_string(kTagged);
  const GeometryModel g = geometry_from_urdf_string(m, kTagged);
  int base_visuals = 0;
  for (const GeometryObject& o : g.visuals) {
    if (o.link != "base") {
      EXPECT_FALSE(o.material.has_color) << o.link;
      continue;
    }
    ++base_visuals;
    EXPECT_TRUE(o.material.has_color);
    EXPECT_EQ(o.material.name, "Gazebo/Orange");
    EXPECT_FLOAT_EQ(o.material.rgba[0], 1.0f);
    EXPECT_FLOAT_EQ(o.material.rgba[1], 0.5f);
    EXPECT_LT(o.material.rgba[2], 0.1f);
  }
  EXPECT_EQ(base_visuals, 1);
}

// <static>true</static> fixes a generic scene's base (Gazebo's static model does not fall); a
// scene that says base: free keeps it free.
TEST(GazeboTags, StaticFixesTheBase) {
  EXPECT_FALSE(scene_model(parse_scene("name: t\n", "."), kTagged).floating);
  EXPECT_TRUE(scene_model(parse_scene("name: t\nbase: free\n", "."), kTagged).floating);
}

// selfCollide on `lower` lets it collide with the robot's other links (not its adjacent
// `upper`) although the scene leaves self_collision off; without the tag it collides with none.
TEST(GazeboTags, SelfCollideTurnsSelfCollisionOnForThatLink) {
  for (bool tagged : {true, false}) {
    std::string urdf = kTagged;
    if (!tagged) urdf.replace(urdf.find("<selfCollide>true"), 17, "<selfCollide>false");
    const Scene scene = parse_scene("name: t\nbase: fixed\nground: {from_collisions: true}\n", ".");
    const Model m = scene_model(scene, urdf);
    const SceneCollision sc = scene_collision(scene, &m, nullptr, urdf);
    auto index = [&](const std::string& link) {
      const auto& objs = sc.model.objects();
      for (size_t k = 0; k < objs.size(); ++k) {
        if (objs[k].link == link) return static_cast<int>(k);
      }
      return -1;
    };
    const int base = index("base"), upper = index("upper"), lower = index("lower");
    ASSERT_GE(base, 0);
    ASSERT_GE(lower, 0);
    EXPECT_EQ(sc.model.may_collide(lower, base), tagged);
    EXPECT_FALSE(sc.model.may_collide(lower, upper));  // adjacent
    EXPECT_FALSE(sc.model.may_collide(upper, base));   // adjacent
  }
}

// A free box sliding on the ground at 2 m/s stops after v^2 / (2 mu g) (Coulomb's law): with
// <mu1>/<mu2> on its link the smaller of the two counts, not the ground's 0.8.
TEST(GazeboTags, MuChangesTheSlidingDistance) {
  auto box = [](const std::string& tags) {
    return "<robot name='box'><link name='box'><inertial><mass value='1'/><inertia ixx='0.00167' "
           "iyy='0.00167' izz='0.00167' ixy='0' ixz='0' iyz='0'/></inertial><collision><geometry>"
           "<box size='0.1 0.1 0.1'/></geometry></collision></link>" +
           tags + "</robot>";
  };
  const Scene scene = parse_scene(
      "name: slide\nbase: free\nbase_pose: {position: [0, 0, 0.05]}\n"
      "base_twist: [0, 0, 0, 2, 0, 0]\nground: {mu: 0.8, from_collisions: true}\n",
      ".");
  for (const auto& [tags, mu] : std::vector<std::pair<std::string, double>>{
           {"", 0.8},
           {"<gazebo reference='box'><mu1>0.3</mu1><mu2>0.45</mu2></gazebo>", 0.3},
           {"<gazebo reference='box'><mu1>0.6</mu1></gazebo>", 0.6}}) {
    SCOPED_TRACE(mu);
    auto sim = make_simulator(scene, box(tags));
    for (int k = 0; k < 1500; ++k) ASSERT_TRUE(sim->step()) << sim->failure();
    const double slid = sim->state().base.p.x();
    const double expected = 2.0 * 2.0 / (2 * mu * 9.81);
    EXPECT_NEAR(slid, expected, 0.03 * expected);
    EXPECT_LT(sim->state().v.norm(), 1e-3);  // stopped
    std::printf("  mu %.2f: slid %.4f m, Coulomb %.4f m\n", mu, slid, expected);
  }
}

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
