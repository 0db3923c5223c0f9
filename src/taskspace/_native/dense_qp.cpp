// proxsuite's dense solver, compiled once for the IK and inverse-dynamics kernels (dense_qp.hpp).

#include "dense_qp.hpp"

#include <proxsuite/proxqp/dense/dense.hpp>

namespace taskspace_native {

namespace pq = proxsuite::proxqp;

struct DenseQP::Impl {
  Impl(int n, int n_eq, int n_in) : qp(n, n_eq, n_in, true) {}
  pq::dense::QP<double> qp;
};

DenseQP::DenseQP(int n, int n_eq, int n_in, const DenseQPSettings& settings)
    : impl_(std::make_unique<Impl>(n, n_eq, n_in)) {
  auto& s = impl_->qp.settings;
  s.eps_abs = settings.eps_abs;
  s.eps_rel = settings.eps_rel;
  s.check_duality_gap = settings.check_duality_gap;
  s.eps_duality_gap_abs = settings.eps_duality_gap_abs;
  s.eps_duality_gap_rel = settings.eps_duality_gap_rel;
  if (settings.default_rho > 0.0) s.default_rho = settings.default_rho;
  s.max_iter = settings.max_iter;
  s.max_iter_in = settings.max_iter_in;
  s.verbose = false;
  s.initial_guess = pq::InitialGuessStatus::NO_INITIAL_GUESS;
}

DenseQP::~DenseQP() = default;

void DenseQP::init(const MatRef& H, const VecRef& g, const MatRef& A, const VecRef& b,
                   const MatRef& C, const VecRef& l, const VecRef& u, const VecRef& lb,
                   const VecRef& ub) {
  impl_->qp.init(H, g, A, b, C, l, u, lb, ub);
}

void DenseQP::update(const MatRef& H, const VecRef& g, const MatRef& A, const VecRef& b,
                     const MatRef& C, const VecRef& l, const VecRef& u, const VecRef& lb,
                     const VecRef& ub) {
  impl_->qp.update(H, g, A, b, C, l, u, lb, ub, false);
}

void DenseQP::solve() { impl_->qp.solve(); }

void DenseQP::warm_start_from_previous() {
  impl_->qp.settings.initial_guess = pq::InitialGuessStatus::WARM_START_WITH_PREVIOUS_RESULT;
}

bool DenseQP::solved() const {
  return impl_->qp.results.info.status == pq::QPSolverOutput::PROXQP_SOLVED;
}

bool DenseQP::primal_infeasible() const {
  return impl_->qp.results.info.status == pq::QPSolverOutput::PROXQP_PRIMAL_INFEASIBLE;
}

long DenseQP::iterations() const { return static_cast<long>(impl_->qp.results.info.iter); }
const Eigen::VectorXd& DenseQP::x() const { return impl_->qp.results.x; }
const Eigen::VectorXd& DenseQP::y() const { return impl_->qp.results.y; }
const Eigen::VectorXd& DenseQP::z() const { return impl_->qp.results.z; }

const char* dense_qp_proxsuite_version() { return PROXSUITE_VERSION; }

}  // namespace taskspace_native
