// The solver layer: pure functions over the Delassus matrix W = J D^-1 J^T of a step's rows
// (constraint.h) and the free residual c = J v* - b; they find the impulses p so that every row's
// velocity residual r = c + W p meets its law:
//   equality: r = 0;  joint limit, contact normal: p >= 0, r >= 0, p r = 0;
//   friction (two rows per contact, found through ConstraintRows::friction): (p_t1, p_t2) in the
//   disc of radius mu p_n, and when sliding (r_t != 0) opposing r_t at the disc's edge.
// Three solvers:
//   - solve_equality: the multipliers of eq. (32) (W x = rhs for equality rows alone) by LDLT,
//     and when W is rank deficient (redundant constraints: a pivot below singular_tol times the
//     largest) the minimum-norm least-squares solution from an eigen-decomposition (the
//     pseudo-inverse);
//   - solve_pgs: projected Gauss-Seidel, one row at a time (a contact's two friction rows
//     together, projected on the disc), warm-started from p; cheap, but soft where impulses
//     must travel through many contacts (stacks) within few sweeps;
//   - solve_active_set: a Newton-type direct method (the active-set form of semi-smooth Newton
//     on the complementarity conditions, Alart and Curnier's for friction): guess which contacts
//     separate, stick or slide, solve the linear system of the active rows exactly (LU with
//     partial pivoting, a relative regularization `regularization` W_ii on the diagonal for
//     redundant contacts), a sliding contact's friction rows replaced by Newton's linearization
//     of p_t = mu p_n z / |z| (z = p_t - r_t / w, w its friction rows' mean W_tt), classify
//     every contact again from the result (first from the warm start: r = c + W p), repeat;
//     then a few PGS sweeps from the result make it feasible to rounding. Exact on stacks
//     where PGS is soft. When the guess returns to the one of two updates before (a contact
//     flipping on and off, or between sticking and sliding, while another flips back), the
//     flipping rows keep their new guess and the others go on; the polish then corrects what
//     the frozen rows violate.
//     It reads W by columns, and only those of the rows that carry impulse (W symmetric:
//     r = c + sum over those rows j of W(:, j) p_j); on W's lazy columns (DelassusColumns,
//     constraint.h) it forms just those, so a problem whose contacts mostly carry no load (a
//     robot's feet with their hulls' near contacts) skips most of the product J D^-1 J^T.
// The workspace is sized once (reserve); the solvers allocate nothing afterwards.
#pragma once

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <string>
#include <vector>

#include "se3_sim/constraint/constraint.h"

namespace se3 {

struct SolverOptions {
  int iterations = 200;         ///< PGS sweeps at most (active set: its polish sweeps)
  double tol = 1e-10;           ///< PGS stops when no impulse changes by more (N s)
  double singular_tol = 1e-10;  ///< solve_equality: relative pivot below which W is singular
  int active_set_iterations = 30;
  int polish_sweeps = 10;         ///< solve_active_set: PGS sweeps after the direct solve
  double regularization = 1e-10;  ///< solve_active_set: + regularization W_ii on the diagonal
};

struct SolverStats {
  int iterations = 0;     ///< sweeps (PGS) or active-set updates
  double change = 0;      ///< largest impulse change of the last sweep
  int rank = 0;           ///< solve_equality: numerical rank
  bool singular = false;  ///< solve_equality took the pseudo-inverse
  bool fallback = false;  ///< solve_active_set did not settle: PGS from the warm start solved it
  int columns = 0;        ///< W's columns formed (lazy columns) or given (the full product)
};

/// What the solvers keep between calls (sized for at most `capacity` rows).
struct SolverWorkspace {
  Eigen::LDLT<MatX> ldlt;
  Eigen::SelfAdjointEigenSolver<MatX> eig;
  MatX A;                            ///< active-set system (capacity x capacity)
  VecX x, r;                         ///< active-set unknowns, residuals
  VecX p0;                           ///< active-set: the warm start (for its PGS fallback)
  std::vector<int> var, piv;         ///< active-set variable rows, LU pivots
  std::vector<int> slot;             ///< per row: its column in the active-set system (or -1)
  std::vector<int> state;            ///< per row: the active-set guess
  std::vector<Eigen::Vector2d> dir;  ///< per normal row: the sliding direction u = z / |z|
  std::vector<double> shrink;        ///< per normal row, sliding: k = mu p_n / |z| (< 1)
  std::vector<int> state1, state2;   ///< active-set: the guesses one and two updates back
  std::vector<std::uint8_t> frozen;  ///< active-set: rows whose guess a two-cycle froze
  int equality_size = -1;
  void reserve(int capacity, int equality_rows);
};

/// W x = rhs (W symmetric positive semi-definite, equality_rows x equality_rows as reserved).
SolverStats solve_equality(const MatX& W, const VecX& rhs, VecX& x, SolverWorkspace& ws,
                           double singular_tol);

/// Projected Gauss-Seidel over rows.count rows (W the top-left block of that size, c and p their
/// first rows.count entries; p is the warm start and the result).
SolverStats solve_pgs(const MatX& W, const VecX& c, const ConstraintRows& rows, VecX& p,
                      const SolverOptions& opt);
/// The active-set (Newton-type) solver, same arguments; p is its first guess (warm start).
SolverStats solve_active_set(const MatX& W, const VecX& c, const ConstraintRows& rows, VecX& p,
                             SolverWorkspace& ws, const SolverOptions& opt);
/// The same on W's lazy columns (W.Y, W.diag and W.done set up by delassus_begin): the columns
/// of the rows that start active, then of those the solver activates. When more than half the
/// rows start active (lazy_columns_pay), and before a fall-back to PGS, every column is formed
/// and the solve is the one above on the whole W.
SolverStats solve_active_set(DelassusColumns& W, const VecX& c, const ConstraintRows& rows, VecX& p,
                             SolverWorkspace& ws, const SolverOptions& opt);
/// The rows that the active set's first guess makes active (a unilateral row with warm impulse
/// or a free residual below -1e-9 m/s, with its friction rows; every equality row): the
/// columns its first system needs.
int starting_active_rows(const VecX& c, const ConstraintRows& rows, const VecX& p);
/// Whether forming W's columns on demand pays: at most half the rows start active.
bool lazy_columns_pay(const VecX& c, const ConstraintRows& rows, const VecX& p);

enum class ContactSolver { PGS, ActiveSet };
/// "pgs" or "active_set" (std::invalid_argument otherwise).
ContactSolver contact_solver_from_name(const std::string& name);

}  // namespace se3
