// URDF -> Model: fixed joints merged into their parent body, moving joints turned so that
// their axis is the body's z axis (the paper's eq. (26) S_j = e_z).
#include <urdf_parser/urdf_parser.h>

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <sstream>
#include <unordered_map>
#include <vector>

#include "se3_sim/model/limits.h"
#include "se3_sim/model/model.h"
#include "urdf_guard.h"
#include "urdf_mimic.h"
#include "urdf_quirks.h"

namespace se3 {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

// A rotation whose third column is the unit vector a (identity when a = e_z).
Mat3 frame_with_z(const Vec3& a) {
  if ((a - Vec3::UnitZ()).norm() < 1e-15) return Mat3::Identity();
  return Eigen::Quaterniond::FromTwoVectors(Vec3::UnitZ(), a).toRotationMatrix();
}

struct ModelBuilder {
  const urdf::ModelInterface& urdf;
  const UrdfOptions& opt;
  Model m;

  void add_body(int parent, const SE3& X_tree, JointType type, const urdf::Joint& j) {
    m.parent.push_back(parent);
    m.X_tree.push_back(X_tree);
    m.joints.emplace_back(type);
    m.inertia.emplace_back();
    m.body_name.push_back(frame_name(j.child_link_name));
    m.joint_name.push_back(j.name);
    double lo = -kInf, hi = kInf, eff = kInf, vel = kInf;
    if (j.limits && j.type != urdf::Joint::CONTINUOUS) {
      lo = j.limits->lower;
      hi = j.limits->upper;
      if (lo >= hi) lo = -kInf, hi = kInf;  // URDF's "no limits" for lower == upper == 0
    }
    if (j.limits) {
      if (j.limits->effort > 0) eff = j.limits->effort;
      if (j.limits->velocity > 0) vel = j.limits->velocity;
    }
    m.lower.push_back(lo);
    m.upper.push_back(hi);
    m.effort.push_back(eff);
    m.velocity.push_back(vel);
    m.damping.push_back(j.dynamics ? j.dynamics->damping : 0.0);
    m.friction.push_back(j.dynamics ? j.dynamics->friction : 0.0);
    ++m.n;
  }

  std::unordered_map<std::string, double> locked;  ///< opt.locked, looked up per joint

  double locked_position(const std::string& joint, bool& found) const {
    const auto it = locked.find(joint);
    found = it != locked.end();
    return found ? it->second : 0.0;
  }

  // parent: index in m.links of the URDF parent link (-1 for the root), j the joint from it.
  void add_link_data(const urdf::Link& link, int body, const SE3& O, int parent,
                     const urdf::Joint* j) {
    const std::string name = frame_name(link.name);
    if (m.link_index(name) >= 0) {
      throw ModelError("link '" + link.name + "': its frame name '" + name +
                       "' is another link's (a leading '/' is stripped, as tf2 does)");
    }
    m.links.push_back(
        {name, body, O, parent, j ? j->name : std::string(), j && j->type == urdf::Joint::FIXED});
    if (link.inertial) add_inertial(link, body, O);
  }

  void add_inertial(const urdf::Link& link, int body, const SE3& O) {
    const urdf::Inertial& in = *link.inertial;
    const double mass = in.mass;
    Mat3 I;
    I << in.ixx, in.ixy, in.ixz, in.ixy, in.iyy, in.iyz, in.ixz, in.iyz, in.izz;
    if (!std::isfinite(mass) || !I.allFinite()) {
      throw ModelError("link '" + link.name + "': inertial has a non-finite number");
    }
    if (mass < 0) throw ModelError("link '" + link.name + "': negative mass");
    if (mass == 0) {
      if (I.cwiseAbs().maxCoeff() > 0) {
        m.warnings.push_back("link '" + link.name +
                             "': rotational inertia without mass, treated as massless");
      }
      return;  // massless link (URDF's rule for a missing inertial, too)
    }
    // A link may be a thin rod (one principal moment zero, as anymal_c's 'hatch'); what the
    // dynamics needs is checked on the merged bodies in check_bodies().
    Eigen::SelfAdjointEigenSolver<Mat3> es(I, Eigen::EigenvaluesOnly);
    const Vec3 ev = es.eigenvalues();
    if (!(ev.minCoeff() >= -1e-9 * std::max(1.0, ev.maxCoeff()))) {
      std::ostringstream os;
      os << "link '" << link.name << "': inertia is not positive definite (principal moments "
         << ev.transpose() << ")";
      throw ModelError(os.str());
    }
    const double tol = 1e-12 * ev.maxCoeff();
    if (ev(0) + ev(1) < ev(2) - tol) {
      std::ostringstream os;
      os << "link '" << link.name << "': principal moments " << ev.transpose()
         << " break the triangle inequality (physically inconsistent; kept as given)";
      m.warnings.push_back(os.str());
    }
    const SE3 Tc = O * se3_from_urdf(in.origin);  // inertial frame in body frame
    const Mat3 I_body = Tc.R * I * Tc.R.transpose();
    m.inertia[body] += Inertia::from_com(mass, Tc.p, I_body);
  }

  // Depth-first, children in URDF order: a body's subtree is contiguous, and parent[i] < i.
  // An explicit stack instead of recursion: a chain of thousands of links overflowed the call
  // stack. Each entry is a link being visited, its index in m.links and the next of its child
  // joints to take.
  struct Visit {
    const urdf::Link* link;
    int body;
    SE3 O;
    int self;
    size_t next = 0;
  };

  void visit(const urdf::Link& root, int root_body, const SE3& root_O) {
    std::vector<Visit> stack;
    // parent: index in m.links of the URDF parent link (-1 for the root), from the joint to it.
    auto enter = [&](const urdf::Link& link, int body, const SE3& O, int parent,
                     const urdf::Joint* from) {
      const int self = static_cast<int>(m.links.size());
      add_link_data(link, body, O, parent, from);
      stack.push_back({&link, body, O, self});
    };
    enter(root, root_body, root_O, -1, nullptr);
    while (!stack.empty()) {
      Visit& top = stack.back();
      if (top.next == top.link->child_joints.size()) {
        stack.pop_back();
        continue;
      }
      const urdf::JointSharedPtr& jp = top.link->child_joints[top.next++];
      const urdf::Joint* j = jp.get();
      const int body = top.body, self = top.self;
      const SE3 O = top.O;  // copies: enter() may move the stack
      const urdf::LinkConstSharedPtr child = urdf.getLink(j->child_link_name);
      if (!child) throw ModelError("joint '" + j->name + "': child link missing");
      const SE3 T = O * se3_from_urdf(j->parent_to_joint_origin_transform);
      Vec3 axis(j->axis.x, j->axis.y, j->axis.z);
      bool is_locked = false;
      const double ql = locked_position(j->name, is_locked);
      switch (j->type) {
        case urdf::Joint::FIXED:
          enter(*child, body, T, self, j);
          break;
        case urdf::Joint::REVOLUTE:
        case urdf::Joint::CONTINUOUS:
        case urdf::Joint::PRISMATIC: {
          if (!(axis.norm() > 1e-12) || !axis.allFinite()) {
            throw ModelError("joint '" + j->name + "': axis is zero");
          }
          axis.normalize();
          const bool prismatic = j->type == urdf::Joint::PRISMATIC;
          if (is_locked) {
            const SE3 motion = prismatic ? SE3(Mat3::Identity(), ql * axis)
                                         : SE3(exp_so3(ql * axis), Vec3::Zero());
            enter(*child, body, T * motion, self, j);
            break;
          }
          const Mat3 Ra = frame_with_z(axis);
          const int i = m.n + 1;
          add_body(body, T * SE3(Ra, Vec3::Zero()),
                   prismatic ? JointType::Prismatic : JointType::Revolute, *j);
          enter(*child, i, SE3(Ra.transpose(), Vec3::Zero()), self, j);
          break;
        }
        case urdf::Joint::FLOATING:
          throw ModelError("joint '" + j->name +
                           "': a floating joint is supported only from the "
                           "URDF's root link (the world) to the robot's base; its parent is '" +
                           j->parent_link_name + "'");
        case urdf::Joint::PLANAR:
          throw ModelError("joint '" + j->name +
                           "': type planar is not supported (lock it, or model it as two "
                           "prismatic joints and a revolute joint)");
        default:
          throw ModelError("joint '" + j->name + "': unknown joint type");
      }
    }
  }
};

// The link the model's base starts from: the URDF's root, or, when the root holds only a
// floating joint (the root is then the world, as in many URDFs), that joint's child, which
// becomes the free base with the joint's origin as its rest pose.
const urdf::Link& base_link(const urdf::ModelInterface& u, const urdf::Link& root, Model& m) {
  const urdf::JointSharedPtr* fl = nullptr;
  for (const auto& j : root.child_joints) {
    if (j->type == urdf::Joint::FLOATING) fl = &j;
  }
  if (!fl) return root;
  const urdf::Joint& j = **fl;
  for (const auto& other : root.child_joints) {
    if (other.get() != &j) {
      throw ModelError("joint '" + j.name + "': the root link '" + root.name +
                       "' before this floating joint is the world and may hold no other joint ('" +
                       other->name + "')");
    }
  }
  if (root.inertial || root.visual || root.collision || !root.visual_array.empty() ||
      !root.collision_array.empty()) {
    throw ModelError("joint '" + j.name + "': the root link '" + root.name +
                     "' before this floating joint is the world and may have no inertial, "
                     "visual or collision");
  }
  const urdf::LinkConstSharedPtr child = u.getLink(j.child_link_name);
  if (!child) throw ModelError("joint '" + j.name + "': child link missing");
  m.floating = true;
  m.X_tree[0] = se3_from_urdf(j.parent_to_joint_origin_transform);
  return *child;
}

}  // namespace

namespace {

// Owns a parsed URDF; releases its link tree without recursion (UrdfRelease).
struct UrdfOwner {
  urdf::ModelInterfaceSharedPtr u;
  ~UrdfOwner() { const UrdfRelease release(u); }
};

}  // namespace

SE3 se3_from_urdf(const urdf::Pose& p) {
  double x, y, z, w;
  p.rotation.getQuaternion(x, y, z, w);
  return SE3(rotation_from_quaternion(x, y, z, w), Vec3(p.position.x, p.position.y, p.position.z));
}

UrdfDocument parse_urdf_document(const std::string& xml) {
  check_urdf_text(xml);  // urdf_guard.h: size and nesting before tinyxml recurses
  UrdfDocument doc;
  const std::string text = urdf_text_quirks(xml, doc.warnings);  // urdf_quirks.h
  std::string err;
  auto owner = std::make_shared<UrdfOwner>();
  owner->u = parse_urdf(text, err, &doc.complaints);
  if (!owner->u) throw ModelError("URDF rejected by urdfdom: " + err);
  check_urdf_joints(*owner->u);
  check_urdf_mimics(*owner->u);
  if (!owner->u->getRoot()) throw ModelError("URDF has no root link");
  // Joints that move only massless links: locked (with the user's locks, in model_from_urdf).
  urdf_model_quirks(*owner->u, doc.massless, doc.warnings);
  {
    std::vector<std::string> links, joints;
    for (const auto& kv : owner->u->links_) links.push_back(kv.first);
    for (const auto& kv : owner->u->joints_) joints.push_back(kv.first);
    doc.gazebo = read_gazebo_tags(text, links, joints);
    doc.warnings.insert(doc.warnings.end(), doc.gazebo.warnings.begin(), doc.gazebo.warnings.end());
  }
  doc.urdf = std::shared_ptr<const urdf::ModelInterface>(owner, owner->u.get());
  return doc;
}

UrdfDocument read_urdf_document(const std::string& path) {
  std::string text, why;
  if (!read_file(path, text, &why, limits::kMaxUrdfBytes)) {
    const bool big = why.find(" bytes, more than the ") != std::string::npos;
    throw ModelError((big ? "URDF file '" : "cannot read URDF file '") + path + "': " + why +
                     (big ? " bytes a URDF may have; see the limits in docs/robustness.md" : ""));
  }
  try {
    UrdfDocument doc = parse_urdf_document(text);
    doc.file = path;
    return doc;
  } catch (const ModelError& e) {
    throw ModelError("URDF file '" + path + "': " + e.what());
  }
}

Model model_from_urdf(const UrdfDocument& doc, const UrdfOptions& options) {
  if (!doc.urdf) throw ModelError("URDF: no document");
  const urdf::ModelInterface& u = *doc.urdf;
  const urdf::LinkConstSharedPtr root = u.getRoot();
  if (!root) throw ModelError("URDF has no root link");

  UrdfOptions opt = options;
  for (const auto& kv : doc.massless) {
    const bool given = std::any_of(opt.locked.begin(), opt.locked.end(),
                                   [&](const auto& l) { return l.first == kv.first; });
    if (!given) opt.locked.push_back(kv);
  }
  ModelBuilder b{u, opt, Model{}, {}};
  for (const auto& kv : opt.locked) b.locked.emplace(kv.first, kv.second);
  b.m.warnings = doc.warnings;
  Model& m = b.m;
  m.name = u.getName();
  m.floating = opt.floating;
  m.start_with_base(frame_name(root->name));
  for (const auto& c : doc.complaints) m.warnings.push_back("urdfdom: " + c);
  const urdf::Link& start = base_link(u, *root, m);
  m.root_link = m.body_name[0] = frame_name(start.name);
  b.visit(start, 0, SE3());
  // Every moving body (and a free base) must have a positive-definite spatial inertia, eq. (23),
  // or be massless (then its subtree check in validate() decides).
  for (int i = m.floating ? 0 : 1; i <= m.n; ++i) {
    if (m.inertia[i].m == 0) continue;
    const Eigen::LLT<Mat6> llt(m.inertia[i].matrix());
    if (llt.info() != Eigen::Success) {
      throw ModelError("link '" + m.body_name[i] +
                       "': spatial inertia of the body (with the links fixed to it) is not "
                       "positive definite");
    }
  }
  for (const auto& kv : opt.locked) {
    if (!u.getJoint(kv.first)) {
      throw ModelError("locked joint '" + kv.first + "' is not in the URDF");
    }
  }
  m.finalize();
  m.validate();
  read_mimics(u, m);
  group_quirk_warnings(m.warnings);
  return m;
}

Model model_from_urdf_string(const std::string& xml, const UrdfOptions& opt) {
  return model_from_urdf(parse_urdf_document(xml), opt);
}

Model model_from_urdf_file(const std::string& path, const UrdfOptions& opt) {
  return model_from_urdf(read_urdf_document(path), opt);
}

}  // namespace se3
