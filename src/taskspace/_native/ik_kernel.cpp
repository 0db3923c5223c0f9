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
#include <structmember.h>  // T_OBJECT_EX, READONLY (arm_advance)
#include <eigenpy/eigenpy.hpp>
#ifdef TASKSPACE_IK_PROXSUITE  // the general step's proxsuite engine (general_step.hpp)
#include "dense_qp.hpp"  // proxsuite's dense solver, compiled once (dense_qp.cpp)
#endif

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
#include <pinocchio/algorithm/geometry.hpp>
#include <pinocchio/collision/distance.hpp>
#include <pinocchio/multibody/geometry.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <map>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

namespace bp = boost::python;
using pinocchio::Data;
using pinocchio::GeometryData;
using pinocchio::GeometryModel;
using pinocchio::Model;
using pinocchio::SE3;
using Eigen::MatrixXd;
using Eigen::VectorXd;
using RowMatrixXd = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

namespace {

enum Kind { kPose = 0, kPosition = 1, kCom = 2, kPosture = 3, kOrientation = 4 };

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

// One collision velocity damper (taskspace.constraints.CollisionAvoidance): the row
// J_d dq >= -gain (d - safety) of collision pair `pair` when its distance d < influence.
struct Damper {
  int pair;
  double safety, influence, gain;
  // the last exact distance and the placements it was computed at (the geometries' sphere
  // centres and rotations): a lower bound of the distance at other placements
  bool ref = false;
  double d_ref = 0.0;
  Eigen::Vector3d ca_ref, cb_ref;
  Eigen::Matrix3d Ra_ref, Rb_ref;
};

// Status codes returned to Python.
constexpr int kUnconstrained = 0;
constexpr int kSolved = 1;
constexpr int kMaxIterations = 2;
constexpr int kBusy = -1;  // WeightedIKKernel::call_advance: another thread holds the solver

class HierarchicalIKKernel;  // hier_kernel.hpp: reuses this kernel's rows and boxes
class GeneralIKStep;  // general_step.hpp: this kernel's QP with equality and inequality rows

class WeightedIKKernel {
  friend class HierarchicalIKKernel;
  friend class GeneralIKStep;

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
    a0_.setZero(nv);
    Lf_.setZero(nv, nv);
    xf_.setZero(nv);
    upd_.setZero(nv);
    free_.reserve(nv);
  }

  int add_pose(const Model& model, int frame) {
    return add({kPose, frame, m_, 6, support_columns(model, frame)});
  }
  int add_position(const Model& model, int frame) {
    return add({kPosition, frame, m_, 3, support_columns(model, frame)});
  }
  // log3 rotation error, Jlog3 times the LOCAL angular Jacobian (taskspace's Orientation);
  // the general step's equality rows (general_step.hpp)
  int add_orientation(const Model& model, int frame) {
    return add({kOrientation, frame, m_, 3, support_columns(model, frame)});
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
    st_model_ = nullptr;
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

  // Collision velocity dampers (CollisionAvoidance): forget them all.
  void clear_dampers() {
    dampers_.clear();
    geom_set_ = false;
  }

  // Add the dampers of one CollisionAvoidance: collision pairs (indices into
  // geom.collisionPairs) with its safety and influence distances [m] and gain. The bounding
  // sphere and the local AABB of each geometry (coal's) are read here: a pair whose spheres,
  // or whose boxes (the local AABBs as world AABBs), are farther apart than the influence
  // distance is skipped without a distance query (its distance is at least theirs: the same
  // rows as the Python path).
  void add_dampers(const Model& model, GeometryModel& geom, bp::object pairs, double safety,
                   double influence, double gain) {
    if (model.nv != nv_) raise_invalid("model size mismatch");
    if (!(safety >= 0.0) || !(influence > safety) || !(gain > 0.0 && gain <= 1.0))
      raise_invalid("damper parameters: need 0 <= safety < influence and 0 < gain <= 1");
    const long n = bp::len(pairs);
    const long npairs = static_cast<long>(geom.collisionPairs.size());
    for (long i = 0; i < n; ++i) {
      const int k = bp::extract<int>(pairs[i]);
      if (k < 0 || k >= npairs) raise_invalid("collision pair index out of range");
      Damper dm;
      dm.pair = k;
      dm.safety = safety;
      dm.influence = influence;
      dm.gain = gain;
      dampers_.push_back(dm);
    }
    const std::size_t ng = geom.geometryObjects.size();
    sphere_c_.resize(ng);
    sphere_r_.resize(ng);
    box_c_.resize(ng);
    box_h_.resize(ng);
    for (std::size_t g = 0; g < ng; ++g) {
      auto& shape = geom.geometryObjects[g].geometry;
      if (!shape) {
        sphere_c_[g].setZero();
        sphere_r_[g] = kInf;
        box_c_[g].setZero();
        box_h_[g].setConstant(kInf);
        continue;
      }
      if (!(shape->aabb_radius >= 0.0)) shape->computeLocalAABB();
      sphere_c_[g] = shape->aabb_center;
      sphere_r_[g] = std::isfinite(shape->aabb_radius) ? shape->aabb_radius : kInf;
      const auto& box = shape->aabb_local;
      box_c_[g] = 0.5 * (box.min_ + box.max_);
      box_h_[g] = 0.5 * (box.max_ - box.min_);
      if (!box_c_[g].allFinite() || !box_h_[g].allFinite()) {
        box_c_[g].setZero();
        box_h_[g].setConstant(kInf);
      }
    }
    // support columns of every joint (the nonzero columns of its WORLD Jacobian)
    joint_cols_.assign(model.njoints, {});
    for (int j = 1; j < model.njoints; ++j) {
      for (const auto s : model.supports[j]) {
        if (s == 0) continue;
        for (int c = 0; c < model.nvs[s]; ++c) joint_cols_[j].push_back(model.idx_vs[s] + c);
      }
      std::sort(joint_cols_[j].begin(), joint_cols_[j].end());
    }
    geom_set_ = true;
  }

  void set_tolerances(double eps_abs, double eps_rel) {
    if (!(eps_abs >= 0.0) || !(eps_rel >= 0.0)) raise_invalid("tolerances must be >= 0");
    eps_abs_ = eps_abs;
    eps_rel_ = eps_rel;
  }

  // The damper rows of the last solve: (C, l, u, pair indices, distances) (copies).
  bp::tuple damper_rows() const {
    const MatrixXd C = C_.topRows(m_in_);
    const VectorXd l = l_.head(m_in_);
    const VectorXd u = VectorXd::Constant(m_in_, kInf);
    bp::list pairs, dists;
    for (int k = 0; k < m_in_; ++k) {
      pairs.append(row_pair_[k]);
      dists.append(row_dist_[k]);
    }
    return bp::make_tuple(C, l, u, pairs, dists);
  }

  // KKT residuals of the last solve (primal, dual, complementarity, duality gap, primal
  // scale, dual scale, gap scale), as taskspace.qp.kkt.kkt_residuals defines them, for the
  // QP with the damper rows and the box; and the multipliers (z of the rows, z_box).
  bp::tuple residuals() const {
    return bp::make_tuple(res_[0], res_[1], res_[2], res_[3], res_[4], res_[5], res_[6]);
  }
  // The structured factorization of the box-only step (no dampers): (used, low-rank rows,
  // solves it ended unconstrained, solves whose minimizer was outside the box (then
  // box_qp), solves that fell back to the dense factorization). `used` is known after the
  // first solve with a model.
  bp::tuple structured_counts() const {
    return bp::make_tuple(st_model_ != nullptr && st_use_, st_r_, st_count_[0], st_count_[1],
                          st_count_[2]);
  }
  bp::tuple multipliers() const {
    const VectorXd z = z_.head(m_in_);
    return bp::make_tuple(z, zbox_);
  }

  // solve() of a stack without dampers (no collision model).
  bp::tuple solve_boxes(const Model& model, Data& data, const Eigen::Ref<const VectorXd>& q,
                        bp::list targets, bp::list hard_boxes, bp::list soft_boxes,
                        double damping, Eigen::Ref<VectorXd> out, int max_iter) {
    return solve(model, data, q, targets, hard_boxes, soft_boxes, damping, out, max_iter,
                 bp::object(), bp::object());
  }

  // Evaluate the stack at (model, data, q) and solve; returns (status, iterations, objective,
  // build time, QP time, row time) [s]. The step is written into ``out`` (size nv).
  // With dampers, geom/gdata are the collision model and a GeometryData of it (placements
  // updated here from data.oMi, distances computed here); otherwise None.
  bp::tuple solve(const Model& model, Data& data, const Eigen::Ref<const VectorXd>& q,
                  bp::list targets, bp::list hard_boxes, bp::list soft_boxes, double damping,
                  Eigen::Ref<VectorXd> out, int max_iter, bp::object geom_obj,
                  bp::object gdata_obj) {
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
    position_box(q);
    combine_bounds(hard_boxes, soft_boxes);
    const Outcome o =
        solve_from(t0, model, data, q, targets, damping, out, max_iter, geom_obj, gdata_obj);
    return bp::make_tuple(o.status, o.iterations, o.objective, o.t_build, o.t_qp, o.t_rows);
  }

  // DifferentialIK.advance's armed step (a stack without dampers): arm() keeps the model,
  // the tasks (their targets are read here, at each call), the boxes evaluated in Python
  // (constant while dt and the robot's version are: the caller re-arms when either changes),
  // the damping and the iteration limit; the call passes only the state's data, q and dt
  // (0: no velocity). The same solve, integration and kinematics as advance(). Returns
  // (status, iterations, objective, build time, QP time, dq, q_next, v_next): dq a new
  // array, q_next and v_next (None without velocity) new read-only views of new locked
  // arrays (as State._adopt makes them); all three None at kMaxIterations (data untouched).
  void arm(bp::object model_obj, bp::list tasks, bp::list hard_boxes, bp::list soft_boxes,
           double damping, int max_iter) {
    armed_ = false;
    fa_armed_ = false;  // arm_advance again
    const Model& model = bp::extract<const Model&>(model_obj);
    if (model.nv != nv_ || model.nq != nq_) raise_invalid("model size mismatch");
    const long nt = bp::len(tasks);
    if (nt != static_cast<long>(items_.size() + posture_.size()))
      raise_invalid("one task per term expected");
    if (!(damping >= 0.0) || !std::isfinite(damping))
      raise_invalid("damping must be finite and >= 0, got " + std::to_string(damping));
    if (max_iter < 0) raise_invalid("max_iter must be >= 0, got " + std::to_string(max_iter));
    if (!dampers_.empty()) raise_invalid("arm: a stack with dampers is not armed");
    intersect(hard_boxes, nv_, ahlb_, ahub_);
    intersect(soft_boxes, nv_, aslb_, asub_);
    a_hard_ = bp::len(hard_boxes) > 0;
    a_soft_ = bp::len(soft_boxes) > 0;
    armed_tasks_.clear();
    for (long k = 0; k < nt; ++k) armed_tasks_.push_back(tasks[k]);
    if (!target_name_) target_name_ = bp::object(bp::handle<>(PyUnicode_InternFromString("_target")));
    armed_model_obj_ = model_obj;  // keeps the model alive while armed
    armed_model_ = &model;
    armed_damping_ = damping;
    armed_max_iter_ = max_iter;
    armed_ = true;
  }

  void disarm() {
    armed_ = false;
    fa_armed_ = false;
    armed_tasks_.clear();
    armed_model_obj_ = bp::object();
    armed_model_ = nullptr;
  }

  bp::tuple step(Data& data, const Eigen::Ref<const VectorXd>& q, double dt) {
    const Stepped s = step_arrays(data, q, dt);
    const Outcome& o = s.outcome;
    if (o.status == kMaxIterations)
      return bp::make_tuple(o.status, o.iterations, o.objective, o.t_build, o.t_qp, bp::object(),
                            bp::object(), bp::object());
    return bp::make_tuple(o.status, o.iterations, o.objective, o.t_build, o.t_qp, s.dq, s.q,
                          s.v);
  }

  // DifferentialIK.advance's whole armed step as one C function (METH_FASTCALL, no Boost.Python
  // dispatch): ``advance(state, dt)`` checks the gate and that the solver's lock is free (see
  // call_advance), runs step() on the
  // state's data and q, records the new q (v) in the state as State._adopt(q, v, True) does and
  // returns a new IKStepResult; None (nothing done) when the lock is held or
  // the gate does not hold; False at kMaxIterations (data untouched). Called after arm() (whose
  // boxes are those of ``dt``) with:
  //   gate:   (dt, robot, robot's version, the tasks.ASSIGNMENTS list, its armed value, the
  //            solver's lock)
  //   state:  (State, its member descriptors _robot, _data, _q, _v, _has_velocity, _a0,
  //            (set None...), (dicts cleared...), (set False...))
  //   result: (IKStepResult, its member descriptors success, status, dq, _velocity, _dt, _qp,
  //            culprits, build_time, solve_time, IKStatus.SOLVED, QPStatus.UNCONSTRAINED,
  //            QPStatus.SOLVED, backend name)
  // A slot is written at the offset its member descriptor gives (checked here: an object
  // slot of that class, writable). The function keeps the kernel alive.
  static bp::object arm_advance(bp::object self, bp::tuple gate, bp::tuple state,
                                bp::tuple result) {
    WeightedIKKernel& k = bp::extract<WeightedIKKernel&>(self);
    k.fa_armed_ = false;
    if (!k.armed_) raise_invalid("arm_advance: the kernel is not armed (arm first)");
    if (bp::len(gate) != 6 || bp::len(state) != 10 || bp::len(result) != 14)
      raise_invalid("arm_advance: (6 gate, 10 state, 14 result) items expected");
    k.fa_dt_ = bp::extract<double>(gate[0]);
    k.fa_robot_ = gate[1];
    k.fa_version_ = gate[2];
    k.fa_assignments_ = gate[3];
    if (!PyList_Check(k.fa_assignments_.ptr()) || PyList_GET_SIZE(k.fa_assignments_.ptr()) < 1)
      raise_invalid("arm_advance: ASSIGNMENTS must be a non-empty list");
    k.fa_assigned_ = gate[4];
    k.fa_locked_ = gate[5].attr("locked");
    bp::object st = state[0];
    if (!PyType_Check(st.ptr())) raise_invalid("arm_advance: State must be a class");
    k.fa_state_type_ = st;
    const auto offsets = [](bp::object cls, bp::object descriptors) {
      std::vector<Py_ssize_t> out;
      for (long i = 0; i < bp::len(descriptors); ++i) out.push_back(slot_offset(cls, descriptors[i]));
      return out;
    };
    k.st_robot_ = slot_offset(st, state[1]);
    k.st_data_ = slot_offset(st, state[2]);
    k.st_q_ = slot_offset(st, state[3]);
    k.st_v_ = slot_offset(st, state[4]);
    k.st_has_v_ = slot_offset(st, state[5]);
    k.st_a0_ = slot_offset(st, state[6]);
    // (assigned only when they change: a step of another thread may be iterating over them)
    for (auto [kept, i] : {std::pair{&k.st_none_, 7}, {&k.st_clear_, 8}, {&k.st_false_, 9}}) {
      std::vector<Py_ssize_t> now = offsets(st, state[i]);
      if (now != *kept) *kept = std::move(now);
    }
    bp::object rt = result[0];
    if (!PyType_Check(rt.ptr())) raise_invalid("arm_advance: IKStepResult must be a class");
    k.fa_result_type_ = rt;
    for (int i = 0; i < 9; ++i) k.rs_[i] = slot_offset(rt, result[1 + i]);
    k.fa_ik_solved_ = result[10];
    k.fa_unconstrained_ = result[11];
    k.fa_solved_ = result[12];
    k.fa_backend_ = result[13];
    if (!k.version_name_)
      k.version_name_ = bp::object(bp::handle<>(PyUnicode_InternFromString("_version")));
    k.fa_data_obj_ = bp::object();
    k.fa_data_ = nullptr;
    k.fa_armed_ = true;
    static PyMethodDef def = {
        "advance", reinterpret_cast<PyCFunction>(reinterpret_cast<void (*)(void)>(&call_advance)),
        METH_FASTCALL, "advance(state, dt): the armed step (see WeightedIKKernel.arm_advance)"};
    PyObject* cap = PyCapsule_New(&k, kCapsule, &release_capsule);
    if (!cap) bp::throw_error_already_set();
    Py_INCREF(self.ptr());  // the capsule's context: keeps the kernel alive
    if (PyCapsule_SetContext(cap, self.ptr()) != 0) {
      Py_DECREF(self.ptr());
      Py_DECREF(cap);
      bp::throw_error_already_set();
    }
    PyObject* fn = PyCFunction_New(&def, cap);
    Py_DECREF(cap);
    if (!fn) bp::throw_error_already_set();
    return bp::object(bp::handle<>(fn));
  }

 private:
  static constexpr const char* kCapsule = "taskspace._ik_kernel.armed_advance";

  static void release_capsule(PyObject* cap) {
    Py_XDECREF(static_cast<PyObject*>(PyCapsule_GetContext(cap)));
  }

  // The offset of the object slot that member descriptor `d` of class `cls` (or a base)
  // reads and writes.
  static Py_ssize_t slot_offset(bp::object cls, bp::object d) {
    PyObject* p = d.ptr();
    if (Py_TYPE(p) != &PyMemberDescr_Type)
      raise_invalid("arm_advance: a slot's member descriptor expected");
    const PyMemberDef* m = reinterpret_cast<PyMemberDescrObject*>(p)->d_member;
    PyTypeObject* owner = reinterpret_cast<PyDescrObject*>(p)->d_type;
    if (m->type != T_OBJECT_EX || (m->flags & READONLY) ||
        !PyType_IsSubtype(reinterpret_cast<PyTypeObject*>(cls.ptr()), owner))
      raise_invalid("arm_advance: a writable object slot of the class expected");
    return m->offset;
  }

  static PyObject*& slot(PyObject* o, Py_ssize_t offset) {
    return *reinterpret_cast<PyObject**>(reinterpret_cast<char*>(o) + offset);
  }

  // o.<slot> = v (a new reference taken)
  static void set_slot(PyObject* o, Py_ssize_t offset, PyObject* v) {
    PyObject*& s = slot(o, offset);
    PyObject* old = s;
    Py_INCREF(v);
    s = v;
    Py_XDECREF(old);
  }

  // The solver's lock is not taken: it is checked free (lock.locked()) right before the
  // kernel's workspaces are used (step_arrays), and from that check until the step is written
  // into new arrays no Python code runs and the GIL is held, so no other thread can run, let
  // alone hold the lock or use the kernel (a thread that holds the lock, or waits for it,
  // resumes only when this one runs Python code again: after the step). What follows (the
  // state's slots, the result) touches only this thread's state and new objects.
  static PyObject* call_advance(PyObject* cap, PyObject* const* args, Py_ssize_t nargs) {
    auto* k = static_cast<WeightedIKKernel*>(PyCapsule_GetPointer(cap, kCapsule));
    if (!k) return nullptr;
    if (nargs != 2) {
      PyErr_SetString(PyExc_TypeError, "advance(state, dt) takes 2 arguments");
      return nullptr;
    }
#ifdef Py_GIL_DISABLED
    Py_RETURN_NONE;  // without a GIL other threads do run: the caller's path, with the lock
#endif
    try {
      return k->advance_unlocked(args[0], args[1]);
    } catch (...) {
      bp::handle_exception();
      return nullptr;
    }
  }

  // call_advance()'s work.
  PyObject* advance_unlocked(PyObject* state, PyObject* dt_obj) {
    const auto t0 = std::chrono::steady_clock::now();
    // the gate: what the kept boxes, tasks and kinematics depend on
    if (!fa_armed_ || !armed_ || !PyFloat_CheckExact(dt_obj) ||
        PyFloat_AS_DOUBLE(dt_obj) != fa_dt_ ||
        Py_TYPE(state) != reinterpret_cast<PyTypeObject*>(fa_state_type_.ptr()) ||
        slot(state, st_robot_) != fa_robot_.ptr())
      Py_RETURN_NONE;
    const int same = PyObject_RichCompareBool(PyList_GET_ITEM(fa_assignments_.ptr(), 0),
                                              fa_assigned_.ptr(), Py_EQ);
    if (same < 0) return nullptr;
    if (!same) Py_RETURN_NONE;
    PyObject* version = PyObject_GetAttr(fa_robot_.ptr(), version_name_.ptr());
    if (!version) return nullptr;
    const int current = PyObject_RichCompareBool(version, fa_version_.ptr(), Py_EQ);
    Py_DECREF(version);
    if (current < 0) return nullptr;
    if (!current) Py_RETURN_NONE;
    // the state's data (made for this robot's model: checked by the state's robot) and q
    PyObject* data_obj = slot(state, st_data_);
    PyObject* q_obj = slot(state, st_q_);
    PyObject* has_v = slot(state, st_has_v_);
    if (!data_obj || !q_obj || !has_v || !PyArray_Check(q_obj)) Py_RETURN_NONE;
    PyArrayObject* qa = reinterpret_cast<PyArrayObject*>(q_obj);
    if (PyArray_TYPE(qa) != NPY_DOUBLE || PyArray_NDIM(qa) != 1 || PyArray_DIM(qa, 0) != nq_ ||
        !PyArray_IS_C_CONTIGUOUS(qa) || !PyArray_ISALIGNED(qa))
      Py_RETURN_NONE;
    if (data_obj != fa_data_obj_.ptr()) {
      bp::extract<Data&> get(data_obj);
      if (!get.check()) Py_RETURN_NONE;
      fa_data_ = &get();
      fa_data_obj_ = bp::object(bp::handle<>(bp::borrowed(data_obj)));  // kept: its address
    }
    const bool with_velocity = has_v == Py_True;
    const double dt = PyFloat_AS_DOUBLE(dt_obj);
    const Eigen::Map<const VectorXd> q(static_cast<const double*>(PyArray_DATA(qa)), nq_);
    const Stepped s = step_arrays(*fa_data_, q, with_velocity ? dt : 0.0, fa_locked_.ptr());
    const Outcome& o = s.outcome;
    if (o.status == kBusy) Py_RETURN_NONE;  // the caller waits for the lock
    if (o.status == kMaxIterations) Py_RETURN_FALSE;
    // State._adopt(q, v, True)
    set_slot(state, st_q_, s.q.ptr());
    if (with_velocity) {
      set_slot(state, st_v_, s.v.ptr());
    } else {
      PyObject* a0 = slot(state, st_a0_);
      if (!a0) raise_invalid("advance: the state has no zero velocity");
      set_slot(state, st_v_, a0);
      set_slot(state, st_has_v_, Py_False);
    }
    for (const Py_ssize_t off : st_clear_) {
      PyObject* d = slot(state, off);
      if (d && PyDict_CheckExact(d)) {
        if (PyDict_GET_SIZE(d)) PyDict_Clear(d);
      } else {
        set_slot(state, off, bp::dict().ptr());
      }
    }
    for (const Py_ssize_t off : st_none_) set_slot(state, off, Py_None);
    for (const Py_ssize_t off : st_false_) set_slot(state, off, Py_False);
    // IKStepResult(True, SOLVED, dq, None, qp, [], build_time, qp_time, dt=dt), its fields
    PyTypeObject* rt = reinterpret_cast<PyTypeObject*>(fa_result_type_.ptr());
    bp::handle<> res(rt->tp_alloc(rt, 0));
    const double elapsed =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    bp::handle<> qp(PyTuple_New(7));
    bp::handle<> objective(PyFloat_FromDouble(o.objective));
    bp::handle<> iterations(PyLong_FromLong(o.iterations));
    bp::handle<> qp_elapsed(PyFloat_FromDouble(elapsed));
    bp::handle<> build_time(PyFloat_FromDouble(o.t_build));
    bp::handle<> qp_time(PyFloat_FromDouble(o.t_qp));
    bp::handle<> culprits(PyList_New(0));
    PyObject* status = (o.status == kUnconstrained ? fa_unconstrained_ : fa_solved_).ptr();
    PyObject* items[7] = {Py_True, status, s.dq.ptr(), objective.get(), iterations.get(),
                          qp_elapsed.get(), fa_backend_.ptr()};
    for (int i = 0; i < 7; ++i) {
      Py_INCREF(items[i]);
      PyTuple_SET_ITEM(qp.get(), i, items[i]);
    }
    PyObject* r = res.get();
    set_slot(r, rs_[0], Py_True);                // success
    set_slot(r, rs_[1], fa_ik_solved_.ptr());    // status
    set_slot(r, rs_[2], s.dq.ptr());             // dq
    set_slot(r, rs_[3], Py_None);                // _velocity (dq / dt on first access)
    set_slot(r, rs_[4], dt_obj);                 // _dt
    set_slot(r, rs_[5], qp.get());               // _qp (the QPResult made on first access)
    set_slot(r, rs_[6], culprits.get());         // culprits
    set_slot(r, rs_[7], build_time.get());       // build_time
    set_slot(r, rs_[8], qp_time.get());          // solve_time
    return res.release();
  }

 private:
  struct Outcome {
    int status, iterations;
    double objective, t_build, t_qp, t_rows;
  };

  // step() without its Python tuple: the outcome, the new dq and the new read-only views of q
  // and v (None without velocity); the arrays are None at kMaxIterations (data untouched).
  struct Stepped {
    Outcome outcome;
    bp::object dq, q, v;
    bp::object dropped[5];  // arrays no longer kept for reuse: released after the step
  };

  // `locked` (call_advance: the solver's lock.locked): checked after the targets are read, the
  // last point before the kernel's workspaces are used where Python code may run (a task's
  // attribute, a collection at the allocation of the list); when it says the lock is held,
  // nothing more is done (status kBusy).
  Stepped step_arrays(Data& data, const Eigen::Ref<const VectorXd>& q, double dt,
                      PyObject* locked = nullptr) {
    if (!armed_) raise_invalid("step: the kernel is not armed (arm first)");
    const Model& model = *armed_model_;
    if (q.size() != nq_) raise_invalid("vector size mismatch");
    const bool with_velocity = dt > 0.0;
    if (dt != 0.0 && !(with_velocity && std::isfinite(dt)))
      raise_invalid("dt must be finite and > 0 (or 0: no velocity), got " + std::to_string(dt));
    if (!scaled_) raise_invalid("set_scaling was not called");
    if (!q.allFinite()) raise_invalid("q must be finite");
    // the tasks' targets, read now
    const long nt = static_cast<long>(armed_tasks_.size());
    PyObject* list = PyList_New(nt);
    if (!list) bp::throw_error_already_set();
    bp::list targets{bp::detail::new_reference(list)};  // owns it (no copy)
    for (long k = 0; k < nt; ++k) {
      PyObject* t = PyObject_GetAttr(armed_tasks_[k].ptr(), target_name_.ptr());
      if (!t) bp::throw_error_already_set();
      PyList_SET_ITEM(targets.ptr(), k, t);
    }
    if (locked) {
      PyObject* held = PyObject_CallNoArgs(locked);
      if (!held) bp::throw_error_already_set();
      const bool busy = held != Py_False;
      Py_DECREF(held);
      if (busy) return {{kBusy, 0, 0.0, 0.0, 0.0, 0.0}, bp::object(), bp::object(), bp::object()};
    }
    // from here to the return no Python code runs (no GC-tracked allocation, no attribute
    // lookup), so no other thread does
    const auto t0 = std::chrono::steady_clock::now();
    position_box(q);
    combine_armed();
    Recycled& old = recycled_[recycle_next_];
    recycle_next_ ^= 1;
    Stepped out;
    double* dq_data = nullptr;
    bp::object dq_obj = fresh_vector(old.dq, nv_, &dq_data, out.dropped[0]);
    Eigen::Map<VectorXd> dq_map(dq_data, nv_);
    out.outcome = solve_from(t0, model, data, q, targets, armed_damping_, dq_map,
                             armed_max_iter_, bp::object(), bp::object());
    if (out.outcome.status == kMaxIterations) return out;
    double* q_data = nullptr;
    bp::object q_obj = fresh_locked(old.q_view, old.q_base, nq_, &q_data, out.dropped + 1);
    Eigen::Map<VectorXd> q_next(q_data, nq_);
    pinocchio::integrate(model, q, x_, q_next);
    bp::object v_obj;
    if (with_velocity) {
      double* v_data = nullptr;
      v_obj = fresh_locked(old.v_view, old.v_base, nv_, &v_data, out.dropped + 3);
      Eigen::Map<VectorXd> v_next(v_data, nv_);
      v_next = x_ / dt;
      pinocchio::forwardKinematics(model, data, q_next, v_next, a0_);
      pinocchio::computeJointJacobians(model, data);
    } else {
      pinocchio::computeJointJacobians(model, data, q_next);
    }
    pinocchio::updateFramePlacements(model, data);
    out.dq = dq_obj;
    out.q = q_obj;
    out.v = v_obj;
    return out;
  }

  // The arrays of the step two calls ago, kept here: when nobody else holds one any more (its
  // only reference is this one, and no weak reference), the next step reuses it rather than
  // making a new one (as CPython's zip() reuses its result tuple). Nobody can see the reuse:
  // a result, q or v that anyone keeps (or any view of it) is never written again.
  struct Recycled {
    bp::object dq, q_view, q_base, v_view, v_base;
  };

  static bool unshared(const bp::object& a, Py_ssize_t references) {
#ifdef Py_GIL_DISABLED
    return false;  // another thread may take a reference at any time: never reused
#endif
    PyObject* p = a.ptr();
    return p != Py_None && Py_REFCNT(p) == references &&
           reinterpret_cast<PyArrayObject_fields*>(p)->weakreflist == nullptr;
  }

  // A new writable vector of size n (or `kept`, unshared), kept for a later reuse; the array
  // it replaces goes to `dropped` (released by the caller after the step: its last release
  // could run Python code, a weak reference's callback).
  static bp::object fresh_vector(bp::object& kept, int n, double** data, bp::object& dropped) {
    if (!unshared(kept, 1)) {
      dropped = kept;
      kept = bp::object(bp::handle<>(new_vector(n)));
    }
    *data = static_cast<double*>(PyArray_DATA(reinterpret_cast<PyArrayObject*>(kept.ptr())));
    return kept;
  }

  // A new read-only view of a new locked vector of size n (locked_view), or `view` and its
  // `base` when both are unshared (the base is held by the view and here); kept for reuse.
  static bp::object fresh_locked(bp::object& view, bp::object& base, int n, double** data,
                                 bp::object* dropped) {
    if (!unshared(view, 1) || !unshared(base, 2)) {
      dropped[0] = view;
      dropped[1] = base;
      base = bp::object(bp::handle<>(new_vector(n)));
      view = locked_view(base.ptr());
    }
    *data = static_cast<double*>(PyArray_DATA(reinterpret_cast<PyArrayObject*>(base.ptr())));
    return view;
  }

  static PyObject* new_vector(int n) {
    npy_intp dims[1] = {n};
    PyObject* a = eigenpy::call_PyArray_SimpleNew(1, dims, NPY_DOUBLE);
    if (!a) bp::throw_error_already_set();
    return a;
  }

  // A read-only view of `base` (a new array nobody else holds), whose buffer is locked:
  // numpy refuses to make the view writable again (State._adopt's q.setflags(write=False);
  // q.view()).
  static bp::object locked_view(PyObject* base) {
    PyArray_CLEARFLAGS(reinterpret_cast<PyArrayObject*>(base), NPY_ARRAY_WRITEABLE);
    PyObject* v = PyArray_View(reinterpret_cast<PyArrayObject*>(base), nullptr, nullptr);
    if (!v) bp::throw_error_already_set();
    return bp::object(bp::handle<>(v));
  }

  // The joint position box at q (the kernel's copy of the limits).
  void position_box(const Eigen::Ref<const VectorXd>& q) {
    if (pl_set_) {
      for (std::size_t k = 0; k < pl_iq_.size(); ++k) {
        const double qk = q[pl_iq_[k]];
        pl_lb_[pl_iv_[k]] = pl_low_[k] - qk;
        pl_ub_[pl_iv_[k]] = pl_high_[k] - qk;
      }
    }
  }

  // g beyond taskspace.qp.solver.MAX_QP_MAGNITUDE (a target 1e31 m away): the Python path
  // refuses such a QP (InvalidInputError naming the entries); the kernel declines it rather
  // than answering (it came back SOLVED with a box-corner step where the Python path raised).
  // NaN passes here (the step's finiteness check raises on it).
  static constexpr double kMaxQpMagnitude = 1e30;
  bool huge_gradient() const {
    for (Eigen::Index i = 0; i < g_.size(); ++i)
      if (std::abs(g_[i]) > kMaxQpMagnitude) return true;
    return false;
  }
  Outcome declined_outcome(std::chrono::steady_clock::time_point t0,
                           std::chrono::steady_clock::time_point t1) const {
    const double build = std::chrono::duration<double>(t1 - t0).count();
    return {kMaxIterations, 0, 0.0, build, 0.0, build};
  }

  // solve() after its checks and the boxes (lb_, ub_): rows, H, g, the QP; the step in out.
  Outcome solve_from(std::chrono::steady_clock::time_point t0, const Model& model, Data& data,
                     const Eigen::Ref<const VectorXd>& q, bp::list& targets, double damping,
                     Eigen::Ref<VectorXd> out, int max_iter, bp::object geom_obj,
                     bp::object gdata_obj) {
    // H = M^T M + mu I (lower triangle), g = -M^T r: one symmetric rank update of the stacked
    // rows (zero outside each task's support columns)
    if (dampers_.empty() && st_model_ != &model) plan_structure(model);
    std::chrono::steady_clock::time_point t1;
    if (dampers_.empty() && st_use_) {
      // the structured path (plan_structure): H0 packed, the unconstrained minimizer by its
      // factor and the low-rank correction; the dense H only when it is outside the box
      g_.setZero();
      st_P_.setZero();
      st_D_.setZero();
      fill_rows(model, data, targets);
      t1 = std::chrono::steady_clock::now();
      gram_struct();  // and g = -M^T r
      st_D_.array() += damping;
      posture_terms<true>(model, q, targets);
      m_in_ = 0;
      if (huge_gradient()) return declined_outcome(t0, t1);
      const bool have_min = struct_minimizer();
      if (have_min && inside(st_x_, lb_, ub_)) {
        ++st_count_[0];
        warm_ = false;
        x_ = st_x_;
        grad_.setZero();
        std::fill(state_.begin(), state_.end(), 0);
        const auto t2 = std::chrono::steady_clock::now();
        const double objective = 0.5 * g_.dot(x_);  // H x = -g
        out = x_;
        const auto t3 = std::chrono::steady_clock::now();
        const auto sec = [](auto a, auto b) { return std::chrono::duration<double>(b - a).count(); };
        return {kUnconstrained, 0, objective, sec(t0, t2), sec(t2, t3), sec(t0, t1)};
      }
      ++st_count_[have_min ? 1 : 2];
      struct_to_dense();
      if (have_min && !warm_) {  // box_qp starts from this (infeasible) unconstrained minimizer
        x_ = st_x_;
        have_min_ = true;
      }
    } else {
      H_.setZero();
      g_.setZero();
      fill_rows(model, data, targets);
      t1 = std::chrono::steady_clock::now();
      add_gram();  // and g = -M^T r
      H_.diagonal().array() += damping;
      add_posture_terms(model, q, targets);
      H_.triangularView<Eigen::StrictlyUpper>() = H_.transpose();
      if (huge_gradient()) return declined_outcome(t0, t1);
    }
    m_in_ = 0;
    if (!dampers_.empty()) {
      if (!geom_set_) raise_invalid("dampers without a collision model");
      const GeometryModel& geom = bp::extract<const GeometryModel&>(geom_obj);
      GeometryData& gdata = bp::extract<GeometryData&>(gdata_obj);
      if (gdata.oMg.size() != geom.geometryObjects.size() ||
          gdata.distanceResults.size() != geom.collisionPairs.size() ||
          sphere_r_.size() != geom.geometryObjects.size())
        raise_invalid("the collision data do not match the collision model");
      fill_dampers(model, data, geom, gdata);
    }
    const auto t2 = std::chrono::steady_clock::now();
    int iterations = 0;
    int status = box_qp(lb_, ub_, max_iter, iterations);
    if (status == kUnconstrained) std::fill(state_.begin(), state_.end(), 0);
    double objective;
    if (m_in_ > 0) {
      status = general_qp(status, max_iter, iterations);
      if (!x_.allFinite())
        raise_invalid("the IK step is not finite: a task target, weight or bound is NaN or inf");
      objective = 0.5 * x_.dot(H_ * x_) + g_.dot(x_);
    } else {
      if (!x_.allFinite())
        raise_invalid("the IK step is not finite: a task target, weight or bound is NaN or inf");
      // 1/2 x^T H x + g^T x, with H x = grad - g (box_qp leaves grad = H x + g at x)
      objective = 0.5 * x_.dot(grad_) + 0.5 * g_.dot(x_);
      if (!dampers_.empty() && status != kMaxIterations) {
        if (!kkt_check()) status = kMaxIterations;
      }
    }
    // A step at the "unbounded" box sentinel (|dx| near kInf = 1e20) is not the QP's answer:
    // the true step is larger (an absurd target, e.g. a position of 1e150 m). The Python path
    // takes it and refuses it with its error (it came back SOLVED with the clipped step).
    if (status != kMaxIterations && x_.size() > 0 && x_.cwiseAbs().maxCoeff() >= 0.5 * kInf)
      status = kMaxIterations;
    out = x_;
    const auto t3 = std::chrono::steady_clock::now();
    const auto sec = [](auto a, auto b) { return std::chrono::duration<double>(b - a).count(); };
    return {status, iterations, objective, sec(t0, t2), sec(t2, t3), sec(t0, t1)};
  }

 public:

  // One whole step in one call (DifferentialIK.advance): solve() at (data, q), whose
  // kinematics the caller guarantees are those of q (a State's), then, unless the status is
  // kMaxIterations (the caller takes the Python path; data untouched), write
  // q_next = integrate(q, step) and recompute the kinematics of ``data`` at q_next exactly as
  // State.update does: computeJointJacobians(q_next), or with the velocity (with_velocity:
  // v_next = step / dt written) forwardKinematics(q_next, v_next, 0) + computeJointJacobians,
  // then updateFramePlacements. geom/gdata as in solve() (None without dampers).
  bp::tuple advance(const Model& model, Data& data, const Eigen::Ref<const VectorXd>& q,
                    bp::list targets, bp::list hard_boxes, bp::list soft_boxes, double damping,
                    Eigen::Ref<VectorXd> out, int max_iter, Eigen::Ref<VectorXd> q_next,
                    Eigen::Ref<VectorXd> v_next, double dt, bp::object geom_obj,
                    bp::object gdata_obj) {
    if (q_next.size() != nq_ || (dt > 0.0 && v_next.size() != nv_))
      raise_invalid("vector size mismatch");
    const bool with_velocity = dt > 0.0;
    if (dt != 0.0 && !(with_velocity && std::isfinite(dt)))
      raise_invalid("dt must be finite and > 0 (or 0: no velocity), got " + std::to_string(dt));
    bp::tuple result = solve(model, data, q, targets, hard_boxes, soft_boxes, damping, out,
                             max_iter, geom_obj, gdata_obj);
    if (bp::extract<int>(result[0]) == kMaxIterations) return result;
    pinocchio::integrate(model, q, x_, q_next);
    if (with_velocity) {
      v_next = x_ / dt;
      pinocchio::forwardKinematics(model, data, q_next, v_next, a0_);
      pinocchio::computeJointJacobians(model, data);
    } else {
      pinocchio::computeJointJacobians(model, data, q_next);
    }
    pinocchio::updateFramePlacements(model, data);
    return result;
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
    st_model_ = nullptr;  // the structured factorization is planned again
    items_.push_back(item);
    m_ += item.dim;
    M_.setZero(m_, nv_);
    r_.setZero(m_);
    e_.setZero(m_);
    return item.row;
  }

  // H += M^T M (lower triangle) and g -= M^T r, task by task on its support columns S: a
  // task's rows are zero outside S, so its block is (M_S)^T M_S scattered to (S, S). Loops
  // over the task's rows with their number fixed at compile time (pose 6, position and CoM
  // 3): about 30 % fewer instructions than the gathered GEMM / rank update it replaces
  // (G1: 56k -> 40k per step, measured standalone), which cost more than the products.
  void add_gram() {
    for (const Item& it : items_) {
      if (it.dim == 6) gram_task<6>(it);
      else if (it.dim == 3) gram_task<3>(it);
      else gram_task<-1>(it);
    }
  }
  template <int D, bool WithG = true>
  void gram_task(const Item& it) {
    const long ld = M_.rows(), ldh = H_.rows();
    const int d = D > 0 ? D : it.dim;
    const int ns = static_cast<int>(it.rows.size());
    const int* S = it.rows.data();
    const double* M = M_.data() + it.row;
    const double* r = r_.data() + it.row;
    double* H = H_.data();
    for (int b = 0; b < ns; ++b) {
      const int cb = S[b];
      const double* mb = M + cb * ld;
      if (WithG) {
        double s = 0.0;
        for (int k = 0; k < d; ++k) s += mb[k] * r[k];
        g_[cb] -= s;
      }
      double* hb = H + cb * ldh;
      for (int a = b; a < ns; ++a) {  // support columns ascending: (a >= b) is lower
        const double* ma = M + S[a] * ld;
        double h = 0.0;
        for (int k = 0; k < d; ++k) h += ma[k] * mb[k];
        hb[S[a]] += h;
      }
    }
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
          const Eigen::Matrix<double, 6, 1> w6 = w_.segment<6>(it.row);
          Jlog_ = w6.asDiagonal() * Jlog_;  // the rows' weights, once per task
          for (int a = 0; a < ns; ++a) {  // fixed-size 6x6 products on the support columns
            const int c = it.rows[a];
            rows.col(c).noalias() = Jlog_ * J6_.col(c);
          }
          e = pinocchio::log6(err).toVector();
          continue;
        }
        case kPosition: {
          const Eigen::Ref<const VectorXd> p = bp::extract<Eigen::Ref<const VectorXd>>(target);
          if (p.size() != 3) raise_invalid("position target size != 3");
          pinocchio::getFrameJacobian(model, data, it.frame, pinocchio::LOCAL_WORLD_ALIGNED, J6_);
          const Eigen::Vector3d w3 = w_.segment<3>(it.row);
          for (int a = 0; a < ns; ++a) {
            const int c = it.rows[a];
            rows.col(c) = w3.cwiseProduct(J6_.col(c).head<3>());
          }
          e = data.oMf[it.frame].translation() - p;
          continue;
        }
        case kOrientation: {
          const Eigen::Ref<const MatrixXd> Rt = bp::extract<Eigen::Ref<const MatrixXd>>(target);
          if (Rt.rows() != 3 || Rt.cols() != 3) raise_invalid("orientation target is not 3x3");
          const Eigen::Matrix3d err = Rt.transpose() * data.oMf[it.frame].rotation();
          pinocchio::getFrameJacobian(model, data, it.frame, pinocchio::LOCAL, J6_);
          Eigen::Matrix3d jlog3;
          pinocchio::Jlog3(err, jlog3);
          jlog3 = w_.segment<3>(it.row).asDiagonal() * jlog3;  // the rows' weights
          for (int a = 0; a < ns; ++a)
            rows.col(it.rows[a]) = jlog3 * J6_.col(it.rows[a]).tail<3>();
          e = pinocchio::log3(err);
          break;
        }
        case kCom: {
          const Eigen::Ref<const VectorXd> c = bp::extract<Eigen::Ref<const VectorXd>>(target);
          if (c.size() != 3) raise_invalid("CoM target size != 3");
          if (!com_done) {
            pinocchio::jacobianCenterOfMass(model, data, true);
            com_done = true;
          }
          rows = w_.segment(it.row, it.dim).asDiagonal() * data.Jcom;
          e = data.com[0] - c;
          continue;
        }
        default:
          throw std::logic_error("unknown task kind");
      }
    }
    r_ = c_.cwiseProduct(e_);
  }

  // ---- The structured factorization of the box-only step (no dampers) ----
  //
  // A frame task's rows are nonzero only on the dofs of its frame's support joints: a chain
  // of dofs from the root. Their Gram blocks, the damping and the posture blocks (one per
  // joint) make H0 with the kinematic tree's branch-induced sparsity: H0(i, j) != 0 only when
  // dof i is an ancestor of dof j or j of i (the arms and legs of a humanoid are coupled only
  // through the base and the waist). Factored from the leaves up, H0 = L^T L has no fill in
  // (Featherstone's LTL factorization): row k of L is nonzero only on k's ancestors. Each dof
  // k keeps its row in packed form: st_dep_[k] values at st_off_[k], on its ancestors in
  // ascending order (st_anc_), and the diagonal in st_D_.
  // Tasks whose rows are not on one chain (the CoM: every column) are the low-rank part
  // U U^T of H = H0 + U U^T (U = their weighted rows transposed, r columns), handled by the
  // Woodbury identity for the unconstrained minimizer: with Y = L^-T U, y0 = L^-T (-g),
  //   x = L^-1 (y0 - Y (I + Y^T Y)^-1 Y^T y0).
  // The minimizer is accepted only when its residual |H x + g| is at the level of a
  // Cholesky solve's; otherwise, and when it lies outside the box (bounds active), the dense
  // H is assembled and box_qp runs as before (from this minimizer when it holds).

  // Plan it for this model and these tasks: the dof tree, the packed layout, which tasks
  // are chains; st_use_ when every piece fits and the estimated work is below the dense.
  void plan_structure(const Model& model) {
    st_model_ = &model;
    st_use_ = false;
    const int n = nv_;
    if (model.nv != n) return;
    std::vector<int> parent(n, -2);
    for (int j = 1; j < model.njoints; ++j) {
      const int iv = model.idx_vs[j], nvj = model.nvs[j];
      if (nvj == 0) continue;
      int pj = model.parents[j];
      while (pj > 0 && model.nvs[pj] == 0) pj = model.parents[pj];
      for (int i = 0; i < nvj; ++i) {
        if (iv + i < 0 || iv + i >= n || parent[iv + i] != -2) return;  // dofs shared (mimic)
        parent[iv + i] = i > 0 ? iv + i - 1 : (pj > 0 ? model.idx_vs[pj] + model.nvs[pj] - 1 : -1);
      }
    }
    st_off_.assign(n, 0);
    st_dep_.assign(n, 0);
    st_anc_.clear();
    for (int k = 0; k < n; ++k) {
      const int p = parent[k];
      if (p == -2 || p >= k) return;  // a dof no joint moves, or a parent after its child
      st_off_[k] = static_cast<int>(st_anc_.size());
      if (p >= 0) {
        st_dep_[k] = st_dep_[p] + 1;
        for (int a = 0; a < st_dep_[p]; ++a) st_anc_.push_back(st_anc_[st_off_[p] + a]);
        st_anc_.push_back(p);
      }
    }
    st_chain_.assign(items_.size(), 0);
    st_r_ = 0;
    for (std::size_t t = 0; t < items_.size(); ++t) {
      const std::vector<int>& S = items_[t].rows;
      bool chain = !S.empty() && static_cast<int>(S.size()) == st_dep_[S.back()] + 1;
      for (std::size_t a = 0; chain && a + 1 < S.size(); ++a)
        chain = S[a] == st_anc_[st_off_[S.back()] + static_cast<int>(a)];
      st_chain_[t] = chain;
      if (!chain) st_r_ += items_[t].dim;
    }
    // work estimates (multiply-adds): dense Cholesky, solve and the low-rank tasks' Gram;
    // the packed factor, the solves (r + 2 vectors) and the residual
    double nnz = 0.0, fact = 0.0;
    for (int k = 0; k < n; ++k) {
      nnz += st_dep_[k];
      fact += 0.5 * st_dep_[k] * st_dep_[k];
    }
    const double dn = n, r = st_r_;
    const double dense = dn * dn * dn / 6.0 + dn * dn + 0.5 * r * dn * dn;
    const double packed = fact + (r + 4.0) * nnz + 2.0 * r * dn;
    if (st_r_ > 6 || packed > 0.7 * dense) return;
    st_P_.setZero(static_cast<long>(st_anc_.size()));
    st_D_.setZero(n);
    st_x_.setZero(n);
    st_hx_.setZero(n);
    st_U_.setZero(n, std::max(st_r_, 1));
    st_B_.setZero(n, 1 + st_r_);
    st_use_ = true;
  }

  // H0 (packed: the chain tasks' Gram) and g = -M^T r of every task.
  void gram_struct() {
    int u = 0;  // the low-rank tasks' rows, as columns of st_U_
    for (std::size_t t = 0; t < items_.size(); ++t) {
      const Item& it = items_[t];
      if (st_chain_[t]) {
        if (it.dim == 6) gram_chain<6>(it);
        else if (it.dim == 3) gram_chain<3>(it);
        else gram_chain<-1>(it);
        continue;
      }
      const long ld = M_.rows();
      const double* r = r_.data() + it.row;
      for (const int c : it.rows) {
        const double* mc = M_.data() + it.row + c * ld;
        double s = 0.0;
        for (int k = 0; k < it.dim; ++k) {
          s += mc[k] * r[k];
          st_U_(c, u + k) = mc[k];
        }
        g_[c] -= s;
      }
      u += it.dim;
    }
  }
  // One chain task (support S = the ancestors of S.back() and itself, ascending): row S[a]
  // of H0 gets (M_S^T M_S)(a, b) at packed position b < a, its diagonal at a.
  template <int D>
  void gram_chain(const Item& it) {
    const long ld = M_.rows();
    const int d = D > 0 ? D : it.dim;
    const int ns = static_cast<int>(it.rows.size());
    const int* S = it.rows.data();
    const double* M = M_.data() + it.row;
    const double* r = r_.data() + it.row;
    using Col = Eigen::Map<const Eigen::Matrix<double, D, 1>>;  // D > 0: vectorized dots
    const auto dot = [d](const double* a, const double* b) {
      if constexpr (D > 0) {
        return Col(a).dot(Col(b));
      } else {
        double h = 0.0;
        for (int k = 0; k < d; ++k) h += a[k] * b[k];
        return h;
      }
    };
    for (int a = 0; a < ns; ++a) {
      const int ca = S[a];
      const double* ma = M + ca * ld;
      g_[ca] -= dot(ma, r);
      st_D_[ca] += dot(ma, ma);
      double* pa = st_P_.data() + st_off_[ca];
      for (int b = 0; b < a; ++b) pa[b] += dot(ma, M + S[b] * ld);
    }
  }

  // The unconstrained minimizer of 1/2 x^T (H0 + U U^T) x + g^T x into st_x_, by the packed
  // LTL factor of H0 and the Woodbury identity. False when H0 is not numerically positive
  // definite or the residual is above a Cholesky solve's level (the caller goes dense).
  bool struct_minimizer() {
    const int n = nv_, r = st_r_;
    st_LP_ = st_P_;
    st_LD_ = st_D_;
    double* P = st_LP_.data();
    double* Dg = st_LD_.data();
    const int* off = st_off_.data();
    const int* dep = st_dep_.data();
    const int* anc = st_anc_.data();
    for (int k = n - 1; k >= 0; --k) {  // leaves first: H0 = L^T L without fill in
      const double dk2 = Dg[k];
      if (!(dk2 > 0.0) || !std::isfinite(dk2)) return false;
      const double lkk = std::sqrt(dk2), inv = 1.0 / lkk;
      Dg[k] = lkk;
      double* __restrict l = P + off[k];
      const int* ak = anc + off[k];
      const int dk = dep[k];
      for (int p = 0; p < dk; ++p) l[p] *= inv;
      for (int p = 0; p < dk; ++p) {  // the Schur complement on k's ancestors (a chain)
        const int i = ak[p];
        const double lp = l[p];
        Dg[i] -= lp * lp;
        double* __restrict li = P + off[i];  // i's ancestors: ak[0 .. p-1]
        for (int q = 0; q < p; ++q) li[q] -= lp * l[q];
      }
    }
    switch (r) {
      case 0: return minimizer_from_factor<1>();
      case 3: return minimizer_from_factor<4>();  // one CoM task
      default: return minimizer_from_factor<-1>();
    }
  }
  // struct_minimizer() after the factorization, with NC = 1 + r columns (fixed at compile
  // time when > 0): [y0 Y] = L^-T [-g U], the capacitance (I + Y^T Y), x, the residual.
  template <int NC>
  bool minimizer_from_factor() {
    const int n = nv_, nc = NC > 0 ? NC : static_cast<int>(st_B_.cols()), r = nc - 1;
    const double* P = st_LP_.data();
    const double* Dg = st_LD_.data();
    const int* off = st_off_.data();
    const int* dep = st_dep_.data();
    const int* anc = st_anc_.data();
    double* B = st_B_.data();
    const double* U = st_U_.data();
    const int ldu = static_cast<int>(st_U_.cols());
    for (int k = 0; k < n; ++k) {
      B[k * nc] = -g_[k];
      for (int j = 0; j < r; ++j) B[k * nc + 1 + j] = U[k * ldu + j];
    }
    // L^T Y = B, leaves first: row k final, then scattered to its ancestors
    using Row = Eigen::Matrix<double, NC, 1>;
    for (int k = n - 1; k >= 0; --k) {
      double* __restrict bk = B + k * nc;
      const double inv = 1.0 / Dg[k];
      const double* l = P + off[k];
      const int* ak = anc + off[k];
      if constexpr (NC > 0) {
        Eigen::Map<Row> bkm(bk);
        const Row yk = bkm * inv;
        bkm = yk;
        for (int p = 0; p < dep[k]; ++p) Eigen::Map<Row>(B + ak[p] * nc) -= l[p] * yk;
      } else {
        for (int c = 0; c < nc; ++c) bk[c] *= inv;
        for (int p = 0; p < dep[k]; ++p) {
          double* __restrict bi = B + ak[p] * nc;
          for (int c = 0; c < nc; ++c) bi[c] -= l[p] * bk[c];
        }
      }
    }
    // z = y0 - Y (I + Y^T Y)^-1 Y^T y0 (r <= 6: small fixed-capacity matrices)
    auto& z = st_hx_;
    for (int k = 0; k < n; ++k) z[k] = B[k * nc];
    if (r > 0) {
      Small S = Small::Identity(r, r);
      SmallVec t = SmallVec::Zero(r);
      for (int k = 0; k < n; ++k) {
        const double* bk = B + k * nc + 1;
        for (int i = 0; i < r; ++i) {
          t[i] += bk[i] * z[k];
          for (int j = 0; j <= i; ++j) S(i, j) += bk[i] * bk[j];
        }
      }
      if (Eigen::internal::llt_inplace<double, Eigen::Lower>::unblocked(S) != -1) return false;
      S.triangularView<Eigen::Lower>().solveInPlace(t);
      S.triangularView<Eigen::Lower>().transpose().solveInPlace(t);
      for (int k = 0; k < n; ++k) {
        const double* bk = B + k * nc + 1;
        double s = 0.0;
        for (int i = 0; i < r; ++i) s += bk[i] * t[i];
        z[k] -= s;
      }
    }
    // x = L^-1 z (root first)
    double* x = st_x_.data();
    for (int k = 0; k < n; ++k) {
      const double* l = P + off[k];
      const int* ak = anc + off[k];
      double s = z[k];
      for (int p = 0; p < dep[k]; ++p) s -= l[p] * x[ak[p]];
      x[k] = s / Dg[k];
    }
    if (!st_x_.allFinite()) return false;
    // residual H x + g, with H0 from the packed rows before the factorization
    double* hx = st_hx_.data();
    for (int k = 0; k < n; ++k) hx[k] = g_[k];
    const double* P0 = st_P_.data();
    SmallVec ux = SmallVec::Zero(std::max(r, 1));
    for (int k = 0; k < n; ++k)
      for (int j = 0; j < r; ++j) ux[j] += U[k * ldu + j] * x[k];
    double hmax = 0.0, gmax = 0.0, xmax = 0.0, res = 0.0;
    for (int k = n - 1; k >= 0; --k) {  // hx[k] complete once its descendants are done
      const double* pk = P0 + off[k];
      const int* ak = anc + off[k];
      const double xk = x[k];
      double s = st_D_[k] * xk, u2 = 0.0;
      for (int p = 0; p < dep[k]; ++p) {
        s += pk[p] * x[ak[p]];
        hx[ak[p]] += pk[p] * xk;
      }
      for (int j = 0; j < r; ++j) {
        s += U[k * ldu + j] * ux[j];
        u2 += U[k * ldu + j] * U[k * ldu + j];
      }
      hx[k] += s;
      res = std::max(res, std::abs(hx[k]));
      hmax = std::max(hmax, st_D_[k] + u2);
      gmax = std::max(gmax, std::abs(g_[k]));
      xmax = std::max(xmax, std::abs(xk));
    }
    return res <= 1e-11 * (1.0 + gmax + hmax * xmax);
  }
  // The dense H_ (both triangles) from the packed H0 and the low-rank tasks' Gram.
  void struct_to_dense() {
    H_.setZero();
    for (int k = 0; k < nv_; ++k) {
      H_(k, k) = st_D_[k];
      const double* pk = st_P_.data() + st_off_[k];
      const int* ak = st_anc_.data() + st_off_[k];
      for (int p = 0; p < st_dep_[k]; ++p) H_(k, ak[p]) = pk[p];  // ak[p] < k: lower
    }
    for (std::size_t t = 0; t < items_.size(); ++t) {
      if (st_chain_[t]) continue;
      if (items_[t].dim == 3) gram_task<3, false>(items_[t]);
      else gram_task<-1, false>(items_[t]);
    }
    H_.triangularView<Eigen::StrictlyUpper>() = H_.transpose();
  }
  // x inside [lb - tol, ub + tol] (box_qp's test of its unconstrained minimizer)
  static bool inside(const VectorXd& x, const VectorXd& lb, const VectorXd& ub) {
    const double tol = 1e-10;
    for (long i = 0; i < x.size(); ++i)
      if (x[i] < lb[i] - tol || x[i] > ub[i] + tol) return false;
    return true;
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
    intersect(hard, nv_, hlb_, hub_);
    const bool any_soft = bp::len(soft) > 0;
    if (any_soft || (pl_set_ && !pl_hard_)) intersect(soft, nv_, slb_, sub_);
    combine(bp::len(hard) > 0, any_soft);
  }

  // combine_bounds() with the boxes kept by arm() (intersected there, once).
  void combine_armed() {
    hlb_ = ahlb_;
    hub_ = ahub_;
    if (a_soft_ || (pl_set_ && !pl_hard_)) {
      slb_ = aslb_;
      sub_ = asub_;
    }
    combine(a_hard_, a_soft_);
  }

  // The rules of combine_bounds() on the intersections of the hard (hlb_, hub_) and soft
  // (slb_, sub_: read only when there are soft boxes) lists and the position box: whether
  // each list had boxes.
  void combine(bool hard_list, bool soft_list) {
    const int n = nv_;
    const bool pl_hard = pl_set_ && pl_hard_, pl_soft = pl_set_ && !pl_hard_;
    if (pl_hard) {
      hlb_ = hlb_.cwiseMax(pl_lb_);
      hub_ = hub_.cwiseMin(pl_ub_);
    }
    const bool any_hard = pl_hard || hard_list;
    for (int i = 0; i < n; ++i)
      if (hlb_[i] > hub_[i]) hlb_[i] = hub_[i] = 0.5 * (hlb_[i] + hub_[i]);
    if (!pl_soft && !soft_list) {
      lb_ = hlb_;
      ub_ = hub_;
      return;
    }
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
  // joint), added as  H += Jd^T W Jd,  g += Jd^T W gain e  joint by joint: into H_ (lower
  // triangle), or with Packed into the packed rows of the structured factorization (st_P_,
  // st_D_; a joint's block lies on its dofs' ancestor chains). A vector-space joint's block
  // is the identity (consecutive ones are added as one range); pinocchio's per-joint
  // dDifference step (its own visitor, the one pinocchio::dDifference runs for every joint)
  // is called only for the Lie-group joints (a free flyer).
  void add_posture_terms(const Model& model, const Eigen::Ref<const VectorXd>& q,
                         bp::list& targets) {
    posture_terms<false>(model, q, targets);
  }
  template <bool Packed>
  void posture_terms(const Model& model, const Eigen::Ref<const VectorXd>& q,
                     bp::list& targets) {
    using ConstRef = Eigen::Ref<const VectorXd>;
    using Step = pinocchio::dDifferenceStep<pinocchio::LieGroupMap, ConstRef, ConstRef, MatrixXd>;
    for (std::size_t k = 0; k < posture_.size(); ++k) {
      bp::object target = targets[items_.size() + k];
      bp::extract<Eigen::Ref<const VectorXd>> get(target);  // (holds a converted copy)
      const Eigen::Ref<const VectorXd> qt = get();
      if (qt.size() != nq_) raise_invalid("posture target size != nq");
      diff_.resize(nv_);
      pinocchio::difference(model, qt, q, diff_);
      const VectorXd& w = pw_[k];
      const VectorXd& c = pc_[k];  // -gain * weight
      int run0 = 0, run1 = 0;  // the current range of vector-space dofs [run0, run1)
      const auto flush = [&]() {
        const int len = run1 - run0;
        if (len <= 0) return;
        if (Packed) st_D_.segment(run0, len) += w.segment(run0, len);
        else H_.diagonal().segment(run0, len) += w.segment(run0, len);
        g_.segment(run0, len) -= c.segment(run0, len).cwiseProduct(diff_.segment(run0, len));
        run0 = run1 = 0;
      };
      for (pinocchio::JointIndex j = 1; j < static_cast<pinocchio::JointIndex>(model.njoints); ++j) {
        const int iv = model.idx_vs[j], nvj = model.nvs[j];
        if (nvj == 0) continue;
        if (model.nqs[j] == nvj) {  // vector-space joint: Jd block = identity
          if (run1 != iv) {
            flush();
            run0 = iv;
          }
          run1 = iv + nvj;
          continue;
        }
        flush();
        Step::run(model.joints[j], typename Step::ArgsType(qt, q, Jdiff_, pinocchio::ARG1));
        const auto B = Jdiff_.block(iv, iv, nvj, nvj);
        const auto wj = w.segment(iv, nvj).asDiagonal();
        g_.segment(iv, nvj).noalias() -=
            B.transpose() * c.segment(iv, nvj).cwiseProduct(diff_.segment(iv, nvj));
        if (!Packed) {
          H_.block(iv, iv, nvj, nvj).noalias() += B.transpose() * (wj * B);
          continue;
        }
        Hb_.noalias() = B.transpose() * (wj * B);
        const int d0 = st_dep_[iv];  // dof iv+a's ancestors: iv's, then iv .. iv+a-1
        for (int a = 0; a < nvj; ++a) {
          st_D_[iv + a] += Hb_(a, a);
          double* row = st_P_.data() + st_off_[iv + a] + d0;
          for (int b = 0; b < a; ++b) row[b] += Hb_(a, b);
        }
      }
      flush();
    }
  }

  // Damper rows of the pairs within their influence distance: C_ (rows), l_ (lower bounds;
  // the upper bounds are +inf). Same rows as CollisionAvoidance.inequalities and
  // CollisionDistance.jacobian: row = [n; p_b x n]^T J_b - [n; p_a x n]^T J_a with J the
  // WORLD joint Jacobians (data.J on the joints' support columns).
  void fill_dampers(const Model& model, Data& data, const GeometryModel& geom,
                    GeometryData& gdata) {
    pinocchio::updateGeometryPlacements(model, data, geom, gdata);
    const int nd = static_cast<int>(dampers_.size());
    if (C_.rows() < nd) {
      C_.setZero(nd, nv_);
      l_.setZero(nd);
      z_.setZero(nd);
      row_pair_.assign(nd, 0);
      row_dist_.assign(nd, 0.0);
    }
    int m = 0;
    for (Damper& dm : dampers_) {
      const auto& pair = geom.collisionPairs[dm.pair];
      const std::size_t ga = pair.first, gb = pair.second;
      const Eigen::Vector3d ca = gdata.oMg[ga].act(sphere_c_[ga]);
      const Eigen::Vector3d cb = gdata.oMg[gb].act(sphere_c_[gb]);
      if ((ca - cb).norm() - sphere_r_[ga] - sphere_r_[gb] >= dm.influence) continue;
      // since the last exact distance no point of a geometry moved more than
      // |centre shift| + radius * |R - R_ref|_F: the distance fell by at most their sum
      if (dm.ref) {
        const double moved = (ca - dm.ca_ref).norm() + (cb - dm.cb_ref).norm() +
                             sphere_r_[ga] * (gdata.oMg[ga].rotation() - dm.Ra_ref).norm() +
                             sphere_r_[gb] * (gdata.oMg[gb].rotation() - dm.Rb_ref).norm();
        if (dm.d_ref - moved >= dm.influence) continue;
      }
      // the world AABBs of the two local boxes: their distance bounds the pair's from below
      const auto& Ra = gdata.oMg[ga].rotation();
      const auto& Rb = gdata.oMg[gb].rotation();
      const Eigen::Vector3d gap =
          ((gdata.oMg[ga].act(box_c_[ga]) - gdata.oMg[gb].act(box_c_[gb])).cwiseAbs() -
           Ra.cwiseAbs() * box_h_[ga] - Rb.cwiseAbs() * box_h_[gb])
              .cwiseMax(0.0);
      if (gap.norm() >= dm.influence) continue;
      const coal::DistanceResult& res = pinocchio::computeDistance(geom, gdata, dm.pair);
      const double d = res.min_distance;
      dm.ref = std::isfinite(d) && std::isfinite(sphere_r_[ga]) && std::isfinite(sphere_r_[gb]);
      dm.d_ref = d;
      dm.ca_ref = ca;
      dm.cb_ref = cb;
      dm.Ra_ref = gdata.oMg[ga].rotation();
      dm.Rb_ref = gdata.oMg[gb].rotation();
      if (!(d < dm.influence)) continue;
      auto row = C_.row(m);
      row.setZero();
      const Eigen::Vector3d n = res.normal;
      const int ja = static_cast<int>(geom.geometryObjects[ga].parentJoint);
      const int jb = static_cast<int>(geom.geometryObjects[gb].parentJoint);
      add_point_row(data, jb, n, res.nearest_points[1], 1.0, row);
      add_point_row(data, ja, n, res.nearest_points[0], -1.0, row);
      l_[m] = -dm.gain * (d - dm.safety);
      row_pair_[m] = dm.pair;
      row_dist_[m] = d;
      ++m;
    }
    m_in_ = m;
  }

  template <typename Row>
  void add_point_row(const Data& data, int joint, const Eigen::Vector3d& n,
                     const Eigen::Vector3d& p, double sign, Row& row) const {
    if (joint <= 0) return;  // the universe (an obstacle) does not move
    Eigen::Matrix<double, 6, 1> w;
    w.head<3>() = n;
    w.tail<3>() = p.cross(n);
    for (const int c : joint_cols_[joint]) row[c] += sign * w.dot(data.J.col(c));
  }

  // KKT residuals of (x_, z_ (rows), zbox_) for min 1/2 x'Hx + g'x, l <= C x, lb <= x <= ub
  // (taskspace.qp.kkt.kkt_residuals); zbox_ is recovered from stationarity on the components
  // held at a bound (state_). Returns whether they meet eps_abs + eps_rel * scale.
  bool kkt_check() {
    const int n = nv_, m = m_in_;
    const auto C = C_.topRows(m);
    const auto z = z_.head(m);
    hx_.noalias() = H_ * x_;
    force_.noalias() = C.transpose() * z;
    // box multipliers: minus the rest of the stationarity on the held components
    zbox_.setZero(n);
    for (int i = 0; i < n; ++i)
      if (state_[i] != 0) zbox_[i] = -(hx_[i] + g_[i] + force_[i]);
    force_ += zbox_;
    double primal = 0.0, comp = 0.0, gap = x_.dot(hx_) + g_.dot(x_);
    double pscale = x_.cwiseAbs().maxCoeff();
    cx_.noalias() = C * x_;
    for (int k = 0; k < m; ++k) {
      const double below = l_[k] - cx_[k], above = cx_[k] - kInf;
      primal = std::max(primal, std::max(below, above));
      pscale = std::max(pscale, std::abs(cx_[k]));
      const double zk = z[k];
      comp = std::max(comp, std::min(std::abs(zk), std::abs(zk > 0 ? above : below)));
      gap += (zk > 0 ? kInf : l_[k]) * zk;
    }
    for (int i = 0; i < n; ++i) {
      const double below = lb_[i] - x_[i], above = x_[i] - ub_[i];
      primal = std::max(primal, std::max(below, above));
      const double zi = zbox_[i];
      comp = std::max(comp, std::min(std::abs(zi), std::abs(zi > 0 ? above : below)));
      if (zi != 0.0) gap += (zi > 0 ? ub_[i] : lb_[i]) * zi;
    }
    const double dual = (hx_ + g_ + force_).cwiseAbs().maxCoeff();
    const double dscale = std::max(
        {hx_.cwiseAbs().maxCoeff(), g_.cwiseAbs().maxCoeff(), force_.cwiseAbs().maxCoeff()});
    const double gscale =
        std::max({1.0, std::abs(x_.dot(hx_)), std::abs(g_.dot(x_))});
    res_[0] = primal;
    res_[1] = dual;
    res_[2] = comp;
    res_[3] = std::abs(gap);
    res_[4] = pscale;
    res_[5] = dscale;
    res_[6] = gscale;
    return primal <= eps_abs_ + eps_rel_ * pscale && dual <= eps_abs_ + eps_rel_ * dscale &&
           comp <= eps_abs_ + eps_rel_ * std::max(pscale, dscale);
  }

  // The equality QP of the working set: box components with state_ != 0 held at their
  // bound, rows with row_on_ held at their lower bound; the others free. Solved by the Schur
  // complement of H_FF. Writes the minimizer to xw_ and the rows' multipliers to z_.
  bool working_set_minimizer() {
    const int n = nv_, m = m_in_;
    F_.clear();
    A_.clear();
    xw_ = x_;
    for (int i = 0; i < n; ++i) {
      if (state_[i] == 0) F_.push_back(i);
      else if (state_[i] == 2) xw_[i] = 0.5 * (lb_[i] + ub_[i]);
      else xw_[i] = state_[i] < 0 ? lb_[i] : ub_[i];
    }
    for (int k = 0; k < m; ++k)
      if (row_on_[k]) A_.push_back(k);
    const int nf = static_cast<int>(F_.size()), na = static_cast<int>(A_.size());
    z_.head(m).setZero();
    if (nf == 0) return na == 0;
    // rhs1 = -g_F - H_FB x_B, rhs2 = l_A - C_AB x_B
    Hff_.resize(nf, nf);
    Caf_.resize(na, nf);
    r1_.resize(nf);
    r2_.resize(na);
    for (int a = 0; a < nf; ++a) {
      double s = -g_[F_[a]];
      for (int j = 0; j < n; ++j)
        if (state_[j] != 0) s -= H_(F_[a], j) * xw_[j];
      r1_[a] = s;
      for (int b = 0; b < nf; ++b) Hff_(a, b) = H_(F_[a], F_[b]);
    }
    for (int c = 0; c < na; ++c) {
      double s = l_[A_[c]];
      for (int j = 0; j < n; ++j)
        if (state_[j] != 0) s -= C_(A_[c], j) * xw_[j];
      r2_[c] = s;
      for (int b = 0; b < nf; ++b) Caf_(c, b) = C_(A_[c], F_[b]);
    }
    if (!cholesky(Hff_)) return false;
    VectorXd xf = r1_;
    cholesky_solve(Hff_, xf);
    if (na > 0) {
      MatrixXd HiCt = Caf_.transpose();
      Hff_.triangularView<Eigen::Lower>().solveInPlace(HiCt);  // L^-1 C'
      MatrixXd S = HiCt.transpose() * HiCt;                     // C H^-1 C'
      Hff_.triangularView<Eigen::Lower>().transpose().solveInPlace(HiCt);  // H^-1 C'
      if (!cholesky(S)) return false;  // dependent rows in the working set
      VectorXd zA = Caf_ * xf - r2_;
      cholesky_solve(S, zA);
      if (!zA.allFinite()) return false;
      xf.noalias() -= HiCt * zA;
      for (int c = 0; c < na; ++c) z_[A_[c]] = zA[c];
    }
    for (int a = 0; a < nf; ++a) xw_[F_[a]] = xf[a];
    return true;
  }

  // The QP with the damper rows (l <= C x, lb <= x <= ub). When the box QP's solution
  // satisfies the rows it is the optimum. Otherwise a primal active-set method (exact,
  // finite): it starts at the point of the segment from 0 to the box solution where the
  // first row blocks (feasible when 0 is: the robot outside the dampers' safety distance and
  // inside its limits), then moves toward the minimizer of its working set, adding the
  // blocking constraint, or drops the constraint whose multiplier has the wrong sign. The
  // result is accepted only when its KKT residuals meet the tolerances (kkt_check);
  // otherwise kMaxIterations: the caller takes the Python path.
  int general_qp(int box_status, int max_iter, int& iterations) {
    const int n = nv_, m = m_in_;
    const double tol = 1e-10;
    row_on_.assign(m, 0);
    cx_.noalias() = C_.topRows(m) * x_;
    double t = 1.0;
    int blocking = -1;
    for (int k = 0; k < m; ++k) {
      if (cx_[k] >= l_[k] - tol * std::max(1.0, std::abs(l_[k]))) continue;
      if (l_[k] > 0.0) return kMaxIterations;  // 0 violates the row: no feasible start here
      const double tk = l_[k] / cx_[k];          // C_k (t x) = l_k, with C_k x < l_k <= 0
      if (tk < t) t = tk, blocking = k;
    }
    if (blocking < 0) {  // the box solution satisfies every row: it is the optimum
      z_.head(m).setZero();
      if (box_status == kMaxIterations) return kMaxIterations;
      return kkt_check() ? box_status : kMaxIterations;
    }
    for (int i = 0; i < n; ++i)
      if (lb_[i] > 0.0 || ub_[i] < 0.0) return kMaxIterations;  // 0 outside the box
    // start: t x (inside the box: 0 and x are), the blocking row held; a box component stays
    // held only where it is still at its bound
    x_ *= t;
    for (int i = 0; i < n; ++i) {
      if (state_[i] == 2) continue;
      if (ub_[i] <= lb_[i]) state_[i] = 2;
      else if (x_[i] <= lb_[i]) state_[i] = -1, x_[i] = lb_[i];
      else if (x_[i] >= ub_[i]) state_[i] = 1, x_[i] = ub_[i];
      else state_[i] = 0;
    }
    row_on_[blocking] = 1;
    for (int it = 0; it < max_iter; ++it) {
      ++iterations;
      if (!working_set_minimizer()) return kMaxIterations;
      // step from x toward the working set's minimizer, stopped by the first constraint
      step_ = xw_ - x_;
      double alpha = 1.0;
      int block_row = -1, block_box = -1, side = 0;
      if (step_.cwiseAbs().maxCoeff() > 1e-15) {
        cx_.noalias() = C_.topRows(m) * x_;
        const VectorXd cp = C_.topRows(m) * step_;
        for (int k = 0; k < m; ++k) {
          if (row_on_[k] || cp[k] >= 0.0) continue;
          const double ak = std::max(0.0, (l_[k] - cx_[k]) / cp[k]);
          if (ak < alpha) alpha = ak, block_row = k, block_box = -1;
        }
        for (const int i : F_) {
          const double d = step_[i];
          if (d < 0.0 && xw_[i] < lb_[i]) {
            const double ai = std::max(0.0, (lb_[i] - x_[i]) / d);
            if (ai < alpha) alpha = ai, block_box = i, side = -1, block_row = -1;
          } else if (d > 0.0 && xw_[i] > ub_[i]) {
            const double ai = std::max(0.0, (ub_[i] - x_[i]) / d);
            if (ai < alpha) alpha = ai, block_box = i, side = 1, block_row = -1;
          }
        }
      }
      if (block_row >= 0 || block_box >= 0) {
        x_ += alpha * step_;
        if (block_row >= 0) row_on_[block_row] = 1;
        else state_[block_box] = side, x_[block_box] = side < 0 ? lb_[block_box] : ub_[block_box];
        continue;
      }
      x_ = xw_;
      // at the working set's minimizer: the multipliers (rows: z <= 0 at a lower bound; box:
      // z_box <= 0 at lb, >= 0 at ub)
      hx_.noalias() = H_ * x_;
      hx_ += g_;
      hx_.noalias() += C_.topRows(m).transpose() * z_.head(m);
      double wrong = 1e-12 * std::max(1.0, g_.cwiseAbs().maxCoeff());
      int drop_row = -1, drop_box = -1;
      for (const int k : A_)
        if (z_[k] > wrong) wrong = z_[k], drop_row = k, drop_box = -1;
      for (int i = 0; i < n; ++i) {
        const double zb = -hx_[i];
        const double v = state_[i] == -1 ? zb : (state_[i] == 1 ? -zb : 0.0);
        if (v > wrong) wrong = v, drop_box = i, drop_row = -1;
      }
      if (drop_row >= 0) {
        row_on_[drop_row] = 0;
        continue;
      }
      if (drop_box >= 0) {
        state_[drop_box] = 0;
        continue;
      }
      return kkt_check() ? kSolved : kMaxIterations;
    }
    return kMaxIterations;
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

  // Cholesky factor Lf_ (lower, leading nf x nf, nf = free_.size()) of H restricted to the
  // free variables free_ (in that order), kept between the active-set iterations of box_qp:
  // a released variable appends a row (O(nf^2)), a variable that meets a bound deletes its
  // row and column with a rank-one update of the trailing block (O(nf^2)), instead of a new
  // factorization (O(nf^3)) at every iteration.
  bool factor_free() {
    const int nf = static_cast<int>(free_.size());
    for (int a = 0; a < nf; ++a)
      for (int b = 0; b <= a; ++b) Lf_(a, b) = H_(free_[a], free_[b]);
    if (nf == 0) return true;
    auto block = Lf_.topLeftCorner(nf, nf);
    return Eigen::internal::llt_inplace<double, Eigen::Lower>::unblocked(block) == -1;
  }
  // Append variable i to the free set: the new row [l^T d] with L l = H(F, i),
  // d^2 = H_ii - l^T l. False when d^2 is not positive (the caller refactorizes).
  bool free_append(int i) {
    const int nf = static_cast<int>(free_.size());
    double d2 = H_(i, i);
    for (int b = 0; b < nf; ++b) {
      double s = H_(i, free_[b]);
      for (int c = 0; c < b; ++c) s -= Lf_(nf, c) * Lf_(b, c);
      s /= Lf_(b, b);
      Lf_(nf, b) = s;
      d2 -= s * s;
    }
    free_.push_back(i);
    if (!(d2 > 0.0)) return false;
    Lf_(nf, nf) = std::sqrt(d2);
    return true;
  }
  // Remove the free variable at position k: rows/columns after k move up/left and the
  // trailing block gets L22 L22^T + l l^T (l: column k below the diagonal) by Givens-free
  // rank-one Cholesky update.
  void free_remove(int k) {
    const int nf = static_cast<int>(free_.size());
    const int m = nf - k - 1;
    upd_.head(m) = Lf_.col(k).segment(k + 1, m);
    for (int a = k + 1; a < nf; ++a)
      for (int b = 0; b < k; ++b) Lf_(a - 1, b) = Lf_(a, b);
    for (int a = k + 1; a < nf; ++a)
      for (int b = k + 1; b <= a; ++b) Lf_(a - 1, b - 1) = Lf_(a, b);
    for (int j = 0; j < m; ++j) {
      const int jj = k + j;
      const double ljj = Lf_(jj, jj), xj = upd_[j];
      const double r = std::hypot(ljj, xj);
      const double c = r / ljj, s = xj / ljj;
      Lf_(jj, jj) = r;
      for (int a = j + 1; a < m; ++a) {
        const int aa = k + a;
        Lf_(aa, jj) = (Lf_(aa, jj) + s * upd_[a]) / c;
        upd_[a] = c * upd_[a] - s * Lf_(aa, jj);
      }
    }
    free_.erase(free_.begin() + k);
  }

  // Primal active-set method on the box (H symmetric positive definite).
  // state_[i]: 0 free, -1 at lb, +1 at ub, 2 fixed (lb == ub).
  // Warm start: after a solve that ended with bounds active (a stack without dampers), the
  // next one starts from that active set (the held variables at their bounds, the others at
  // the previous step clipped to the box) and skips the factorization of the whole H; it
  // ends at the same unique minimizer. The factor of the free block is updated between
  // iterations (free_append / free_remove); at the end the free gradient is checked against
  // a fresh factorization's accuracy (else refactorized once), and the multipliers of the
  // held variables have their signs, so SOLVED is exact as before.
  int box_qp(const VectorXd& lb, const VectorXd& ub,
             int max_iter, int& iterations) {
    const int n = nv_;
    const double tol = 1e-10;
    const bool warm = warm_ && x_.allFinite();
    const bool have_min = have_min_ && !warm;  // x_: the unconstrained minimizer (structured)
    warm_ = false;
    have_min_ = false;
    if (warm) {
      for (int i = 0; i < n; ++i) {
        if (ub[i] <= lb[i]) {
          state_[i] = 2;
          x_[i] = 0.5 * (lb[i] + ub[i]);
        } else if (state_[i] == -1 || state_[i] == 1) {
          x_[i] = state_[i] < 0 ? lb[i] : ub[i];
        } else {
          state_[i] = 0;
          x_[i] = std::min(std::max(x_[i], lb[i]), ub[i]);
        }
      }
    } else {
      if (!have_min) {
        L_ = H_;
        if (!cholesky(L_)) raise_not_positive_definite();
        x_ = -g_;
        cholesky_solve(L_, x_);
      }
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
    }
    free_.clear();
    for (int i = 0; i < n; ++i)
      if (state_[i] == 0) free_.push_back(i);
    if (!factor_free()) raise_not_positive_definite();
    bool fresh = true;  // Lf_ is a new factorization (not updated)
    for (iterations = 1; iterations <= max_iter; ++iterations) {
      const int nf = static_cast<int>(free_.size());
      // minimizer on the free variables with the others held
      for (int a = 0; a < nf; ++a) {
        const int i = free_[a];
        double s = -g_[i];
        for (int j = 0; j < n; ++j)
          if (state_[j] != 0) s -= H_(i, j) * x_[j];
        xf_[a] = s;
      }
      if (nf > 0) {
        auto L = Lf_.topLeftCorner(nf, nf);
        auto xf = xf_.head(nf);
        L.triangularView<Eigen::Lower>().solveInPlace(xf);
        L.triangularView<Eigen::Lower>().transpose().solveInPlace(xf);
      }
      // step from x toward the free minimizer, stopped by the first bound it meets
      double alpha = 1.0;
      int blocking = -1;
      int side = 0;
      for (int a = 0; a < nf; ++a) {
        const int i = free_[a];
        const double d = xf_[a] - x_[i];
        if (d < 0 && xf_[a] < lb[i] - tol) {
          const double t = (lb[i] - x_[i]) / d;
          if (t < alpha) { alpha = t; blocking = a; side = -1; }
        } else if (d > 0 && xf_[a] > ub[i] + tol) {
          const double t = (ub[i] - x_[i]) / d;
          if (t < alpha) { alpha = t; blocking = a; side = 1; }
        }
      }
      if (alpha < 0) alpha = 0;
      for (int a = 0; a < nf; ++a) {
        const int i = free_[a];
        x_[i] += alpha * (xf_[a] - x_[i]);
      }
      if (blocking >= 0) {
        const int i = free_[blocking];
        state_[i] = side;
        x_[i] = side < 0 ? lb[i] : ub[i];
        free_remove(blocking);
        fresh = false;
        continue;
      }
      // at the minimizer of the current face: check the multipliers of the held variables
      grad_.noalias() = H_ * x_;
      grad_ += g_;
      if (!grad_.allFinite()) {  // a NaN/inf in H or g (a warm start may hold every variable)
        x_.setConstant(std::numeric_limits<double>::quiet_NaN());  // solve() refuses it
        return kSolved;
      }
      if (!fresh) {  // the updated factor's free gradient as small as a new one's would be
        double worst = 0.0, scale = g_.cwiseAbs().maxCoeff();
        for (int a = 0; a < nf; ++a) worst = std::max(worst, std::abs(grad_[free_[a]]));
        scale += H_.cwiseAbs().maxCoeff() * x_.cwiseAbs().maxCoeff();
        if (worst > 1e-12 * (1.0 + scale)) {
          if (!factor_free()) raise_not_positive_definite();
          fresh = true;
          continue;
        }
      }
      int release = -1;
      double worst = tol;
      for (int i = 0; i < n; ++i) {
        // at lb the gradient must be >= 0, at ub <= 0
        const double v = state_[i] == -1 ? -grad_[i] : (state_[i] == 1 ? grad_[i] : 0.0);
        if (v > worst) { worst = v; release = i; }
      }
      if (release < 0) {
        // the next solve starts from this active set (a stack without dampers)
        warm_ = dampers_.empty() && nf < n;
        if (nf == n) return kUnconstrained;  // (a warm start released every bound)
        return kSolved;
      }
      state_[release] = 0;
      if (!free_append(release)) {
        if (!factor_free()) raise_not_positive_definite();
        fresh = true;
      } else {
        fresh = false;
      }
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
  Eigen::Matrix<double, 6, Eigen::Dynamic> J6_;
  std::vector<int> pl_iq_, pl_iv_;
  VectorXd pl_low_, pl_high_, pl_lb_, pl_ub_;
  bool pl_set_ = false, pl_hard_ = false;
  Eigen::Matrix<double, 6, 6> Jlog_;
  VectorXd r_, e_, w_, c_, g_, x_, grad_;
  // collision dampers
  std::vector<Damper> dampers_;
  std::vector<Eigen::Vector3d> sphere_c_, box_c_, box_h_;
  std::vector<double> sphere_r_;
  std::vector<std::vector<int>> joint_cols_;
  bool geom_set_ = false;
  int m_in_ = 0;
  RowMatrixXd C_;
  VectorXd l_, z_, zbox_, hx_, force_, cx_;
  std::vector<int> row_pair_, row_on_, F_, A_;
  MatrixXd Hff_, Caf_;
  VectorXd r1_, r2_, xw_, step_;
  std::vector<double> row_dist_;
  double eps_abs_ = 1e-9, eps_rel_ = 1e-9;
  double res_[7] = {0, 0, 0, 0, 0, 0, 0};
  std::vector<int> state_;
  MatrixXd L_, Lf_;
  std::vector<int> free_;
  VectorXd xf_, upd_;
  bool warm_ = false;  // the next box_qp starts from the last active set
  VectorXd a0_;  // zero acceleration (advance with a velocity)
  // arm() / step(): what an armed DifferentialIK.advance keeps
  bool armed_ = false, a_hard_ = false, a_soft_ = false;
  VectorXd ahlb_, ahub_, aslb_, asub_;
  std::vector<bp::object> armed_tasks_;
  bp::object armed_model_obj_, target_name_;
  const Model* armed_model_ = nullptr;
  double armed_damping_ = 0.0;
  int armed_max_iter_ = 0;
  // arm_advance() / call_advance(): the gate, the state's and the result's slots
  bool fa_armed_ = false;
  double fa_dt_ = 0.0;
  bp::object fa_robot_, fa_version_, fa_assignments_, fa_assigned_, fa_locked_;
  bp::object fa_state_type_, fa_result_type_, fa_ik_solved_, fa_unconstrained_, fa_solved_;
  bp::object fa_backend_, version_name_, fa_data_obj_;
  Data* fa_data_ = nullptr;
  Py_ssize_t st_robot_ = 0, st_data_ = 0, st_q_ = 0, st_v_ = 0, st_has_v_ = 0, st_a0_ = 0;
  std::vector<Py_ssize_t> st_none_, st_clear_, st_false_;
  Py_ssize_t rs_[9] = {0, 0, 0, 0, 0, 0, 0, 0, 0};
  Recycled recycled_[2];  // step_arrays(): the arrays of the last two steps
  int recycle_next_ = 0;
  // the structured factorization of the box-only step (plan_structure)
  const Model* st_model_ = nullptr;  // planned for this model (nullptr: plan again)
  bool st_use_ = false, have_min_ = false;
  int st_r_ = 0;
  std::vector<int> st_off_, st_dep_, st_anc_, st_chain_;
  VectorXd st_P_, st_D_, st_LP_, st_LD_, st_x_, st_hx_;
  RowMatrixXd st_U_, st_B_;
  MatrixXd Hb_;  // a Lie-group joint's posture block
  using Small = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, 0, 6, 6>;
  using SmallVec = Eigen::Matrix<double, Eigen::Dynamic, 1, 0, 6, 1>;
  long st_count_[3] = {0, 0, 0};  // unconstrained by it, then box_qp, dense fallbacks
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

#include "hier_kernel.hpp"  // the compiled closed-form step of HierarchicalIK
#include "general_step.hpp"  // the weighted step with equality and inequality rows

}  // namespace

BOOST_PYTHON_MODULE(_ik_kernel) {
  eigenpy::enableEigenPy();
  bp::scope().attr("PINOCCHIO_VERSION") = std::string(PINOCCHIO_VERSION);
  bp::scope().attr("UNCONSTRAINED") = kUnconstrained;
  bp::scope().attr("SOLVED") = kSolved;
  bp::scope().attr("MAX_ITERATIONS") = kMaxIterations;
  bp::def("abi_selfcheck", &abi_selfcheck, bp::args("model"));
  register_hierarchical_ik_kernel();  // hier_kernel.hpp
  register_general_ik_step();  // general_step.hpp
  bp::class_<WeightedIKKernel>("WeightedIKKernel", bp::init<int, int>(bp::args("self", "nv", "nq")))
      .def("add_pose", &WeightedIKKernel::add_pose)
      .def("add_position", &WeightedIKKernel::add_position)
      .def("add_com", &WeightedIKKernel::add_com)
      .def("add_orientation", &WeightedIKKernel::add_orientation)
      .def("add_posture", &WeightedIKKernel::add_posture)
      .add_property("rows", &WeightedIKKernel::rows)
      .def("set_scaling", &WeightedIKKernel::set_scaling)
      .def("set_position_limits", &WeightedIKKernel::set_position_limits)
      .def("clear_dampers", &WeightedIKKernel::clear_dampers)
      .def("add_dampers", &WeightedIKKernel::add_dampers)
      .def("set_tolerances", &WeightedIKKernel::set_tolerances)
      .def("damper_rows", &WeightedIKKernel::damper_rows)
      .def("residuals", &WeightedIKKernel::residuals)
      .def("multipliers", &WeightedIKKernel::multipliers)
      .def("structured_counts", &WeightedIKKernel::structured_counts)
      .def("solve", &WeightedIKKernel::solve_boxes)
      .def("solve", &WeightedIKKernel::solve)
      // the 9-argument solve under its own name: one signature, no overload dispatch (a
      // failed arity match of the 11-argument overload first cost ~0.4 us per call)
      .def("solve_boxes", &WeightedIKKernel::solve_boxes)
      // solve, integrate and the kinematics at the new configuration in one call
      .def("advance", &WeightedIKKernel::advance)
      // DifferentialIK.advance's armed step: what depends only on the stack, dt and the
      // robot's version bound once (arm), the call passes the state's data, q and dt
      .def("arm", &WeightedIKKernel::arm)
      .def("disarm", &WeightedIKKernel::disarm)
      .def("step", &WeightedIKKernel::step)
      // the whole armed DifferentialIK.advance as one C function (lock, gate, step, State
      // update, result)
      .def("arm_advance", &WeightedIKKernel::arm_advance);
}
