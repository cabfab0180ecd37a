// Forward kinematics: the product of exponentials f_0j = f_0 prod KK_k exp(S_k q_k) (section 5),
// and the twist recursion (33) that every algorithm and the energy functions share.
#include "joint.h"
#include "se3_sim/dynamics/dynamics.h"
#include "sincos.h"

namespace se3 {
namespace detail {

void joint_transforms(const Model& model, Data& data, const VecX& q) {
  double* s = data.sin_q.data();
  double* c = data.cos_q.data();
  sincos_n(q.data(), model.nq, s, c);  // prismatic joints get values nobody reads
  for (int i = 1; i <= model.n; ++i) {
    const JointModel& jm = model.joints[i];
    const int k = jm.idx_q;
    with_joint_form(jm, [&](auto J) SE3_LAMBDA {
      J.transform(model.X_tree[i], q[k], c[k], s[k], data.Xup[i]);
    });
  }
}

}  // namespace detail

void forward_kinematics(const Model& model, Data& data, const SE3& base, const VecX& q) {
  detail::joint_transforms(model, data, q);
  data.oMb[0] = base;
  for (int i = 1; i <= model.n; ++i) {
    detail::with_joint(model.joints[i], [&](auto J) SE3_LAMBDA {
      detail::compose(J, data.oMb[model.parent[i]], data.Xup[i], data.oMb[i]);
    });
  }
}

void body_twists(const Model& model, Data& data, const VecX& v) {
  if (model.floating) {
    data.V[0] = v.head<6>();
  } else {
    data.V[0].setZero();
  }
  for (int i = 1; i <= model.n; ++i) {
    const JointModel& jm = model.joints[i];
    detail::with_joint(jm, [&](auto J) SE3_LAMBDA {
      detail::child_twist(J, data.Xup[i], data.V[model.parent[i]].data(), v[jm.idx_v],
                          data.V[i].data());
    });
  }
}

void forward_kinematics(const Model& model, Data& data, const SE3& base, const VecX& q,
                        const VecX& v) {
  forward_kinematics(model, data, base, q);
  body_twists(model, data, v);
}

}  // namespace se3
