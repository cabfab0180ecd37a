// URDF -> Model: fixed joints merged into their parent body, moving joints turned so that
// their axis is the body's z axis (the paper's eq. (26) S_j = e_z).
#include <console_bridge/console.h>
#include <urdf_parser/urdf_parser.h>

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <cmath>
#include <fstream>
#include <functional>
#include <limits>
#include <mutex>
#include <sstream>

#include "se3_sim/model.h"
#include "urdf_quirks.h"

namespace se3 {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

// Collects urdfdom's console_bridge messages so a rejection becomes one clear line.
class CaptureHandler : public console_bridge::OutputHandler {
 public:
  void log(const std::string& text, console_bridge::LogLevel level, const char*, int) override {
    if (level >= console_bridge::CONSOLE_BRIDGE_LOG_ERROR && first_error.empty())
      first_error = text;
  }
  std::string first_error;
};

SE3 to_se3(const urdf::Pose& p) {
  double x, y, z, w;
  p.rotation.getQuaternion(x, y, z, w);
  return SE3(rotation_from_quaternion(x, y, z, w), Vec3(p.position.x, p.position.y, p.position.z));
}

// A rotation whose third column is the unit vector a (identity when a = e_z).
Mat3 frame_with_z(const Vec3& a) {
  if ((a - Vec3::UnitZ()).norm() < 1e-15) return Mat3::Identity();
  return Eigen::Quaterniond::FromTwoVectors(Vec3::UnitZ(), a).toRotationMatrix();
}

bool convert_geometry(const urdf::GeometrySharedPtr& g, Geometry& out) {
  if (!g) return false;
  switch (g->type) {
    case urdf::Geometry::BOX: {
      auto b = std::static_pointer_cast<urdf::Box>(g);
      out.type = GeometryType::Box;
      out.size = Vec3(b->dim.x, b->dim.y, b->dim.z);
      return true;
    }
    case urdf::Geometry::CYLINDER: {
      auto c = std::static_pointer_cast<urdf::Cylinder>(g);
      out.type = GeometryType::Cylinder;
      out.size = Vec3(c->radius, c->length, 0);
      return true;
    }
    case urdf::Geometry::SPHERE: {
      auto s = std::static_pointer_cast<urdf::Sphere>(g);
      out.type = GeometryType::Sphere;
      out.size = Vec3(s->radius, 0, 0);
      return true;
    }
    case urdf::Geometry::MESH: {
      auto m = std::static_pointer_cast<urdf::Mesh>(g);
      out.type = GeometryType::Mesh;
      out.mesh = m->filename;
      out.mesh_scale = Vec3(m->scale.x, m->scale.y, m->scale.z);
      return true;
    }
  }
  return false;
}

struct Builder {
  const urdf::ModelInterface& urdf;
  const UrdfOptions& opt;
  Model m;

  void add_body(int parent, const SE3& X_tree, JointType type, const urdf::Joint& j) {
    m.parent.push_back(parent);
    m.X_tree.push_back(X_tree);
    m.joint_type.push_back(type);
    m.inertia.emplace_back();
    m.body_name.push_back(j.child_link_name);
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

  double locked_position(const std::string& joint, bool& found) const {
    for (const auto& kv : opt.locked) {
      if (kv.first == joint) {
        found = true;
        return kv.second;
      }
    }
    found = false;
    return 0;
  }

  // parent: index in m.links of the URDF parent link (-1 for the root), j the joint from it.
  void add_link_data(const urdf::Link& link, int body, const SE3& O, int parent,
                     const urdf::Joint* j) {
    m.links.push_back({link.name, body, O, parent, j ? j->name : std::string(),
                       j && j->type == urdf::Joint::FIXED});
    if (link.inertial) add_inertial(link, body, O);
    auto add_geoms = [&](const auto& arr, const auto& single, std::vector<Geometry>& dst,
                         std::vector<int>& dst_body, bool visual) {
      auto add = [&](const auto& v) {
        if (!v) return;
        Geometry g;
        if (!convert_geometry(v->geometry, g)) return;
        g.origin = O * to_se3(v->origin);
        g.link = link.name;
        if constexpr (std::is_same_v<std::decay_t<decltype(*v)>, urdf::Visual>) {
          urdf::MaterialSharedPtr mat = v->material;
          if (!mat && !v->material_name.empty()) mat = urdf.getMaterial(v->material_name);
          if (mat && (mat->color.r + mat->color.g + mat->color.b + mat->color.a) > 0) {
            g.rgba = Eigen::Vector4d(mat->color.r, mat->color.g, mat->color.b, mat->color.a);
            g.has_color = true;
          }
        }
        (void)visual;
        dst.push_back(g);
        dst_body.push_back(body);
      };
      if (!arr.empty()) {
        for (const auto& v : arr) add(v);
      } else {
        add(single);
      }
    };
    add_geoms(link.visual_array, link.visual, m.visuals, m.visual_body, true);
    add_geoms(link.collision_array, link.collision, m.collisions, m.collision_body, false);
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
    const SE3 Tc = O * to_se3(in.origin);  // inertial frame in body frame
    const Mat3 I_body = Tc.R * I * Tc.R.transpose();
    m.inertia[body] += Inertia::from_com(mass, Tc.p, I_body);
  }

  // Depth-first: a body's subtree is contiguous, and parent[i] < i.
  void visit(const urdf::Link& link, int body, const SE3& O, int parent_link = -1,
             const urdf::Joint* from = nullptr) {
    const int self = static_cast<int>(m.links.size());
    add_link_data(link, body, O, parent_link, from);
    for (const auto& j : link.child_joints) {
      const urdf::LinkConstSharedPtr child = urdf.getLink(j->child_link_name);
      if (!child) throw ModelError("joint '" + j->name + "': child link missing");
      const SE3 T = O * to_se3(j->parent_to_joint_origin_transform);
      Vec3 axis(j->axis.x, j->axis.y, j->axis.z);
      bool locked = false;
      const double ql = locked_position(j->name, locked);
      switch (j->type) {
        case urdf::Joint::FIXED:
          visit(*child, body, T, self, j.get());
          break;
        case urdf::Joint::REVOLUTE:
        case urdf::Joint::CONTINUOUS:
        case urdf::Joint::PRISMATIC: {
          if (!(axis.norm() > 1e-12) || !axis.allFinite()) {
            throw ModelError("joint '" + j->name + "': axis is zero");
          }
          axis.normalize();
          const bool prismatic = j->type == urdf::Joint::PRISMATIC;
          if (locked) {
            const SE3 motion = prismatic ? SE3(Mat3::Identity(), ql * axis)
                                         : SE3(exp_so3(ql * axis), Vec3::Zero());
            visit(*child, body, T * motion, self, j.get());
            break;
          }
          const Mat3 Ra = frame_with_z(axis);
          const int i = m.n + 1;
          add_body(body, T * SE3(Ra, Vec3::Zero()),
                   prismatic ? JointType::Prismatic : JointType::Revolute, *j);
          visit(*child, i, SE3(Ra.transpose(), Vec3::Zero()), self, j.get());
          break;
        }
        case urdf::Joint::FLOATING:
          throw ModelError("joint '" + j->name +
                           "': type floating is not supported inside the tree (a free base is "
                           "chosen with --floating / base: free)");
        case urdf::Joint::PLANAR:
          throw ModelError("joint '" + j->name + "': type planar is not supported");
        default:
          throw ModelError("joint '" + j->name + "': unknown joint type");
      }
    }
  }
};

std::mutex g_console_mutex;

}  // namespace

Model model_from_urdf_string(const std::string& xml, const UrdfOptions& options) {
  std::vector<std::string> quirks;
  const std::string text = urdf_text_quirks(xml, quirks);  // urdf_quirks.h
  urdf::ModelInterfaceSharedPtr u;
  std::string err;
  {
    std::lock_guard<std::mutex> lock(g_console_mutex);
    CaptureHandler h;
    console_bridge::OutputHandler* previous = console_bridge::getOutputHandler();
    console_bridge::useOutputHandler(&h);
    try {
      u = urdf::parseURDF(text);
    } catch (const std::exception& e) {
      h.first_error = e.what();
    }
    console_bridge::useOutputHandler(previous);
    err = h.first_error;
  }
  if (!u) {
    throw ModelError("URDF rejected by urdfdom: " +
                     (err.empty() ? std::string("parse error") : err));
  }
  const urdf::LinkConstSharedPtr root = u->getRoot();
  if (!root) throw ModelError("URDF has no root link");

  UrdfOptions opt = options;
  urdf_model_quirks(*u, opt.locked, quirks);  // joints that move only massless links: locked
  Builder b{*u, opt, Model{}};
  b.m.warnings = quirks;
  Model& m = b.m;
  m.name = u->getName();
  m.floating = opt.floating;
  m.start_with_base(root->name);
  b.visit(*root, 0, SE3());
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
    if (!u->getJoint(kv.first)) {
      throw ModelError("locked joint '" + kv.first + "' is not in the URDF");
    }
  }
  m.finalize();
  m.validate();
  group_quirk_warnings(m.warnings);
  return m;
}

Model model_from_urdf_file(const std::string& path, const UrdfOptions& opt) {
  std::ifstream f(path);
  if (!f) throw ModelError("cannot read URDF file '" + path + "'");
  std::stringstream ss;
  ss << f.rdbuf();
  return model_from_urdf_string(ss.str(), opt);
}

}  // namespace se3
