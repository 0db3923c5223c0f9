// Compiled step of taskspace's hierarchical differential IK (HierarchicalIK).
//
// Included by ik_kernel.cpp (inside its anonymous namespace, after WeightedIKKernel, whose
// row evaluation it reuses: HierarchicalIKKernel is its friend). One call fills every
// level's weighted task rows  J_k x ~ r_k  from a State's pinocchio Data (the same rows as
// taskspace.qp.rows.TaskRowStack.velocity), combines the boxes (the weighted kernel's rules),
// and runs the equality cascade of taskspace/qp/hierarchy.py (HierarchySolver
// ._equality_cascade): per level, the least-norm solution of  J_k Z z = r_k - J_k x  and the
// nullspace basis of  J_k Z  from one Householder QR (of J_k Z when it has at least as many
// rows as columns, else of its transpose), with the Python path's rank test (a diagonal entry
// of R at most 1e-6 times the largest, or 1: declined); the last level by a Cholesky solve
// of its damped normal equations. Then the `_violations` check: the bounds, the hard
// inequality rows and every level's inequality rows at the cascade's point (1e-10).
//
// When an inequality or a bound is violated at that point, the Python path's level QPs are
// solved here (qp_cascade: the same QPs in the same nullspace coordinates, by the dual
// active-set method GoldfarbIdnani below, each level certified by its KKT residuals).
//
// Anything this path does not decide exactly is declined (a status > 0) and the caller runs
// the Python cascade: near-rank-deficient levels (pivoted QR / damped SVD there), a level QP
// not certified, a held row vanishing in a level's freedom while violated (a culprit there),
// a failed Cholesky or a non-finite step.

// A strictly convex dense QP  min 1/2 y'Hy + g'y  s.t.  A y >= b  by the dual active-set method
// of Goldfarb and Idnani (1983; quadprog's method; the Givens updates of the factors are
// written as in L. Di Gaspero's QuadProg++): from the unconstrained minimum, the most
// violated constraint is added, dropping active ones whose multipliers would turn negative,
// until none is violated. Factors: J = L^-T (H = L L'), rotated by the active constraints
// (J'A_act' = [R; 0]).
// The add/drop steps and their Givens updates follow QuadProg++, Copyright (C) 2001-2016
// Luca Di Gaspero, released under the MIT License (https://github.com/liuq/QuadProgpp):
// "Permission is hereby granted, free of charge, to any person obtaining a copy of this
// software ... The above copyright notice and this permission notice shall be included in all
// copies or substantial portions of the Software." See THIRD_PARTY_NOTICES.md.
// The caller certifies the answer by its KKT residuals (HierarchicalIKKernel::qp_cascade).
class GoldfarbIdnani {
 public:
  static constexpr int kSolved = 0;
  static constexpr int kFailed = 1;  // infeasible, degenerate, or the cap
  static constexpr int kDependent = 2;  // an equality row is a combination of the earlier ones
  static constexpr int kNotPositiveDefinite = 3;  // H is not positive definite

  // y, u (multipliers of the rows of A: >= 0 and zero on inactive rows for the inequality
  // rows, any sign for the first `meq` rows, which are equalities A y = b); returns the
  // status. The equality rows are added first, in order, and never leave the active set
  // (QuadProg++'s treatment of equalities).
  int solve(const MatrixXd& H, const VectorXd& g, const MatrixXd& A, const VectorXd& b,
            VectorXd& y, VectorXd& u, int& iterations, int meq = 0) {
    const int n = static_cast<int>(H.rows()), m = static_cast<int>(A.rows());
    iterations = 0;
    llt_.compute(H);
    if (llt_.info() != Eigen::Success) return kNotPositiveDefinite;
    J_.setIdentity(n, n);
    llt_.matrixU().solveInPlace(J_);  // L' J = I
    R_.setZero(n, n);
    y.noalias() = -(J_ * (J_.transpose() * g));
    u.setZero(m);
    act_.clear();
    lam_.setZero(n + 1);  // multipliers of the active rows (then the one being added)
    active_.assign(m, 0);
    skipped_.assign(m, 0);
    double r_norm = 1.0;
    const int cap = 10 * (m + n) + 10;
    const double eps = std::numeric_limits<double>::epsilon();
    meq_ = meq;
    if (meq > n) return kDependent;
    // the equality rows: the full step onto each (its multiplier may have either sign)
    for (int p = 0; p < meq; ++p) {
      ++iterations;
      const int q = static_cast<int>(act_.size());
      d_.noalias() = J_.transpose() * A.row(p).transpose();
      z_.noalias() = J_.rightCols(n - q) * d_.tail(n - q);
      r_ = d_.head(q);
      if (q) R_.topLeftCorner(q, q).triangularView<Eigen::Upper>().solveInPlace(r_);
      const double zn = z_.dot(A.row(p));
      const double sp = A.row(p).dot(y) - b[p];
      const double t = zn > 0.0 ? -sp / zn : 0.0;
      if (!std::isfinite(t)) return kDependent;
      y += t * z_;
      if (q) lam_.head(q) -= t * r_;
      if (!add(q, r_norm)) return kDependent;  // row p depends on the earlier equalities
      lam_[q] = t;
      act_.push_back(p);
      active_[p] = 1;
    }
    for (;;) {
      // the most violated inactive row (relative to its size)
      int p = -1;
      double worst = 0.0;
      s_.noalias() = A * y - b;
      for (int i = 0; i < m; ++i) {
        if (active_[i] || skipped_[i]) continue;
        const double tol = 1e-13 * (1.0 + std::abs(b[i]));
        if (s_[i] < -tol && s_[i] < worst) worst = s_[i], p = i;
      }
      if (p < 0) break;
      double sp = s_[p];
      double uplus = 0.0;
      for (;;) {  // step 2: move towards satisfying row p
        if (++iterations > cap) return kFailed;
        const int q = static_cast<int>(act_.size());
        d_.noalias() = J_.transpose() * A.row(p).transpose();
        z_.noalias() = J_.rightCols(n - q) * d_.tail(n - q);
        r_ = d_.head(q);
        if (q) R_.topLeftCorner(q, q).triangularView<Eigen::Upper>().solveInPlace(r_);
        double t1 = std::numeric_limits<double>::infinity();
        int l = -1;
        for (int j = meq_; j < q; ++j)  // (the equalities never leave)
          if (r_[j] > 0.0 && lam_[j] / r_[j] < t1) t1 = lam_[j] / r_[j], l = j;
        const double zn = z_.dot(A.row(p));
        const bool full = z_.squaredNorm() > eps && zn > 0.0;
        const double t2 = full ? -sp / zn : std::numeric_limits<double>::infinity();
        const double t = std::min(t1, t2);
        if (!std::isfinite(t)) {
          // row p is (numerically) a combination of the active rows with no multiplier to
          // trade: the problem would be infeasible. At a degenerate vertex (more rows
          // tight than freedoms: a level whose freedom the held rows and boxes block) that
          // is rounding: a row barely violated is left out and to the certificate (its
          // violation is in the primal residual; the refinement below restores the
          // stationarity of the active set, whose multipliers' signs are checked there)
          if (-sp <= 1e-9 * (1.0 + std::abs(b[p]))) {
            skipped_[p] = 1;
            break;
          }
          return kFailed;
        }
        if (full) y += t * z_;
        if (q) lam_.head(q) -= t * r_;
        uplus += t;
        if (full && t2 <= t1) {  // row p joins the active set
          if (!add(q, r_norm)) return kFailed;
          lam_[q] = uplus;
          act_.push_back(p);
          active_[p] = 1;
          break;
        }
        // a partial step: row act_[l] leaves
        active_[act_[l]] = 0;
        drop(l);
        sp = A.row(p).dot(y) - b[p];
      }
    }
    // iterative refinement on the final active set: the KKT system's residuals in the
    // original H and A, corrected through the factors (y = J v: v2 = J2'rd, R'v1 = ra,
    // du = R^-1 (v1 - J1'rd)); the factors lose about cond(H) eps, the residuals do not
    const int q = static_cast<int>(act_.size());
    for (int pass = 0; pass < 2; ++pass) {
      rd_.noalias() = -(H * y) - g;  // H y + g = A_act' lam
      for (int j = 0; j < q; ++j) rd_ += lam_[j] * A.row(act_[j]).transpose();
      ra_.resize(q);
      for (int j = 0; j < q; ++j) ra_[j] = b[act_[j]] - A.row(act_[j]).dot(y);
      d_.noalias() = J_.transpose() * rd_;
      z_ = ra_;
      if (q) R_.topLeftCorner(q, q).triangularView<Eigen::Upper>().transpose().solveInPlace(z_);
      r_ = z_ - d_.head(q);
      if (q) R_.topLeftCorner(q, q).triangularView<Eigen::Upper>().solveInPlace(r_);
      y.noalias() += J_.leftCols(q) * z_;
      y.noalias() += J_.rightCols(n - q) * d_.tail(n - q);
      lam_.head(q) += r_;
    }
    for (int j = 0; j < q; ++j) u[act_[j]] = lam_[j];
    return kSolved;
  }

 private:
  // d = J'a_p: rotate J so that d has zeros after entry q; R's column q is d's head.
  bool add(int q, double& r_norm) {
    const int n = static_cast<int>(J_.rows());
    for (int j = n - 1; j >= q + 1; --j) {
      double cc = d_[j - 1], ss = d_[j];
      const double h = std::hypot(cc, ss);
      if (h == 0.0) continue;
      d_[j] = 0.0;
      ss /= h;
      cc /= h;
      if (cc < 0.0) cc = -cc, ss = -ss, d_[j - 1] = -h;
      else d_[j - 1] = h;
      const double xny = ss / (1.0 + cc);
      for (int k = 0; k < n; ++k) {
        const double a = J_(k, j - 1), b = J_(k, j);
        J_(k, j - 1) = a * cc + b * ss;
        J_(k, j) = xny * (a + J_(k, j - 1)) - b;
      }
    }
    R_.col(q).head(q + 1) = d_.head(q + 1);
    if (std::abs(d_[q]) <= std::numeric_limits<double>::epsilon() * r_norm) return false;
    r_norm = std::max(r_norm, std::abs(d_[q]));
    return true;
  }

  // Remove the l-th active row: shift R's columns, restore the triangle by Givens rotations
  // (applied to J's columns too).
  void drop(int l) {
    const int n = static_cast<int>(J_.rows());
    const int q = static_cast<int>(act_.size());
    for (int i = l; i < q - 1; ++i) {
      act_[i] = act_[i + 1];
      lam_[i] = lam_[i + 1];
      R_.col(i) = R_.col(i + 1);
    }
    act_.pop_back();
    lam_[q - 1] = 0.0;
    R_.col(q - 1).setZero();
    const int nq = q - 1;
    for (int j = l; j < nq; ++j) {
      double cc = R_(j, j), ss = R_(j + 1, j);
      const double h = std::hypot(cc, ss);
      if (h == 0.0) continue;
      cc /= h;
      ss /= h;
      R_(j + 1, j) = 0.0;
      if (cc < 0.0) R_(j, j) = -h, cc = -cc, ss = -ss;
      else R_(j, j) = h;
      const double xny = ss / (1.0 + cc);
      for (int k = j + 1; k < nq; ++k) {
        const double a = R_(j, k), b = R_(j + 1, k);
        R_(j, k) = a * cc + b * ss;
        R_(j + 1, k) = xny * (a + R_(j, k)) - b;
      }
      for (int k = 0; k < n; ++k) {
        const double a = J_(k, j), b = J_(k, j + 1);
        J_(k, j) = a * cc + b * ss;
        J_(k, j + 1) = xny * (J_(k, j) + a) - b;
      }
    }
  }

  Eigen::LLT<MatrixXd> llt_;
  MatrixXd J_, R_;
  VectorXd d_, z_, r_, s_, lam_, rd_, ra_;
  std::vector<int> act_;
  std::vector<char> active_, skipped_;
  int meq_ = 0;
};

class HierarchicalIKKernel {
  struct Bounds {  // a FeatureBounds evaluated here (see add_bounds)
    int row, dim, level;
    double gain;
    VectorXd lower, upper;
  };

 public:
  // Status codes (returned to Python).
  static constexpr int kAnswered = 0;
  static constexpr int kRankDeficient = 1;
  static constexpr int kNotFinite = 2;
  static constexpr int kInfeasible = 3;
  static constexpr int kNotCertified = 4;
  static constexpr int kCulprit = 5;
  static constexpr int kInfoColumns = 14;
  static constexpr double kBig = 1e19;  // a bound beyond is infinite (INF = 1e20)

  HierarchicalIKKernel(int nv, int nq) : k_(nv, nq), nv_(nv), nq_(nq) {}

  // Terms are registered level by level (all terms of level 0 first, ...), then set_levels.
  void add_pose(const Model& model, int frame) { k_.add_pose(model, frame), order_.push_back(0); }
  void add_position(const Model& model, int frame) {
    k_.add_position(model, frame), order_.push_back(0);
  }
  void add_com() { k_.add_com(), order_.push_back(0); }
  void add_posture(bp::object rows) { k_.add_posture(rows), order_.push_back(1); }

  // Bounds lower <= phi(q) + J dq <= upper on a CoM or frame-origin feature (FeatureBounds,
  // with its gain), held by level `level` (-1: by every level, a hard constraint). Registered
  // after every task (their rows follow the tasks' in the weighted kernel's row block: the
  // feature's rows with weight 1 and target 0, i.e. J and phi); their targets (zeros) follow
  // the row tasks' targets.
  void add_bounds(const Model& model, int kind, int frame, const Eigen::Ref<const VectorXd>& lower,
                  const Eigen::Ref<const VectorXd>& upper, double gain, int level) {
    if (kind == kCom) k_.add_com();
    else if (kind == kPosition) k_.add_position(model, frame);
    else raise_invalid("bounds: only CoM and frame-origin features");
    const Item& it = k_.items_.back();
    if (lower.size() != it.dim || upper.size() != it.dim) raise_invalid("bounds: size != 3");
    if (lower.hasNaN() || upper.hasNaN() || !(gain > 0.0 && gain <= 1.0))
      raise_invalid("bounds: NaN bounds or a gain outside (0, 1]");
    bounds_.push_back({it.row, it.dim, level, gain, lower, upper});
  }

  // New lower, upper bounds and gain of the i-th registered bounds.
  void set_bounds(int i, const Eigen::Ref<const VectorXd>& lower,
                  const Eigen::Ref<const VectorXd>& upper, double gain) {
    if (i < 0 || i >= static_cast<int>(bounds_.size())) raise_invalid("bounds index out of range");
    Bounds& b = bounds_[i];
    if (lower.size() != b.dim || upper.size() != b.dim) raise_invalid("bounds: size != 3");
    if (lower.hasNaN() || upper.hasNaN() || !(gain > 0.0 && gain <= 1.0))
      raise_invalid("bounds: NaN bounds or a gain outside (0, 1]");
    b.lower = lower;
    b.upper = upper;
    b.gain = gain;
  }

  // counts[k]: the number of terms of level k (in registration order).
  void set_levels(bp::object counts) {
    const long nl = bp::len(counts);
    long total = 0;
    level_rows_.clear();
    level_posture_.clear();
    std::size_t term = 0;
    int row = 0, posture = 0;
    for (long k = 0; k < nl; ++k) {
      const int c = bp::extract<int>(counts[k]);
      if (c < 0) raise_invalid("level term counts must be >= 0");
      total += c;
      if (total > static_cast<long>(order_.size())) raise_invalid("more terms than registered");
      const int first = row;
      std::vector<int> pst;
      for (int i = 0; i < c; ++i, ++term) {
        if (order_[term] == 1) {
          pst.push_back(posture++);
        } else {
          // the row item registered as number (term - postures so far)
          const Item& it = k_.items_[term - posture];
          if (it.row != row) throw std::logic_error("row layout");
          row += it.dim;
        }
      }
      level_rows_.push_back({first, row});
      level_posture_.push_back(pst);
    }
    if (total != static_cast<long>(order_.size())) raise_invalid("fewer terms than registered");
    if (!bounds_.empty() && bounds_.front().row < row) raise_invalid("bounds before tasks");
    J_.assign(nl, MatrixXd());
    r_.assign(nl, VectorXd());
    for (long k = 0; k < nl; ++k) {
      int m = level_rows_[k].second - level_rows_[k].first;
      for (const int p : level_posture_[k]) m += k_.posture_[p].dim;
      J_[k].setZero(m, nv_);
      r_[k].setZero(m);
    }
    info_.setZero(nl, kInfoColumns);
    levels_set_ = true;
  }

  // The weighted kernel's scaling (row tasks, then nv entries per posture task), kept here
  // for the posture rows: sqrt(weight) and -gain * sqrt(weight) per tangent row.
  void set_scaling(const Eigen::Ref<const VectorXd>& w, const Eigen::Ref<const VectorXd>& c) {
    k_.set_scaling(w, c);
    const int m = k_.m_;
    psw_.resize(k_.posture_.size());
    psc_.resize(k_.posture_.size());
    for (const Bounds& b : bounds_)
      if ((w.segment(b.row, b.dim).array() != 1.0).any() ||
          (c.segment(b.row, b.dim).array() != 1.0).any())
        raise_invalid("bounds rows: weight and scale must be 1");
    for (std::size_t k = 0; k < k_.posture_.size(); ++k) {
      psw_[k] = w.segment(m + k * nv_, nv_);
      psc_[k] = c.segment(m + k * nv_, nv_);
    }
  }

  void set_position_limits(bp::object iq, bp::object iv, const Eigen::Ref<const VectorXd>& low,
                           const Eigen::Ref<const VectorXd>& high, bool hard) {
    k_.set_position_limits(iq, iv, low, high, hard);
  }

  // One step: rows, boxes, cascade, checks (then the level QPs when a row is violated).
  // `inequalities`: per level None or (C, l, u) (the level's inequality rows, evaluated by
  // the caller); `hard`: None or (C, l, u) binding every level. Writes the step to `out`
  // (size nv, valid when the status is 0) and the rows of `info` (levels x 14): |J_k x - r_k|,
  // the level's inequality violation, the nullspace dimension after the level, the level's
  // KKT residuals (primal, dual, complementarity, duality gap, primal scale, dual scale, gap
  // scale; see taskspace.qp.kkt: least_squares_kkt_residuals in closed form, kkt_residuals of
  // the level QP), its objective, the length of its step, 1 for a level QP (else 0) and the
  // active-set iterations. `steps` (size >= the sum of the levels' freedoms) receives each
  // closed-form level's step z, concatenated (the level QPs' (z, w): qp_steps). Returns
  // (status, sum of squared r over all levels, build time, cascade time [s], level QPs ran).
  bp::tuple solve(const Model& model, Data& data, const Eigen::Ref<const VectorXd>& q,
                  bp::list targets, bp::list hard_boxes, bp::list soft_boxes,
                  bp::list inequalities, bp::object hard, double damping,
                  Eigen::Ref<VectorXd> out, Eigen::Ref<VectorXd> steps) {
    if (!levels_set_) raise_invalid("set_levels was not called");
    if (model.nv != nv_ || model.nq != nq_) raise_invalid("model size mismatch");
    if (q.size() != nq_ || out.size() != nv_) raise_invalid("vector size mismatch");
    const int nl = static_cast<int>(J_.size());
    if (steps.size() < static_cast<long>(nl) * nv_) raise_invalid("steps buffer too small");
    if (bp::len(targets) != static_cast<long>(k_.items_.size() + k_.posture_.size()))
      raise_invalid("one target per task expected");
    if (bp::len(inequalities) != nl) raise_invalid("one inequality entry per level expected");
    if (!k_.scaled_) raise_invalid("set_scaling was not called");
    if (!(damping >= 0.0) || !std::isfinite(damping))
      raise_invalid("damping must be finite and >= 0, got " + std::to_string(damping));
    if (!q.allFinite()) raise_invalid("q must be finite");
    const auto t0 = std::chrono::steady_clock::now();
    // boxes (the weighted kernel's position limits from q and combination rules)
    if (k_.pl_set_) {
      for (std::size_t k = 0; k < k_.pl_iq_.size(); ++k) {
        const double qk = q[k_.pl_iq_[k]];
        k_.pl_lb_[k_.pl_iv_[k]] = k_.pl_low_[k] - qk;
        k_.pl_ub_[k_.pl_iv_[k]] = k_.pl_high_[k] - qk;
      }
    }
    k_.combine_bounds(hard_boxes, soft_boxes);
    // the row tasks' rows (M_, r_ = -gain sqrt(w) e), then the levels' rows
    k_.fill_rows(model, data, targets);
    fill_posture(model, q, targets);
    double r2 = 0.0;
    for (int k = 0; k < nl; ++k) {
      const int a = level_rows_[k].first, m = level_rows_[k].second - a;
      J_[k].topRows(m) = k_.M_.middleRows(a, m);
      r_[k].head(m) = k_.r_.segment(a, m);
      int row = m;
      for (const int p : level_posture_[k]) {
        const Item& it = k_.posture_[p];
        for (int i = 0; i < it.dim; ++i, ++row) {
          const int t = it.rows.empty() ? i : it.rows[i];
          J_[k].row(row) = psw_[p][t] * pjd_[p].row(t);
          r_[k][row] = psc_[p][t] * pdiff_[p][t];
        }
      }
      r2 += r_[k].squaredNorm();
    }
    const auto t1 = std::chrono::steady_clock::now();
    int status = cascade(damping, steps);
    bool qp = false;
    if (status == kAnswered) {
      status = check(inequalities, hard);
      if (status == kInfeasible && level_qps_) {
        qp = true;
        status = qp_cascade(damping, inequalities, hard);
      }
      if (status == kAnswered) out = x_;
    }
    const auto t2 = std::chrono::steady_clock::now();
    const auto sec = [](auto a, auto b) { return std::chrono::duration<double>(b - a).count(); };
    return bp::make_tuple(status, r2, sec(t0, t1), sec(t1, t2), qp);
  }

  // The per-level data of the last solve (levels x 14, see solve).
  MatrixXd info() const { return info_; }

  // The level QPs' steps (z, w) of the last solve, concatenated (when it ran them).
  VectorXd qp_steps() const { return qsteps_; }

  // Whether an active inequality or bound runs the level QPs here (else: declined, status 3).
  void set_level_qps(bool on) { level_qps_ = on; }

  // The rows of level k of the last solve: (J, r) (copies; for tests and inspection).
  bp::tuple level_rows(int k) const {
    if (k < 0 || k >= static_cast<int>(J_.size())) raise_invalid("level index out of range");
    return bp::make_tuple(J_[k], r_[k]);
  }

 private:
  // Posture rows: sqrt(w) dDifference(q*, q) (block diagonal per joint: identity on the
  // vector-space joints) and -gain sqrt(w) difference(q*, q), for every posture task.
  void fill_posture(const Model& model, const Eigen::Ref<const VectorXd>& q, bp::list& targets) {
    const std::size_t np = k_.posture_.size();
    pjd_.resize(np);
    pdiff_.resize(np);
    for (std::size_t p = 0; p < np; ++p) posture_jd(model, q, targets, p, pjd_[p], pdiff_[p]);
  }

  void posture_jd(const Model& model, const Eigen::Ref<const VectorXd>& q, bp::list& targets,
                  std::size_t k, MatrixXd& Jd, VectorXd& diff) {
    const VectorXd qt = bp::extract<VectorXd>(targets[k_.items_.size() + k]);
    if (qt.size() != nq_) raise_invalid("posture target size != nq");
    diff.resize(nv_);
    pinocchio::difference(model, qt, q, diff);
    Jd.setZero(nv_, nv_);
    bool jd_done = false;
    for (pinocchio::JointIndex j = 1; j < static_cast<pinocchio::JointIndex>(model.njoints); ++j) {
      const int iv = model.idx_vs[j], nvj = model.nvs[j];
      if (nvj == 0) continue;
      if (model.nqs[j] == nvj) {  // vector-space joint: identity
        Jd.block(iv, iv, nvj, nvj).setIdentity();
        continue;
      }
      if (!jd_done) {  // one dDifference for every Lie-group joint (the weighted kernel's)
        pinocchio::dDifference(model, qt, q, k_.Jdiff_, pinocchio::ARG1);
        jd_done = true;
      }
      Jd.block(iv, iv, nvj, nvj) = k_.Jdiff_.block(iv, iv, nvj, nvj);
    }
  }

 private:
  // Least-norm solution of JZ z = res and a basis of null(JZ) by one QR (hierarchy.py's
  // _qr_level); false when JZ is close to rank-deficient (the Python path decides).
  bool qr_level(const MatrixXd& JZ, const VectorXd& res, VectorXd& z, MatrixXd& basis) {
    const int m = static_cast<int>(JZ.rows()), r = static_cast<int>(JZ.cols());
    if (m >= r) {
      if (r == 0) {
        z.resize(0);
        basis.resize(0, 0);
        return true;
      }
      qr_.compute(JZ);
      const auto R = qr_.matrixQR().topRows(r);
      const VectorXd d = R.diagonal().cwiseAbs();
      if (d.minCoeff() <= 1e-6 * std::max(1.0, d.maxCoeff())) return false;
      z.noalias() = JZ.transpose() * res;
      R.triangularView<Eigen::Upper>().transpose().solveInPlace(z);
      R.triangularView<Eigen::Upper>().solveInPlace(z);
      basis.resize(r, 0);
      return true;
    }
    qr_.compute(JZ.transpose());
    const auto& QR = qr_.matrixQR();
    const VectorXd d = QR.diagonal().cwiseAbs();
    if (d.minCoeff() <= 1e-6 * std::max(1.0, d.maxCoeff())) return false;
    Q_.setIdentity(r, r);
    Q_.applyOnTheLeft(qr_.householderQ());
    VectorXd y = res;
    QR.topLeftCorner(m, m).triangularView<Eigen::Upper>().transpose().solveInPlace(y);
    z.noalias() = Q_.leftCols(m) * y;
    basis = Q_.rightCols(r - m);
    return true;
  }

  // The equality cascade (hierarchy.py's _equality_cascade from x = 0, Z = I) and each
  // level's KKT residuals without the primal part (added by check).
  int cascade(double damping, Eigen::Ref<VectorXd> steps) {
    const int nl = static_cast<int>(J_.size()), n = nv_;
    x_.setZero(n);
    bool identity = true;  // Z = I (no level has reduced the freedom yet)
    info_.setZero(nl, kInfoColumns);
    long zpos = 0;
    zin_ident_.assign(nl, true);
    zin_.resize(nl);
    for (int k = 0; k < nl; ++k) {
      const MatrixXd& J = J_[k];
      const int m = static_cast<int>(J.rows());
      const int r = identity ? n : static_cast<int>(Z_.cols());
      zin_ident_[k] = identity;  // the level's freedom (for the level QPs)
      if (!identity) zin_[k] = Z_;
      if (m > 0 && r > 0) {
        if (identity) JZ_ = J;
        else JZ_.noalias() = J * Z_;
        res_ = r_[k];
        res_.noalias() -= J * x_;
        double mu = damping;
        if (k == nl - 1) {
          mu = std::max(mu, 1e-12);
          G_.setZero(r, r);
          G_.selfadjointView<Eigen::Lower>().rankUpdate(JZ_.transpose());
          G_.diagonal().array() += mu;
          z_.noalias() = JZ_.transpose() * res_;
          if (!WeightedIKKernel::cholesky(G_)) return kNotFinite;
          WeightedIKKernel::cholesky_solve(G_, z_);
        } else if (!qr_level(JZ_, res_, z_, basis_)) {
          return kRankDeficient;
        }
        if (identity) x_ += z_;
        else x_.noalias() += Z_ * z_;
        if (k < nl - 1) {
          if (identity) Z_ = basis_;
          else tmp_.noalias() = Z_ * basis_, Z_.swap(tmp_);
          identity = false;
        }
        steps.segment(zpos, r) = z_;
        zpos += r;
        // least_squares_kkt_residuals (primal: set by check)
        fit_.noalias() = JZ_ * z_;
        Hz_.noalias() = JZ_.transpose() * fit_;  // H z = JZ^T JZ z + mu z
        Hz_ += mu * z_;
        g_.noalias() = -(JZ_.transpose() * res_);  // g = -JZ^T res
        fit_ -= res_;
        const double zHz = z_.dot(Hz_), gz = g_.dot(z_);
        info_(k, 4) = (Hz_ + g_).cwiseAbs().maxCoeff();
        info_(k, 5) = 0.0;
        info_(k, 6) = std::abs(zHz + gz);
        info_(k, 7) = z_.cwiseAbs().maxCoeff();
        info_(k, 8) = std::max(Hz_.cwiseAbs().maxCoeff(), g_.cwiseAbs().maxCoeff());
        info_(k, 9) = std::max({1.0, std::abs(zHz), std::abs(gz)});
        info_(k, 10) = 0.5 * (fit_.squaredNorm() + mu * z_.squaredNorm());
      } else {
        info_(k, 9) = 1.0;  // an empty level: KKTResiduals(primal, 0, 0, 0, 0, 0, 1)
      }
      info_(k, 2) = identity ? n : static_cast<double>(Z_.cols());
      info_(k, 11) = static_cast<double>(r > 0 && m > 0 ? r : 0);  // length of the level's z
    }
    if (!x_.allFinite()) return kNotFinite;
    return kAnswered;
  }

  // Largest violation of l <= C x <= u (0 when none), C given as a (C, l, u) tuple.
  double violation(bp::object rows, bool& ok) const {
    const Eigen::Ref<const RowMatrixXd> C = bp::extract<Eigen::Ref<const RowMatrixXd>>(rows[0]);
    const Eigen::Ref<const VectorXd> l = bp::extract<Eigen::Ref<const VectorXd>>(rows[1]);
    const Eigen::Ref<const VectorXd> u = bp::extract<Eigen::Ref<const VectorXd>>(rows[2]);
    if (C.cols() != nv_ || l.size() != C.rows() || u.size() != C.rows()) {
      ok = false;
      return 0.0;
    }
    double v = 0.0;
    for (long i = 0; i < C.rows(); ++i) {
      const double cx = C.row(i).dot(x_);
      v = std::max(v, std::max(l[i] - cx, cx - u[i]));
    }
    return v;
  }

  // Violation at x of FeatureBounds' rows (their inequalities(): lower - phi <= J dq <=
  // upper - phi, a bound already violated relaxed to the fraction `gain` of the way back).
  double bound_violation(const Bounds& b) const {
    double v = 0.0;
    for (int i = 0; i < b.dim; ++i) {
      const double y = k_.r_[b.row + i];  // phi (weight 1, target 0)
      const double cx = k_.M_.row(b.row + i).dot(x_);
      double lo = b.lower[i] - y, hi = b.upper[i] - y;
      if (lo > 0) lo *= b.gain;
      if (hi < 0) hi *= b.gain;
      lo = std::max(lo, -WeightedIKKernel::kInf);
      hi = std::min(hi, WeightedIKKernel::kInf);
      v = std::max(v, std::max(lo - cx, cx - hi));
    }
    return v;
  }

  // The cascade of level QPs (hierarchy.py's HierarchySolver.solve after its closed form was
  // refused): level k minimizes 1/2 |JZ z + (J x - r)|^2 + mu/2 |z|^2 + 1/2 |w|^2 over the
  // nullspace coordinates z of the levels above (the cascade's bases) and the slacks w of
  // its own inequality rows (l - w <= C x <= u + w, w >= 0), subject to the boxes (rows Z_j
  // once Z is not the identity), the hard rows and the rows held by the levels above (their
  // bounds widened to their values at x: min(l, Cx), max(u, Cx)); after the first QP, the
  // bounds relative to x are clipped so that z = 0 stays feasible. Rows that vanish in the
  // level's freedom (|c Z| <= 1e-10 |c|) are left out, as in the Python path, and a vanished
  // row whose bounds exclude x declines (the Python path reports it as a culprit). Each level
  // QP is solved by GoldfarbIdnani and certified by its KKT residuals (1e-9 absolute and
  // relative, the Python path's exact first pass); anything else declines.
  int qp_cascade(double damping, bp::list& inequalities, bp::object& hard) {
    const int nl = static_cast<int>(J_.size()), n = nv_;
    // the hard rows: the Python-evaluated ones and the compiled FeatureBounds of level -1
    held_.clear();
    held_.emplace_back();
    gather(hard, -1, held_.back());
    if (held_.back().C.rows() == 0) held_.pop_back();
    x_.setZero(n);
    bool held_once = false;
    const double inf = WeightedIKKernel::kInf;
    qsteps_.resize(0);
    long pos = 0;
    for (int k = 0; k < nl; ++k) {
      Rows own;
      gather(inequalities[k], k, own);
      const int p = static_cast<int>(own.C.rows());
      const bool ident = zin_ident_[k];
      const MatrixXd& Z = zin_[k];
      const int r = ident ? n : static_cast<int>(Z.cols());
      for (int c = 3; c < kInfoColumns; ++c) info_(k, c) = 0.0;
      if (r == 0) {
        info_(k, 9) = 1.0;
        info_(k, 11) = 0.0;
        info_(k, 12) = 0.0;
      } else {
        const MatrixXd& J = J_[k];
        const int N = r + p;
        if (ident) JZ_ = J;
        else JZ_.noalias() = J * Z;
        res_.noalias() = J * x_;
        res_ -= r_[k];  // J x - r
        const double mu = std::max(damping, 1e-14);
        Hq_.setZero(N, N);
        if (JZ_.rows())
          Hq_.topLeftCorner(r, r).selfadjointView<Eigen::Lower>().rankUpdate(JZ_.transpose());
        Hq_.topLeftCorner(r, r).triangularView<Eigen::StrictlyUpper>() =
            Hq_.topLeftCorner(r, r).transpose();
        Hq_.diagonal().head(r).array() += mu;
        Hq_.diagonal().tail(p).setOnes();
        gq_.setZero(N);
        gq_.head(r).noalias() = JZ_.transpose() * res_;
        // one-sided rows a y >= b
        const double slack = held_once ? 0.0 : inf;
        nrows_ = 0;
        Aq_.resize(2 * (n + p) + p + 2 * held_rows(), N);
        bq_.resize(Aq_.rows());
        if (ident) {
          for (int j = 0; j < n; ++j) {
            const double lo = std::min(k_.lb_[j] - x_[j], slack);
            const double hi = std::max(k_.ub_[j] - x_[j], -slack);
            row_.setZero(N);
            row_[j] = 1.0;
            add_sides(lo, hi, inf);
          }
        } else {
          for (int j = 0; j < n; ++j) {
            if (!(k_.lb_[j] > -inf || k_.ub_[j] < inf)) continue;
            const double lo = std::min(k_.lb_[j] - x_[j], slack);
            const double hi = std::max(k_.ub_[j] - x_[j], -slack);
            row_.setZero(N);
            row_.head(r) = Z.row(j).transpose();
            if (!keep(1.0, lo, hi)) return kCulprit;
          }
        }
        for (const Rows& h : held_) {
          const VectorXd Cx = h.C * x_;
          for (long i = 0; i < h.C.rows(); ++i) {
            const double lo = std::min(h.l[i] - Cx[i], slack);
            const double hi = std::max(h.u[i] - Cx[i], -slack);
            row_.setZero(N);
            if (ident) {
              row_.head(r) = h.C.row(i).transpose();
              add_sides(lo, hi, inf);
            } else {
              row_.head(r).noalias() = Z.transpose() * h.C.row(i).transpose();
              if (!keep(h.C.row(i).norm(), lo, hi)) return kCulprit;
            }
          }
        }
        if (p) {
          const VectorXd Cx = own.C * x_;
          for (int i = 0; i < p; ++i) {
            row_.setZero(N);
            if (ident) row_.head(r) = own.C.row(i).transpose();
            else row_.head(r).noalias() = Z.transpose() * own.C.row(i).transpose();
            const double lo = own.l[i] - Cx[i], hi = own.u[i] - Cx[i];
            row_[r + i] = 1.0;  // C z + w >= l - C x
            if (lo > -kBig) push_row(lo);
            if (hi < kBig) {  // -C z + w >= -(u - C x)
              row_.head(r) = -row_.head(r);
              push_row(-hi);
            }
            row_.setZero(N);
            row_[r + i] = 1.0;  // w >= 0
            push_row(0.0);
          }
        }
        const auto A = Aq_.topRows(nrows_);
        const auto b = bq_.head(nrows_);
        Aa_ = A;
        ba_ = b;
        int iterations = 0;
        if (gi_.solve(Hq_, gq_, Aa_, ba_, yq_, uq_, iterations) != GoldfarbIdnani::kSolved)
          return kNotCertified;
        if (!yq_.allFinite()) return kNotCertified;
        // KKT residuals (taskspace.qp.kkt.kkt_residuals of the level's QP)
        Hz_.noalias() = Hq_ * yq_;
        force_.noalias() = -(Aa_.transpose() * uq_);  // the solver's sign: C'z + z_box
        const VectorXd Ay = Aa_ * yq_;
        double primal = 0.0, compl_ = 0.0, pscale = yq_.cwiseAbs().maxCoeff();
        for (int i = 0; i < nrows_; ++i) {
          const double s = Ay[i] - ba_[i];
          primal = std::max(primal, -s);
          pscale = std::max(pscale, std::abs(Ay[i]));
          // a negative multiplier pushes against the other side: a sign error, |u|
          if (uq_[i] < 0.0) compl_ = std::max(compl_, -uq_[i]);
          else if (uq_[i] > 0.0) compl_ = std::max(compl_, std::min(uq_[i], std::abs(s)));
        }
        const double dual = (Hz_ + gq_ + force_).cwiseAbs().maxCoeff();
        const double dscale = std::max({Hz_.cwiseAbs().maxCoeff(), gq_.cwiseAbs().maxCoeff(),
                                        force_.cwiseAbs().maxCoeff()});
        const double yHy = yq_.dot(Hz_), gy = gq_.dot(yq_);
        const double gap = std::abs(yHy + gy - uq_.dot(ba_));
        const double eps = 1e-9;
        if (!(primal <= eps + eps * pscale && dual <= eps + eps * dscale &&
              compl_ <= eps + eps * std::max(pscale, dscale)))
          return kNotCertified;
        info_(k, 3) = primal;
        info_(k, 4) = dual;
        info_(k, 5) = compl_;
        info_(k, 6) = gap;
        info_(k, 7) = pscale;
        info_(k, 8) = dscale;
        info_(k, 9) = std::max({1.0, std::abs(yHy), std::abs(gy)});
        info_(k, 10) = 0.5 * yHy + gy;
        info_(k, 11) = N;
        info_(k, 12) = 1.0;  // a level QP
        info_(k, 13) = iterations;
        held_once = true;
        if (ident) x_ += yq_.head(r);
        else x_.noalias() += Z * yq_.head(r);
        qsteps_.conservativeResize(pos + N);
        qsteps_.segment(pos, N) = yq_;
        pos += N;
      }
      if (p) {
        const VectorXd Cx = own.C * x_;
        own.l = own.l.cwiseMin(Cx);
        own.u = own.u.cwiseMax(Cx);
        held_.push_back(std::move(own));
      }
    }
    if (!x_.allFinite()) return kNotFinite;
    // hierarchy.py's _finish: each level's residual and the violation of its own rows
    for (int k = 0; k < nl; ++k) {
      info_(k, 0) = (J_[k] * x_ - r_[k]).norm();
      Rows own;
      gather(inequalities[k], k, own);
      double v = 0.0;
      if (own.C.rows()) {
        const VectorXd Cx = own.C * x_;
        v = std::max(0.0, std::max((own.l - Cx).maxCoeff(), (Cx - own.u).maxCoeff()));
      }
      info_(k, 1) = v;
    }
    return kAnswered;
  }

  struct Rows {
    MatrixXd C;
    VectorXd l, u;
  };

  long held_rows() const {
    long m = 0;
    for (const Rows& h : held_) m += h.C.rows();
    return m;
  }

  // The inequality rows of a level (or, level -1, the hard ones): the Python-evaluated
  // (C, l, u) (or None) and the compiled FeatureBounds' rows (lower - phi <= J dq <= upper -
  // phi, a violated bound relaxed to the fraction gain of the way back).
  void gather(bp::object rows, int level, Rows& out) const {
    long m = 0;
    RowMatrixXd Cp;
    VectorXd lp, up;
    if (!rows.is_none()) {
      Cp = bp::extract<Eigen::Ref<const RowMatrixXd>>(rows[0])();
      lp = bp::extract<Eigen::Ref<const VectorXd>>(rows[1])();
      up = bp::extract<Eigen::Ref<const VectorXd>>(rows[2])();
      if (Cp.cols() != nv_ || lp.size() != Cp.rows() || up.size() != Cp.rows())
        raise_invalid("inequality rows: sizes differ");
      m += Cp.rows();
    }
    for (const Bounds& b : bounds_)
      if (b.level == level) m += b.dim;
    out.C.resize(m, nv_);
    out.l.resize(m);
    out.u.resize(m);
    long i = Cp.rows();
    if (i) out.C.topRows(i) = Cp, out.l.head(i) = lp, out.u.head(i) = up;
    for (const Bounds& b : bounds_) {
      if (b.level != level) continue;
      for (int j = 0; j < b.dim; ++j, ++i) {
        const double y = k_.r_[b.row + j];
        double lo = b.lower[j] - y, hi = b.upper[j] - y;
        if (lo > 0) lo *= b.gain;
        if (hi < 0) hi *= b.gain;
        out.C.row(i) = k_.M_.row(b.row + j);
        out.l[i] = std::max(lo, -WeightedIKKernel::kInf);
        out.u[i] = std::min(hi, WeightedIKKernel::kInf);
      }
    }
  }

  void push_row(double b) {
    Aq_.row(nrows_) = row_.transpose();
    bq_[nrows_++] = b;
  }

  // row_ (a box, hard or held row in the level's coordinates) with bounds lo <= row_ y <= hi
  void add_sides(double lo, double hi, double /*inf*/) {
    if (lo > -kBig) push_row(lo);
    if (hi < kBig) {
      row_ = -row_;
      push_row(-hi);
      row_ = -row_;
    }
  }

  // add_sides, unless the row vanishes in the level's freedom (|row| <= 1e-10 norm): then it
  // is left out, and false when its bounds exclude the current point (a culprit)
  bool keep(double norm, double lo, double hi) {
    if (row_.norm() <= 1e-10 * norm) {
      return !(std::max(lo - 1e-9 * (1.0 + std::abs(lo)), -hi - 1e-9 * (1.0 + std::abs(hi))) >
               0.0);
    }
    add_sides(lo, hi, WeightedIKKernel::kInf);
    return true;
  }

  // hierarchy.py's _violations at x (tol 1e-10) and _finish's residuals and violations.
  int check(bp::list& inequalities, bp::object& hard) {
    const int nl = static_cast<int>(J_.size());
    const double tol = 1e-10;
    double h = 0.0;
    for (int i = 0; i < nv_; ++i)
      h = std::max(h, std::max(k_.lb_[i] - x_[i], x_[i] - k_.ub_[i]));
    if (h > tol) return kInfeasible;
    bool ok = true;
    for (const Bounds& b : bounds_)
      if (b.level < 0) h = std::max(h, bound_violation(b));
    if (!hard.is_none()) {
      h = std::max(h, violation(hard, ok));
      if (!ok) raise_invalid("hard inequality rows: sizes differ");
      if (h > tol) return kInfeasible;
    }
    for (int k = 0; k < nl; ++k) {
      double own = 0.0;
      bp::object rows = inequalities[k];
      if (!rows.is_none()) {
        own = violation(rows, ok);
        if (!ok) raise_invalid("level inequality rows: sizes differ");
      }
      for (const Bounds& b : bounds_)
        if (b.level == k) own = std::max(own, bound_violation(b));
      const double v = std::max(h, own);
      if (v > tol) return kInfeasible;
      info_(k, 3) = v;                   // the KKT primal residual
      info_(k, 1) = std::max(own, 0.0);  // the level's violation (_finish)
      info_(k, 0) = (J_[k] * x_ - r_[k]).norm();
    }
    return kAnswered;
  }

 private:
  WeightedIKKernel k_;
  std::vector<Bounds> bounds_;
  int nv_, nq_;
  bool levels_set_ = false;
  std::vector<int> order_;  // per registered term: 0 a row task, 1 a posture task
  std::vector<std::pair<int, int>> level_rows_;
  std::vector<std::vector<int>> level_posture_;
  std::vector<VectorXd> psw_, psc_, pdiff_;
  std::vector<MatrixXd> pjd_;
  std::vector<MatrixXd> J_;
  std::vector<VectorXd> r_;
  MatrixXd Z_, JZ_, basis_, tmp_, G_, Q_, info_;
  VectorXd x_, z_, res_, Hz_, g_, fit_;
  Eigen::HouseholderQR<MatrixXd> qr_;
  // the level QPs
  bool level_qps_ = true;
  std::vector<char> zin_ident_;
  std::vector<MatrixXd> zin_;
  std::vector<Rows> held_;
  GoldfarbIdnani gi_;
  MatrixXd Hq_, Aq_, Aa_;
  VectorXd gq_, bq_, ba_, row_, yq_, uq_, force_, qsteps_;
  int nrows_ = 0;
};

void register_hierarchical_ik_kernel() {
  bp::scope().attr("HIERARCHY_ANSWERED") = HierarchicalIKKernel::kAnswered;
  bp::scope().attr("HIERARCHY_RANK_DEFICIENT") = HierarchicalIKKernel::kRankDeficient;
  bp::scope().attr("HIERARCHY_NOT_FINITE") = HierarchicalIKKernel::kNotFinite;
  bp::scope().attr("HIERARCHY_INFEASIBLE") = HierarchicalIKKernel::kInfeasible;
  bp::scope().attr("HIERARCHY_NOT_CERTIFIED") = HierarchicalIKKernel::kNotCertified;
  bp::scope().attr("HIERARCHY_CULPRIT") = HierarchicalIKKernel::kCulprit;
  bp::class_<HierarchicalIKKernel, boost::noncopyable>(
      "HierarchicalIKKernel", bp::init<int, int>(bp::args("self", "nv", "nq")))
      .def("add_pose", &HierarchicalIKKernel::add_pose)
      .def("add_position", &HierarchicalIKKernel::add_position)
      .def("add_com", &HierarchicalIKKernel::add_com)
      .def("add_posture", &HierarchicalIKKernel::add_posture)
      .def("set_levels", &HierarchicalIKKernel::set_levels)
      .def("add_bounds", &HierarchicalIKKernel::add_bounds)
      .def("set_bounds", &HierarchicalIKKernel::set_bounds)
      .def("set_scaling", &HierarchicalIKKernel::set_scaling)
      .def("set_position_limits", &HierarchicalIKKernel::set_position_limits)
      .def("solve", &HierarchicalIKKernel::solve)
      .def("info", &HierarchicalIKKernel::info)
      .def("qp_steps", &HierarchicalIKKernel::qp_steps)
      .def("set_level_qps", &HierarchicalIKKernel::set_level_qps)
      .def("level_rows", &HierarchicalIKKernel::level_rows);
}
