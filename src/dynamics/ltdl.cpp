// The mass matrix factorized along the tree, D = L^T Diag L (Featherstone's LTDL, Rigid Body
// Dynamics Algorithms, sec. 6.5), and the two triangular solves that apply D^-1 with it.
// Numbering the dofs so that a dof's parent (Data::v_parent) precedes it, L(k, i) is non-zero
// only for i an ancestor of k: eliminating the leaves first creates no fill-in, and every loop
// below walks a dof's ancestors alone.
#include "se3_sim/dynamics/dynamics.h"

namespace se3 {

// The loops run 1 to depth times: GCC's vectorized versions (alias checks, peeling) cost more
// than they save at these lengths.
#if defined(__GNUC__) && !defined(__clang__)
__attribute__((optimize("no-tree-vectorize")))
#endif
const MatX&
mass_matrix_ltdl(const Model& model, Data& data, const SE3& base, const VecX& q) {
  const int nv = model.nv;
  const MatX& M = crba(model, data, base, q);
  MatX& LD = data.LD;
  double* H = LD.data();  // column-major: H[r + nv c]
  const int* lam = data.v_parent.data();
  const auto at = [nv](int r, int c) { return r + static_cast<std::ptrdiff_t>(c) * nv; };
  for (int c = 0; c < nv; ++c) {
    for (int r = c; r < nv; ++r) H[at(r, c)] = M(r, c);
  }
  // The leaves first: row k's ancestors i update rows i's ancestor entries.
  for (int k = nv - 1; k > 0; --k) {
    const double dk = H[at(k, k)];
    for (int i = lam[k]; i >= 0; i = lam[i]) {
      const double a = H[at(k, i)] / dk;
      for (int j = i; j >= 0; j = lam[j]) H[at(i, j)] -= a * H[at(k, j)];
      H[at(k, i)] = a;
    }
  }
  double* dinv = data.Dinv.data();
  for (int k = 0; k < nv; ++k) dinv[k] = 1.0 / H[at(k, k)];
  return LD;
}

void ltdl_solve_lt(const Data& data, double* x) {
  // L^T y = x: y_k is final once every descendant (all of index > k) is done.
  const MatX& L = data.LD;
  const int* lam = data.v_parent.data();
  for (int k = static_cast<int>(L.rows()) - 1; k > 0; --k) {
    const double xk = x[k];
    if (xk == 0) continue;
    for (int i = lam[k]; i >= 0; i = lam[i]) x[i] -= L(k, i) * xk;
  }
}

void ltdl_solve_l(const Data& data, double* x) {
  // L y = x: y_k = x_k - sum over ancestors i of L(k, i) y_i, the root first.
  const MatX& L = data.LD;
  const int* lam = data.v_parent.data();
  const int nv = static_cast<int>(L.rows());
  for (int k = 1; k < nv; ++k) {
    double s = x[k];
    for (int i = lam[k]; i >= 0; i = lam[i]) s -= L(k, i) * x[i];
    x[k] = s;
  }
}

}  // namespace se3
