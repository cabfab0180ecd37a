// Forward kinematics: the product of exponentials f_0j = f_0 prod KK_k exp(S_k q_k) (section 5).
#include "joint.h"
#include "se3_sim/dynamics.h"

namespace se3 {

void forward_kinematics(const Model& model, Data& data, const SE3& base, const VecX& q) {
  data.oMb[0] = base;
  for (int i = 1; i <= model.n; ++i) {
    detail::joint_transform(model.X_tree[i], model.joint_type[i], q[i - 1], data.Xup[i]);
    data.oMb[i] = data.oMb[model.parent[i]] * data.Xup[i];
  }
}

}  // namespace se3
