// Compiled general step of taskspace's weighted differential IK (DifferentialIK): the QP of
// a WeightedIKKernel's stack with equality rows and general inequality rows besides its box
// and its collision dampers.
//
// Included by ik_kernel.cpp (inside its anonymous namespace, after hier_kernel.hpp, whose
// dual active-set solver GoldfarbIdnani it uses: no second copy). The kernel's own rows (the
// compiled task terms, the position box from q, the boxes' combination rules, the damper
// rows from coal distances) are assembled exactly as WeightedIKKernel::solve assembles them
// (GeneralIKStep is its friend); the rows the kernel does not evaluate come from Python:
//     A x = b        equality rows (DifferentialIK's equality tasks; those whose feature
//                    declares a term the kernel evaluates are evaluated here by a second
//                    WeightedIKKernel holding only them: its weighted rows are the rows),
//     l <= C x <= u  inequality rows of constraints without a compiled declaration of a kind
//                    the weighted kernel evaluates (FeatureBounds, a user's rows).
// The QP  min 1/2 x'Hx + g'x  s.t. those rows, the dampers and lb <= x <= ub  is solved by
// one of two engines (set_engine):
//   * active set (default): GoldfarbIdnani (equalities first, never dropped), warm-started:
//     the QP is first solved with the previous step's active rows held as equalities
//     (solve_on_set), and that point is kept only when it is the minimizer (every row holds,
//     no active inequality row has a negative multiplier); otherwise GoldfarbIdnani runs
//     from the unconstrained minimizer;
//   * proxsuite (when built with it): proxsuite's dense solver, one workspace per problem
//     size kept between steps (updated without a new preconditioner, warm-started with the
//     previous result), its point then solved exactly on its active set.
// The step is returned only when its KKT residuals (taskspace.qp.kkt.kkt_residuals of that
// QP, multipliers signed as proxsuite signs them) meet the kernel's tolerances (eps_abs +
// eps_rel * scale). Otherwise the step is declined with a status saying why, and the caller
// runs the Python path.

class GeneralIKStep {
 public:
  // Status codes (returned to Python): 0 and 1 are WeightedIKKernel's kUnconstrained and
  // kSolved; the others decline the step.
  static constexpr int kInfeasible = 3;        // no point satisfies the rows (or a degenerate
                                               // vertex the dual method cannot leave)
  static constexpr int kDependent = 4;         // the equality rows are linearly dependent
  static constexpr int kNotCertified = 5;      // KKT residuals above the tolerances
  static constexpr int kNotPositiveDefinite = 6;  // H = M'M + mu I is not positive definite
  static constexpr double kBig = 1e19;         // a bound beyond is infinite (INF = 1e20)
  static constexpr int kEngineActiveSet = 0;   // GoldfarbIdnani (hier_kernel.hpp)
  static constexpr int kEngineProxsuite = 1;   // proxsuite's dense solver

  // One step of `kernel`'s stack at (model, data, q) with rows = (eq_kernel, eq_targets,
  // equalities, inequalities): the equality rows of `eq_kernel` (None, or a WeightedIKKernel
  // of the equality tasks it evaluates, without posture terms; its targets `eq_targets`, a
  // list) followed by the Python rows `equalities` (None or (A, b)), and the Python rows
  // `inequalities` (None or (C, l, u)); the other arguments as
  // WeightedIKKernel::solve (geom/gdata: None without dampers). The step is written into
  // `out` when the status is 0 or 1. Returns (status, iterations, objective, build time, QP
  // time, row time) [s]; the kernel's residuals() then hold the KKT residuals of the step.
  bp::tuple solve(WeightedIKKernel& k, const Model& model, Data& data,
                  const Eigen::Ref<const VectorXd>& q, bp::list targets, bp::list hard_boxes,
                  bp::list soft_boxes, double damping, Eigen::Ref<VectorXd> out,
                  bp::object geom_obj, bp::object gdata_obj, bp::tuple rows) {
    if (bp::len(rows) != 4)
      raise_invalid("rows: (eq_kernel, eq_targets, equalities, inequalities) expected");
    bp::object eq_kernel = rows[0], equalities = rows[2], inequalities = rows[3];
    bp::list eq_targets = bp::extract<bp::list>(rows[1]);
    const int n = k.nv_;
    if (model.nv != n || model.nq != k.nq_) raise_invalid("model size mismatch");
    if (q.size() != k.nq_ || out.size() != n) raise_invalid("vector size mismatch");
    if (bp::len(targets) != static_cast<long>(k.items_.size() + k.posture_.size()))
      raise_invalid("one target per task expected");
    if (!k.scaled_) raise_invalid("set_scaling was not called");
    if (!(damping >= 0.0) || !std::isfinite(damping))
      raise_invalid("damping must be finite and >= 0, got " + std::to_string(damping));
    if (!q.allFinite()) raise_invalid("q must be finite");
    WeightedIKKernel* ek = nullptr;
    if (!eq_kernel.is_none()) {
      ek = bp::extract<WeightedIKKernel*>(eq_kernel);
      if (ek->nv_ != n || ek->nq_ != k.nq_ || !ek->posture_.empty())
        raise_invalid("equality kernel: size mismatch or posture terms");
      if (bp::len(eq_targets) != static_cast<long>(ek->items_.size()))
        raise_invalid("one target per equality task expected");
      if (!ek->scaled_) raise_invalid("set_scaling was not called (equality kernel)");
    }
    const auto t0 = std::chrono::steady_clock::now();
    if (ek != nullptr) ek->fill_rows(model, data, eq_targets);
    read_rows(ek, equalities, inequalities, n);
    // the weighted kernel's QP (WeightedIKKernel::solve's assembly)
    if (k.pl_set_) {
      for (std::size_t i = 0; i < k.pl_iq_.size(); ++i) {
        const double qi = q[k.pl_iq_[i]];
        k.pl_lb_[k.pl_iv_[i]] = k.pl_low_[i] - qi;
        k.pl_ub_[k.pl_iv_[i]] = k.pl_high_[i] - qi;
      }
    }
    k.combine_bounds(hard_boxes, soft_boxes);
    k.H_.setZero();
    k.g_.setZero();
    k.fill_rows(model, data, targets);
    const auto t1 = std::chrono::steady_clock::now();
    k.add_gram();  // and g = -M^T r
    k.H_.diagonal().array() += damping;
    k.add_posture_terms(model, q, targets);
    k.H_.triangularView<Eigen::StrictlyUpper>() = k.H_.transpose();
    k.m_in_ = 0;
    if (!k.dampers_.empty()) {
      if (!k.geom_set_) raise_invalid("dampers without a collision model");
      const GeometryModel& geom = bp::extract<const GeometryModel&>(geom_obj);
      GeometryData& gdata = bp::extract<GeometryData&>(gdata_obj);
      if (gdata.oMg.size() != geom.geometryObjects.size() ||
          gdata.distanceResults.size() != geom.collisionPairs.size() ||
          k.sphere_r_.size() != geom.geometryObjects.size())
        raise_invalid("the collision data do not match the collision model");
      k.fill_dampers(model, data, geom, gdata);
    }
    if (!k.H_.allFinite() || !k.g_.allFinite())
      raise_invalid("the IK step is not finite: a task target, weight or bound is NaN or inf");
    const auto t2 = std::chrono::steady_clock::now();
    // the rows a'x >= b of the dual method: equalities first, then the box, the dampers and
    // the Python inequality rows (each finite side); kind_/index_/sign_ map them back
    const int meq = static_cast<int>(A_.rows()), md = k.m_in_;
    const int mc = static_cast<int>(C_.rows());
    const int cap = meq + 2 * n + md + 2 * mc;
    G_.resize(cap, n);
    h_.resize(cap);
    kind_.clear();
    index_.clear();
    sign_.clear();
    int m = 0;
    slot_row_.assign(2 * n + md + 2 * mc, -1);
    auto push = [&](int kind, int index, double sign, double rhs) {
      if (kind > 0) slot_row_[slot({kind, index, sign < 0.0}, n, md)] = m;
      kind_.push_back(kind);
      index_.push_back(index);
      sign_.push_back(sign);
      h_[m++] = rhs;
    };
    for (int i = 0; i < meq; ++i) {
      G_.row(m) = A_.row(i);
      push(0, i, 1.0, b_[i]);
    }
    for (int i = 0; i < n; ++i) {
      if (k.lb_[i] > -kBig) {
        G_.row(m).setZero();
        G_(m, i) = 1.0;
        push(1, i, 1.0, k.lb_[i]);
      }
      if (k.ub_[i] < kBig) {
        G_.row(m).setZero();
        G_(m, i) = -1.0;
        push(1, i, -1.0, -k.ub_[i]);
      }
    }
    for (int i = 0; i < md; ++i) {
      G_.row(m) = k.C_.row(i);
      push(2, i, 1.0, k.l_[i]);
    }
    for (int i = 0; i < mc; ++i) {
      if (l_[i] > -kBig) {
        G_.row(m) = C_.row(i);
        push(3, i, 1.0, l_[i]);
      }
      if (u_[i] < kBig) {
        G_.row(m) = -C_.row(i);
        push(3, i, -1.0, -u_[i]);
      }
    }
    Ga_ = G_.topRows(m);
    ha_ = h_.head(m);
    int iterations = 0;
    int status = kSolved;
    if (engine_ == kEngineProxsuite) {
      status = solve_proxsuite(k, meq, md, mc, iterations);
    } else {
      bool done = false;
      // (without equalities and with no row active before, the warm start would test the
      // unconstrained minimizer: GoldfarbIdnani's own first test)
      if (warm_start_ && warm_valid_ && (meq > 0 || !prev_.empty())) {
        // the previous step's active rows (those that still exist), held with equality;
        // kept only when that point is feasible with nonnegative multipliers, i.e. optimal
        set_.clear();
        for (int i = 0; i < meq; ++i) set_.push_back(i);
        for (const auto& key : prev_) {
          const int r = row_of(key, n, md, mc);
          if (r >= 0) set_.push_back(r);
        }
        done = solve_on_set(k.H_, k.g_, meq);
        if (done) ++warm_hits_, iterations = 1;
        else ++warm_misses_;
      }
      if (!done) {
        const int gi = gi_.solve(k.H_, k.g_, Ga_, ha_, x_, w_, iterations, meq);
        if (gi == GoldfarbIdnani::kDependent) status = kDependent;
        else if (gi == GoldfarbIdnani::kNotPositiveDefinite) status = kNotPositiveDefinite;
        else if (gi != GoldfarbIdnani::kSolved || !x_.allFinite()) status = kInfeasible;
      }
    }
    warm_valid_ = false;
    double objective = std::numeric_limits<double>::quiet_NaN();
    bool active = false;
    // multipliers signed as proxsuite's (H x + g + A'y + C'z + z_box = 0): a row
    // sign * c'x >= rhs with multiplier w contributes -sign * w to c's multiplier; then the
    // KKT check of the step
    auto certify = [&]() {
      y_.setZero(meq);
      z_.setZero(mc);
      zd_.setZero(md);
      zbox_.setZero(n);
      active = false;
      for (int r = 0; r < m; ++r) {
        const double v = -sign_[r] * w_[r];
        if (w_[r] != 0.0) active = true;
        switch (kind_[r]) {
          case 0: y_[index_[r]] += v; break;
          case 1: zbox_[index_[r]] += v; break;
          case 2: zd_[index_[r]] += v; break;
          default: z_[index_[r]] += v; break;
        }
      }
      return kkt(k);
    };
    const bool have_point = status == kSolved;
    if (status == kSolved) {
      bool certified = certify();
      if (!certified && engine_ == kEngineProxsuite && !last_fresh_) {
        // a warm proxsuite run whose point is not certified: once more from a fresh
        // workspace (a stale preconditioner or warm start, as the Python path rebuilds it)
        drop_workspace();
        int more = 0;
        status = solve_proxsuite(k, meq, md, mc, more);
        iterations += more;
        certified = status == kSolved && certify();
      }
      if (status == kSolved && !certified) status = kNotCertified;
    }
    if (have_point) {
      if (status == kSolved) {
        if (!active && meq == 0) status = kUnconstrained;
        // the active inequality rows, the next step's warm start
        prev_.clear();
        for (int r = meq; r < m; ++r)
          if (w_[r] > 0.0) prev_.push_back({kind_[r], index_[r], sign_[r] < 0.0});
        warm_valid_ = true;
      }
      k.x_ = x_;
      objective = 0.5 * x_.dot(k.H_ * x_) + k.g_.dot(x_);
      if (status == kSolved || status == kUnconstrained) out = x_;
    }
    k.warm_ = false;  // the box QP's active set is not this step's
    const auto t3 = std::chrono::steady_clock::now();
    const auto sec = [](auto a, auto b) { return std::chrono::duration<double>(b - a).count(); };
    return bp::make_tuple(status, iterations, objective, sec(t0, t2), sec(t2, t3), sec(t0, t1));
  }

  // solve(), then, unless the step was declined (data untouched), q_next = integrate(q, step)
  // and the kinematics of `data` at q_next exactly as WeightedIKKernel::advance computes
  // them (with the velocity v_next = step / dt when dt > 0).
  bp::tuple advance(WeightedIKKernel& k, const Model& model, Data& data,
                    const Eigen::Ref<const VectorXd>& q, bp::list targets, bp::list hard_boxes,
                    bp::list soft_boxes, double damping, Eigen::Ref<VectorXd> out,
                    bp::object geom_obj, bp::object gdata_obj, bp::tuple rows,
                    Eigen::Ref<VectorXd> q_next, Eigen::Ref<VectorXd> v_next, double dt) {
    if (q_next.size() != k.nq_ || (dt > 0.0 && v_next.size() != k.nv_))
      raise_invalid("vector size mismatch");
    const bool with_velocity = dt > 0.0;
    if (dt != 0.0 && !(with_velocity && std::isfinite(dt)))
      raise_invalid("dt must be finite and > 0 (or 0: no velocity), got " + std::to_string(dt));
    bp::tuple result = solve(k, model, data, q, targets, hard_boxes, soft_boxes, damping, out,
                             geom_obj, gdata_obj, rows);
    if (bp::extract<int>(result[0]) > kSolved) return result;
    pinocchio::integrate(model, q, x_, q_next);
    if (with_velocity) {
      v_next = x_ / dt;
      pinocchio::forwardKinematics(model, data, q_next, v_next, k.a0_);
      pinocchio::computeJointJacobians(model, data);
    } else {
      pinocchio::computeJointJacobians(model, data, q_next);
    }
    pinocchio::updateFramePlacements(model, data);
    return result;
  }

  // Multipliers of the last solve, signed as proxsuite's: (y of the equality rows, z of the
  // Python inequality rows, z of the damper rows, z_box).
  bp::tuple multipliers() const { return bp::make_tuple(y_, z_, zd_, zbox_); }

  // The engine of the next solves: kEngineActiveSet (GoldfarbIdnani, warm-started with the
  // previous step's active set) or kEngineProxsuite (proxsuite's dense solver, workspace
  // kept per problem size and warm-started). Changing it forgets the warm starts.
  void set_engine(int engine) {
    if (engine != kEngineActiveSet && engine != kEngineProxsuite)
      raise_invalid("engine: 0 (active set) or 1 (proxsuite) expected, got " +
                    std::to_string(engine));
#ifndef TASKSPACE_IK_PROXSUITE
    if (engine == kEngineProxsuite)
      raise_invalid("this build of the IK kernel has no proxsuite engine (proxsuite's CMake "
                    "config was not found when it was built)");
#endif
    engine_ = engine;
    reset_warm_start();
  }
  int engine() const { return engine_; }

  // Whether the active-set engine tries the previous step's active set first (default on).
  void set_warm_start(bool on) {
    warm_start_ = on;
    reset_warm_start();
  }

  // Forget the previous step (active set; proxsuite workspaces).
  void reset_warm_start() {
    warm_valid_ = false;
    prev_.clear();
#ifdef TASKSPACE_IK_PROXSUITE
    qps_.clear();
#endif
  }

  // (steps solved on the previous active set, steps where that set was wrong and the cold
  // solve ran, proxsuite solves that started from a fresh workspace)
  bp::tuple warm_stats() const { return bp::make_tuple(warm_hits_, warm_misses_, fresh_qps_); }

 private:
  // an inequality row of the QP by what it bounds: kind 1 the box (index: the variable),
  // 2 a damper row, 3 a Python row; upper: the row's upper side
  struct Key {
    int kind, index;
    bool upper;
  };
  static int slot(const Key& key, int n, int md) {
    if (key.kind == 1) return 2 * key.index + key.upper;
    if (key.kind == 2) return 2 * n + key.index;
    return 2 * n + md + 2 * key.index + key.upper;
  }
  // The row of this step's QP that bounds what `key` bounded (-1: none).
  int row_of(const Key& key, int n, int md, int mc) const {
    const int size = key.kind == 1 ? n : key.kind == 2 ? md : mc;
    if (key.kind < 1 || key.kind > 3 || key.index < 0 || key.index >= size) return -1;
    return slot_row_[slot(key, n, md)];
  }

  // The minimizer of 1/2 x'Hx + g'x with the rows set_ of (Ga_, ha_) held with equality (the
  // equality rows first): V = L^-1 Ga_S' (H = LL'), S = V'V, lambda = S^-1 (h_S + V'L^-1 g),
  // x = L^-T (V lambda - L^-1 g), then one step of iterative refinement on the same
  // factors. Written to x_ and w_ (multipliers of Ga_'s rows, >= 0 for inequality rows:
  // H x + g = Ga_' w) only when it is the QP's minimizer: every row of Ga_ holds (to 1e-12
  // relative) and no inequality row of the set has a negative multiplier (beyond 1e-12
  // relative). Otherwise (or a singular S: dependent rows) false.
  bool solve_on_set(const MatrixXd& H, const VectorXd& g, int meq) {
    const int n = static_cast<int>(H.rows()), m = static_cast<int>(Ga_.rows());
    const int q = static_cast<int>(set_.size());
    if (q > n) return false;
    llt_.compute(H);
    if (llt_.info() != Eigen::Success) return false;
    V_.resize(n, q);
    for (int j = 0; j < q; ++j) V_.col(j) = Ga_.row(set_[j]).transpose();
    llt_.matrixL().solveInPlace(V_);
    if (q) {
      S_.noalias() = V_.transpose() * V_;
      sllt_.compute(S_);
      if (sllt_.info() != Eigen::Success) return false;
      const auto d = sllt_.matrixLLT().diagonal();
      if (!(d.minCoeff() > 1e-7 * d.maxCoeff())) return false;  // rows nearly dependent
    }
    // the KKT system [H -G'; G 0] (x, lam) = (r1, r2) solved on the factors
    auto kkt_solve = [&](const VectorXd& r1, const VectorXd& r2, VectorXd& x, VectorXd& lam) {
      t_ = r1;
      llt_.matrixL().solveInPlace(t_);
      if (q) {
        lam = r2;
        lam.noalias() -= V_.transpose() * t_;
        sllt_.solveInPlace(lam);
        t_.noalias() += V_ * lam;
      } else {
        lam.resize(0);
      }
      llt_.matrixU().solveInPlace(t_);
      x = t_;
    };
    r1_ = -g;
    r2_.resize(q);
    for (int j = 0; j < q; ++j) r2_[j] = ha_[set_[j]];
    kkt_solve(r1_, r2_, xs_, lams_);
    // refinement: the residuals in H and Ga_, corrected through the factors
    r1_.noalias() = -(H * xs_) - g;
    for (int j = 0; j < q; ++j) {
      r1_ += lams_[j] * Ga_.row(set_[j]).transpose();
      r2_[j] = ha_[set_[j]] - Ga_.row(set_[j]).dot(xs_);
    }
    kkt_solve(r1_, r2_, dx_, dlam_);
    xs_ += dx_;
    if (q) lams_ += dlam_;
    if (!xs_.allFinite() || !lams_.allFinite()) return false;
    const double lam_tol = 1e-12 * std::max(1.0, q ? lams_.cwiseAbs().maxCoeff() : 0.0);
    for (int j = 0; j < q; ++j)
      if (set_[j] >= meq && lams_[j] < -lam_tol) return false;
    s_.noalias() = Ga_ * xs_ - ha_;
    for (int i = meq; i < m; ++i)
      if (s_[i] < -1e-12 * (1.0 + std::abs(ha_[i]))) return false;
    x_ = xs_;
    w_.setZero(m);
    for (int j = 0; j < q; ++j) w_[set_[j]] = set_[j] >= meq ? std::max(lams_[j], 0.0) : lams_[j];
    return true;
  }

#ifdef TASKSPACE_IK_PROXSUITE
  // proxsuite's dense solver on  min 1/2 x'Hx + g'x  s.t. A x = b, l <= C x <= u (the damper
  // rows, then the Python rows), lb <= x <= ub, with the settings of taskspace's QP layer
  // (QPSolverOptions' defaults: the kernel's eps_abs and eps_rel, the duality-gap test,
  // rho 1e-6, 200 iterations, 30 inner). One workspace per (equality rows, inequality rows)
  // kept between steps: updated without recomputing its preconditioner and warm-started
  // with the previous result. Its point is then solved exactly on its active set
  // (solve_on_set, as taskspace.qp.solver's refinement); when that set does not give the
  // minimizer, proxsuite's own point and multipliers are returned (the caller certifies
  // them). A warm run that does not solve is run once more from a fresh workspace.
  int solve_proxsuite(WeightedIKKernel& k, int meq, int md, int mc, int& iterations) {
    const int n = k.nv_, nin = md + mc, m = static_cast<int>(Ga_.rows());
    Aq_ = A_;
    Cq_.resize(nin, n);
    lq_.resize(nin);
    uq_.resize(nin);
    if (md) {
      Cq_.topRows(md) = k.C_.topRows(md);
      lq_.head(md) = k.l_.head(md);
      uq_.head(md).setConstant(WeightedIKKernel::kInf);
    }
    if (mc) {
      Cq_.bottomRows(mc) = C_;
      lq_.tail(mc) = l_.cwiseMax(-WeightedIKKernel::kInf);
      uq_.tail(mc) = u_.cwiseMin(WeightedIKKernel::kInf);
    }
    lbq_ = k.lb_.cwiseMax(-WeightedIKKernel::kInf);
    ubq_ = k.ub_.cwiseMin(WeightedIKKernel::kInf);
    const long key = (static_cast<long>(meq) << 32) | static_cast<long>(nin);
    last_key_ = key;
    iterations = 0;
    for (int attempt = 0; attempt < 2; ++attempt) {
      auto it = qps_.find(key);
      const bool fresh = it == qps_.end();
      last_fresh_ = fresh;
      if (fresh) {
        if (qps_.size() >= 16) qps_.clear();
        taskspace_native::DenseQPSettings st;
        st.eps_abs = k.eps_abs_;
        st.eps_rel = k.eps_rel_;
        st.check_duality_gap = true;
        st.eps_duality_gap_abs = k.eps_abs_;
        st.eps_duality_gap_rel = k.eps_rel_;
        st.default_rho = 1e-6;
        st.max_iter = 200;
        st.max_iter_in = 30;
        auto qp = std::make_unique<taskspace_native::DenseQP>(n, meq, nin, st);
        qp->init(k.H_, k.g_, Aq_, b_, Cq_, lq_, uq_, lbq_, ubq_);
        it = qps_.emplace(key, std::move(qp)).first;
        ++fresh_qps_;
      } else {
        it->second->update(k.H_, k.g_, Aq_, b_, Cq_, lq_, uq_, lbq_, ubq_);
      }
      taskspace_native::DenseQP& qp = *it->second;
      qp.solve();
      if (fresh) qp.warm_start_from_previous();
      iterations += static_cast<int>(qp.iterations());
      if (!qp.solved()) {
        const bool infeasible = qp.primal_infeasible();
        qps_.erase(it);  // stale preconditioner or warm start: rebuilt
        if (!fresh) continue;
        return infeasible ? kInfeasible : kNotCertified;
      }
      // proxsuite's multipliers as the rows' (w >= 0 on a'x >= h: see the mapping in solve)
      px_ = qp.x();
      const Eigen::VectorXd& ry = qp.y();
      const Eigen::VectorXd& rz = qp.z();
      w_.resize(m);
      set_.clear();
      const double tight = 1e-6 * std::max(1.0, px_.cwiseAbs().maxCoeff());
      for (int row = 0; row < m; ++row) {
        const int i = index_[row];
        double zp = 0.0;
        switch (kind_[row]) {
          case 0: zp = ry[i]; break;
          case 1: zp = rz[nin + i]; break;
          case 2: zp = rz[i]; break;
          default: zp = rz[md + i]; break;
        }
        if (kind_[row] == 0) {
          w_[row] = -zp;
          set_.push_back(row);
          continue;
        }
        w_[row] = std::max(0.0, -sign_[row] * zp);
        if (w_[row] > 0.0 && std::abs(Ga_.row(row).dot(px_) - ha_[row]) <= tight)
          set_.push_back(row);
      }
      wp_ = w_;
      if (!solve_on_set(k.H_, k.g_, meq)) {
        x_ = px_;
        w_ = wp_;
      }
      return kSolved;
    }
    return kNotCertified;
  }

  // forget the workspace of the last proxsuite solve
  void drop_workspace() { qps_.erase(last_key_); }

  std::map<long, std::unique_ptr<taskspace_native::DenseQP>> qps_;
  long last_key_ = -1;
  MatrixXd Aq_, Cq_;
  VectorXd lq_, uq_, lbq_, ubq_, px_, wp_;
#else
  int solve_proxsuite(WeightedIKKernel&, int, int, int, int&) { return kNotCertified; }
  void drop_workspace() {}
#endif
  bool last_fresh_ = true;  // whether the last proxsuite solve started from a new workspace

  // A_, b_: the equality kernel's weighted rows (sqrt(w) J, -gain sqrt(w) e) then the
  // Python equality rows; C_, l_, u_: the Python inequality rows.
  void read_rows(const WeightedIKKernel* ek, bp::object& equalities, bp::object& inequalities,
                 int n) {
    const int me = ek != nullptr ? ek->m_ : 0;
    long mp = 0;
    if (!equalities.is_none()) {
      Ap_ = bp::extract<Eigen::Ref<const RowMatrixXd>>(equalities[0])();
      bp_ = bp::extract<Eigen::Ref<const VectorXd>>(equalities[1])();
      if (Ap_.cols() != n || bp_.size() != Ap_.rows()) raise_invalid("equality rows: sizes differ");
      mp = Ap_.rows();
    }
    A_.resize(me + mp, n);
    b_.resize(me + mp);
    if (me) {
      A_.topRows(me) = ek->M_;
      b_.head(me) = ek->r_;
    }
    if (mp) {
      A_.bottomRows(mp) = Ap_;
      b_.tail(mp) = bp_;
    }
    if (!A_.allFinite() || !b_.allFinite())
      raise_invalid("equality rows must be finite (an equality task's target, weight or "
                    "Jacobian is NaN or inf)");
    C_.resize(0, n);
    l_.resize(0);
    u_.resize(0);
    if (!inequalities.is_none()) {
      C_ = bp::extract<Eigen::Ref<const RowMatrixXd>>(inequalities[0])();
      l_ = bp::extract<Eigen::Ref<const VectorXd>>(inequalities[1])();
      u_ = bp::extract<Eigen::Ref<const VectorXd>>(inequalities[2])();
      if (C_.cols() != n || l_.size() != C_.rows() || u_.size() != C_.rows())
        raise_invalid("inequality rows: sizes differ");
      if (!C_.allFinite() || l_.hasNaN() || u_.hasNaN())
        raise_invalid("inequality rows must not be NaN (C finite; l, u may be +-inf)");
    }
  }

  // taskspace.qp.kkt.kkt_residuals of (x_, y_, [zd_; z_], zbox_) for the QP with the
  // equality rows, the damper and Python inequality rows and the box; written to the
  // kernel's res_. Returns whether they meet its eps_abs + eps_rel * scale.
  bool kkt(WeightedIKKernel& k) {
    const int n = k.nv_, md = k.m_in_;
    const double inf = WeightedIKKernel::kInf;
    hx_.noalias() = k.H_ * x_;
    force_ = zbox_;
    double primal = 0.0, comp = 0.0, pscale = x_.cwiseAbs().maxCoeff();
    double gap = x_.dot(hx_) + k.g_.dot(x_), by = 0.0;
    if (A_.rows()) {
      force_.noalias() += A_.transpose() * y_;
      primal = (A_ * x_ - b_).cwiseAbs().maxCoeff();
      pscale = std::max(pscale, b_.cwiseAbs().maxCoeff());
      by = b_.dot(y_);
      gap += by;
    }
    // one row of l <= value <= u with multiplier zi (the inequality rows, then the box)
    auto row = [&](double value, double lo, double hi, double zi, bool scaled) {
      lo = std::max(lo, -inf);
      hi = std::min(hi, inf);
      const double above = value - hi, below = lo - value;
      primal = std::max(primal, std::max(above, below));
      if (scaled) pscale = std::max(pscale, std::abs(value));
      comp = std::max(comp, std::min(std::abs(zi), std::abs(zi > 0.0 ? above : below)));
      gap += (zi > 0.0 ? hi : lo) * zi;
    };
    if (md) {
      force_.noalias() += k.C_.topRows(md).transpose() * zd_;
      cd_.noalias() = k.C_.topRows(md) * x_;
      for (int i = 0; i < md; ++i) row(cd_[i], k.l_[i], inf, zd_[i], true);
    }
    if (C_.rows()) {
      force_.noalias() += C_.transpose() * z_;
      cd_.noalias() = C_ * x_;
      for (long i = 0; i < C_.rows(); ++i) row(cd_[i], l_[i], u_[i], z_[i], true);
    }
    for (int i = 0; i < n; ++i) row(x_[i], k.lb_[i], k.ub_[i], zbox_[i], false);
    const double dual = (hx_ + k.g_ + force_).cwiseAbs().maxCoeff();
    const double dscale = std::max({hx_.cwiseAbs().maxCoeff(), k.g_.cwiseAbs().maxCoeff(),
                                    force_.cwiseAbs().maxCoeff()});
    k.res_[0] = primal;
    k.res_[1] = dual;
    k.res_[2] = comp;
    k.res_[3] = std::abs(gap);
    k.res_[4] = pscale;
    k.res_[5] = dscale;
    k.res_[6] = std::max({1.0, std::abs(x_.dot(hx_)), std::abs(k.g_.dot(x_)), std::abs(by)});
    const double ea = k.eps_abs_, er = k.eps_rel_;
    return primal <= ea + er * pscale && dual <= ea + er * dscale &&
           comp <= ea + er * std::max(pscale, dscale);
  }

  int engine_ = kEngineActiveSet;
  bool warm_start_ = true, warm_valid_ = false;
  long warm_hits_ = 0, warm_misses_ = 0, fresh_qps_ = 0;
  std::vector<Key> prev_;
  std::vector<int> slot_row_, set_;
  Eigen::LLT<MatrixXd> llt_, sllt_;
  MatrixXd V_, S_;
  VectorXd t_, r1_, r2_, xs_, lams_, dx_, dlam_, s_;
  GoldfarbIdnani gi_;
  RowMatrixXd A_, C_, Ap_;
  VectorXd bp_;
  VectorXd b_, l_, u_;
  MatrixXd G_, Ga_;
  VectorXd h_, ha_, x_, w_, y_, z_, zd_, zbox_, hx_, force_, cd_;
  std::vector<int> kind_, index_;
  std::vector<double> sign_;
};

void register_general_ik_step() {
  bp::scope().attr("GENERAL_INFEASIBLE") = GeneralIKStep::kInfeasible;
  bp::scope().attr("GENERAL_DEPENDENT") = GeneralIKStep::kDependent;
  bp::scope().attr("GENERAL_NOT_CERTIFIED") = GeneralIKStep::kNotCertified;
  bp::scope().attr("GENERAL_NOT_POSITIVE_DEFINITE") = GeneralIKStep::kNotPositiveDefinite;
  bp::list engines;
  engines.append("active_set");
#ifdef TASKSPACE_IK_PROXSUITE
  engines.append("proxsuite");
#endif
  bp::scope().attr("GENERAL_ENGINES") = bp::tuple(engines);  // index = set_engine's argument
  bp::class_<GeneralIKStep, boost::noncopyable>("GeneralIKStep", bp::init<>(bp::args("self")))
      .def("solve", &GeneralIKStep::solve)
      .def("advance", &GeneralIKStep::advance)
      .def("multipliers", &GeneralIKStep::multipliers)
      .def("set_engine", &GeneralIKStep::set_engine)
      .add_property("engine", &GeneralIKStep::engine)
      .def("set_warm_start", &GeneralIKStep::set_warm_start)
      .def("reset_warm_start", &GeneralIKStep::reset_warm_start)
      .def("warm_stats", &GeneralIKStep::warm_stats);
}
