#include "se3_sim/model/model.h"

#include <Eigen/Cholesky>
#include <cmath>
#include <limits>
#include <sstream>

namespace se3 {

namespace {
// R = [Q 0; 0 1] exactly: the joint's kernels may then skip R's third row and column.
bool is_z_rotation(const Mat3& R) {
  return R(2, 0) == 0 && R(2, 1) == 0 && R(0, 2) == 0 && R(1, 2) == 0 && R(2, 2) == 1;
}
// k when R maps e_3 exactly onto +-e_k with row k = (0, 0, +-1), for a rotation that is not a
// z rotation; else -1.
signed char axis_row(const Mat3& R) {
  if (is_z_rotation(R)) return -1;
  for (int k = 0; k < 3; ++k) {
    bool ok = R(k, 0) == 0 && R(k, 1) == 0 && (R(k, 2) == 1 || R(k, 2) == -1);
    for (int r = 0; r < 3; ++r) ok = ok && (r == k || R(r, 2) == 0);
    if (ok) return static_cast<signed char>(k);
  }
  return -1;
}
// Entries within 4 ulp of 0 or +-1 become exactly that (cos(pi/2) = 6e-17, products of such
// turns 1e-27, 1 - 2e-16): the joint forms above see the structure the URDF meant, and the
// rotation moves by less than its own rounding. 1.57079632679 in a file is 4.9e-12 off, and
// stays so.
void snap_rotation(Mat3& R) {
  constexpr double tol = 4 * std::numeric_limits<double>::epsilon();
  for (int k = 0; k < 9; ++k) {
    double& x = R.data()[k];
    if (std::abs(x) <= tol)
      x = 0;
    else if (std::abs(std::abs(x) - 1) <= tol)
      x = x > 0 ? 1 : -1;
  }
}
// Bit k set for p[k] != 0 (NaN counts as nonzero).
unsigned char offset_axes(const Vec3& p) {
  return static_cast<unsigned char>((p[0] != 0 ? 1 : 0) | (p[1] != 0 ? 2 : 0) |
                                    (p[2] != 0 ? 4 : 0));
}
}  // namespace

JointModel::JointModel(JointType t) : type(t) {
  nq = (t == JointType::Revolute || t == JointType::Prismatic) ? 1 : 0;
  nv = t == JointType::Free ? 6 : nq;
  kind = dispatch_kind();
}

unsigned char JointModel::dispatch_kind() const {
  const int form = z_rotation ? 1 : axis_row >= 0 ? 2 + axis_row : 0;
  switch (type) {
    case JointType::Revolute:
      return static_cast<unsigned char>(8 * form + (offset_axes & 7));
    case JointType::Prismatic:
      return static_cast<unsigned char>(40 + (z_rotation ? 1 : 0));
    default:
      return 42;
  }
}

Eigen::Matrix<double, 6, Eigen::Dynamic> JointModel::motion_subspace() const {
  Eigen::Matrix<double, 6, Eigen::Dynamic> S =
      Eigen::Matrix<double, 6, Eigen::Dynamic>::Zero(6, nv);
  if (type == JointType::Free) S.setIdentity();
  if (axis() >= 0) S(axis(), 0) = 1;
  return S;
}

SE3 JointModel::transform(const SE3& X_tree, const double* q) const {
  switch (type) {
    case JointType::Revolute:
      return X_tree * SE3(exp_so3(Vec3(0, 0, q[0])), Vec3::Zero());
    case JointType::Prismatic:
      return X_tree * SE3(Mat3::Identity(), Vec3(0, 0, q[0]));
    default:
      return X_tree;
  }
}

const char* JointModel::name() const {
  switch (type) {
    case JointType::Revolute:
      return "revolute";
    case JointType::Prismatic:
      return "prismatic";
    case JointType::Free:
      return "free";
    case JointType::Fixed:
      return "fixed";
  }
  return "unknown";
}

const char* JointModel::urdf_type(bool limited) const {
  switch (type) {
    case JointType::Revolute:
      return limited ? "revolute" : "continuous";
    case JointType::Prismatic:
      return "prismatic";
    default:
      return nullptr;
  }
}

int Model::joint_index(const std::string& joint) const {
  for (int i = 1; i <= n; ++i) {
    if (joint_name[i] == joint) return i;
  }
  return -1;
}

std::string frame_name(const std::string& urdf_link) {
  return !urdf_link.empty() && urdf_link[0] == '/' ? urdf_link.substr(1) : urdf_link;
}

int Model::link_index(const std::string& link) const {
  const std::string name = frame_name(link);
  for (size_t k = 0; k < links.size(); ++k) {
    if (links[k].name == name) return static_cast<int>(k);
  }
  return -1;
}

double Model::total_mass() const {
  double m = 0;
  for (int i = floating ? 0 : 1; i <= n; ++i) m += inertia[i].m;
  return m;
}

bool Model::continuous(int i) const {
  return i >= 1 && i <= n && joints[i].angular() &&
         !(std::isfinite(lower[i]) && std::isfinite(upper[i]));
}

double wrap_angle(double q) {
  if (!std::isfinite(q) || (q > -M_PI && q <= M_PI)) return q;
  // remainder: q - k 2pi for the nearest integer k, exactly (for the double 2pi), in
  // [-pi, pi]; -pi is the same point as pi.
  const double r = std::remainder(q, 2 * M_PI);
  return r <= -M_PI ? r + 2 * M_PI : r;
}

int wrap_continuous_joints(const Model& model, Eigen::VectorXd& q) {
  int changed = 0;
  for (int i = 1; i <= model.n && model.idx_q(i) < q.size(); ++i) {
    if (!model.continuous(i)) continue;
    double& a = q[model.idx_q(i)];
    const double w = wrap_angle(a);
    if (w != a) {
      a = w;
      ++changed;
    }
  }
  return changed;
}

void Model::finalize() {
  joints.resize(n + 1);
  joints[0] = JointModel(floating ? JointType::Free : JointType::Fixed);
  nq = nv = 0;
  for (JointModel& j : joints) {
    j.idx_q = nq;
    j.idx_v = nv;
    nq += j.nq;
    nv += j.nv;
  }
  for (int i = 1; i <= n && i < static_cast<int>(X_tree.size()); ++i) {
    snap_rotation(X_tree[i].R);
    joints[i].z_rotation = is_z_rotation(X_tree[i].R);
    joints[i].axis_row = axis_row(X_tree[i].R);
    joints[i].offset_axes = offset_axes(X_tree[i].p);
  }
  for (JointModel& j : joints) j.kind = j.dispatch_kind();
  children.assign(n + 1, {});
  for (int i = 1; i <= n; ++i) children[parent[i]].push_back(i);
  subtree_end.resize(n + 1);
  for (int i = n; i >= 0; --i) {
    subtree_end[i] = i;
    for (int c : children[i]) subtree_end[i] = std::max(subtree_end[i], subtree_end[c]);
  }
}

void Model::start_with_base(const std::string& root, const Inertia& base_inertia) {
  n = 0;
  root_link = root;
  parent = {-1};
  X_tree = {SE3()};
  joints = {JointModel(JointType::Fixed)};
  inertia = {base_inertia};
  body_name = {root};
  joint_name = {""};
  lower = {0};
  upper = {0};
  effort = {0};
  velocity = {0};
  damping = {0};
  friction = {0};
}

int Model::add_body(int parent_body, JointType type, const SE3& X, const Inertia& I,
                    const std::string& body, const std::string& joint) {
  const double inf = std::numeric_limits<double>::infinity();
  parent.push_back(parent_body);
  X_tree.push_back(X);
  joints.emplace_back(type);
  inertia.push_back(I);
  body_name.push_back(body);
  joint_name.push_back(joint);
  lower.push_back(-inf);
  upper.push_back(inf);
  effort.push_back(inf);
  velocity.push_back(inf);
  damping.push_back(0);
  friction.push_back(0);
  return ++n;
}

void Model::validate() const {
  const size_t nb = static_cast<size_t>(n) + 1;
  if (parent.size() != nb || X_tree.size() != nb || joints.size() != nb || inertia.size() != nb ||
      joint_name.size() != nb || lower.size() != nb || upper.size() != nb || effort.size() != nb ||
      damping.size() != nb || friction.size() != nb || velocity.size() != nb ||
      body_name.size() != nb) {
    throw ModelError("model '" + name + "': per-body arrays do not have n + 1 entries");
  }
  if (joints[0].type != (floating ? JointType::Free : JointType::Fixed)) {
    throw ModelError("model '" + name +
                     "': the base's joint does not match `floating` (finalize())");
  }
  int nq_sum = 0, nv_sum = 0;
  for (int i = 0; i <= n; ++i) {
    const JointModel& j = joints[i];
    if (i > 0 && j.axis() < 0) {
      throw ModelError("joint '" + joint_name[i] + "': a " + j.name() +
                       " joint can only be the base's");
    }
    if (j.idx_q != nq_sum || j.idx_v != nv_sum || JointModel(j.type).nq != j.nq ||
        JointModel(j.type).nv != j.nv ||
        (i > 0 &&
         (j.z_rotation != is_z_rotation(X_tree[i].R) || j.axis_row != axis_row(X_tree[i].R) ||
          j.offset_axes != offset_axes(X_tree[i].p))) ||
        j.kind != j.dispatch_kind()) {
      throw ModelError("model '" + name + "': joint coordinates out of order (finalize())");
    }
    nq_sum += j.nq;
    nv_sum += j.nv;
  }
  if (nq_sum != nq || nv_sum != nv) {
    throw ModelError("model '" + name + "': nq or nv does not match the joints (finalize())");
  }
  for (int i = 1; i <= n; ++i) {
    if (parent[i] < 0 || parent[i] >= i) {
      throw ModelError("joint '" + joint_name[i] + "': bodies are not in topological order");
    }
  }
  // Composite inertia of every subtree at q = 0 (exp(S 0) = identity, so Xup = X_tree). A joint
  // that moves nothing with inertia about its axis makes D singular (S^T Ic S = 0 in eq. 50).
  std::vector<Inertia> Ic(inertia);
  for (int i = n; i >= 1; --i) Ic[parent[i]] += Ic[i].transformed(X_tree[i]);
  for (int i = 1; i <= n; ++i) {
    const int k = joints[i].axis();  // S^T Ic S = Ic(k, k) for S = e_k
    const double about_axis = Ic[i].matrix()(k, k);
    if (!(about_axis > 1e-15)) {
      throw ModelError("joint '" + joint_name[i] +
                       "': its subtree has no mass or inertia about the joint axis");
    }
  }
  if (floating) {
    // A massless free base makes the first joint's motion a duplicate of the base's own
    // (D singular): the base itself must carry a positive-definite inertia.
    const Eigen::LLT<Mat6> llt(inertia[0].matrix());
    if (llt.info() != Eigen::Success || !(inertia[0].m > 0)) {
      throw ModelError("link '" + body_name[0] +
                       "': a free-floating base needs mass and a positive-definite inertia "
                       "(with the links fixed to it)");
    }
  }
}

Model make_chain(int n, bool floating, const std::vector<double>& masses, double length) {
  Model m;
  m.name = "chain" + std::to_string(n);
  m.floating = floating;
  const double w = 0.04;
  auto box_inertia = [&](double mass, double L) {
    Mat3 I = Mat3::Zero();
    I(0, 0) = mass / 12.0 * (2 * w * w);
    I(1, 1) = I(2, 2) = mass / 12.0 * (L * L + w * w);
    return Inertia::from_com(mass, Vec3(0.5 * L, 0, 0), I);
  };
  auto mass_of = [&](int i) { return masses.empty() ? 1.0 : masses[i % masses.size()]; };
  m.start_with_base("base", box_inertia(mass_of(0), length));
  m.links.push_back({"base", 0, SE3()});
  // Successive joint axes cycle through the parent's z, y and x directions.
  const Mat3 turns[3] = {Mat3::Identity(),
                         Eigen::AngleAxisd(-M_PI / 2, Vec3::UnitX()).toRotationMatrix(),
                         Eigen::AngleAxisd(M_PI / 2, Vec3::UnitY()).toRotationMatrix()};
  for (int i = 1; i <= n; ++i) {
    m.add_body(i - 1, JointType::Revolute, SE3(turns[i % 3], Vec3(length, 0, 0)),
               box_inertia(mass_of(i), length), "link" + std::to_string(i),
               "j" + std::to_string(i));
    m.links.push_back({m.body_name.back(), i, SE3(), i - 1, m.joint_name.back(), false});
  }
  m.finalize();
  m.validate();
  return m;
}

}  // namespace se3
