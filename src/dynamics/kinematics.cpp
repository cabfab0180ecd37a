// Forward kinematics: the product of exponentials f_0j = f_0 prod KK_k exp(S_k q_k) (section 5).
#include "joint.h"
#include "se3_sim/dynamics.h"
#include "sincos.h"

namespace se3 {
namespace detail {

void joint_transforms(const Model& model, Data& data, const VecX& q) {
  const int n = model.n;
  double* s = data.sin_q.data() + 1;
  double* c = data.cos_q.data() + 1;
  sincos_n(q.data(), n, s, c);  // prismatic joints get values nobody reads
  for (int i = 1; i <= n; ++i) {
    if (model.joint_type[i] == JointType::Revolute) {
      revolute_transform(model.X_tree[i], data.cos_q[i], data.sin_q[i], data.Xup[i]);
    } else {
      prismatic_transform(model.X_tree[i], q[i - 1], data.Xup[i]);
    }
  }
}

}  // namespace detail

void forward_kinematics(const Model& model, Data& data, const SE3& base, const VecX& q) {
  detail::joint_transforms(model, data, q);
  data.oMb[0] = base;
  for (int i = 1; i <= model.n; ++i) {
    data.oMb[i] = data.oMb[model.parent[i]] * data.Xup[i];
  }
}

}  // namespace se3
