// Compiled step of taskspace's weighted inverse-dynamics QP (control.InverseDynamicsQP).
//
// One call evaluates, from a State's pinocchio Data (kinematics at (q, v, a = 0), joint
// Jacobians, frame placements, as State.update leaves them) and the kernel's own Data:
//   * the dynamics M (CRBA) and h (nonlinear effects),
//   * the contact Jacobians, drifts and Baumgarte terms,
//   * the task rows (frame pose, frame orientation, frame origin, center of mass, posture),
//   * the QP  min 1/2 x'Hx + g'x  s.t.  A x = b,  l <= C x <= u,  lb <= x <= ub  on
//     x = (a, f): unactuated dynamics and rigid contacts (A), friction cones, normal-force
//     limits and torque limits (C), joint-limit acceleration bounds (lb, ub),
// and solves it exactly: first the equality-constrained KKT system (Cholesky of H, Schur
// complement of A); when that point violates an inequality or a bound, a primal-dual
// active-set method on the same factorization (the Schur complement extended by the working
// rows), warm-started with the previous step's active set; when that fails, proxsuite's dense
// solver (workspace kept and warm-started between steps), whose active set is then solved
// directly (as taskspace.qp.solver's refinement does). Every returned point comes with its
// KKT residuals (taskspace.qp.kkt); the caller reports SOLVED only when they meet the
// tolerances and otherwise takes the Python path. The Python implementation in
// taskspace/control/inverse_dynamics_qp.py is the reference: tests require both to agree.

#include <boost/python.hpp>
#include <eigenpy/eigenpy.hpp>

#include "dense_qp.hpp"  // proxsuite's dense solver, compiled once (dense_qp.cpp)

#if __has_include(<pinocchio/multibody/data.hpp>)  // Pinocchio 3
#include <pinocchio/multibody/data.hpp>
#include <pinocchio/multibody/model.hpp>
#include <pinocchio/spatial/explog.hpp>
#else  // Pinocchio 4: one header per module
#include <pinocchio/multibody.hpp>
#include <pinocchio/spatial.hpp>
#endif
#include <pinocchio/algorithm/center-of-mass.hpp>
#include <pinocchio/algorithm/crba.hpp>
#include <pinocchio/algorithm/frames.hpp>
#include <pinocchio/algorithm/jacobian.hpp>
#include <pinocchio/algorithm/joint-configuration.hpp>
#include <pinocchio/algorithm/kinematics.hpp>
#include <pinocchio/algorithm/rnea.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

namespace bp = boost::python;
using pinocchio::Data;
using pinocchio::Model;
using pinocchio::SE3;
using Eigen::MatrixXd;
using Eigen::VectorXd;

namespace {

constexpr double kInf = 1e20;  // taskspace.qp.problem.INF

enum TaskKind { kPose = 0, kPosition = 1, kCom = 2, kPosture = 3, kOrientation = 4 };
enum ContactKind { kContact6D = 0, kPointContact = 1 };

// Status codes returned to Python.
constexpr int kUnconstrained = 0;  // the equality-constrained minimizer is feasible
constexpr int kSolved = 1;         // proxsuite + active-set solve, KKT residuals within tolerance
constexpr int kNotSolved = 2;      // the caller takes the Python path
constexpr int kActiveSet = 3;      // active-set solve, KKT residuals within tolerance

[[noreturn]] void raise_invalid(const std::string& message) {
  bp::object cls = bp::import("taskspace.errors").attr("InvalidInputError");
  PyErr_SetString(cls.ptr(), message.c_str());
  bp::throw_error_already_set();
  throw std::logic_error(message);  // not reached
}

std::vector<int> int_list(bp::object seq) {
  std::vector<int> out;
  if (seq.is_none()) return out;
  const long n = bp::len(seq);
  for (long i = 0; i < n; ++i) out.push_back(bp::extract<int>(seq[i]));
  return out;
}

struct TaskItem {
  int kind, frame, row, dim;
  std::vector<int> rows;  // posture: selected tangent rows
  bool lie;               // posture: a selected row belongs to a Lie-group joint
};

struct ContactItem {
  int kind, frame, row, dim;
};

struct Residuals {
  double primal = 0, dual = 0, comp = 0, gap = 0, sp = 1, sd = 1, sg = 1;
  bool within(double eps_abs, double eps_rel) const {
    return primal <= eps_abs + eps_rel * sp && dual <= eps_abs + eps_rel * sd &&
           comp <= eps_abs + eps_rel * std::max(sp, sd);
  }
};

double max_abs(const Eigen::Ref<const VectorXd>& v) {
  return v.size() ? v.cwiseAbs().maxCoeff() : 0.0;
}

class InverseDynamicsKernel {
 public:
  explicit InverseDynamicsKernel(const Model& model)
      : nv_(static_cast<int>(model.nv)), nq_(static_cast<int>(model.nq)), data_(model) {}

  int add_task(const Model& model, int kind, int frame, bp::object rows) {
    check_model(model);
    if (finalized_) raise_invalid("add_task after finalize");
    TaskItem t{kind, frame, m_, 0, int_list(rows), false};
    switch (kind) {
      case kPose: t.dim = 6; break;
      case kPosition: case kOrientation: case kCom: t.dim = 3; break;
      case kPosture: {
        if (t.rows.empty()) for (int i = 0; i < nv_; ++i) t.rows.push_back(i);
        t.dim = static_cast<int>(t.rows.size());
        for (int r : t.rows) {
          if (r < 0 || r >= nv_) raise_invalid("posture row out of range");
          for (pinocchio::JointIndex j = 1; j < static_cast<pinocchio::JointIndex>(model.njoints); ++j)
            if (model.idx_vs[j] <= r && r < model.idx_vs[j] + model.nvs[j] && model.nqs[j] != model.nvs[j])
              t.lie = true;
        }
        break;
      }
      default: raise_invalid("unknown task kind " + std::to_string(kind));
    }
    if (kind != kCom && kind != kPosture &&
        (frame < 0 || frame >= static_cast<int>(model.frames.size())))
      raise_invalid("frame index out of range");
    tasks_.push_back(t);
    m_ += t.dim;
    return t.row;
  }

  int add_contact(const Model& model, int kind, int frame, const Eigen::Ref<const MatrixXd>& K,
                  const Eigen::Ref<const VectorXd>& k, int limit_row) {
    check_model(model);
    if (finalized_) raise_invalid("add_contact after finalize");
    if (kind != kContact6D && kind != kPointContact) raise_invalid("unknown contact kind");
    if (frame < 0 || frame >= static_cast<int>(model.frames.size()))
      raise_invalid("frame index out of range");
    const int dim = kind == kContact6D ? 6 : 3;
    if (K.cols() != dim || K.rows() != k.size()) raise_invalid("cone size mismatch");
    contacts_.push_back({kind, frame, nf_, dim});
    cones_K_.push_back(K);
    cones_k_.push_back(k);
    cone_limit_.push_back(limit_row);
    nf_ += dim;
    return nf_ - dim;
  }

  // Constant parts: regularization (diagonal of H: nv + nf entries), actuation, torque and
  // joint-limit settings, tolerances. Allocates the buffers.
  void finalize(const Eigen::Ref<const VectorXd>& reg, bp::object actuated,
                const Eigen::Ref<const VectorXd>& effort, bool torque_limits, bp::object iq,
                bp::object iv, const Eigen::Ref<const VectorXd>& lower,
                const Eigen::Ref<const VectorXd>& upper, const Eigen::Ref<const VectorXd>& vmax,
                double horizon, double eps_abs, double eps_rel, double feasibility_tolerance,
                int max_iter, int max_iter_in) {
    n_ = nv_ + nf_;
    if (reg.size() != n_) raise_invalid("regularization size != nv + nf");
    if ((reg.array() <= 0).any())
      raise_invalid("the compiled step needs positive regularizations (H positive definite)");
    reg_ = reg;
    act_ = int_list(actuated);
    std::vector<bool> is_act(nv_, false);
    for (int a : act_) {
      if (a < 0 || a >= nv_) raise_invalid("actuated index out of range");
      is_act[a] = true;
    }
    unact_.clear();
    for (int i = 0; i < nv_; ++i)
      if (!is_act[i]) unact_.push_back(i);
    if (effort.size() != static_cast<long>(act_.size())) raise_invalid("effort size mismatch");
    effort_ = effort;
    torque_limits_ = torque_limits;
    lim_iq_ = int_list(iq);
    lim_iv_ = int_list(iv);
    const long nl = static_cast<long>(lim_iq_.size());
    if (static_cast<long>(lim_iv_.size()) != nl || lower.size() != nl || upper.size() != nl ||
        vmax.size() != nl)
      raise_invalid("joint-limit sizes differ");
    for (long i = 0; i < nl; ++i)
      if (lim_iq_[i] < 0 || lim_iq_[i] >= nq_ || lim_iv_[i] < 0 || lim_iv_[i] >= nv_)
        raise_invalid("joint-limit index out of range");
    horizon_ = horizon;
    c_ = 2.0 / (horizon * horizon);
    lim_c_lo_ = c_ * lower;
    lim_c_hi_ = c_ * upper;
    lim_vmax_T_ = vmax / horizon;
    eps_abs_ = eps_abs;
    eps_rel_ = eps_rel;
    feas_tol_ = feasibility_tolerance;
    max_iter_ = max_iter;
    max_iter_in_ = max_iter_in;

    nu_ = static_cast<int>(unact_.size());
    n_eq_ = nu_ + nf_;
    n_cone_ = 0;
    for (const auto& K : cones_K_) n_cone_ += static_cast<int>(K.rows());
    n_tau_ = torque_limits_ ? static_cast<int>(act_.size()) : 0;
    n_in_ = n_cone_ + n_tau_;
    H_.setZero(n_, n_);
    H_.diagonal() = reg_;
    g_.setZero(n_);
    A_.setZero(n_eq_, n_);
    b_.setZero(n_eq_);
    C_.setZero(n_in_, n_);
    l_.setConstant(n_in_, -kInf);
    u_.setConstant(n_in_, kInf);
    lb_.setConstant(n_, -kInf);
    ub_.setConstant(n_, kInf);
    int r = 0, col = nv_;
    limit_rows_.clear();
    for (std::size_t c = 0; c < contacts_.size(); ++c) {
      const auto& K = cones_K_[c];
      C_.block(r, col, K.rows(), K.cols()) = K;
      l_.segment(r, K.rows()) = cones_k_[c];
      if (cone_limit_[c] >= 0) limit_rows_.push_back(r + cone_limit_[c]);
      r += static_cast<int>(K.rows());
      col += contacts_[c].dim;
    }
    Jraw_.setZero(m_, nv_);
    // rows whose Jacobian is not a selection of identity rows enter H by a rank update; the
    // posture rows of vector-space joints (the identity) go straight onto H's diagonal
    dense_rows_.clear();
    for (const auto& t : tasks_)
      if (t.kind != kPosture || t.lie)
        for (int a = 0; a < t.dim; ++a) dense_rows_.push_back(t.row + a);
    Jd_.setZero(static_cast<long>(dense_rows_.size()), nv_);
    rd_.setZero(static_cast<long>(dense_rows_.size()));
    e_.setZero(m_);
    drift_.setZero(m_);
    rt_.setZero(m_);
    w_.setOnes(m_);
    kp_.setZero(m_);
    kd_.setZero(m_);
    Jc_.setZero(nf_, nv_);
    bc_.setZero(nf_);
    ckd_.setZero(nf_);
    ckp_.setZero(contacts_.size());
    J6_.setZero(6, nv_);
    Jdiff_.setZero(nv_, nv_);
    diff_.setZero(nv_);
    M_.setZero(nv_, nv_);
    h_.setZero(nv_);
    x_.setZero(n_);
    y_.setZero(n_eq_);
    z_.setZero(n_in_);
    zbox_.setZero(n_);
    qp_.reset();
    finalized_ = true;
  }

  // Per-row sqrt(weight), kp, kd of the task rows (sent when a task's values were reassigned).
  void set_task_gains(const Eigen::Ref<const VectorXd>& w, const Eigen::Ref<const VectorXd>& kp,
                      const Eigen::Ref<const VectorXd>& kd) {
    if (w.size() != m_ || kp.size() != m_ || kd.size() != m_) raise_invalid("gain size mismatch");
    if (!w.allFinite() || !kp.allFinite() || !kd.allFinite())
      raise_invalid("task weights and gains must be finite");
    w_ = w;
    kp_ = kp;
    kd_ = kd;
  }

  // Per-contact kd (applied to every force row of the contact) and kp.
  void set_contact_gains(const Eigen::Ref<const VectorXd>& kd, const Eigen::Ref<const VectorXd>& kp) {
    if (kd.size() != static_cast<long>(contacts_.size()) || kp.size() != kd.size())
      raise_invalid("contact gain size mismatch");
    for (std::size_t c = 0; c < contacts_.size(); ++c)
      ckd_.segment(contacts_[c].row, contacts_[c].dim).setConstant(kd[c]);
    ckp_ = kp;
  }

  // One control step. targets: per task (SE3, 3-vector, 3x3 rotation or configuration);
  // offsets: per task None or kd y'_ref + y''_ref; references: per contact None or its SE3
  // (only when its kp > 0); limits: the current normal-force limits (one per limit row).
  // Writes (x, tau, y, z, z_box) into ``out`` (x = (a, f), tau, the multipliers of the
  // equalities, inequalities and bounds; n + nv + n_eq + n_in + n entries); returns (status, primal, dual,
  // complementarity, duality gap, primal scale, dual scale, gap scale, iterations, objective,
  // build time, solve time).
  bp::tuple solve(const Model& model, Data& sdata, const Eigen::Ref<const VectorXd>& q,
                  const Eigen::Ref<const VectorXd>& v, bp::list targets, bp::object offsets,
                  bp::object references, const Eigen::Ref<const VectorXd>& limits,
                  Eigen::Ref<VectorXd> out) {
    if (!finalized_) raise_invalid("finalize was not called");
    check_model(model);
    if (q.size() != nq_ || v.size() != nv_) raise_invalid("q or v size mismatch");
    if (out.size() != 2 * n_ + nv_ + n_eq_ + n_in_) raise_invalid("output size mismatch");
    if (bp::len(targets) != static_cast<long>(tasks_.size())) raise_invalid("one target per task");
    if (limits.size() != static_cast<long>(limit_rows_.size()))
      raise_invalid("one normal-force limit per limit row");
    const auto t0 = std::chrono::steady_clock::now();
    build(model, sdata, q, v, targets, offsets, references, limits);
    const auto t1 = std::chrono::steady_clock::now();
    int iterations = 0;
    Residuals res;
    int status = solve_qp(iterations, res);
    if (!x_.allFinite()) status = kNotSolved;
    out.head(n_) = x_;
    auto tau_out = out.segment(n_, nv_);
    out.segment(n_ + nv_, n_eq_) = y_;
    out.segment(n_ + nv_ + n_eq_, n_in_) = z_;
    out.tail(n_) = zbox_;
    // tau = S (M a + h - J_c^T f)
    tmp_nv_.noalias() = M_ * x_.head(nv_);
    tmp_nv_ += h_;
    if (nf_) tmp_nv_.noalias() -= Jc_.transpose() * x_.tail(nf_);
    tau_out.setZero();
    for (int a : act_) tau_out[a] = tmp_nv_[a];
    const double objective = 0.5 * x_.dot(H_ * x_) + g_.dot(x_);
    const auto t2 = std::chrono::steady_clock::now();
    const auto sec = [](auto a, auto b) { return std::chrono::duration<double>(b - a).count(); };
    return bp::make_tuple(status, res.primal, res.dual, res.comp, res.gap, res.sp, res.sd, res.sg,
                          iterations, objective, sec(t0, t1), sec(t1, t2));
  }

  // The QP of the last step (for tests and the Python fallback): (H, g, A, b, C, l, u, lb, ub).
  bp::tuple problem() const {
    return bp::make_tuple(MatrixXd(H_), VectorXd(g_), MatrixXd(A_), VectorXd(b_), MatrixXd(C_),
                          VectorXd(l_), VectorXd(u_), VectorXd(lb_), VectorXd(ub_));
  }

  // Wall times of the stages of the last step [s]: dynamics, contacts, task rows, assembly
  // (H, g, A, C, bounds), equality-constrained solve, proxsuite + active-set solve.
  bp::tuple stage_times() const {
    return bp::make_tuple(stage_[0], stage_[1], stage_[2], stage_[3], stage_[4], stage_[5]);
  }

  // Whether the active-set method runs before proxsuite (tests switch it off to exercise
  // proxsuite alone).
  void set_active_set(bool on) { use_active_set_ = on; }

  int rows() const { return m_; }
  int n() const { return n_; }
  int n_eq() const { return n_eq_; }
  int n_in() const { return n_in_; }

 private:
  void check_model(const Model& model) const {
    if (model.nv != nv_ || model.nq != nq_) raise_invalid("model size mismatch");
  }

  void build(const Model& model, Data& sd, const Eigen::Ref<const VectorXd>& q,
             const Eigen::Ref<const VectorXd>& v, bp::list& targets, bp::object& offsets,
             bp::object& references, const Eigen::Ref<const VectorXd>& limits) {
    const auto t_start = std::chrono::steady_clock::now();
    // dynamics on the kernel's own Data (the state's kinematics stay untouched)
    pinocchio::crba(model, data_, q, pinocchio::Convention::LOCAL);
    M_ = data_.M;
    M_.triangularView<Eigen::StrictlyLower>() = M_.transpose();
    h_ = pinocchio::nonLinearEffects(model, data_, q, v);
    const auto t_dyn = std::chrono::steady_clock::now();
    // contacts: J_c, b_c = -kd J_c v - Jdot_c v - kp e_c
    const bool has_refs = !references.is_none();
    for (std::size_t c = 0; c < contacts_.size(); ++c) {
      const ContactItem& it = contacts_[c];
      auto Jrows = Jc_.middleRows(it.row, it.dim);
      auto b = bc_.segment(it.row, it.dim);
      J6_.setZero();
      if (it.kind == kContact6D) {
        pinocchio::getFrameJacobian(model, sd, it.frame, pinocchio::LOCAL, J6_);
        Jrows = J6_;
        b = -pinocchio::getFrameAcceleration(model, sd, it.frame, pinocchio::LOCAL).toVector();
      } else {
        pinocchio::getFrameJacobian(model, sd, it.frame, pinocchio::LOCAL_WORLD_ALIGNED, J6_);
        Jrows = J6_.topRows<3>();
        b = -pinocchio::getFrameClassicalAcceleration(model, sd, it.frame,
                                                      pinocchio::LOCAL_WORLD_ALIGNED)
                 .linear();
      }
      if (has_refs && ckp_[c] != 0.0) {
        bp::object ref = references[c];
        if (!ref.is_none()) {
          const SE3& R = bp::extract<const SE3&>(ref);
          if (it.kind == kContact6D) {
            b -= ckp_[c] * pinocchio::log6(R.actInv(sd.oMf[it.frame])).toVector();
          } else {
            b -= ckp_[c] * (sd.oMf[it.frame].translation() - R.translation());
          }
        }
      }
    }
    if (nf_) {
      tmp_nf_.noalias() = Jc_ * v;
      bc_ -= ckd_.cwiseProduct(tmp_nf_);
    }
    const auto t_contacts = std::chrono::steady_clock::now();
    // task rows
    const bool has_offsets = !offsets.is_none();
    bool com_done = false;
    for (std::size_t k = 0; k < tasks_.size(); ++k) {
      const TaskItem& it = tasks_[k];
      auto J = Jraw_.middleRows(it.row, it.dim);
      auto e = e_.segment(it.row, it.dim);
      auto d = drift_.segment(it.row, it.dim);
      bp::object target = targets[k];
      switch (it.kind) {
        case kPose: {
          const SE3& T = bp::extract<const SE3&>(target);
          const SE3 err = T.actInv(sd.oMf[it.frame]);
          J6_.setZero();
          pinocchio::getFrameJacobian(model, sd, it.frame, pinocchio::LOCAL, J6_);
          pinocchio::Jlog6(err, Jlog_);
          J.noalias() = Jlog_ * J6_;
          e = pinocchio::log6(err).toVector();
          d = pinocchio::getFrameAcceleration(model, sd, it.frame, pinocchio::LOCAL).toVector();
          break;
        }
        case kOrientation: {
          const Eigen::Ref<const MatrixXd> Rt = bp::extract<Eigen::Ref<const MatrixXd>>(target);
          if (Rt.rows() != 3 || Rt.cols() != 3) raise_invalid("orientation target is not 3x3");
          const Eigen::Matrix3d err = Rt.transpose() * sd.oMf[it.frame].rotation();
          J6_.setZero();
          pinocchio::getFrameJacobian(model, sd, it.frame, pinocchio::LOCAL, J6_);
          pinocchio::Jlog3(err, Jlog3_);
          J.noalias() = Jlog3_ * J6_.bottomRows<3>();
          e = pinocchio::log3(err);
          d = pinocchio::getFrameAcceleration(model, sd, it.frame, pinocchio::LOCAL).angular();
          break;
        }
        case kPosition: {
          const Eigen::Ref<const VectorXd> p = bp::extract<Eigen::Ref<const VectorXd>>(target);
          if (p.size() != 3) raise_invalid("position target size != 3");
          J6_.setZero();
          pinocchio::getFrameJacobian(model, sd, it.frame, pinocchio::LOCAL_WORLD_ALIGNED, J6_);
          J = J6_.topRows<3>();
          e = sd.oMf[it.frame].translation() - p;
          d = pinocchio::getFrameClassicalAcceleration(model, sd, it.frame,
                                                       pinocchio::LOCAL_WORLD_ALIGNED)
                  .linear();
          break;
        }
        case kCom: {
          const Eigen::Ref<const VectorXd> c = bp::extract<Eigen::Ref<const VectorXd>>(target);
          if (c.size() != 3) raise_invalid("CoM target size != 3");
          if (!com_done) {
            pinocchio::jacobianCenterOfMass(model, sd, true);
            com_J_ = sd.Jcom;
            com_ = sd.com[0];
            pinocchio::centerOfMass(model, sd, pinocchio::ACCELERATION, true);
            com_acc_ = sd.acom[0];
            com_done = true;
          }
          J = com_J_;
          e = com_ - c;
          d = com_acc_;
          break;
        }
        case kPosture: {
          const Eigen::Ref<const VectorXd> qt = bp::extract<Eigen::Ref<const VectorXd>>(target);
          if (qt.size() != nq_) raise_invalid("posture target size != nq");
          pinocchio::difference(model, qt, q, diff_);
          const int nr = it.dim;
          if (it.lie) pinocchio::dDifference(model, qt, q, Jdiff_, pinocchio::ARG1);
          for (int a = 0; a < nr; ++a) {
            const int r = it.rows[a];
            e[a] = diff_[r];
            if (it.lie) {
              J.row(a) = Jdiff_.row(r);
            } else {
              J.row(a).setZero();
              J(a, r) = 1.0;
            }
          }
          d.setZero();
          break;
        }
        default:
          throw std::logic_error("unknown task kind");
      }
    }
    // rhs = -w (kd J v + kp e + drift - offset), Jt = w J
    rt_.noalias() = Jraw_ * v;
    rt_ = kd_.cwiseProduct(rt_) + kp_.cwiseProduct(e_) + drift_;
    if (has_offsets) {
      for (std::size_t k = 0; k < tasks_.size(); ++k) {
        bp::object off = offsets[k];
        if (off.is_none()) continue;
        const Eigen::Ref<const VectorXd> o = bp::extract<Eigen::Ref<const VectorXd>>(off);
        if (o.size() != tasks_[k].dim) raise_invalid("task offset size mismatch");
        rt_.segment(tasks_[k].row, tasks_[k].dim) -= o;
      }
    }
    rt_ = -w_.cwiseProduct(rt_);
    const auto t_tasks = std::chrono::steady_clock::now();
    // H = reg + [Jt'Jt, 0; 0, 0] (force block: the constant regularization), g = [-Jt' rt; 0]
    // with Jt = w J: dense rows by one rank update, identity rows on the diagonal
    for (std::size_t k = 0; k < dense_rows_.size(); ++k) {
      const int r = dense_rows_[k];
      Jd_.row(k) = w_[r] * Jraw_.row(r);
      rd_[k] = rt_[r];
    }
    auto Haa = H_.topLeftCorner(nv_, nv_);
    Haa.setZero();
    Haa.selfadjointView<Eigen::Lower>().rankUpdate(Jd_.transpose());
    Haa.triangularView<Eigen::StrictlyUpper>() = Haa.transpose();
    Haa.diagonal() += reg_.head(nv_);
    g_.head(nv_).noalias() = -Jd_.transpose() * rd_;
    for (const auto& t : tasks_) {
      if (t.kind != kPosture || t.lie) continue;
      for (int a = 0; a < t.dim; ++a) {
        const int c = t.rows[a], r = t.row + a;
        Haa(c, c) += w_[r] * w_[r];
        g_[c] -= w_[r] * rt_[r];
      }
    }
    // equalities: unactuated dynamics, contacts
    for (int i = 0; i < nu_; ++i) {
      const int r = unact_[i];
      A_.row(i).head(nv_) = M_.col(r).transpose();
      if (nf_) A_.row(i).tail(nf_) = -Jc_.col(r).transpose();
      b_[i] = -h_[r];
    }
    if (nf_) {
      A_.bottomLeftCorner(nf_, nv_) = Jc_;
      b_.tail(nf_) = bc_;
    }
    // inequalities: normal-force limits, torque limits
    for (std::size_t i = 0; i < limit_rows_.size(); ++i) l_[limit_rows_[i]] = -limits[i];
    if (n_tau_) {
      for (int i = 0; i < n_tau_; ++i) {
        const int r = act_[i];
        C_.row(n_cone_ + i).head(nv_) = M_.col(r).transpose();
        if (nf_) C_.row(n_cone_ + i).tail(nf_) = -Jc_.col(r).transpose();
        l_[n_cone_ + i] = -effort_[i] - h_[r];
        u_[n_cone_ + i] = effort_[i] - h_[r];
      }
    }
    // joint-limit bounds: c (lo - q) - 2 v / T <= a <= c (hi - q) - 2 v / T and
    // (-vmax - v) / T <= a <= (vmax - v) / T; conflicting boxes: the midpoint
    for (std::size_t i = 0; i < lim_iq_.size(); ++i) {
      const double qi = q[lim_iq_[i]], vi = v[lim_iv_[i]];
      const double shift = c_ * qi + (2.0 / horizon_) * vi;
      const double vT = vi / horizon_;
      double lo = std::max(lim_c_lo_[i] - shift, -lim_vmax_T_[i] - vT);
      double hi = std::min(lim_c_hi_[i] - shift, lim_vmax_T_[i] - vT);
      if (lo > hi) lo = hi = 0.5 * (lo + hi);
      lb_[lim_iv_[i]] = lo;
      ub_[lim_iv_[i]] = hi;
    }
    const auto t_end = std::chrono::steady_clock::now();
    const auto sec = [](auto a, auto b) { return std::chrono::duration<double>(b - a).count(); };
    stage_[0] = sec(t_start, t_dyn);
    stage_[1] = sec(t_dyn, t_contacts);
    stage_[2] = sec(t_contacts, t_tasks);
    stage_[3] = sec(t_tasks, t_end);
  }

  // Largest violation of the equalities, inequalities and bounds at x (NaN-propagating).
  double violation(const VectorXd& x) {
    double worst = 0.0;
    if (n_eq_) {
      tmp_eq_.noalias() = A_ * x;
      tmp_eq_ -= b_;
      worst = std::max(worst, max_abs(tmp_eq_));
    }
    if (n_in_) {
      tmp_in_.noalias() = C_ * x;
      worst = std::max(worst, (l_ - tmp_in_).maxCoeff());
      worst = std::max(worst, (tmp_in_ - u_).maxCoeff());
    }
    worst = std::max(worst, (lb_ - x).maxCoeff());
    worst = std::max(worst, (x - ub_).maxCoeff());
    if (!x.allFinite()) return std::numeric_limits<double>::quiet_NaN();
    return worst;
  }

  // Equality-constrained minimizer: H = blockdiag(Haa, diag(reg_f)); Cholesky of Haa, Schur
  // complement S = A H^-1 A' (Cholesky), y = -S^-1 (b + A H^-1 g), x = -H^-1 (g + A'y).
  bool equality_solve() {
    La_ = H_.topLeftCorner(nv_, nv_);
    if (Eigen::internal::llt_inplace<double, Eigen::Lower>::unblocked(La_) != -1) return false;
    const auto L = La_.triangularView<Eigen::Lower>();
    inv_sqrt_f_ = reg_.tail(nf_).cwiseSqrt().cwiseInverse();
    // Y = L^-1 A' (n x n_eq)
    Y_.resize(n_, n_eq_);
    Y_.topRows(nv_) = A_.leftCols(nv_).transpose();
    L.solveInPlace(Y_.topRows(nv_));
    Y_.bottomRows(nf_) = inv_sqrt_f_.asDiagonal() * A_.rightCols(nf_).transpose();
    // t = L^-1 g
    t_.resize(n_);
    t_.head(nv_) = g_.head(nv_);
    L.solveInPlace(t_.head(nv_));
    t_.tail(nf_) = inv_sqrt_f_.cwiseProduct(g_.tail(nf_));
    if (n_eq_) {
      S_.setZero(n_eq_, n_eq_);
      S_.selfadjointView<Eigen::Lower>().rankUpdate(Y_.transpose());
      if (Eigen::internal::llt_inplace<double, Eigen::Lower>::unblocked(S_) != -1) return false;
      // S y = -(b + A H^-1 g) = -(b + Y' t)
      y_ = -b_;
      y_.noalias() -= Y_.transpose() * t_;
      S_.triangularView<Eigen::Lower>().solveInPlace(y_);
      S_.triangularView<Eigen::Lower>().transpose().solveInPlace(y_);
      // x = -L^-T (t + Y y)
      t_.noalias() += Y_ * y_;
    }
    x_.head(nv_) = -t_.head(nv_);
    La_.transpose().triangularView<Eigen::Upper>().solveInPlace(x_.head(nv_));
    x_.tail(nf_) = -inv_sqrt_f_.cwiseProduct(t_.tail(nf_));
    return true;
  }

  // taskspace.qp.kkt.kkt_residuals of (x, y, z, z_box).
  Residuals kkt(const VectorXd& x, const VectorXd& y, const VectorXd& z, const VectorXd& zb) {
    Residuals r;
    Hx_.noalias() = H_ * x;
    const double xHx = x.dot(Hx_), gx = g_.dot(x);
    force_ = zb;
    double gap = xHx + gx, by = 0.0;
    r.sp = max_abs(x);
    if (n_eq_) {
      force_.noalias() += A_.transpose() * y;
      tmp_eq_.noalias() = A_ * x;
      tmp_eq_ -= b_;
      r.primal = max_abs(tmp_eq_);
      r.sp = std::max(r.sp, max_abs(b_));
      by = b_.dot(y);
      gap += by;
    }
    if (n_in_) {
      force_.noalias() += C_.transpose() * z;
      tmp_in_.noalias() = C_ * x;
      r.sp = std::max(r.sp, max_abs(tmp_in_));
    }
    double comp = 0.0;
    const auto account = [&](double value, double lo, double hi, double w) {
      const double above = value - hi, below = lo - value;
      r.primal = std::max(r.primal, std::max(above, below));
      const bool up = w > 0.0;
      comp = std::max(comp, std::min(std::abs(w), std::abs(up ? above : below)));
      gap += (up ? hi : lo) * w;
    };
    for (int i = 0; i < n_in_; ++i) account(tmp_in_[i], l_[i], u_[i], z[i]);
    for (int i = 0; i < n_; ++i) account(x[i], lb_[i], ub_[i], zb[i]);
    r.primal = std::max(r.primal, 0.0);
    r.comp = comp;
    stat_ = Hx_ + g_ + force_;
    r.dual = max_abs(stat_);
    r.gap = std::abs(gap);
    r.sd = std::max({max_abs(Hx_), max_abs(g_), max_abs(force_)});
    r.sg = std::max({1.0, std::abs(xHx), std::abs(gx), std::abs(by)});
    if (!x.allFinite() || !std::isfinite(r.dual)) r.primal = r.dual = std::numeric_limits<double>::quiet_NaN();
    return r;
  }

  int solve_qp(int& iterations, Residuals& res) {
    iterations = 0;
    z_.setZero();
    zbox_.setZero();
    const auto t0 = std::chrono::steady_clock::now();
    const auto sec = [](auto a, auto b) { return std::chrono::duration<double>(b - a).count(); };
    stage_[5] = 0.0;
    const bool ok = equality_solve();
    stage_[4] = sec(t0, std::chrono::steady_clock::now());
    if (ok) {
      const double viol = violation(x_);
      if (viol <= feas_tol_) {  // False for NaN
        // taskspace.qp.kkt.equality_kkt_residuals
        Hx_.noalias() = H_ * x_;
        stat_ = Hx_ + g_;
        if (n_eq_) stat_.noalias() += A_.transpose() * y_;
        const double xHx = x_.dot(Hx_), gx = g_.dot(x_), by = n_eq_ ? b_.dot(y_) : 0.0;
        res.primal = viol;
        res.dual = max_abs(stat_);
        res.comp = 0.0;
        res.gap = std::abs(xHx + gx + by);
        res.sp = max_abs(x_);
        res.sd = std::max(max_abs(Hx_), max_abs(g_));
        res.sg = std::max({1.0, std::abs(xHx), std::abs(gx), std::abs(by)});
        if (res.within(eps_abs_, eps_rel_)) return kUnconstrained;
      }
    }
    const auto t1 = std::chrono::steady_clock::now();
    if (ok && use_active_set_ && active_set(iterations)) {
      res = kkt(x_, y_, z_, zbox_);
      if (res.within(eps_abs_, eps_rel_)) {
        stage_[5] = sec(t1, std::chrono::steady_clock::now());
        return kActiveSet;
      }
    }
    working_.clear();
    const int status = solve_proxsuite(iterations, res);
    stage_[5] = sec(t1, std::chrono::steady_clock::now());
    return status;
  }

  // Rows of the working set: index k < n_in is inequality row k of C, k >= n_in the bound of
  // variable k - n_in; side +1 at the upper bound, -1 at the lower one.
  struct Working {
    int index;
    int side;
  };

  double row_value(int k, const VectorXd& x) const {
    return k < n_in_ ? C_.row(k).dot(x) : x[k - n_in_];
  }
  double row_bound(const Working& w) const {
    const int k = w.index;
    if (k < n_in_) return w.side > 0 ? u_[k] : l_[k];
    return w.side > 0 ? ub_[k - n_in_] : lb_[k - n_in_];
  }
  bool row_is_equality(int k) const {
    return k < n_in_ ? l_[k] == u_[k] : lb_[k - n_in_] == ub_[k - n_in_];
  }

  // Minimizer with the equalities and the working rows at their bounds (the Schur complement
  // of equality_solve, extended by the working rows): writes x_ and wy_ (the n_eq + |W|
  // multipliers). Needs equality_solve's factor La_, Y_ and t_ = L^-1 g.
  bool solve_working() {
    const int nw = static_cast<int>(working_.size()), m = n_eq_ + nw;
    const auto L = La_.triangularView<Eigen::Lower>();
    Yw_.resize(n_, m);
    Yw_.leftCols(n_eq_) = Y_;
    for (int j = 0; j < nw; ++j) {
      auto col = Yw_.col(n_eq_ + j);
      const int k = working_[j].index;
      if (k < n_in_) {
        col.head(nv_) = C_.row(k).head(nv_).transpose();
        col.tail(nf_) = inv_sqrt_f_.cwiseProduct(C_.row(k).tail(nf_).transpose());
      } else {
        col.setZero();
        const int i = k - n_in_;
        if (i < nv_) col[i] = 1.0; else col[i] = inv_sqrt_f_[i - nv_];
      }
    }
    if (nw) L.solveInPlace(Yw_.block(0, n_eq_, nv_, nw));
    Sw_.setZero(m, m);
    Sw_.selfadjointView<Eigen::Lower>().rankUpdate(Yw_.transpose());
    if (Eigen::internal::llt_inplace<double, Eigen::Lower>::unblocked(Sw_) != -1) return false;
    wy_.resize(m);
    wy_.head(n_eq_) = -b_;
    for (int j = 0; j < nw; ++j) wy_[n_eq_ + j] = -row_bound(working_[j]);
    wy_.noalias() -= Yw_.transpose() * t_;
    Sw_.triangularView<Eigen::Lower>().solveInPlace(wy_);
    Sw_.triangularView<Eigen::Lower>().transpose().solveInPlace(wy_);
    wt_ = t_;
    wt_.noalias() += Yw_ * wy_;
    x_.head(nv_) = -wt_.head(nv_);
    La_.transpose().triangularView<Eigen::Upper>().solveInPlace(x_.head(nv_));
    x_.tail(nf_) = -inv_sqrt_f_.cwiseProduct(wt_.tail(nf_));
    return x_.allFinite() && wy_.allFinite();
  }

  // A primal-dual active-set method on the Schur complement, warm-started with the working
  // set of the previous step: drop the working row whose multiplier has the wrong sign, else
  // add the most violated row, until neither exists. Not guaranteed to terminate on
  // degenerate problems (bounded iterations; proxsuite takes over); the point it returns is
  // certified by the caller's KKT residuals.
  bool active_set(int& iterations) {
    const int max_it = 2 * (n_in_ + n_) + 10;
    t_.resize(n_);  // t = L^-1 g (equality_solve overwrote it)
    t_.head(nv_) = g_.head(nv_);
    La_.triangularView<Eigen::Lower>().solveInPlace(t_.head(nv_));
    t_.tail(nf_) = inv_sqrt_f_.cwiseProduct(g_.tail(nf_));
    // the warm start keeps the rows still valid (equal sides of l == u rows are kept too)
    std::vector<Working> start;
    for (const auto& w : working_) {
      if (w.index >= n_in_ + n_) continue;
      const double bound = row_bound(w);
      if (std::abs(bound) < kInf) start.push_back(w);
    }
    working_ = start;
    in_working_.assign(n_in_ + n_, 0);
    for (const auto& w : working_) in_working_[w.index] = w.side;
    for (int it = 0; it < max_it; ++it) {
      iterations = it + 1;
      if (!solve_working()) {
        if (working_.empty()) return false;
        working_.clear();  // a dependent warm start: start again from the equalities
        in_working_.assign(n_in_ + n_, 0);
        continue;
      }
      // a working row whose multiplier pushes the wrong way: drop the worst
      int drop = -1;
      double worst = 0.0;
      const double mult_tol = 1e-12 * std::max(1.0, max_abs(wy_));
      for (std::size_t j = 0; j < working_.size(); ++j) {
        if (row_is_equality(working_[j].index)) continue;
        const double val = working_[j].side * wy_[n_eq_ + j];  // must be >= 0
        if (val < -mult_tol && val < worst) {
          worst = val;
          drop = static_cast<int>(j);
        }
      }
      if (drop >= 0) {
        in_working_[working_[drop].index] = 0;
        working_.erase(working_.begin() + drop);
        continue;
      }
      // the most violated row outside the working set
      int add = -1, side = 0;
      double most = feas_tol_;
      if (n_in_) tmp_in_.noalias() = C_ * x_;
      for (int k = 0; k < n_in_ + n_; ++k) {
        if (in_working_[k]) continue;
        const double value = k < n_in_ ? tmp_in_[k] : x_[k - n_in_];
        const double lo = k < n_in_ ? l_[k] : lb_[k - n_in_];
        const double hi = k < n_in_ ? u_[k] : ub_[k - n_in_];
        if (lo - value > most) {
          most = lo - value;
          add = k;
          side = -1;
        } else if (value - hi > most) {
          most = value - hi;
          add = k;
          side = 1;
        }
      }
      if (!(most == most)) return false;  // NaN
      if (add < 0) {  // optimal: multipliers out of the working set's
        y_ = wy_.head(n_eq_);
        z_.setZero();
        zbox_.setZero();
        for (std::size_t j = 0; j < working_.size(); ++j) {
          const int k = working_[j].index;
          if (k < n_in_) z_[k] = wy_[n_eq_ + j]; else zbox_[k - n_in_] = wy_[n_eq_ + j];
        }
        return true;
      }
      working_.push_back({add, side});
      in_working_[add] = side;
    }
    return false;
  }

  // proxsuite, warm-started; when that run is not certified, once more from a fresh
  // workspace (a stale preconditioner or warm start: the Python path rebuilds it likewise).
  int solve_proxsuite(int& iterations, Residuals& res) {
    const bool warm = static_cast<bool>(qp_);
    const int status = proxsuite_once(iterations, res);
    if (status == kSolved || !warm) return status;
    int more = 0;
    const int again = proxsuite_once(more, res);
    iterations += more;
    return again;
  }

  int proxsuite_once(int& iterations, Residuals& res) {
    bool fresh = false;
    if (!qp_) {
      taskspace_native::DenseQPSettings s;
      s.eps_abs = eps_abs_;
      s.eps_rel = eps_rel_;
      s.check_duality_gap = true;
      s.eps_duality_gap_abs = eps_abs_;
      s.eps_duality_gap_rel = eps_rel_;
      s.max_iter = max_iter_;
      s.max_iter_in = max_iter_in_;
      qp_ = std::make_unique<taskspace_native::DenseQP>(n_, n_eq_, n_in_, s);
      qp_->init(H_, g_, A_, b_, C_, l_, u_, lb_, ub_);
      fresh = true;
    } else {
      qp_->update(H_, g_, A_, b_, C_, l_, u_, lb_, ub_);
    }
    qp_->solve();
    if (fresh) qp_->warm_start_from_previous();
    iterations = static_cast<int>(qp_->iterations());
    if (!qp_->solved()) {
      qp_.reset();  // stale preconditioner or warm start: rebuilt next time
      res = Residuals{};
      res.primal = res.dual = std::numeric_limits<double>::quiet_NaN();
      return kNotSolved;
    }
    const VectorXd px = qp_->x(), py = qp_->y(), pz = qp_->z().head(n_in_),
                   pzb = qp_->z().tail(n_);
    if (refine(px, pz, pzb)) {
      res = kkt(x_, y_, z_, zbox_);
      if (res.within(eps_abs_, eps_rel_)) return kSolved;
    }
    x_ = px;
    y_ = py;
    z_ = pz;
    zbox_ = pzb;
    res = kkt(x_, y_, z_, zbox_);
    if (res.within(eps_abs_, eps_rel_)) return kSolved;
    qp_.reset();
    return kNotSolved;
  }

  // taskspace.qp.solver._refine_on_active_set: the exact minimizer on the active set of
  // proxsuite's point (bounds at their value fixed, equality and active rows in the KKT
  // system of the free variables), multipliers from stationarity. Writes x_, y_, z_, zbox_.
  bool refine(const VectorXd& x, const VectorXd& z, const VectorXd& zb) {
    const double tol = 1e-6 * std::max(1.0, max_abs(x));
    std::vector<int> free_idx, fixed_idx;
    VectorXd xfix_all = VectorXd::Zero(n_);
    for (int i = 0; i < n_; ++i) {
      const bool up = zb[i] > 0.0 && ub_[i] - x[i] <= tol;
      const bool lo = !up && zb[i] < 0.0 && x[i] - lb_[i] <= tol;
      if (up || lo) {
        fixed_idx.push_back(i);
        xfix_all[i] = up ? ub_[i] : lb_[i];
      } else {
        free_idx.push_back(i);
      }
    }
    std::vector<int> active;
    VectorXd bound_of_row = VectorXd::Zero(n_in_);
    if (n_in_) {
      tmp_in_.noalias() = C_ * x;
      for (int i = 0; i < n_in_; ++i) {
        const bool up = z[i] > 0.0 && u_[i] - tmp_in_[i] <= tol;
        const bool lo = !up && z[i] < 0.0 && tmp_in_[i] - l_[i] <= tol;
        if (up || lo) {
          active.push_back(i);
          bound_of_row[i] = up ? u_[i] : l_[i];
        }
      }
    }
    const int nfr = static_cast<int>(free_idx.size()), nfx = static_cast<int>(fixed_idx.size());
    const int na = static_cast<int>(active.size()), m = n_eq_ + na;
    // rows R = [A; C_active], rhs r
    MatrixXd R(m, n_);
    VectorXd rr(m);
    if (n_eq_) {
      R.topRows(n_eq_) = A_;
      rr.head(n_eq_) = b_;
    }
    for (int k = 0; k < na; ++k) {
      R.row(n_eq_ + k) = C_.row(active[k]);
      rr[n_eq_ + k] = bound_of_row[active[k]];
    }
    MatrixXd K = MatrixXd::Zero(nfr + m, nfr + m);
    VectorXd rhs(nfr + m);
    for (int a = 0; a < nfr; ++a) {
      const int i = free_idx[a];
      for (int b = 0; b < nfr; ++b) K(a, b) = H_(i, free_idx[b]);
      double s = -g_[i];
      for (int j : fixed_idx) s -= H_(i, j) * xfix_all[j];
      rhs[a] = s;
      for (int k = 0; k < m; ++k) K(a, nfr + k) = K(nfr + k, a) = R(k, i);
    }
    for (int k = 0; k < m; ++k) {
      double s = rr[k];
      for (int j : fixed_idx) s -= R(k, j) * xfix_all[j];
      rhs[nfr + k] = s;
    }
    VectorXd sol;
    if (nfr + m > 0) {
      Eigen::PartialPivLU<MatrixXd> lu(K);
      // singular: the LU's reciprocal condition estimate
      if (!(lu.rcond() > 1e-14)) return false;
      sol = lu.solve(rhs);
      if (!sol.allFinite()) return false;
    }
    x_ = xfix_all;
    for (int a = 0; a < nfr; ++a) x_[free_idx[a]] = sol[a];
    y_ = sol.segment(nfr, n_eq_);
    z_.setZero();
    for (int k = 0; k < na; ++k) z_[active[k]] = sol[nfr + n_eq_ + k];
    zbox_.setZero();
    if (nfx) {
      for (int j : fixed_idx) {
        double s = H_.row(j).dot(x_) + g_[j];
        for (int k = 0; k < m; ++k) s += R(k, j) * sol[nfr + k];
        zbox_[j] = -s;
      }
    }
    return true;
  }

  int nv_, nq_;
  Data data_;
  bool finalized_ = false;
  int m_ = 0, nf_ = 0, n_ = 0, nu_ = 0, n_eq_ = 0, n_cone_ = 0, n_tau_ = 0, n_in_ = 0;
  std::vector<TaskItem> tasks_;
  std::vector<ContactItem> contacts_;
  std::vector<MatrixXd> cones_K_;
  std::vector<VectorXd> cones_k_;
  std::vector<int> cone_limit_, limit_rows_, act_, unact_, lim_iq_, lim_iv_;
  VectorXd reg_, effort_, lim_c_lo_, lim_c_hi_, lim_vmax_T_;
  bool torque_limits_ = true;
  double horizon_ = 0.05, c_ = 0.0, eps_abs_ = 1e-9, eps_rel_ = 1e-9, feas_tol_ = 1e-10;
  int max_iter_ = 200, max_iter_in_ = 30;
  std::vector<int> dense_rows_;
  std::vector<Working> working_;
  bool use_active_set_ = true;
  std::vector<int> in_working_;
  MatrixXd Yw_, Sw_;
  VectorXd wy_, wt_;
  double stage_[6] = {0, 0, 0, 0, 0, 0};
  VectorXd rd_;
  MatrixXd M_, Jraw_, Jd_, Jc_, Jdiff_, H_, A_, C_, La_, Y_, S_;
  VectorXd h_, e_, drift_, rt_, w_, kp_, kd_, bc_, ckd_, ckp_, diff_, g_, b_, l_, u_, lb_, ub_;
  VectorXd x_, y_, z_, zbox_, t_, inv_sqrt_f_, Hx_, force_, stat_, tmp_nv_, tmp_nf_, tmp_eq_,
      tmp_in_;
  Eigen::Matrix<double, 6, Eigen::Dynamic> J6_;
  Eigen::Matrix<double, 3, Eigen::Dynamic> com_J_;
  Eigen::Vector3d com_, com_acc_;
  Eigen::Matrix<double, 6, 6> Jlog_;
  Eigen::Matrix3d Jlog3_;
  std::unique_ptr<taskspace_native::DenseQP> qp_;
};

}  // namespace

BOOST_PYTHON_MODULE(_idqp_kernel) {
  eigenpy::enableEigenPy();
  bp::scope().attr("PINOCCHIO_VERSION") = std::string(PINOCCHIO_VERSION);
  bp::scope().attr("PROXSUITE_VERSION") = std::string(taskspace_native::dense_qp_proxsuite_version());
  bp::scope().attr("UNCONSTRAINED") = kUnconstrained;
  bp::scope().attr("SOLVED") = kSolved;
  bp::scope().attr("NOT_SOLVED") = kNotSolved;
  bp::scope().attr("ACTIVE_SET") = kActiveSet;
  bp::scope().attr("POSE") = static_cast<int>(kPose);
  bp::scope().attr("POSITION") = static_cast<int>(kPosition);
  bp::scope().attr("COM") = static_cast<int>(kCom);
  bp::scope().attr("POSTURE") = static_cast<int>(kPosture);
  bp::scope().attr("ORIENTATION") = static_cast<int>(kOrientation);
  bp::scope().attr("CONTACT6D") = static_cast<int>(kContact6D);
  bp::scope().attr("POINT_CONTACT") = static_cast<int>(kPointContact);
  bp::class_<InverseDynamicsKernel, boost::noncopyable>(
      "InverseDynamicsKernel", bp::init<const Model&>(bp::args("self", "model")))
      .def("add_task", &InverseDynamicsKernel::add_task)
      .def("add_contact", &InverseDynamicsKernel::add_contact)
      .def("finalize", &InverseDynamicsKernel::finalize)
      .def("set_task_gains", &InverseDynamicsKernel::set_task_gains)
      .def("set_contact_gains", &InverseDynamicsKernel::set_contact_gains)
      .def("solve", &InverseDynamicsKernel::solve)
      .def("problem", &InverseDynamicsKernel::problem)
      .def("stage_times", &InverseDynamicsKernel::stage_times)
      .def("set_active_set", &InverseDynamicsKernel::set_active_set)
      .add_property("rows", &InverseDynamicsKernel::rows)
      .add_property("n", &InverseDynamicsKernel::n)
      .add_property("n_eq", &InverseDynamicsKernel::n_eq)
      .add_property("n_in", &InverseDynamicsKernel::n_in);
}
