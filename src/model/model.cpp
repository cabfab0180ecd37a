#include "se3_sim/model.h"

#include <Eigen/Cholesky>
#include <cmath>
#include <limits>
#include <sstream>

namespace se3 {

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

void Model::finalize() {
  nv = n + (floating ? 6 : 0);
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
  joint_type = {JointType::Revolute};
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

void Model::validate() const {
  const size_t nb = static_cast<size_t>(n) + 1;
  if (parent.size() != nb || X_tree.size() != nb || joint_type.size() != nb ||
      inertia.size() != nb || joint_name.size() != nb || lower.size() != nb || upper.size() != nb ||
      effort.size() != nb || damping.size() != nb || friction.size() != nb ||
      velocity.size() != nb || body_name.size() != nb) {
    throw ModelError("model '" + name + "': per-body arrays do not have n + 1 entries");
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
    const double about_axis = joint_type[i] == JointType::Revolute ? Ic[i].I(2, 2) : Ic[i].m;
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
  const double inf = std::numeric_limits<double>::infinity();
  m.start_with_base("base", box_inertia(mass_of(0), length));
  m.links.push_back({"base", 0, SE3()});
  // Successive joint axes cycle through the parent's z, y and x directions.
  const Mat3 turns[3] = {Mat3::Identity(),
                         Eigen::AngleAxisd(-M_PI / 2, Vec3::UnitX()).toRotationMatrix(),
                         Eigen::AngleAxisd(M_PI / 2, Vec3::UnitY()).toRotationMatrix()};
  for (int i = 1; i <= n; ++i) {
    m.parent.push_back(i - 1);
    m.X_tree.push_back(SE3(turns[i % 3], Vec3(length, 0, 0)));
    m.joint_type.push_back(JointType::Revolute);
    m.inertia.push_back(box_inertia(mass_of(i), length));
    m.body_name.push_back("link" + std::to_string(i));
    m.joint_name.push_back("j" + std::to_string(i));
    m.lower.push_back(-inf);
    m.upper.push_back(inf);
    m.effort.push_back(inf);
    m.velocity.push_back(inf);
    m.damping.push_back(0);
    m.friction.push_back(0);
    m.links.push_back({m.body_name.back(), i, SE3(), i - 1, m.joint_name.back(), false});
    m.n = i;
  }
  m.finalize();
  m.validate();
  return m;
}

}  // namespace se3
