// Model building: every URDF of data/robots, checked link by link against urdfdom's own parse
// and a hand-written forward kinematics of the URDF; clear errors for models that cannot be
// simulated; generated chains.
#include <gtest/gtest.h>
#include <urdf_parser/urdf_parser.h>

#include <cmath>
#include <fstream>
#include <functional>
#include <map>
#include <random>
#include <sstream>
#include <string>

#include "test_util.h"

using namespace se3;
using se3_test::robot_files;
using se3_test::robot_path;

namespace {

std::string read_file(const std::string& path) {
  std::ifstream f(path);
  std::stringstream ss;
  ss << f.rdbuf();
  return ss.str();
}

// urdfdom keeps an origin as a unit quaternion (its rpy read back is ill-conditioned at
// pitch = pi/2, which ur5 uses): the rotation by the textbook formula.
SE3 urdf_pose(const urdf::Pose& p) {
  double x, y, z, w;
  p.rotation.getQuaternion(x, y, z, w);
  const double s = 1.0 / (x * x + y * y + z * z + w * w);
  Mat3 R;
  R << 1 - 2 * s * (y * y + z * z), 2 * s * (x * y - z * w), 2 * s * (x * z + y * w),
      2 * s * (x * y + z * w), 1 - 2 * s * (x * x + z * z), 2 * s * (y * z - x * w),
      2 * s * (x * z - y * w), 2 * s * (y * z + x * w), 1 - 2 * s * (x * x + y * y);
  return SE3(R, Vec3(p.position.x, p.position.y, p.position.z));
}

// World pose of every URDF link at joint positions q (by joint name; absent = 0), computed from
// urdfdom's tree directly: T_child = T_parent * origin * motion(axis, q).
std::map<std::string, SE3> urdf_link_poses(const urdf::ModelInterface& u, const SE3& base,
                                           const std::map<std::string, double>& q) {
  std::map<std::string, SE3> out;
  std::function<void(const urdf::Link&, const SE3&)> visit = [&](const urdf::Link& l,
                                                                 const SE3& T) {
    out[l.name] = T;
    for (const auto& j : l.child_joints) {
      const auto it = q.find(j->name);
      const double qj = it == q.end() ? 0.0 : it->second;
      const Vec3 axis = Vec3(j->axis.x, j->axis.y, j->axis.z).normalized();
      SE3 motion;
      if (j->type == urdf::Joint::PRISMATIC) {
        motion.p = qj * axis;
      } else if (j->type != urdf::Joint::FIXED) {
        motion.R = Eigen::AngleAxisd(qj, axis).toRotationMatrix();
      }
      visit(*u.getLink(j->child_link_name),
            T * urdf_pose(j->parent_to_joint_origin_transform) * motion);
    }
  };
  visit(*u.getRoot(), base);
  return out;
}

// The URDF's inertia of a link, placed in the world at T (link pose).
Mat6 urdf_world_inertia(const urdf::Link& l, const SE3& T) {
  if (!l.inertial) return Mat6::Zero();
  const urdf::Inertial& in = *l.inertial;
  Mat3 I;
  I << in.ixx, in.ixy, in.ixz, in.ixy, in.iyy, in.iyz, in.ixz, in.iyz, in.izz;
  const SE3 Tc = T * urdf_pose(in.origin);
  return spatial_inertia(in.mass, Tc.p, Tc.R * I * Tc.R.transpose());
}

Model load(const std::string& file, bool floating) {
  UrdfOptions opt;
  opt.floating = floating;
  return model_from_urdf_file(robot_path(file), opt);
}

// Expects model_from_urdf_string to throw ModelError whose message contains every needle.
void expect_model_error(const std::string& xml, const std::vector<std::string>& needles,
                        bool floating = false) {
  UrdfOptions opt;
  opt.floating = floating;
  try {
    const Model m = model_from_urdf_string(xml, opt);
    ADD_FAILURE() << "no error for:\n" << xml;
  } catch (const ModelError& e) {
    const std::string msg = e.what();
    std::printf("  ModelError: %s\n", msg.c_str());
    for (const std::string& s : needles) {
      EXPECT_NE(msg.find(s), std::string::npos) << "message '" << msg << "' lacks '" << s << "'";
    }
  } catch (const std::exception& e) {
    ADD_FAILURE() << "threw something other than ModelError: " << e.what();
  }
}

const char* kInertial =
    "<inertial><mass value='1'/><inertia ixx='0.1' iyy='0.1' izz='0.1' ixy='0' ixz='0' "
    "iyz='0'/></inertial>";

// base -(revolute j1)- b, with b's inertial and j1's type/axis given.
std::string two_links(const std::string& type, const std::string& axis,
                      const std::string& b_inertial) {
  return std::string("<robot name='t'><link name='base'>") + kInertial + "</link><link name='b'>" +
         b_inertial + "</link><joint name='j1' type='" + type +
         "'><parent link='base'/><child link='b'/><axis xyz='" + axis +
         "'/><limit lower='-1' upper='1' effort='1' velocity='1'/></joint></robot>";
}

}  // namespace

TEST(Model, EveryRobotLoadsFixedAndFloating) {
  for (const auto& r : robot_files()) {
    SCOPED_TRACE(r.file);
    const Model fixed = load(r.file, false);
    EXPECT_EQ(fixed.n, r.dof);
    EXPECT_EQ(fixed.nv, r.dof);
    EXPECT_FALSE(fixed.floating);
    EXPECT_GT(fixed.total_mass(), 0.0);
    EXPECT_NO_THROW(fixed.validate());
    if (r.floating_ok) {
      const Model fl = load(r.file, true);
      EXPECT_EQ(fl.n, r.dof);
      EXPECT_EQ(fl.nv, r.dof + 6);
      EXPECT_TRUE(fl.floating);
      EXPECT_GT(fl.total_mass(), fixed.total_mass() - 1e-12);
      std::printf("%-28s dof %2d  bodies %2d  links %2zu  mass fixed %.6g floating %.6g\n",
                  r.file.c_str(), fl.n, fl.n + 1, fl.links.size(), fixed.total_mass(),
                  fl.total_mass());
    }
  }
}

TEST(Model, KukaFloatingIsRejectedNamingItsMasslessRoot) {
  UrdfOptions opt;
  opt.floating = true;
  try {
    model_from_urdf_file(robot_path("kuka_iiwa.urdf"), opt);
    ADD_FAILURE() << "kuka_iiwa floating was accepted";
  } catch (const ModelError& e) {
    std::printf("  %s\n", e.what());
    EXPECT_NE(std::string(e.what()).find("lbr_iiwa_link_0"), std::string::npos) << e.what();
  }
}

// Every URDF link's world pose from the model (body pose * offset) equals a forward kinematics
// written directly on urdfdom's tree; the merged spatial inertias add up to the URDF's.
TEST(Model, LinkFramesAndInertiasMatchTheUrdf) {
  std::mt19937_64 rng(21);
  for (const auto& r : robot_files()) {
    for (bool floating : {false, true}) {
      if (floating && !r.floating_ok) continue;
      SCOPED_TRACE(r.file + (floating ? " floating" : " fixed"));
      const Model m = load(r.file, floating);
      const urdf::ModelInterfaceSharedPtr u = urdf::parseURDF(read_file(robot_path(r.file)));
      ASSERT_TRUE(u);
      Data d(m);
      for (int trial = 0; trial < 5; ++trial) {
        const se3_test::RandomState s = se3_test::random_state(m, rng);
        std::map<std::string, double> qmap;
        for (int i = 1; i <= m.n; ++i) qmap[m.joint_name[i]] = s.q[i - 1];
        const auto poses = urdf_link_poses(*u, s.base, qmap);
        forward_kinematics(m, d, s.base, s.q);
        ASSERT_EQ(m.links.size(), poses.size());
        Mat6 total_urdf = Mat6::Zero(), total_model = Mat6::Zero();
        double worst = 0;
        for (const LinkFrame& lf : m.links) {
          const SE3 T = d.oMb[lf.body] * lf.offset;
          const SE3& ref = poses.at(lf.name);
          worst = std::max(
              {worst, (T.R - ref.R).cwiseAbs().maxCoeff(), (T.p - ref.p).cwiseAbs().maxCoeff()});
          if (lf.body > 0 || floating) total_urdf += urdf_world_inertia(*u->getLink(lf.name), ref);
        }
        for (int i = floating ? 0 : 1; i <= m.n; ++i) {
          total_model += m.inertia[i].transformed(d.oMb[i]).matrix();
        }
        EXPECT_LE(worst, 1e-13);
        EXPECT_LE((total_model - total_urdf).cwiseAbs().maxCoeff(),
                  1e-12 * std::max(1.0, total_urdf.cwiseAbs().maxCoeff()));
      }
      // Joint limits and dynamics data are carried over by name.
      for (int i = 1; i <= m.n; ++i) {
        const urdf::JointConstSharedPtr j = u->getJoint(m.joint_name[i]);
        ASSERT_TRUE(j) << m.joint_name[i];
        EXPECT_EQ(m.body_name[i], j->child_link_name);
        if (j->type == urdf::Joint::REVOLUTE && j->limits && j->limits->lower < j->limits->upper) {
          EXPECT_EQ(m.lower[i], j->limits->lower);
          EXPECT_EQ(m.upper[i], j->limits->upper);
        }
        if (j->dynamics) {
          EXPECT_EQ(m.damping[i], j->dynamics->damping);
        }
        EXPECT_EQ(m.joints[i].type == JointType::Prismatic, j->type == urdf::Joint::PRISMATIC);
      }
    }
  }
}

TEST(Model, RomeoLoadsWithTriangleInequalityWarnings) {
  const Model m = load("romeo_small.urdf", true);
  std::vector<std::string> named;
  for (const std::string& w : m.warnings) {
    std::printf("  warning: %s\n", w.c_str());
    if (w.find("triangle") != std::string::npos) named.push_back(w);
  }
  ASSERT_EQ(named.size(), 1u);  // one line naming every such link (urdf_quirks.cpp)
  auto mentions = [&](const std::string& link) {
    for (const std::string& w : named) {
      if (w.find(link) != std::string::npos) return true;
    }
    return false;
  };
  EXPECT_TRUE(mentions("RShoulderYawLink"));
  EXPECT_TRUE(mentions("RElbowYawLink"));
  // The other robots' moving links have consistent inertias (some fixed sensor frames of
  // anymal_c and hyq do not, and are warned about).
  for (const auto& r : robot_files()) {
    if (r.file == "romeo_small.urdf") continue;
    const Model t = load(r.file, false);
    for (const std::string& w : t.warnings) {
      for (int i = 1; i <= t.n; ++i) {
        EXPECT_EQ(w.find("'" + t.body_name[i] + "'"), std::string::npos) << r.file << ": " << w;
      }
    }
  }
}

TEST(Model, Errors) {
  // Malformed XML and a tree urdfdom rejects.
  expect_model_error("<robot name='t'><link name='a'", {"urdfdom"});
  expect_model_error(
      "<robot name='t'><link name='a'/><joint name='j1' type='revolute'><parent link='a'/>"
      "<child link='ghost'/><axis xyz='0 0 1'/>"
      "<limit lower='-1' upper='1' effort='1' velocity='1'/></joint></robot>",
      {"urdfdom", "ghost"});
  expect_model_error("not xml at all", {"urdfdom"});
  // A moving link without inertia (and nothing below it: a sensor or tool frame on a moving
  // joint, as real URDFs have) has no dynamics: the joint is locked at 0 with one warning naming
  // it (urdf_quirks.cpp), not refused.
  for (const char* type : {"revolute", "prismatic"}) {
    const Model m = model_from_urdf_string(two_links(type, "0 1 0", ""));
    EXPECT_EQ(m.n, 0) << type;
    std::string all;
    for (const auto& w : m.warnings) all += w + "\n";
    EXPECT_NE(all.find("j1"), std::string::npos) << all;
    EXPECT_NE(all.find("locked"), std::string::npos) << all;
  }
  // A revolute joint moving a massless link whose only child hangs on the joint axis as a
  // point mass: its subtree has mass but no inertia about the axis (the merged body's spatial
  // inertia is singular, and the error names it).
  expect_model_error(std::string("<robot name='t'><link name='base'>") + kInertial +
                         "</link><link name='b'/><link name='c'><inertial><mass value='2'/>"
                         "<inertia ixx='0' iyy='0' izz='0' ixy='0' ixz='0' iyz='0'/>"
                         "</inertial></link>"
                         "<joint name='j1' type='revolute'><parent link='base'/><child link='b'/>"
                         "<axis xyz='0 0 1'/><limit lower='-1' upper='1' effort='1' "
                         "velocity='1'/></joint><joint name='f' type='fixed'><parent link='b'/>"
                         "<child link='c'/><origin xyz='0 0 0.5'/></joint></robot>",
                     {"'b'", "positive definite"});
  // A non-positive-definite inertia: negative principal moment.
  expect_model_error(
      two_links("revolute", "0 0 1",
                "<inertial><mass value='1'/><inertia ixx='-0.1' iyy='0.1' izz='0.1' ixy='0' "
                "ixz='0' iyz='0'/></inertial>"),
      {"'b'", "positive definite"});
  expect_model_error(
      two_links("revolute", "0 0 1",
                "<inertial><mass value='1'/><inertia ixx='0.1' iyy='0.1' izz='0.1' ixy='0.5' "
                "ixz='0' iyz='0'/></inertial>"),
      {"'b'", "positive definite"});
  expect_model_error(
      two_links("revolute", "0 0 1",
                "<inertial><mass value='-1'/><inertia ixx='0.1' iyy='0.1' izz='0.1' ixy='0' "
                "ixz='0' iyz='0'/></inertial>"),
      {"'b'"});
  // Unsupported joint types (a floating joint from the root is the free base, if the root is
  // empty: here it carries an inertial).
  expect_model_error(two_links("floating", "0 0 1", kInertial), {"'j1'", "floating", "'base'"});
  expect_model_error(two_links("planar", "0 0 1", kInertial), {"'j1'", "planar"});
  // A zero axis.
  expect_model_error(two_links("revolute", "0 0 0", kInertial), {"'j1'", "axis"});
  // A massless free base.
  std::string massless_base = two_links("revolute", "0 0 1", kInertial);
  massless_base.erase(massless_base.find(kInertial), std::string(kInertial).size());
  expect_model_error(massless_base, {"'base'"}, true);
  EXPECT_NO_THROW(model_from_urdf_string(massless_base));  // fine on a fixed base
  // A missing file and a locked joint that does not exist.
  try {
    model_from_urdf_file("/nonexistent/robot.urdf");
    ADD_FAILURE() << "missing file accepted";
  } catch (const ModelError& e) {
    EXPECT_NE(std::string(e.what()).find("/nonexistent/robot.urdf"), std::string::npos);
  }
  UrdfOptions opt;
  opt.locked = {{"no_such_joint", 0.0}};
  try {
    model_from_urdf_string(two_links("revolute", "0 0 1", kInertial), opt);
    ADD_FAILURE() << "unknown locked joint accepted";
  } catch (const ModelError& e) {
    EXPECT_NE(std::string(e.what()).find("no_such_joint"), std::string::npos);
  }
  // The good counterpart of the cases above loads.
  EXPECT_NO_THROW(model_from_urdf_string(two_links("revolute", "0 0 1", kInertial)));
  EXPECT_NO_THROW(model_from_urdf_string(two_links("continuous", "1 1 0", kInertial)));
}

// Links joined by fixed joints become one body; each link frame is recovered as body * offset.
// Checked against a hand computation of this URDF:
//   base -(j1 revolute, axis x)- l1 -(f1 fixed)- l2 -(j2 prismatic, axis y)- l3 -(f2)- l4.
TEST(Model, FixedJointsMergeLinks) {
  const std::string xml = R"(<robot name='m'>
    <link name='base'><inertial><mass value='4'/><inertia ixx='0.2' iyy='0.3' izz='0.4' ixy='0' ixz='0' iyz='0'/></inertial></link>
    <link name='l1'><inertial><origin xyz='0.05 0 0'/><mass value='2'/><inertia ixx='0.01' iyy='0.02' izz='0.03' ixy='0' ixz='0' iyz='0'/></inertial></link>
    <link name='l2'><inertial><origin xyz='0 0.1 0' rpy='0.3 0 0'/><mass value='3'/><inertia ixx='0.04' iyy='0.05' izz='0.06' ixy='0' ixz='0' iyz='0'/></inertial></link>
    <link name='l3'><inertial><mass value='1'/><inertia ixx='0.01' iyy='0.01' izz='0.01' ixy='0' ixz='0' iyz='0'/></inertial></link>
    <link name='l4'/>
    <joint name='j1' type='revolute'><parent link='base'/><child link='l1'/>
      <origin xyz='0.1 0.2 0.3' rpy='0.1 -0.2 0.3'/><axis xyz='1 0 0'/>
      <limit lower='-2' upper='2' effort='10' velocity='3'/><dynamics damping='0.5' friction='0.1'/></joint>
    <joint name='f1' type='fixed'><parent link='l1'/><child link='l2'/><origin xyz='0 0 0.4' rpy='0.5 0 0'/></joint>
    <joint name='j2' type='prismatic'><parent link='l2'/><child link='l3'/>
      <origin xyz='0.2 0 0'/><axis xyz='0 1 0'/><limit lower='-0.1' upper='0.1' effort='5' velocity='1'/></joint>
    <joint name='f2' type='fixed'><parent link='l3'/><child link='l4'/><origin xyz='0 0 0.1' rpy='0 0 1.5707963267948966'/></joint>
  </robot>)";
  const Model m = model_from_urdf_string(xml);
  ASSERT_EQ(m.n, 2);
  EXPECT_EQ(m.joint_name[1], "j1");
  EXPECT_EQ(m.joint_name[2], "j2");
  EXPECT_EQ(m.joints[2].type, JointType::Prismatic);
  EXPECT_EQ(m.parent[2], 1);
  EXPECT_EQ(m.body_name[1], "l1");
  ASSERT_EQ(m.links.size(), 5u);
  EXPECT_EQ(m.links[m.link_index("base")].body, 0);
  EXPECT_EQ(m.links[m.link_index("l1")].body, 1);
  EXPECT_EQ(m.links[m.link_index("l2")].body, 1);
  EXPECT_EQ(m.links[m.link_index("l3")].body, 2);
  EXPECT_EQ(m.links[m.link_index("l4")].body, 2);
  EXPECT_EQ(m.link_index("nope"), -1);
  EXPECT_EQ(m.joint_index("j2"), 2);
  EXPECT_EQ(m.joint_index("f1"), -1);
  EXPECT_EQ(m.lower[1], -2.0);
  EXPECT_EQ(m.upper[1], 2.0);
  EXPECT_EQ(m.effort[1], 10.0);
  EXPECT_EQ(m.velocity[1], 3.0);
  EXPECT_EQ(m.damping[1], 0.5);
  EXPECT_EQ(m.friction[1], 0.1);
  EXPECT_NEAR(m.inertia[1].m, 5.0, 1e-15);
  EXPECT_NEAR(m.inertia[2].m, 1.0, 1e-15);
  EXPECT_NEAR(m.total_mass(), 6.0, 1e-15);

  auto rpy = [](double r, double p, double y) {
    return Mat3((Eigen::AngleAxisd(y, Vec3::UnitZ()) * Eigen::AngleAxisd(p, Vec3::UnitY()) *
                 Eigen::AngleAxisd(r, Vec3::UnitX()))
                    .toRotationMatrix());
  };
  const SE3 J1(rpy(0.1, -0.2, 0.3), Vec3(0.1, 0.2, 0.3));
  const SE3 F1(rpy(0.5, 0, 0), Vec3(0, 0, 0.4));
  const SE3 J2(Mat3::Identity(), Vec3(0.2, 0, 0));
  const SE3 F2(rpy(0, 0, M_PI / 2), Vec3(0, 0, 0.1));
  std::mt19937_64 rng(22);
  Data d(m);
  for (int trial = 0; trial < 10; ++trial) {
    const SE3 base = se3_test::random_pose(rng);
    VecX q(2);
    q << se3_test::uniform(rng, -2, 2), se3_test::uniform(rng, -0.1, 0.1);
    const SE3 l1 =
        base * J1 * SE3(Eigen::AngleAxisd(q[0], Vec3::UnitX()).toRotationMatrix(), Vec3::Zero());
    const SE3 l2 = l1 * F1;
    const SE3 l3 = l2 * J2 * SE3(Mat3::Identity(), Vec3(0, q[1], 0));
    const SE3 l4 = l3 * F2;
    forward_kinematics(m, d, base, q);
    const std::pair<const char*, SE3> expected[] = {
        {"base", base}, {"l1", l1}, {"l2", l2}, {"l3", l3}, {"l4", l4}};
    for (const auto& e : expected) {
      const LinkFrame& lf = m.links[m.link_index(e.first)];
      EXPECT_TRUE((d.oMb[lf.body] * lf.offset).isApprox(e.second, 1e-14)) << e.first;
    }
    // Body 1's inertia is l1's plus l2's: compare in the world frame.
    const Mat6 I1 = spatial_inertia(2, l1.act(Vec3(0.05, 0, 0)),
                                    l1.R * Vec3(0.01, 0.02, 0.03).asDiagonal() * l1.R.transpose());
    const SE3 c2 = l2 * SE3(rpy(0.3, 0, 0), Vec3(0, 0.1, 0));
    const Mat6 I2 =
        spatial_inertia(3, c2.p, c2.R * Vec3(0.04, 0.05, 0.06).asDiagonal() * c2.R.transpose());
    EXPECT_LE((m.inertia[1].transformed(d.oMb[1]).matrix() - (I1 + I2)).cwiseAbs().maxCoeff(),
              1e-14);
  }
  // Locking j2 merges l3 and l4 into body 1 at the locked position.
  UrdfOptions opt;
  opt.locked = {{"j2", 0.05}};
  const Model ml = model_from_urdf_string(xml, opt);
  ASSERT_EQ(ml.n, 1);
  EXPECT_NEAR(ml.inertia[1].m, 6.0, 1e-15);
  Data dl(ml);
  VecX q1(1);
  q1 << 0.7;
  forward_kinematics(ml, dl, SE3(), q1);
  const SE3 l1 = J1 * SE3(Eigen::AngleAxisd(0.7, Vec3::UnitX()).toRotationMatrix(), Vec3::Zero());
  const SE3 l4 = l1 * F1 * J2 * SE3(Mat3::Identity(), Vec3(0, 0.05, 0)) * F2;
  const LinkFrame& lf = ml.links[ml.link_index("l4")];
  EXPECT_EQ(lf.body, 1);
  EXPECT_TRUE((dl.oMb[1] * lf.offset).isApprox(l4, 1e-14));
}

TEST(Model, TreeStructure) {
  const Model m = load("solo12.urdf", true);
  ASSERT_EQ(m.n, 12);
  EXPECT_EQ(m.children[0].size(), 4u);
  for (const char* leg : {"FL", "FR", "HL", "HR"}) {
    const std::string L(leg);
    const int haa = m.joint_index(L + "_HAA"), hfe = m.joint_index(L + "_HFE"),
              kfe = m.joint_index(L + "_KFE");
    ASSERT_GT(haa, 0);
    ASSERT_GT(hfe, 0);
    ASSERT_GT(kfe, 0);
    EXPECT_EQ(m.parent[haa], 0) << leg;
    EXPECT_EQ(m.parent[hfe], haa) << leg;
    EXPECT_EQ(m.parent[kfe], hfe) << leg;
    EXPECT_EQ(m.subtree_end[haa], kfe) << leg;
    EXPECT_EQ(m.children[kfe].size(), 0u);
  }
  // On every robot: topological order, and the subtree of i is exactly i..subtree_end[i].
  for (const auto& r : robot_files()) {
    const Model t = load(r.file, false);
    for (int i = 1; i <= t.n; ++i) {
      EXPECT_LT(t.parent[i], i);
      for (int j = 1; j <= t.n; ++j) {
        bool is_desc = false;
        for (int k = j; k >= 0; k = t.parent[k]) is_desc = is_desc || k == i;
        EXPECT_EQ(is_desc, j >= i && j <= t.subtree_end[i]) << r.file << " " << i << " " << j;
      }
    }
  }
}

TEST(Model, GeneratedChains) {
  for (int n : {1, 2, 10, 200}) {
    for (bool floating : {false, true}) {
      const Model m = make_chain(n, floating);
      EXPECT_EQ(m.n, n);
      EXPECT_EQ(m.nv, n + (floating ? 6 : 0));
      EXPECT_EQ(m.parent[0], -1);
      for (int i = 1; i <= n; ++i) {
        EXPECT_EQ(m.parent[i], i - 1);
        EXPECT_EQ(m.subtree_end[i], n);
      }
      EXPECT_NEAR(m.total_mass(), n + (floating ? 1.0 : 0.0), 1e-12);
      EXPECT_NO_THROW(m.validate());
    }
  }
  const std::vector<double> masses = {1e-2, 1, 100};
  const Model m = make_chain(7, true, masses, 0.5);
  for (int i = 0; i <= 7; ++i) EXPECT_EQ(m.inertia[i].m, masses[i % 3]);
  // Links of length 0.5: every joint sits 0.5 from its parent's origin.
  for (int i = 1; i <= 7; ++i) EXPECT_NEAR(m.X_tree[i].p.norm(), 0.5, 1e-15);
}

// The joint model: coordinates, motion subspace and transform of each joint type, and the
// coordinate layout finalize() gives a model.
TEST(Joint, ModelCoordinatesSubspaceAndTransform) {
  const JointModel rev(JointType::Revolute), pri(JointType::Prismatic);
  const JointModel free(JointType::Free), fixed(JointType::Fixed);
  EXPECT_EQ(rev.nq, 1);
  EXPECT_EQ(rev.nv, 1);
  EXPECT_EQ(rev.axis(), 2);
  EXPECT_EQ(pri.nq, 1);
  EXPECT_EQ(pri.nv, 1);
  EXPECT_EQ(pri.axis(), 5);
  EXPECT_EQ(free.nq, 0);
  EXPECT_EQ(free.nv, 6);
  EXPECT_EQ(free.axis(), -1);
  EXPECT_EQ(fixed.nq, 0);
  EXPECT_EQ(fixed.nv, 0);
  EXPECT_EQ(fixed.axis(), -1);
  EXPECT_EQ(rev.motion_subspace(), Vec6::Unit(2));
  EXPECT_EQ(pri.motion_subspace(), Vec6::Unit(5));
  EXPECT_EQ(free.motion_subspace(), Mat6::Identity());
  EXPECT_EQ(fixed.motion_subspace().cols(), 0);
  EXPECT_STREQ(rev.urdf_type(true), "revolute");
  EXPECT_STREQ(rev.urdf_type(false), "continuous");
  EXPECT_STREQ(pri.urdf_type(true), "prismatic");
  EXPECT_EQ(free.urdf_type(true), nullptr);
  // X_tree exp(S q), S q the joint's twist: against the group exponential.
  const SE3 Xt(exp_so3(Vec3(0.3, -0.2, 0.7)), Vec3(0.1, 0.2, -0.3));
  const double q = 0.83;
  EXPECT_TRUE(rev.transform(Xt, &q).isApprox(Xt * exp_se3(q * Vec6::Unit(2)), 1e-15));
  EXPECT_TRUE(pri.transform(Xt, &q).isApprox(Xt * exp_se3(q * Vec6::Unit(5)), 1e-15));
  EXPECT_TRUE(free.transform(Xt, nullptr).isApprox(Xt, 0));
  // The dynamics' joint transforms are the joint model's.
  for (bool floating : {false, true}) {
    Model m = make_chain(4, floating);
    m.joints[2] = JointModel(JointType::Prismatic);
    m.finalize();
    m.validate();
    EXPECT_EQ(m.joints[0].type, floating ? JointType::Free : JointType::Fixed);
    EXPECT_EQ(m.nq, 4);
    EXPECT_EQ(m.nv, floating ? 10 : 4);
    EXPECT_EQ(m.nv_base(), floating ? 6 : 0);
    for (int i = 1; i <= 4; ++i) {
      EXPECT_EQ(m.idx_q(i), i - 1);
      EXPECT_EQ(m.idx_v(i), m.nv_base() + i - 1);
    }
    Data d(m);
    VecX qs(4);
    qs << 0.4, -1.1, 0.25, 2.0;
    forward_kinematics(m, d, SE3(), qs);
    for (int i = 1; i <= 4; ++i) {
      EXPECT_TRUE(d.Xup[i].isApprox(m.joints[i].transform(m.X_tree[i], &qs[m.idx_q(i)]), 1e-15))
          << i;
    }
  }
  // Bodies 1..n take one-dof joints only, and the coordinates must come from finalize().
  Model bad = make_chain(2, false);
  bad.joints[1] = JointModel(JointType::Free);
  bad.finalize();
  EXPECT_THROW(bad.validate(), ModelError);
  Model stale = make_chain(2, true);
  stale.floating = false;  // not finalized since
  EXPECT_THROW(stale.validate(), ModelError);
}

// URDF floating joints. From the root link (the world) to the base: that base is free, with the
// joint's origin as its rest pose, and the model is the same as the URDF without the world link
// loaded with --floating. Anywhere else, and planar joints: a one-line error naming the joint.
TEST(Joint, UrdfFloatingJointFromTheWorldIsTheFreeBase) {
  const std::string robot =
      std::string("<link name='base'>") + kInertial + "</link><link name='b'>" + kInertial +
      "</link><joint name='j1' type='revolute'><parent link='base'/><child link='b'/>"
      "<origin xyz='0.2 0 0'/><axis xyz='0 1 0'/>"
      "<limit lower='-1' upper='1' effort='1' velocity='1'/></joint>";
  const std::string world_joint =
      "<link name='world'/><joint name='root_float' type='floating'><parent link='world'/>"
      "<child link='base'/><origin xyz='0.5 -1 2' rpy='0.1 0.2 0.3'/></joint>";
  const std::string with_world = "<robot name='t'>" + world_joint + robot + "</robot>";
  const Model m = model_from_urdf_string(with_world);  // no --floating needed
  EXPECT_TRUE(m.floating);
  EXPECT_EQ(m.root_link, "base");
  EXPECT_EQ(m.body_name[0], "base");
  EXPECT_EQ(m.links[0].name, "base");
  EXPECT_EQ(m.link_index("world"), -1);
  EXPECT_EQ(m.n, 1);
  EXPECT_EQ(m.nv, 7);
  const SE3 rest(exp_so3(Vec3(0, 0, 0.3)) * exp_so3(Vec3(0, 0.2, 0)) * exp_so3(Vec3(0.1, 0, 0)),
                 Vec3(0.5, -1, 2));
  EXPECT_TRUE(m.X_tree[0].isApprox(rest, 1e-12));
  EXPECT_TRUE(State(m).base.isApprox(m.X_tree[0], 0));
  UrdfOptions free;
  free.floating = true;
  const Model ref = model_from_urdf_string("<robot name='t'>" + robot + "</robot>", free);
  EXPECT_TRUE(model_from_urdf_string(with_world, free).X_tree[0].isApprox(m.X_tree[0], 0));
  Data d(m), dr(ref);
  VecX q(1);
  q << 0.4;
  EXPECT_EQ(crba(m, d, rest, q), crba(ref, dr, rest, q));
  // The world may hold nothing but the floating joint.
  expect_model_error("<robot name='t'><link name='world'>" + std::string(kInertial) + "</link>" +
                         world_joint.substr(world_joint.find("<joint")) + robot + "</robot>",
                     {"'root_float'", "'world'", "inertial"});
  expect_model_error("<robot name='t'>" + world_joint + robot +
                         "<link name='table'/><joint name='bolt' type='fixed'><parent "
                         "link='world'/><child link='table'/></joint></robot>",
                     {"'root_float'", "'bolt'"});
  // A floating joint inside the tree, and a planar one, are refused by name.
  expect_model_error("<robot name='t'>" + robot + "<link name='c'>" + kInertial +
                         "</link><joint name='loose' type='floating'><parent link='b'/>"
                         "<child link='c'/></joint></robot>",
                     {"'loose'", "floating", "root link", "'b'"});
  expect_model_error("<robot name='t'>" + robot + "<link name='c'>" + kInertial +
                         "</link><joint name='slider' type='planar'><parent link='b'/>"
                         "<child link='c'/><axis xyz='0 0 1'/></joint></robot>",
                     {"'slider'", "planar"});
}

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
