// Compiled kernel of taskspace's weighted differential IK (DifferentialIK).
//
// One call evaluates the task rows of a weighted stack from a State's pinocchio Data (the
// joint Jacobians and frame placements computed by State.update), assembles
//     H = M^T M + mu I,   g = -M^T r,
// and solves the box-constrained QP  min 1/2 x^T H x + g^T x  s.t.  lb <= x <= ub
// with a primal active-set method (exact, finite). The Python implementation in
// taskspace/ik/differential_ik.py is the reference: tests require both to agree.
//
// Kinematics are Pinocchio's own (getFrameJacobian, log6/Jlog6, jacobianCenterOfMass,
// difference/dDifference); nothing of Pinocchio is re-implemented here.

#include <boost/python.hpp>
#include <eigenpy/eigenpy.hpp>

#if __has_include(<pinocchio/multibody/data.hpp>)  // Pinocchio 3
#include <pinocchio/multibody/data.hpp>
#include <pinocchio/multibody/model.hpp>
#include <pinocchio/spatial/explog.hpp>
#else  // Pinocchio 4: one header per module
#include <pinocchio/multibody.hpp>
#include <pinocchio/spatial.hpp>
#endif
#include <pinocchio/algorithm/center-of-mass.hpp>
#include <pinocchio/algorithm/frames.hpp>
#include <pinocchio/algorithm/jacobian.hpp>
#include <pinocchio/algorithm/joint-configuration.hpp>
#include <pinocchio/algorithm/kinematics.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

namespace bp = boost::python;
using pinocchio::Data;
using pinocchio::Model;
using pinocchio::SE3;
using Eigen::MatrixXd;
using Eigen::VectorXd;
using RowMatrixXd = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

namespace {

enum Kind { kPose = 0, kPosition = 1, kCom = 2, kPosture = 3 };

struct Item {
  int kind;
  int frame;
  int row;
  int dim;
  std::vector<int> rows;  // frame tasks: support columns; posture: selected rows (empty: all)
};

// Raise the taskspace.errors exception `name` (a TaskspaceError) with the message; the GIL is
// held (every entry point is called from Python and keeps it).
[[noreturn]] void raise_error(const char* name, const std::string& message) {
  bp::object cls = bp::import("taskspace.errors").attr(name);
  PyErr_SetString(cls.ptr(), message.c_str());
  bp::throw_error_already_set();
  throw std::logic_error(message);  // not reached
}

[[noreturn]] void raise_invalid(const std::string& message) {
  raise_error("InvalidInputError", message);
}

[[noreturn]] void raise_not_positive_definite() {
  raise_error("SolverError",
              "the IK Hessian H = M^T M + mu I is not positive definite (damping 0 and a "
              "rank-deficient task stack, or a NaN weight); use a damping > 0");
}

// Status codes returned to Python.
constexpr int kUnconstrained = 0;
constexpr int kSolved = 1;
constexpr int kMaxIterations = 2;

class WeightedIKKernel {
 public:
  WeightedIKKernel(int nv, int nq) : nv_(nv), nq_(nq), m_(0) {
    if (nv <= 0 || nq <= 0) raise_invalid("nv and nq must be positive");
    J6_.setZero(6, nv);
    Jlog_.setZero(6, 6);
    Jdiff_.setZero(nv, nv);
    H_.setZero(nv, nv);
    g_.setZero(nv);
    x_.setZero(nv);
    grad_.setZero(nv);
    state_.assign(nv, 0);
  }

  int add_pose(const Model& model, int frame) {
    return add({kPose, frame, m_, 6, support_columns(model, frame)});
  }
  int add_position(const Model& model, int frame) {
    return add({kPosition, frame, m_, 3, support_columns(model, frame)});
  }
  int add_com() {
    std::vector<int> all(nv_);
    for (int i = 0; i < nv_; ++i) all[i] = i;
    return add({kCom, -1, m_, 3, all});
  }
  int add_posture(bp::object rows) {
    std::vector<int> r;
    if (!rows.is_none()) {
      const long n = bp::len(rows);
      for (long i = 0; i < n; ++i) r.push_back(bp::extract<int>(rows[i]));
    }
    const int dim = r.empty() ? nv_ : static_cast<int>(r.size());
    posture_.push_back({kPosture, -1, static_cast<int>(posture_.size()), dim, r});
    return -1;
  }

  int rows() const { return m_; }

  // Per-row sqrt(weight) and -gain * sqrt(weight) of the row tasks (in order), then of the
  // posture tasks (nv entries each: zero on unselected rows); set when weights change.
  void set_scaling(const Eigen::Ref<const VectorXd>& w, const Eigen::Ref<const VectorXd>& c) {
    const long n = m_ + static_cast<long>(posture_.size()) * nv_;
    if (w.size() != n || c.size() != n) raise_invalid("scaling size mismatch");
    if (!w.allFinite() || !c.allFinite())
      raise_invalid("task weights and gains must be finite (a sqrt_weight or gain is NaN or inf)");
    w_ = w.head(m_);
    c_ = c.head(m_);
    pw_.resize(posture_.size());
    pc_.resize(posture_.size());
    for (std::size_t k = 0; k < posture_.size(); ++k) {
      pw_[k] = w.segment(m_ + k * nv_, nv_).cwiseAbs2();  // weight per tangent row
      pc_[k] = c.segment(m_ + k * nv_, nv_).cwiseProduct(w.segment(m_ + k * nv_, nv_));
    }
    scaled_ = true;
  }

  // Joint position limits evaluated here from q (the box of taskspace's JointPositionLimits:
  // lb[iv] = low - q[iq], ub[iv] = high - q[iq], unbounded elsewhere), in the hard or the
  // soft group of the box rules.
  void set_position_limits(bp::object iq, bp::object iv, const Eigen::Ref<const VectorXd>& low,
                           const Eigen::Ref<const VectorXd>& high, bool hard) {
    const long n = bp::len(iq);
    if (bp::len(iv) != n || low.size() != n || high.size() != n)
      raise_invalid("position limits: sizes differ");
    pl_iq_.clear();
    pl_iv_.clear();
    for (long i = 0; i < n; ++i) {
      const int a = bp::extract<int>(iq[i]), b = bp::extract<int>(iv[i]);
      if (a < 0 || a >= nq_ || b < 0 || b >= nv_)
        raise_invalid("position limits: index out of range");
      pl_iq_.push_back(a);
      pl_iv_.push_back(b);
    }
    if (low.hasNaN() || high.hasNaN()) raise_invalid("position limits must not be NaN");
    pl_low_ = low;
    pl_high_ = high;
    pl_lb_.setConstant(nv_, -kInf);
    pl_ub_.setConstant(nv_, kInf);
    pl_hard_ = hard;
    pl_set_ = true;
  }

  // Evaluate the stack at (model, data, q) and solve; returns (status, iterations, objective,
  // build time, QP time, row time) [s]. The step is written into ``out`` (size nv).
  bp::tuple solve(const Model& model, Data& data, const Eigen::Ref<const VectorXd>& q,
                  bp::list targets, bp::list hard_boxes, bp::list soft_boxes, double damping,
                  Eigen::Ref<VectorXd> out, int max_iter) {
    if (model.nv != nv_ || model.nq != nq_) raise_invalid("model size mismatch");
    if (q.size() != nq_ || out.size() != nv_)
      raise_invalid("vector size mismatch");
    if (bp::len(targets) != static_cast<long>(items_.size() + posture_.size()))
      raise_invalid("one target per task expected");
    if (!scaled_) raise_invalid("set_scaling was not called");
    if (!(damping >= 0.0) || !std::isfinite(damping))
      raise_invalid("damping must be finite and >= 0, got " + std::to_string(damping));
    if (max_iter < 0) raise_invalid("max_iter must be >= 0, got " + std::to_string(max_iter));
    if (!q.allFinite()) raise_invalid("q must be finite");
    const auto t0 = std::chrono::steady_clock::now();
    if (pl_set_) {
      for (std::size_t k = 0; k < pl_iq_.size(); ++k) {
        const double qk = q[pl_iq_[k]];
        pl_lb_[pl_iv_[k]] = pl_low_[k] - qk;
        pl_ub_[pl_iv_[k]] = pl_high_[k] - qk;
      }
    }
    combine_bounds(hard_boxes, soft_boxes);
    // H = M^T M + mu I (lower triangle), g = -M^T r: one symmetric rank update of the stacked
    // rows (zero outside each task's support columns)
    H_.setZero();
    g_.setZero();
    fill_rows(model, data, targets);
    const auto t1 = std::chrono::steady_clock::now();
    H_.selfadjointView<Eigen::Lower>().rankUpdate(M_.transpose());
    g_.noalias() -= M_.transpose() * r_;
    H_.diagonal().array() += damping;
    add_posture_terms(model, q, targets);
    H_.triangularView<Eigen::StrictlyUpper>() = H_.transpose();
    const auto t2 = std::chrono::steady_clock::now();
    int iterations = 0;
    const int status = box_qp(lb_, ub_, max_iter, iterations);
    if (!x_.allFinite())
      raise_invalid("the IK step is not finite: a task target, weight or bound is NaN or inf");
    out = x_;
    // 1/2 x^T H x + g^T x, with H x = grad - g (box_qp leaves grad = H x + g at x)
    const double objective = 0.5 * x_.dot(grad_) + 0.5 * g_.dot(x_);
    const auto t3 = std::chrono::steady_clock::now();
    const auto sec = [](auto a, auto b) { return std::chrono::duration<double>(b - a).count(); };
    return bp::make_tuple(status, iterations, objective, sec(t0, t2), sec(t2, t3), sec(t0, t1));
  }

 private:
  // Tangent indices of the joints that move a frame (its Jacobian is zero elsewhere).
  std::vector<int> support_columns(const Model& model, int frame) const {
    if (model.nv != nv_) raise_invalid("model size mismatch");
    if (frame < 0 || frame >= static_cast<int>(model.frames.size()))
      raise_invalid("frame index out of range");
    std::vector<int> cols;
    for (const auto j : model.supports[model.frames[frame].parentJoint]) {
      for (int k = 0; k < model.nvs[j]; ++k) cols.push_back(model.idx_vs[j] + k);
    }
    std::sort(cols.begin(), cols.end());
    return cols;
  }

  int add(Item item) {
    items_.push_back(item);
    m_ += item.dim;
    M_.setZero(m_, nv_);
    r_.setZero(m_);
    e_.setZero(m_);
    return item.row;
  }

  // Weighted task rows sqrt(w) J in M (written on each task's support columns S only: the
  // other columns stay zero) and the weighted targets r = -gain sqrt(w) e.
  void fill_rows(const Model& model, Data& data, bp::list& targets) {
    bool com_done = false;
    for (std::size_t k = 0; k < items_.size(); ++k) {
      const Item& it = items_[k];
      const int ns = static_cast<int>(it.rows.size());
      auto rows = M_.middleRows(it.row, it.dim);
      auto e = e_.segment(it.row, it.dim);
      bp::object target = targets[k];
      switch (it.kind) {
        case kPose: {
          const SE3& T = bp::extract<const SE3&>(target);
          const SE3 err = T.actInv(data.oMf[it.frame]);
          pinocchio::getFrameJacobian(model, data, it.frame, pinocchio::LOCAL, J6_);
          pinocchio::Jlog6(err, Jlog_);
          Jg_.resize(6, ns);
          for (int a = 0; a < ns; ++a) Jg_.col(a) = J6_.col(it.rows[a]);
          Jw_.noalias() = Jlog_ * Jg_;
          for (int a = 0; a < ns; ++a) rows.col(it.rows[a]) = Jw_.col(a);
          e = pinocchio::log6(err).toVector();
          break;
        }
        case kPosition: {
          const Eigen::Ref<const VectorXd> p = bp::extract<Eigen::Ref<const VectorXd>>(target);
          if (p.size() != 3) raise_invalid("position target size != 3");
          pinocchio::getFrameJacobian(model, data, it.frame, pinocchio::LOCAL_WORLD_ALIGNED, J6_);
          for (int a = 0; a < ns; ++a) rows.col(it.rows[a]) = J6_.col(it.rows[a]).head<3>();
          e = data.oMf[it.frame].translation() - p;
          break;
        }
        case kCom: {
          const Eigen::Ref<const VectorXd> c = bp::extract<Eigen::Ref<const VectorXd>>(target);
          if (c.size() != 3) raise_invalid("CoM target size != 3");
          if (!com_done) {
            pinocchio::jacobianCenterOfMass(model, data, true);
            com_done = true;
          }
          rows = data.Jcom;
          e = data.com[0] - c;
          break;
        }
        default:
          throw std::logic_error("unknown task kind");
      }
      rows.array().colwise() *= w_.segment(it.row, it.dim).array();
    }
    r_ = c_.cwiseProduct(e_);
  }

  // Intersection of the boxes (lb, ub) of the constraints; where the physical (hard) boxes
  // and the soft ones conflict the hard ones win. Same rules as combine_bounds() in
  // taskspace/ik/differential_ik.py.
  static void intersect(bp::list& boxes, int n, VectorXd& lb, VectorXd& ub) {
    lb.setConstant(n, -kInf);
    ub.setConstant(n, kInf);
    const long k = bp::len(boxes);
    for (long i = 0; i < k; ++i) {
      bp::object box = boxes[i];
      const Eigen::Ref<const VectorXd> l = bp::extract<Eigen::Ref<const VectorXd>>(box[0]);
      const Eigen::Ref<const VectorXd> u = bp::extract<Eigen::Ref<const VectorXd>>(box[1]);
      if (l.size() != n || u.size() != n) raise_invalid("box size != nv");
      if (l.hasNaN() || u.hasNaN()) raise_invalid("a constraint's bounds are NaN");
      lb = lb.cwiseMax(l);
      ub = ub.cwiseMin(u);
    }
  }

  void combine_bounds(bp::list& hard, bp::list& soft) {
    const int n = nv_;
    intersect(hard, n, hlb_, hub_);
    const bool pl_hard = pl_set_ && pl_hard_, pl_soft = pl_set_ && !pl_hard_;
    if (pl_hard) {
      hlb_ = hlb_.cwiseMax(pl_lb_);
      hub_ = hub_.cwiseMin(pl_ub_);
    }
    const bool any_hard = pl_hard || bp::len(hard) > 0;
    for (int i = 0; i < n; ++i)
      if (hlb_[i] > hub_[i]) hlb_[i] = hub_[i] = 0.5 * (hlb_[i] + hub_[i]);
    if (!pl_soft && bp::len(soft) == 0) {
      lb_ = hlb_;
      ub_ = hub_;
      return;
    }
    intersect(soft, n, slb_, sub_);
    if (pl_soft) {
      slb_ = slb_.cwiseMax(pl_lb_);
      sub_ = sub_.cwiseMin(pl_ub_);
    }
    if (!any_hard) {
      for (int i = 0; i < n; ++i)
        if (slb_[i] > sub_[i]) slb_[i] = sub_[i] = 0.5 * (slb_[i] + sub_[i]);
      lb_ = slb_;
      ub_ = sub_;
      return;
    }
    lb_ = hlb_.cwiseMax(slb_);
    ub_ = hub_.cwiseMin(sub_);
    for (int i = 0; i < n; ++i) {
      if (lb_[i] <= ub_[i]) continue;
      const bool above = slb_[i] > hub_[i], below = sub_[i] < hlb_[i];
      if (below) {
        lb_[i] = ub_[i] = hlb_[i];
      } else if (above) {
        lb_[i] = ub_[i] = hub_[i];
      } else {  // the soft box itself is empty: its center, inside the hard box
        const double mid = 0.5 * (slb_[i] + sub_[i]);
        lb_[i] = ub_[i] = std::min(std::max(mid, hlb_[i]), hub_[i]);
      }
    }
  }

  // Posture tasks: residual difference(q*, q), Jacobian dDifference (block diagonal per
  // joint), added as  H += Jd^T W Jd,  g += Jd^T W gain e  joint by joint.
  void add_posture_terms(const Model& model, const Eigen::Ref<const VectorXd>& q,
                         bp::list& targets) {
    for (std::size_t k = 0; k < posture_.size(); ++k) {
      const VectorXd qt = bp::extract<VectorXd>(targets[items_.size() + k]);
      if (qt.size() != nq_) raise_invalid("posture target size != nq");
      diff_.resize(nv_);
      pinocchio::difference(model, qt, q, diff_);
      const VectorXd& w = pw_[k];
      const VectorXd& c = pc_[k];  // -gain * weight
      bool jd_done = false;
      for (pinocchio::JointIndex j = 1; j < static_cast<pinocchio::JointIndex>(model.njoints); ++j) {
        const int iv = model.idx_vs[j], nvj = model.nvs[j];
        if (nvj == 0) continue;
        if (model.nqs[j] == nvj) {  // vector-space joint: Jd block = identity
          H_.diagonal().segment(iv, nvj) += w.segment(iv, nvj);
          g_.segment(iv, nvj) -= c.segment(iv, nvj).cwiseProduct(diff_.segment(iv, nvj));
          continue;
        }
        if (!jd_done) {  // one dDifference for every Lie-group joint of this task
          pinocchio::dDifference(model, qt, q, Jdiff_, pinocchio::ARG1);
          jd_done = true;
        }
        const auto B = Jdiff_.block(iv, iv, nvj, nvj);
        const auto wj = w.segment(iv, nvj).asDiagonal();
        H_.block(iv, iv, nvj, nvj).noalias() += B.transpose() * (wj * B);
        g_.segment(iv, nvj).noalias() -=
            B.transpose() * c.segment(iv, nvj).cwiseProduct(diff_.segment(iv, nvj));
      }
    }
  }

  // In-place Cholesky factor (lower) of a small SPD matrix: Eigen's unblocked kernel, which
  // at these sizes (n < 100) is several times faster than the blocked LLT.
  static bool cholesky(MatrixXd& A) {
    return Eigen::internal::llt_inplace<double, Eigen::Lower>::unblocked(A) == -1;
  }
  static void cholesky_solve(const MatrixXd& L, VectorXd& x) {
    L.triangularView<Eigen::Lower>().solveInPlace(x);
    L.triangularView<Eigen::Lower>().transpose().solveInPlace(x);
  }

  // Primal active-set method on the box (H symmetric positive definite).
  // state_[i]: 0 free, -1 at lb, +1 at ub, 2 fixed (lb == ub).
  int box_qp(const VectorXd& lb, const VectorXd& ub,
             int max_iter, int& iterations) {
    const int n = nv_;
    const double tol = 1e-10;
    L_ = H_;
    if (!cholesky(L_)) raise_not_positive_definite();
    x_ = -g_;
    cholesky_solve(L_, x_);
    bool feasible = true;
    for (int i = 0; i < n; ++i) {
      if (x_[i] < lb[i] - tol || x_[i] > ub[i] + tol) {
        feasible = false;
        break;
      }
    }
    if (feasible) {
      grad_.setZero();  // H x + g = 0 at the unconstrained minimizer
      return kUnconstrained;
    }
    // feasible start: the unconstrained minimizer clipped to the box
    for (int i = 0; i < n; ++i) {
      if (ub[i] <= lb[i]) {
        state_[i] = 2;
        x_[i] = 0.5 * (lb[i] + ub[i]);
      } else if (x_[i] <= lb[i]) {
        state_[i] = -1;
        x_[i] = lb[i];
      } else if (x_[i] >= ub[i]) {
        state_[i] = 1;
        x_[i] = ub[i];
      } else {
        state_[i] = 0;
      }
    }
    std::vector<int> free_idx;
    free_idx.reserve(n);
    for (iterations = 1; iterations <= max_iter; ++iterations) {
      free_idx.clear();
      for (int i = 0; i < n; ++i)
        if (state_[i] == 0) free_idx.push_back(i);
      const int nf = static_cast<int>(free_idx.size());
      // minimizer on the free variables with the others held
      VectorXd xf(nf);
      if (nf > 0) {
        MatrixXd Hff(nf, nf);
        VectorXd rhs(nf);
        for (int a = 0; a < nf; ++a) {
          const int i = free_idx[a];
          double s = -g_[i];
          for (int j = 0; j < n; ++j)
            if (state_[j] != 0) s -= H_(i, j) * x_[j];
          rhs[a] = s;
          for (int b = 0; b <= a; ++b) Hff(a, b) = H_(i, free_idx[b]);
        }
        if (!cholesky(Hff)) raise_not_positive_definite();
        xf = rhs;
        cholesky_solve(Hff, xf);
      }
      // step from x toward the free minimizer, stopped by the first bound it meets
      double alpha = 1.0;
      int blocking = -1;
      int side = 0;
      for (int a = 0; a < nf; ++a) {
        const int i = free_idx[a];
        const double d = xf[a] - x_[i];
        if (d < 0 && xf[a] < lb[i] - tol) {
          const double t = (lb[i] - x_[i]) / d;
          if (t < alpha) { alpha = t; blocking = i; side = -1; }
        } else if (d > 0 && xf[a] > ub[i] + tol) {
          const double t = (ub[i] - x_[i]) / d;
          if (t < alpha) { alpha = t; blocking = i; side = 1; }
        }
      }
      if (alpha < 0) alpha = 0;
      for (int a = 0; a < nf; ++a) {
        const int i = free_idx[a];
        x_[i] += alpha * (xf[a] - x_[i]);
      }
      if (blocking >= 0) {
        state_[blocking] = side;
        x_[blocking] = side < 0 ? lb[blocking] : ub[blocking];
        continue;
      }
      // at the minimizer of the current face: check the multipliers of the held variables
      grad_.noalias() = H_ * x_;
      grad_ += g_;
      int release = -1;
      double worst = tol;
      for (int i = 0; i < n; ++i) {
        // at lb the gradient must be >= 0, at ub <= 0
        const double v = state_[i] == -1 ? -grad_[i] : (state_[i] == 1 ? grad_[i] : 0.0);
        if (v > worst) { worst = v; release = i; }
      }
      if (release < 0) return kSolved;
      state_[release] = 0;
    }
    iterations = max_iter;
    return kMaxIterations;
  }

  int nv_, nq_, m_;
  std::vector<Item> items_, posture_;
  std::vector<VectorXd> pw_, pc_;
  VectorXd lb_, ub_, hlb_, hub_, slb_, sub_;
  static constexpr double kInf = 1e20;  // taskspace.qp.problem.INF
  VectorXd diff_;
  bool scaled_ = false;
  MatrixXd M_, Jdiff_, H_;
  Eigen::Matrix<double, 6, Eigen::Dynamic> J6_, Jg_, Jw_;
  std::vector<int> pl_iq_, pl_iv_;
  VectorXd pl_low_, pl_high_, pl_lb_, pl_ub_;
  bool pl_set_ = false, pl_hard_ = false;
  Eigen::Matrix<double, 6, 6> Jlog_;
  VectorXd r_, e_, w_, c_, g_, x_, grad_;
  std::vector<int> state_;
  MatrixXd L_;
};

// Objects allocated by Pinocchio's library and freed here (a Data, the vector of neutral):
// crashes when the kernel's Eigen allocator differs from the wheels' (see build.py). Returns
// the distance of the last joint from the origin at the neutral configuration [m].
double abi_selfcheck(const Model& model) {
  Data data(model);
  const VectorXd q = pinocchio::neutral(model);
  pinocchio::forwardKinematics(model, data, q);
  return data.oMi[model.njoints - 1].translation().norm();
}

}  // namespace

BOOST_PYTHON_MODULE(_ik_kernel) {
  eigenpy::enableEigenPy();
  bp::scope().attr("PINOCCHIO_VERSION") = std::string(PINOCCHIO_VERSION);
  bp::scope().attr("UNCONSTRAINED") = kUnconstrained;
  bp::scope().attr("SOLVED") = kSolved;
  bp::scope().attr("MAX_ITERATIONS") = kMaxIterations;
  bp::def("abi_selfcheck", &abi_selfcheck, bp::args("model"));
  bp::class_<WeightedIKKernel>("WeightedIKKernel", bp::init<int, int>(bp::args("self", "nv", "nq")))
      .def("add_pose", &WeightedIKKernel::add_pose)
      .def("add_position", &WeightedIKKernel::add_position)
      .def("add_com", &WeightedIKKernel::add_com)
      .def("add_posture", &WeightedIKKernel::add_posture)
      .add_property("rows", &WeightedIKKernel::rows)
      .def("set_scaling", &WeightedIKKernel::set_scaling)
      .def("set_position_limits", &WeightedIKKernel::set_position_limits)
      .def("solve", &WeightedIKKernel::solve);
}
