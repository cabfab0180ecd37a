// The depth of every dof in the tree of dofs (Data::v_parent), for Data's cost estimates.
#pragma once

namespace se3::detail {

/// depth[k] = the number of ancestors of dof k, parent(k) its parent dof (-1 for a root), every
/// parent before its child (parent(k) < k). parent is any callable int(int). One look-up per dof:
/// a dof's depth is its parent's plus one (walking every dof's ancestors would be n^2 / 2
/// look-ups for a chain of n).
template <class Parent>
void dof_depths(int nv, Parent&& parent, int* depth) {
  for (int k = 0; k < nv; ++k) {
    const int p = parent(k);
    depth[k] = p >= 0 ? depth[p] + 1 : 0;
  }
}

}  // namespace se3::detail
