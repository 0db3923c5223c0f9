// proxsuite's dense QP solver behind a small interface (dense_qp.cpp), shared by the IK kernel
// (general_step.hpp's proxsuite engine) and the inverse-dynamics kernel (idqp_kernel.cpp).
//
// proxsuite is header-only: every translation unit that includes its dense solver compiles the
// whole solver again. Here it is compiled once, in dense_qp.cpp, into an object library that
// both modules link (CMakeLists.txt), and the kernels include only this header.
//
//   min 1/2 x'Hx + g'x  s.t.  A x = b,  l <= C x <= u,  lb <= x <= ub
//
// with n variables, n_eq equality rows, n_in inequality rows and the box always present (the
// results' z holds the n_in row multipliers, then the n box multipliers, as proxsuite's).

#pragma once

#include <Eigen/Core>

#include <memory>

namespace taskspace_native {

struct DenseQPSettings {
  double eps_abs = 1e-8;
  double eps_rel = 0.0;
  bool check_duality_gap = true;
  double eps_duality_gap_abs = 1e-8;
  double eps_duality_gap_rel = 0.0;
  double default_rho = 0.0;  // 0: proxsuite's own default
  long max_iter = 10000;
  long max_iter_in = 1500;
};

class DenseQP {
 public:
  using MatRef = Eigen::Ref<const Eigen::MatrixXd>;
  using VecRef = Eigen::Ref<const Eigen::VectorXd>;

  // A workspace for these sizes and settings, started without an initial guess.
  DenseQP(int n, int n_eq, int n_in, const DenseQPSettings& settings);
  ~DenseQP();
  DenseQP(const DenseQP&) = delete;
  DenseQP& operator=(const DenseQP&) = delete;

  // proxsuite's init (preconditioner computed) and update (kept: update_preconditioner false).
  void init(const MatRef& H, const VecRef& g, const MatRef& A, const VecRef& b, const MatRef& C,
            const VecRef& l, const VecRef& u, const VecRef& lb, const VecRef& ub);
  void update(const MatRef& H, const VecRef& g, const MatRef& A, const VecRef& b,
              const MatRef& C, const VecRef& l, const VecRef& u, const VecRef& lb,
              const VecRef& ub);
  void solve();
  // Later solves start from the previous result (WARM_START_WITH_PREVIOUS_RESULT).
  void warm_start_from_previous();

  bool solved() const;              // PROXQP_SOLVED
  bool primal_infeasible() const;   // PROXQP_PRIMAL_INFEASIBLE
  long iterations() const;
  const Eigen::VectorXd& x() const;
  const Eigen::VectorXd& y() const;
  const Eigen::VectorXd& z() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// PROXSUITE_VERSION of the headers dense_qp.cpp was compiled with.
const char* dense_qp_proxsuite_version();

}  // namespace taskspace_native
