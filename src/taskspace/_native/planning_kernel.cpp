// Compiled kernel of taskspace's RRT-Connect and of its collision check.
//
// The Python implementation in taskspace/planning/rrt_connect.py is the reference (same
// algorithm: EXTEND with the step's end point first then its coarse interior in bisection
// order, CONNECT as one line of steps, lazy coarse-to-fine edge checking with removal of the
// subtree of a rejected edge, local sampling and turns for a trapped tree); tests compare the collision
// answers with taskspace.planning.CollisionChecker and re-check every returned path.
//
// Collision checking is Pinocchio's and coal's own: updateGeometryPlacements (kinematics and
// geometry placements), coal's CollisionObject::computeAABB for the broad phase and
// pinocchio::computeCollision (coal's exact narrow phase) for every pair whose boxes overlap;
// the checked pairs are those Pinocchio's broad-phase managers check (active pairs, no
// disabled object, no degenerate geometry), with the same box inflation. Three modes
// (CollisionKernel.mode), same answers up to configurations that graze an obstacle (coal's
// GJK warm start depends on the history of calls):
//  0. Pinocchio's TreeBroadPhaseManager (one coal manager per joint) with its update and its
//     default callback stopping at the first colliding pair (the Python checker's structure);
//  1. the same with an update that skips what does not change between configurations (the
//     universe manager: obstacles and fixed base; the inflation pass over all pairs);
//  2. (default) a list of pairs grouped by moving object (collides_pairs). Only the joint
//     placements are computed for every configuration (the kernel's loop, as the sphere
//     checkers); then, each test conservative: per link (moving joint) a bounding sphere of
//     its objects' box spheres against the boxes of the static partners (bit masks, two boxes
//     per vector operation); per object the bounding sphere of its inflated oriented box
//     against a static partner's box or a moving partner's sphere; only an object that a
//     remaining pair needs is placed (its geometry placement as Pinocchio's
//     updateGeometryPlacements computes it, coal's AABB, inflated), then the world boxes, the
//     two oriented boxes (each object's local AABB, inflated, at its placement:
//     coal::obbDisjoint, as coal's OBB::overlap) and the narrow phase. A pair is skipped only
//     when bounding volumes of the inflated objects are disjoint, so the answers are those of
//     the narrow phase on every pair that may touch (tests: Pinocchio's computeCollisions on
//     every pair). Before 2026-11-27 every object was placed and boxed for every
//     configuration (Pinocchio's updateGeometryPlacements, static objects included); the
//     answers and planned paths are the same (H2-meshfast, 107 problems, 28,000
//     configurations).
// In every mode the last colliding pair is tested first. Measured on the MotionBenchMaker
// Panda problems inside RRT-Connect (planner included, 2-core machine): 6.3 us per check with
// dynamic AABB trees per joint, 3.6 us with mode 1 on them, 2.4 us with mode 1 on coal's
// NaiveCollisionManager (a link holds 1-3 objects: re-inserting tree leaves costs more than
// the box tests), 1.9 us with mode 2 without and 1.35 us with the oriented boxes (random
// configurations: 1.1-1.3 us; placements 0.3 us of it). The Python path: 10-13 us per check.
// On 42,000 random configurations over the seven scenes the answers differed from the Python
// pool's once, at a configuration 0.6 mm inside an obstacle.
//
// Where the time goes on cage (16 valid problems x 3 seeds, 2026-11-25): 6,900 checks and
// 2,060 iterations per problem on average (median 4,200 / 1,250), at most 31,000 checks and
// 4,300 + 830 nodes. The goal lies inside the cage: the goal tree's EXTEND succeeds in 11 %
// (uniform targets) and 16 % (local targets) of its tries, the start tree's in 86 %; of 48,900
// CONNECT lines 192 reach their target. Checks: 75 % in EXTEND (about half of all for the
// start tree growing in free space, 4 per step), 19 % in CONNECT, 5 % in the fine pass
// (3 lazy rejections per problem); nearest neighbours were 20-23 % of the time with the
// scalar scan (1.8 ns per node, mean tree 460 nodes, 4,300 at most), about 11 % with the
// blocked scan below. The other scenes: nearest 1-6 %, the rest the checks.
// Hence the trapped tree's turns (RRTConnectOptions.trapped_priority, 0.75): while a tree has
// fewer than a quarter of the other's nodes, it takes the other's turn with that probability
// (the other then CONNECTs towards its new node), so that fewer checks go into growing the
// free tree. Measured against 0 (alternate turns) in the same runs, interleaved, on every
// valid problem with three sets of 20 seeds: median time per scenario 2-15 % lower (cage
// 6.28 -> 5.45, 5.41 -> 4.81, 6.43 -> 5.72 ms) but box's in one set (+2 %); mean time 1-29 %
// lower but box's in one set (+5 %); all solved. Probability 0.5: smaller gains; 1.0 (the big
// tree waits for the trapped one): heavy tails, mean time x1.5 over all scenarios.

//
// Sphere checkers (CollisionKernel.set_spheres, collisions_with(rows, checker),
// first_invalid_on_edge, rrt_connect(..., collision_checker)): the conservative spheres of
// taskspace.planning.sphere_model on every moving geometry object (Panda: 204). Per
// configuration: the joint placements only (a loop over revolute / prismatic x, y, z joints,
// Pinocchio's forwardKinematics for other models; no geometry placements); per link (moving
// joint) a bounding sphere of its spheres against the boxes of the static partners (a bit
// mask, at most 64 partners); per moving object its bounding sphere, then its spheres against
// each static partner left in the mask (exact point distance to a box, sphere, cylinder or
// capsule; coal's sphere-vs-geometry collide for meshes and convex hulls) and against the
// spheres of its moving partners (self pairs from the same pair list as the exact check),
// each test inflated by the pair's security margin and swept-sphere radii. Where spheres
// touch: checker 1 ("spheres") places the two objects, applies the oriented-box test and
// coal's exact narrow phase (the exact answer: same trees and paths as the mesh checker in
// the planner), checker 2 ("spheres_only") answers "colliding" (conservative: 10-16 % of
// random free configurations flagged on the MotionBenchMaker scenes, self pairs most);
// rrt_connect's fallback_iterations switches a plan from checker 2 to checker 1 after that
// many iterations without a path (the spheres' margin closes narrow passages: cage, grasps).
// The final validator: with a sphere checker, rrt_connect's lazy fine pass (verify) uses
// checker 0 (or checker 1 with validator = kSpheres: the same answers, 0.69 instead of
// 1.16 us per path point, median over 63 problems), the endpoints checker 0, the nodes and
// coarse points the plan's sphere checker. When the spheres carry sphere_model's volume
// certificate (set_spheres' certified_margin > 0: every point of each object's convex hull
// lies that margin inside the union of its spheres, proved by simplices), a sphere
// checker's "free" implies checker 0's "free" (the proof is at RRTConnect::recheck), so
// every point of the returned path at the resolution has been validated: no re-check.
// Without the certificate the returned path's nodes and coarse points (all its points with
// validator kSpheres, the straight line or a plan that is not lazy) are re-checked with
// checker 0; a failure returns no path (the Python side re-plans with "mesh").
// Measured (300 configurations near the planner's trees, minimum of 300 rounds, loaded
// 2-core machine): mesh 1.0-1.5 us, spheres 0.86-1.3 us, spheres only 0.73-0.9 us per
// configuration; kinematics about 0.22 us of it, the link masks 0.17 us. GJK warm start: off
// (see the constructor).
//
// Edge clearance certificates (checker kClearance, rrt_connect only; #22 items 4-5): the sphere
// check returns a certified radius instead of a verdict (spheres_clearance: each sphere's
// clearance to the obstacles and to the spheres of its self pairs, over a per-link bound on
// how fast its centre moves along the edge, mb_ from the joint placements), and
// certify_edge covers a whole edge with such intervals; the tree edges are then free
// everywhere, no lazy fine pass (see the comment above setup_motion_bounds). Measured
// (2026-11-27, loaded 2-core machine, every 5th MotionBenchMaker problem, validator
// "spheres"): median 0.85 ms against 0.59 for "spheres_only"; on the 36 problems without a
// fallback 0.54 against 0.36 ms, 332 against 321 checks: a clearance check costs about twice a
// point check (distances instead of the first hit) and certifies about as much edge as the
// coarse points plus the fine pass check, because the radius is about 7x below the first
// contact along the edge (median over random configurations: the bound is a worst case over
// all configurations and the clearance is Euclidean, not along the motion). Its value is the
// guarantee: a path with log path_certified is free everywhere along it.
//
// Interrupts, limits and threads. rrt_connect checks every argument (InvalidInputError, a
// TaskspaceError, raised from here: NaN, non-finite bounds, negative counts, steps too small
// for the bounds) and plans with the GIL released; every kPollInterval (2 ms) it takes the GIL
// back for a moment and runs Python's signal handlers (PyErr_CheckSignals), so Ctrl-C stops it
// and raises KeyboardInterrupt; the time limit is a saturating deadline (a limit beyond the
// clock's range is none, never an overflowed deadline in the past). A CollisionKernel holds
// Pinocchio and coal data that its queries overwrite: a mutex serializes the plans and queries
// on one kernel (a thread that finds it busy waits with the GIL released), so two threads may
// share a kernel (one after the other) or plan at the same time on two kernels.

// rrt_connect takes 18 arguments (Boost.Python's default limit is 15).
#define BOOST_PYTHON_MAX_ARITY 18
#include <boost/python.hpp>
#include <eigenpy/eigenpy.hpp>

#include <pinocchio/multibody.hpp>
#include <pinocchio/algorithm/geometry.hpp>
#include <pinocchio/collision/broadphase.hpp>
#include <pinocchio/collision/collision.hpp>
#include <pinocchio/collision/tree-broadphase-manager.hpp>

#include <coal/broadphase/broadphase_bruteforce.h>
#include <coal/BV/OBB.h>
#include <coal/broadphase/broadphase_dynamic_AABB_tree.h>
#include <coal/collision.h>
#include <coal/distance.h>
#include <coal/shape/geometric_shapes.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <limits>
#include <map>
#include <memory>
#include <mutex>
#include <stdexcept>
#include <string>
#include <vector>

#include "sphere_batch.hpp"
#if defined(__x86_64__) && defined(__GNUC__)
#include <immintrin.h>
// The filter twice more (sphere_batch.hpp), chosen at run time with the kernel's SIMD level
// (simd_levels.hpp below): for AVX2 with FMA and for AVX-512 (x86-64-v4's AVX-512 subsets).
// GCC contracts a * b + c into one fused operation where FMA is enabled (C++ is not ISO C
// there), so these two round differently from the SSE2 build, within the header's bound:
// a fused a * b + c is rounded once, its error below that of the product then the sum, so
// every step of the bound holds (tests/planning: the placements against Pinocchio and the
// first contacts, at every level this processor has).
#pragma GCC push_options
#pragma GCC target("arch=x86-64-v3")
#define TASKSPACE_SPHERE_BATCH_NS taskspace_sphere_batch_avx2
#include "sphere_batch.hpp"
#pragma GCC pop_options
#pragma GCC push_options
#pragma GCC target("arch=x86-64-v4")
#define TASKSPACE_SPHERE_BATCH_NS taskspace_sphere_batch_avx512
#include "sphere_batch.hpp"
#pragma GCC pop_options
#define TASKSPACE_SIMD_X86 1
#endif

namespace {
// SIMD levels of the compiled planning code: 1 SSE2 (the x86-64 baseline; any other
// processor: the portable code), 2 AVX2 with FMA, 3 AVX-512 (F, VL, BW, DQ). The level of
// the processor, lowered by the environment variable TASKSPACE_SIMD ("sse2", "avx2",
// "avx512") when set.
int processor_simd_level() {
  static const int level = [] {
#ifdef TASKSPACE_SIMD_X86
    __builtin_cpu_init();
    if (__builtin_cpu_supports("x86-64-v4")) return 3;
    return __builtin_cpu_supports("x86-64-v3") ? 2 : 1;
#else
    return 1;
#endif
  }();
  return level;
}
int initial_simd_level() {
  static const int level = [] {
    int l = processor_simd_level();
    if (const char* v = std::getenv("TASKSPACE_SIMD")) {
      const std::string s(v);
      if (s == "sse2") l = 1;
      else if (s == "avx2") l = std::min(l, 2);
    }
    return l;
  }();
  return level;
}

// The sphere filter of the batched checks in its builds (sphere_batch.hpp): the input is kept
// and the build of the current level set up with it when first used; calls go to that build.
// The builds give the same answers for the kernel (a lane they clear is free for the double
// test, a lane they find sure colliding collides for it: the header's bound); their masks may
// differ where a float distance is within a rounding of the inflated radius.
class SphereFilters {
 public:
#ifdef TASKSPACE_SIMD_X86
#define TASKSPACE_FILTER_CALL(call) \
  (level_ == 3 ? avx512_.call : level_ == 2 ? avx2_.call : plain_.call)
#else
#define TASKSPACE_FILTER_CALL(call) (plain_.call)
#endif
  void set_level(int level) {
    level_ = level;
    if (has_input_) setup_level();
  }
  void reset() {
    has_input_ = false;
    input_ = taskspace_sphere_batch::Input{};
    plain_ = taskspace_sphere_batch::SphereFilter{};
#ifdef TASKSPACE_SIMD_X86
    avx2_ = taskspace_sphere_batch_avx2::SphereFilter{};
    avx512_ = taskspace_sphere_batch_avx512::SphereFilter{};
#endif
  }
  void setup(const taskspace_sphere_batch::Input& in) {
    reset();
    input_ = in;
    has_input_ = true;
    setup_level();
  }
  bool ready() const { return TASKSPACE_FILTER_CALL(ready()); }
  double eps() const { return TASKSPACE_FILTER_CALL(eps()); }
  double scale() const { return TASKSPACE_FILTER_CALL(scale()); }
  int depth() const { return TASKSPACE_FILTER_CALL(depth()); }
  int units() const { return TASKSPACE_FILTER_CALL(units()); }
  int joints() const { return TASKSPACE_FILTER_CALL(joints()); }
  void load_q(const double* const* q) { TASKSPACE_FILTER_CALL(load_q(q)); }
  std::array<float, 12> placement(int j, int l) const {
    return TASKSPACE_FILTER_CALL(placement(j, l));
  }
  unsigned run(unsigned active, int stop_lane) {
    return TASKSPACE_FILTER_CALL(run(active, stop_lane));
  }
  unsigned sure() const { return TASKSPACE_FILTER_CALL(sure()); }
  int first_pair(int lane) { return TASKSPACE_FILTER_CALL(first_pair(lane)); }
  int next_pair() { return TASKSPACE_FILTER_CALL(next_pair()); }
#undef TASKSPACE_FILTER_CALL

 private:
  void setup_level() {
#ifdef TASKSPACE_SIMD_X86
    if (level_ == 3 && !avx512_.ready()) avx512_.setup(input_);
    if (level_ == 2 && !avx2_.ready()) avx2_.setup(input_);
#endif
    if (level_ == 1 && !plain_.ready()) plain_.setup(input_);
  }
  int level_ = 1;
  bool has_input_ = false;
  taskspace_sphere_batch::Input input_;
  taskspace_sphere_batch::SphereFilter plain_;
#ifdef TASKSPACE_SIMD_X86
  taskspace_sphere_batch_avx2::SphereFilter avx2_;
  taskspace_sphere_batch_avx512::SphereFilter avx512_;
#endif
};
}  // namespace

#if defined(__x86_64__) && defined(__GNUC__)
#include <x86intrin.h>
#endif

namespace bp = boost::python;
using pinocchio::Data;
using pinocchio::GeometryData;
using pinocchio::GeometryModel;
using pinocchio::Model;
using Eigen::MatrixXd;
using Eigen::VectorXd;
using RowMatrixXd = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
// A read-only vector argument: eigenpy maps a contiguous float64 array to it without a copy.
using VecRef = Eigen::Ref<const VectorXd>;
using Manager = pinocchio::TreeBroadPhaseManagerTpl<coal::NaiveCollisionManager>;

namespace {

// Status codes returned to Python (taskspace.planning.PlannerStatus).
constexpr int kSolved = 0;
constexpr int kTimeLimit = 1;
constexpr int kIterationLimit = 2;
// The start (3) or the goal (4) is not a valid endpoint: not finite, outside the bounds or in
// collision (exact checker). The Python side then re-runs its own endpoint check, which
// raises PlanningError with the reason (the coordinates out of bounds, the colliding pairs).
constexpr int kStartInvalid = 3;
constexpr int kGoalInvalid = 4;

// ---------------------------------------------------------------------------- Python glue
// Raise taskspace.errors.InvalidInputError (a TaskspaceError and a ValueError) from C++ (the
// GIL must be held). The Python callers validate first; this guards direct calls.
[[noreturn]] void raise_invalid(const std::string& message) {
  bp::object cls = bp::import("taskspace.errors").attr("InvalidInputError");
  PyErr_SetString(cls.ptr(), message.c_str());
  bp::throw_error_already_set();
  throw std::logic_error(message);  // not reached
}

// The GIL released for the lifetime of the object (reacquired by the destructor, also when a
// C++ exception unwinds). poll() takes the GIL back for a moment and runs Python's signal
// handlers (PyErr_CheckSignals: only the main thread runs them); it returns true when a
// handler raised (KeyboardInterrupt for Ctrl-C), the exception then pending in this thread.
class GilRelease {
 public:
  GilRelease() : state_(PyEval_SaveThread()) {}
  ~GilRelease() {
    if (state_ != nullptr) PyEval_RestoreThread(state_);
  }
  GilRelease(const GilRelease&) = delete;
  GilRelease& operator=(const GilRelease&) = delete;

  bool poll() {
    PyEval_RestoreThread(state_);
    const bool raised = PyErr_CheckSignals() != 0;
    state_ = PyEval_SaveThread();
    return raised;
  }

 private:
  PyThreadState* state_;
};

// Interval between two polls of Python's signal handlers while the GIL is released.
constexpr auto kPollInterval = std::chrono::milliseconds(2);

// Lock a kernel's mutex from a thread that holds the GIL: at once when it is free, else with
// the GIL released while waiting (a planner that holds the lock takes the GIL back to poll
// signals: waiting with the GIL would deadlock), polling signals. Throws the pending Python
// exception when a signal handler raised while waiting.
std::unique_lock<std::timed_mutex> lock_with_gil(std::timed_mutex& mutex) {
  std::unique_lock<std::timed_mutex> lock(mutex, std::try_to_lock);
  if (lock.owns_lock()) return lock;
  bool raised = false;
  {
    GilRelease gil;
    while (!lock.try_lock_for(kPollInterval)) {
      if (gil.poll()) {
        raised = true;
        break;
      }
    }
  }
  if (raised) bp::throw_error_already_set();
  return lock;
}

// ---------------------------------------------------------------------------- collision
constexpr int kManager = 0;
constexpr int kManagerFast = 1;
constexpr int kPairs = 2;
// Checkers (collides): exact meshes, spheres then exact, spheres only.
constexpr int kMesh = 0;
constexpr int kSpheres = 1;
constexpr int kSpheresOnly = 2;
// rrt_connect only: "spheres_only" with every edge certified by clearance (certify_edge).
constexpr int kClearance = 3;
// Certified edges (CollisionKernel::certify_edge), in units of the resolution delta in the
// metric of q: an interval narrower than the min step blocks the edge (s_min), and one check
// certifies at most the max step on each side (its cap: the cost of a check grows with the
// pairs within reach). Set by set_clearance_tuning (benchmarks).
std::atomic<double> g_min_step_fraction{1e-3};
std::atomic<double> g_max_step_fraction{5.0};

std::vector<int> bisection_order(int n);

class CollisionKernel {
 public:
  // The model, geometry model and their data are Python objects (created by Pinocchio's
  // library, copies owned by taskspace's CollisionChecker); the kernel keeps references to
  // them so that they outlive it.
  // geometry_data None: the kernel makes its own (lean_geometry_data), the usual case
  // (CollisionChecker); a GeometryData of the geometry model is used as given.
  CollisionKernel(bp::object model, bp::object data, bp::object geom, bp::object gdata,
                  int cache_size)
      : py_{model, data, geom, gdata},
        own_gdata_(gdata.is_none()
                       ? lean_geometry_data(bp::extract<const GeometryModel&>(geom)())
                       : nullptr),
        model_(bp::extract<const Model&>(model)),
        data_(bp::extract<Data&>(data)),
        geom_(bp::extract<const GeometryModel&>(geom)),
        gdata_(own_gdata_ ? *own_gdata_ : static_cast<GeometryData&>(bp::extract<GeometryData&>(gdata))) {
    if (model_.nq != model_.nv) throw std::invalid_argument("the kernel needs nq == nv");
    if (gdata_.oMg.size() != geom_.geometryObjects.size())
      throw std::invalid_argument("geometry data does not belong to the geometry model");
    // No GJK warm start: Pinocchio's requests cache the last GJK guess and support-function
    // hints of every pair (enable_cached_gjk_guess), and the kernels call a pair's narrow
    // phase only for some configurations, so the guess may come from a far one. Seen on
    // bookshelf_small (problem 1): panda_link5 1.3 cm inside shelf_bottom (coal's distance)
    // reported free by computeCollision after a call at another configuration, found free
    // with the default guess (also from coal's own collide with that request).
    // Collision threshold at GJK's tolerance: without contact information (Pinocchio's
    // default, enable_contact false) coal's shape-shape collide skips EPA when GJK returns
    // "Collision" and then compares GJK's last distance (anything up to gjk_tolerance,
    // 1e-6 m) with collision_distance_threshold (1e-12 by default): a GJK that stops at
    // 2e-7 reports "free". Seen on cage (tests: CAGE_DEEP): panda_hand_0 3.5 cm inside
    // side_right (an LP on the hull's vertices and the box's corners confirms the overlap
    // with the box shrunk by 3 cm) reported free by computeCollision and by this kernel's
    // mesh and "spheres" checkers; 3 of 1,266 colliding pair evaluations on 2,100 random
    // configurations of the seven scenes (coal 3.0.3). With the threshold at the tolerance
    // every GJK "Collision" counts; a pair closer than 1e-6 m counts as colliding.
    for (auto& request : gdata_.collisionRequests) {
      request.enable_cached_gjk_guess = false;
      request.gjk_initial_guess = coal::GJKInitialGuess::DefaultGuess;
      request.collision_distance_threshold =
          std::max(request.collision_distance_threshold, request.gjk_tolerance);
    }
    // Pinocchio's managers (modes 0 and 1) are made when such a mode is set (make_manager).
    // Their construction computes every geometry's local AABB (coal's CollisionObject), which
    // the pair list below reads (degenerate geometries are left out): computed here.
    for (const auto& obj : geom_.geometryObjects)
      if (obj.geometry) obj.geometry->computeLocalAABB();
    const VectorXd q0 = VectorXd::Zero(model_.nq);  // any configuration: obstacles are static
    pinocchio::updateGeometryPlacements(model_, data_, geom_, gdata_, q0);
    // The pair list of collides_pairs: the pairs Pinocchio's managers check (active, not
    // disabled, no degenerate geometry), each object's inflation as in the managers.
    const std::size_t ng = geom_.geometryObjects.size();
    inflation_.assign(ng, 0.0);
    boxes_.resize(ng);
    std::vector<char> used(ng, 0);
    for (std::size_t p = 0; p < geom_.collisionPairs.size(); ++p) {
      const auto& pair = geom_.collisionPairs[p];
      const auto& o1 = geom_.geometryObjects[pair.first];
      const auto& o2 = geom_.geometryObjects[pair.second];
      if (!gdata_.activeCollisionPairs[p] || o1.disableCollision || o2.disableCollision) continue;
      if (o1.geometry->aabb_local.volume() <= 0. || o2.geometry->aabb_local.volume() <= 0.)
        continue;
      const coal::CollisionRequest& cr = gdata_.collisionRequests[p];
      const double infl = (cr.break_distance + cr.security_margin) * 0.5;
      inflation_[pair.first] = std::max(inflation_[pair.first], infl);
      inflation_[pair.second] = std::max(inflation_[pair.second], infl);
      used[pair.first] = used[pair.second] = 1;
      pairs_.push_back(p);
    }
    local_center_.resize(ng);
    half_.resize(ng);
    centers_.resize(ng);
    obb_ok_.assign(ng, 0);
    for (std::size_t i = 0; i < ng; ++i) {
      const coal::AABB& local = geom_.geometryObjects[i].geometry->aabb_local;
      local_center_[i] = local.center();
      half_[i] = (local.max_ - local.min_) * 0.5 + coal::Vec3s::Constant(inflation_[i]);
      obb_ok_[i] = local_center_[i].allFinite() && half_[i].allFinite() &&
                   half_[i].maxCoeff() < 1e6 && half_[i].minCoeff() >= 0.0;
      centers_[i] = gdata_.oMg[i].rotation() * local_center_[i] + gdata_.oMg[i].translation();
    }
    for (std::size_t i = 0; i < ng; ++i) {
      objects_.push_back(std::make_unique<coal::CollisionObject>(
          geom_.geometryObjects[i].geometry, false));
      objects_[i]->setTransform(pinocchio::toCoalTransform3s(gdata_.oMg[i]));
      objects_[i]->computeAABB();
      boxes_[i] = objects_[i]->getAABB();
      boxes_[i].expand(inflation_[i]);
      if (used[i] && geom_.geometryObjects[i].parentJoint != 0) moving_.push_back(i);
    }
    // Pairs grouped by their moving object (pairs of two static objects never change: they are
    // checked with the moving ones of the first object, as any pair), in pair order.
    std::vector<std::vector<std::pair<std::size_t, pinocchio::PairIndex>>> by_object(ng);
    for (pinocchio::PairIndex p : pairs_) {
      const auto& pair = geom_.collisionPairs[p];
      const bool first_moves = geom_.geometryObjects[pair.first].parentJoint != 0;
      const std::size_t owner = first_moves ? pair.first : pair.second;
      by_object[owner].push_back({first_moves ? pair.second : pair.first, p});
    }
    for (std::size_t i = 0; i < ng; ++i) {
      if (by_object[i].empty()) continue;
      Group g;
      g.object = i;
      g.begin = group_pairs_.size();
      bool any_static = false;
      for (const auto& [partner, p] : by_object[i]) {
        const bool st = geom_.geometryObjects[partner].parentJoint == 0 &&
                        geom_.geometryObjects[i].parentJoint != 0;
        if (st) {
          if (!any_static) g.partners_box = boxes_[partner];
          else g.partners_box += boxes_[partner];
          any_static = true;
        }
        group_pairs_.push_back({partner, p, st});
      }
      g.end = group_pairs_.size();
      groups_.push_back(g);
    }
    // Bounding spheres of the oriented boxes (collides_pairs' first test): the box's centre in
    // the frame of the object's joint, the half diagonal of the inflated box as the radius
    // (with 1e-9 m against rounding).
    box_joint_center_.resize(ng);
    box_world_center_.resize(ng);
    box_radius_.assign(ng, std::numeric_limits<double>::infinity());
    placed_.assign(ng, 0u);
    for (std::size_t i = 0; i < ng; ++i) {
      const auto& obj = geom_.geometryObjects[i];
      box_joint_center_[i] = obj.placement.rotation() * local_center_[i] + obj.placement.translation();
      box_world_center_[i] = centers_[i];
      if (obb_ok_[i]) box_radius_[i] = half_[i].norm() * (1.0 + 1e-12) + 1e-9;
    }
    setup_mesh_links();
    setup_kinematics();
    set_cache_size(cache_size);
  }

  // Pinocchio's TreeBroadPhaseManager::update without the parts that do not change between
  // configurations: the manager of the universe (joint 0: obstacles and the fixed base) is
  // static, and the per-object inflation (a pass over all collision pairs in every manager's
  // update) is the one computed at construction. The moving objects get their placement,
  // coal's computeAABB and the inflation, then coal's manager update, as in Pinocchio's.
  void fast_update() {
    auto& managers = manager_->getBroadPhaseManagers();
    for (std::size_t m = 1; m < managers.size(); ++m) {
      auto& bm = managers[m];
      auto& objects = bm.getCollisionObjects();
      const auto& inflation = bm.getCollisionObjectInflation();
      const auto& active = bm.getCollisionObjectStatus();
      for (std::size_t k = 0; k < objects.size(); ++k) {
        if (!active[k]) continue;
        pinocchio::CollisionObject& obj = objects[k];
        obj.setTransform(pinocchio::toCoalTransform3s(gdata_.oMg[obj.geometryObjectIndex]));
        obj.computeAABB();
        obj.getAABB().expand(inflation[static_cast<Eigen::Index>(k)]);
      }
      bm.getManager().update();
    }
  }

  // Pinocchio's tree of broad-phase managers (modes 0 and 1), made at the first set_mode that
  // needs it: the default mode (pairs) never uses it, and a scene's set-up paid for its
  // construction (one manager per joint, each selecting among all pairs) and a complete update.
  // That update registers the active objects and computes their inflation (per pair settings),
  // which later updates reuse; the static objects' placements (any configuration) are set.
  void make_manager() {
    manager_ = std::make_unique<Manager>(&model_, &geom_, &gdata_);
    manager_->update(false);
  }

  int nq() const { return model_.nq; }
  long checks() const { return checks_; }
  void reset_checks() { checks_ = 0; }
  int ngeoms() const { return static_cast<int>(geom_.ngeoms); }
  int npairs() const { return static_cast<int>(geom_.collisionPairs.size()); }

  // 0: Pinocchio's tree manager and its update; 1: the same with fast_update; 2: pair list.
  void set_mode(int mode) {
    if (mode < 0 || mode > 2) raise_invalid("mode must be 0, 1 or 2, got " + std::to_string(mode));
    const auto lock = lock_with_gil(mutex_);
    if (mode != kPairs && !manager_) make_manager();
    mode_ = mode;
    cache_.clear();
  }
  int mode() const { return mode_; }

  void set_cache_size(int n) {
    const auto lock = lock_with_gil(mutex_);
    cache_size_ = std::max(0, n);
    cache_.clear();
  }

  // True if q is in collision; stops at the first colliding pair. checker: kMesh (the exact
  // check of `mode`), kSpheres (sphere broad phase, exact narrow phase on the pairs whose
  // spheres touch) or kSpheresOnly (conservative: a pair whose spheres touch collides).
  template <typename Vec>
  bool collides(const Eigen::MatrixBase<Vec>& q, int checker = kMesh) {
    if (checker != kMesh) return collides_spheres(q, checker);
    ++checks_;
    if (mode_ == kPairs) {  // joint placements only: collides_pairs places what it tests
      kinematics(q);
      return collides_pairs();
    }
    pinocchio::updateGeometryPlacements(model_, data_, geom_, gdata_, q);
    for (std::size_t k = 0; k < cache_.size(); ++k) {
      const pinocchio::PairIndex p = cache_[k];
      if (pinocchio::computeCollision(geom_, gdata_, p)) {
        // move to front (most recent first)
        std::rotate(cache_.begin(), cache_.begin() + k, cache_.begin() + k + 1);
        return true;
      }
    }
    if (mode_ == kManagerFast) fast_update(); else manager_->update(false);
    pinocchio::CollisionCallBackDefault callback(geom_, gdata_, true);
    manager_->collide(&callback);
    if (!callback.collision) return false;
    remember(callback.collisionPairIndex);
    return true;
  }

  // ------------------------------------------------------------------ sphere checker
  // Spheres of the moving geometry objects (taskspace.planning.sphere_model: conservative,
  // in the frame of the object's parent joint), rows of centers / radii / joints /
  // geometries. Every moving object of a checked pair needs spheres. Each object also gets
  // a bounding sphere of its spheres (the first level of the hierarchy); the static objects
  // (obstacles, fixed base) get an exact point distance when they are a box, sphere,
  // cylinder or capsule, otherwise coal's sphere-vs-geometry test.
  // certified_margin > 0: the spheres come with sphere_model's volume certificate (every
  // point of each object's convex hull lies that far inside the union of its spheres), so a
  // "free" of the sphere checkers implies the exact checker's "free" (spheres_certified).
  void set_spheres(const Eigen::Ref<const RowMatrixXd>& centers, const VectorXd& radii,
                   const Eigen::VectorXi& joints, const Eigen::VectorXi& geometries,
                   double certified_margin = 0.0) {
    const Eigen::Index m = centers.rows();
    if (!(certified_margin >= 0.0) || !std::isfinite(certified_margin))
      raise_invalid("certified_margin must be finite and >= 0");
    if (centers.cols() != 3 || radii.size() != m || joints.size() != m || geometries.size() != m)
      raise_invalid("centers (M, 3), radii, joints and geometries (M,) must have M rows");
    if (!centers.allFinite() || !radii.allFinite() || (radii.array() < 0.0).any())
      raise_invalid("sphere centers and radii must be finite, radii >= 0");
    const std::size_t ng = geom_.geometryObjects.size();
    std::vector<std::vector<Eigen::Index>> rows(ng);
    for (Eigen::Index k = 0; k < m; ++k) {
      const int g = geometries[k];
      if (g < 0 || static_cast<std::size_t>(g) >= ng)
        raise_invalid("sphere geometry index " + std::to_string(g) + " out of range");
      if (static_cast<int>(geom_.geometryObjects[g].parentJoint) != joints[k])
        raise_invalid("sphere " + std::to_string(k) + " of '" + geom_.geometryObjects[g].name +
                      "' is attached to joint " + std::to_string(joints[k]) +
                      ", the geometry to joint " +
                      std::to_string(geom_.geometryObjects[g].parentJoint));
      rows[g].push_back(k);
    }
    std::string missing;
    for (std::size_t i : moving_)
      if (rows[i].empty()) missing += (missing.empty() ? "" : ", ") + geom_.geometryObjects[i].name;
    if (!missing.empty()) raise_invalid("moving geometry objects without spheres: " + missing);
    const auto lock = lock_with_gil(mutex_);
    exact_pair_.assign(geom_.collisionPairs.size(), 0);  // (mark_exact_pairs)
    sph_begin_.assign(ng + 1, 0);
    sph_local_.clear();
    sph_r_.clear();
    bound_local_.assign(ng, coal::Vec3s::Zero());
    bound_r_.assign(ng, -1.0);
    for (std::size_t i = 0; i < ng; ++i) {
      sph_begin_[i] = static_cast<int>(sph_local_.size());
      if (rows[i].empty()) continue;
      for (Eigen::Index k : rows[i]) {
        sph_local_.push_back(centers.row(k).transpose());
        sph_r_.push_back(radii[k]);
      }
      double mid[3];
      const std::vector<Eigen::Index>& ks = rows[i];
      bound_r_[i] = taskspace_sphere_batch::bounding_sphere(
          static_cast<int>(ks.size()),
          [&centers, &radii, &ks](int q) {
            const Eigen::Index k = ks[q];
            return std::array<double, 4>{centers(k, 0), centers(k, 1), centers(k, 2), radii[k]};
          },
          mid);
      bound_local_[i] = coal::Vec3s(mid[0], mid[1], mid[2]);
    }
    sph_begin_[ng] = static_cast<int>(sph_local_.size());
    sph_world_.assign(sph_local_.size(), coal::Vec3s::Zero());
    bound_world_.assign(ng, coal::Vec3s::Zero());
    stamp_of_.assign(ng, 0);
    // static objects: placements as computed at construction (they never change)
    prim_.assign(ng, Primitive{});
    for (std::size_t i = 0; i < ng; ++i) {
      const auto& obj = geom_.geometryObjects[i];
      if (obj.parentJoint != 0) continue;
      Primitive& P = prim_[i];
      P.R = gdata_.oMg[i].rotation();
      P.t = gdata_.oMg[i].translation();
      P.tf = pinocchio::toCoalTransform3s(gdata_.oMg[i]);
      const coal::CollisionGeometry* geo = obj.geometry.get();
      if (const auto* b = dynamic_cast<const coal::Box*>(geo)) {
        P.type = kBox;
        P.half = b->halfSide;
      } else if (const auto* sp = dynamic_cast<const coal::Sphere*>(geo)) {
        P.type = kBall;
        P.radius = sp->radius;
      } else if (const auto* cy = dynamic_cast<const coal::Cylinder*>(geo)) {
        P.type = kCylinder;
        P.radius = cy->radius;
        P.half_length = cy->halfLength;
      } else if (const auto* ca = dynamic_cast<const coal::Capsule*>(geo)) {
        P.type = kCapsule;
        P.radius = ca->radius;
        P.half_length = ca->halfLength;
      }
      if (const auto* shape = dynamic_cast<const coal::ShapeBase*>(geo))
        P.swept = shape->getSweptSphereRadius();
    }
    max_margin_ = 0.0;
    for (pinocchio::PairIndex p : pairs_)
      max_margin_ = std::max(max_margin_, gdata_.collisionRequests[p].security_margin);
    // Link level: one bounding sphere per moving joint over the spheres of its objects, and
    // the static partners (at most 64, one bit each) with their boxes, inflated by the
    // largest security margin, in arrays (a vectorizable loop per link).
    link_of_.assign(ng, -1);
    links_.clear();
    for (std::size_t i : moving_) {
      const int j = static_cast<int>(geom_.geometryObjects[i].parentJoint);
      auto it = std::find_if(links_.begin(), links_.end(), [j](const Link& l) { return l.joint == j; });
      if (it == links_.end()) {
        links_.push_back(Link{j, {}, coal::Vec3s::Zero(), 0.0, coal::Vec3s::Zero(), 0});
        it = links_.end() - 1;
      }
      it->objects.push_back(i);
      link_of_[i] = static_cast<int>(it - links_.begin());
    }
    for (Link& l : links_) {
      coal::Vec3s lo = coal::Vec3s::Constant(std::numeric_limits<double>::infinity());
      coal::Vec3s hi = -lo;
      for (std::size_t i : l.objects)
        for (int k = sph_begin_[i]; k < sph_begin_[i + 1]; ++k) {
          lo = lo.cwiseMin(sph_local_[k] - coal::Vec3s::Constant(sph_r_[k]));
          hi = hi.cwiseMax(sph_local_[k] + coal::Vec3s::Constant(sph_r_[k]));
        }
      l.center = 0.5 * (lo + hi);
      l.radius = 0.0;
      for (std::size_t i : l.objects)
        for (int k = sph_begin_[i]; k < sph_begin_[i + 1]; ++k)
          l.radius = std::max(l.radius, (sph_local_[k] - l.center).norm() + sph_r_[k]);
    }
    static_bit_.assign(ng, -1);
    for (int a = 0; a < 6; ++a) static_box_[a].clear();
    for (const GroupPair& gp : group_pairs_) {
      if (!gp.partner_static || static_bit_[gp.partner] >= 0) continue;
      const int bit = static_cast<int>(static_box_[0].size());
      if (bit >= 64) break;  // more: the partners without a bit are always tested
      static_bit_[gp.partner] = bit;
      for (int a = 0; a < 3; ++a) {
        static_box_[a].push_back(boxes_[gp.partner].min_[a] - max_margin_);
        static_box_[3 + a].push_back(boxes_[gp.partner].max_[a] + max_margin_);
      }
    }
    // whole blocks of kBoxLanes (at most 64 bits): padding boxes at +inf never touch
    while (static_box_[0].size() % kBoxLanes != 0)
      for (int a = 0; a < 6; ++a)
        static_box_[a].push_back(std::numeric_limits<double>::infinity());
    pair_bit_.assign(group_pairs_.size(), -1);
    pair_margin_.assign(group_pairs_.size(), 0.0);
    for (std::size_t j = 0; j < group_pairs_.size(); ++j) {
      const GroupPair& gp = group_pairs_[j];
      pair_margin_[j] = std::max(0.0, gdata_.collisionRequests[gp.pair].security_margin);
      if (gp.partner_static) pair_bit_[j] = static_bit_[gp.partner];
    }
    sphere_groups_.assign(groups_.size(), SphereGroup{});
    for (std::size_t gi = 0; gi < groups_.size(); ++gi) {
      SphereGroup& sg = sphere_groups_[gi];
      sg.by_bit.assign(64, 0);
      for (std::size_t j = groups_[gi].begin; j < groups_[gi].end; ++j) {
        const int bit = pair_bit_[j];
        if (group_pairs_[j].partner_static && bit >= 0 && !((sg.bits >> bit) & 1u)) {
          sg.bits |= std::uint64_t{1} << bit;
          sg.by_bit[bit] = j;
        } else {
          sg.others.push_back(j);
        }
      }
    }
    setup_kinematics();
    setup_motion_bounds();
    setup_filter();
    has_spheres_ = true;
    certified_margin_ = certified_margin;
  }

  // The single-precision sphere filter of the batched checks (sphere_batch.hpp): the same
  // pairs, margins, spheres and bounding spheres as spheres_placed. Not set up (the batched
  // checks then test every lane in double) without the loop kinematics or with a pair of two
  // static objects (checked exactly by spheres_placed).
  void setup_filter() {
    namespace sb = taskspace_sphere_batch;
    filter_.reset();
    filter_.set_level(simd_);
    if (!fast_fk_) return;
    for (const Group& g : groups_)
      if (geom_.geometryObjects[g.object].parentJoint == 0) return;
    sb::Input in;
    double scale = 1.0, reach = 0.0, far = 0.0;
    for (const FkJoint& f : fk_) {
      reach += f.t0.norm();
      if (f.kind == 1)  // a prismatic joint's travel (its limits)
        reach += std::max(std::abs(model_.lowerPositionLimit[f.idx_q]),
                          std::abs(model_.upperPositionLimit[f.idx_q]));
    }
    for (const Link& l : links_) {
      in.links.push_back({l.joint, {l.center[0], l.center[1], l.center[2]}, l.radius});
      far = std::max(far, l.center.norm() + l.radius);
    }
    std::vector<int> obj(geom_.geometryObjects.size(), -1), obs(obj.size(), -1);
    for (std::size_t i : moving_) {
      sb::Input::Object o;
      o.geometry = static_cast<int>(i);
      o.link = link_of_[i];
      for (int a = 0; a < 3; ++a) o.center[a] = bound_local_[i][a];
      o.radius = bound_r_[i];
      for (int k = sph_begin_[i]; k < sph_begin_[i + 1]; ++k) {
        for (int a = 0; a < 3; ++a) o.sph.push_back(sph_local_[k][a]);
        o.sph.push_back(sph_r_[k]);
        far = std::max(far, sph_local_[k].norm() + sph_r_[k]);
      }
      obj[i] = static_cast<int>(in.objects.size());
      in.objects.push_back(std::move(o));
    }
    scale = std::max(scale, reach + far);
    pair_object_.assign(group_pairs_.size(), 0);
    for (std::size_t j = 0; j < group_pairs_.size(); ++j) {
      const GroupPair& gp = group_pairs_[j];
      const std::size_t a = groups_[group_of_pair(j)].object;
      pair_object_[j] = a;
      int b = -1;
      if (gp.partner_static) {
        if (obs[gp.partner] < 0) {
          const Primitive& P = prim_[gp.partner];
          sb::Obstacle o;
          o.type = P.type;  // kGeneric 0, kBox 1, kBall 2, kCylinder 3, kCapsule 4
          for (int r = 0; r < 3; ++r)
            for (int c = 0; c < 3; ++c) o.R[r + 3 * c] = P.R(r, c);
          for (int a3 = 0; a3 < 3; ++a3) {
            o.t[a3] = P.t[a3];
            o.half[a3] = P.half[a3];
            o.lo[a3] = boxes_[gp.partner].min_[a3];
            o.hi[a3] = boxes_[gp.partner].max_[a3];
            scale = std::max({scale, std::abs(o.lo[a3]), std::abs(o.hi[a3]),
                              std::abs(P.t[a3]) + P.half[a3]});
          }
          o.radius = P.radius;
          o.half_length = P.half_length;
          o.swept = P.swept;
          scale = std::max(scale, P.t.norm() + P.radius + P.half_length + P.swept);
          obs[gp.partner] = static_cast<int>(in.obstacles.size());
          in.obstacles.push_back(o);
        }
        b = obs[gp.partner];
      } else {
        b = obj[gp.partner];
      }
      in.pairs.push_back(
          {obj[a], b, gp.partner_static, pair_margin_[j], exact_pair_[gp.pair] != 0});
    }
    for (std::size_t k = 0; k < fk_.size(); ++k) {
      const FkJoint& f = fk_[k];
      sb::Input::Joint j{f.parent, f.kind, f.axis, f.idx_q, {}, {}};
      for (int e = 0; e < 9; ++e) j.R0[e] = f.R0c[e];
      for (int a = 0; a < 3; ++a) j.t0[a] = f.t0c[a];
      in.chain.push_back(j);
    }
    if (!std::isfinite(scale)) return;
    in.scale = scale;
    filter_.setup(in);
  }

  std::size_t group_of_pair(std::size_t j) const {
    for (std::size_t g = 0; g < groups_.size(); ++g)
      if (j >= groups_[g].begin && j < groups_[g].end) return g;
    return 0;
  }

  // The batched sphere checks: mode 0 tests every lane in double (the path before the
  // filter, for comparisons); 1 the single-precision filter, then the double test on the lanes
  // it cannot clear (the double path's answers); 2 (default) as 1, but for "spheres only" a
  // lane whose spheres the filter finds overlapping a primitive or a self pair's spheres by
  // more than its bound eps is colliding without the double test (filter_.sure(): the double
  // test's answer) in edge checks (first_collision: the planner, first_invalid_on_edge). The
  // initial mode is the environment variable TASKSPACE_SPHERE_FILTER (0, 1 or 2) when set.
  void set_sphere_filter(int mode) {
    if (mode < 0 || mode > 2) raise_invalid("sphere filter mode must be 0, 1 or 2");
    const auto lock = lock_with_gil(mutex_);
    filter_mode_ = mode;
  }
  int sphere_filter_mode() const { return filter_mode_; }
  bool sphere_filter() const { return filter_mode_ > 0 && filter_.ready(); }
  double sphere_filter_eps() const { return filter_.eps(); }
  // S and n of the filter's rounding bound (sphere_batch.hpp: eps = (140 n + 342) u S).
  bp::tuple sphere_filter_bound() const {
    return bp::make_tuple(filter_.scale(), filter_.depth());
  }
  int sphere_filter_units() const { return filter_.units(); }

  // The filter's raw answer for up to kBatch rows: flags 1 where it finds that the row may
  // collide (a row outside is free for the double-precision sphere test), no early exit. Tests.
  Eigen::VectorXi sphere_filter_flags(const Eigen::Ref<const RowMatrixXd>& qs) {
    Eigen::VectorXi out(qs.rows());
    filter_batches(qs, [&](Eigen::Index s, int m, unsigned maybe) {
      for (int l = 0; l < m; ++l) out[s + l] = (maybe >> l) & 1u;
    });
    return out;
  }

  // The filter's single-precision joint placements (load_q) of each row of qs: row r, columns
  // 12 j .. 12 j + 11 joint j's R (row-major) then t. Tests.
  RowMatrixXd sphere_filter_placements(const Eigen::Ref<const RowMatrixXd>& qs) {
    check_cols(qs);
    if (!has_spheres_ || !filter_.ready()) raise_invalid("the sphere filter is not set up");
    const auto lock = lock_with_gil(mutex_);
    const int nj = filter_.joints();
    RowMatrixXd out(qs.rows(), 12 * nj);
    const double* lanes[kBatch];
    for (Eigen::Index s = 0; s < qs.rows(); s += kBatch) {
      const int m = static_cast<int>(std::min<Eigen::Index>(kBatch, qs.rows() - s));
      for (int l = 0; l < kBatch; ++l) lanes[l] = qs.row(s + std::min(l, m - 1)).data();
      filter_.load_q(lanes);
      for (int l = 0; l < m; ++l)
        for (int j = 0; j < nj; ++j) {
          const std::array<float, 12> p = filter_.placement(j, l);
          for (int r = 0; r < 3; ++r) {
            for (int c = 0; c < 3; ++c) out(s + l, 12 * j + 3 * r + c) = p[r + 3 * c];
            out(s + l, 12 * j + 9 + r) = p[9 + r];
          }
        }
    }
    return out;
  }

  // The pairs that spheres_lane tests for each row (the filter's walk, filter_.first_pair and
  // next_pair, after a run on the row's batch with no early exit): out(r, p) counts the times
  // collision pair p was given for row r (0 for every pair of a row the filter clears). Tests.
  Eigen::MatrixXi sphere_filter_pairs(const Eigen::Ref<const RowMatrixXd>& qs) {
    Eigen::MatrixXi out = Eigen::MatrixXi::Zero(qs.rows(), geom_.collisionPairs.size());
    filter_batches(qs, [&](Eigen::Index s, int m, unsigned maybe) {
      for (int l = 0; l < m; ++l) {
        if (!((maybe >> l) & 1u)) continue;
        for (int j = filter_.first_pair(l); j >= 0; j = filter_.next_pair())
          ++out(s + l, static_cast<Eigen::Index>(group_pairs_[j].pair));
      }
    });
    return out;
  }

  // The test hooks' walk: the rows of qs in batches of kBatch (the last batch's missing lanes
  // repeat its last row), each batch's kinematics and a filter run with no early exit, then
  // per_batch(first row, rows in the batch, the filter's mask of rows that may collide).
  template <class PerBatch>
  void filter_batches(const Eigen::Ref<const RowMatrixXd>& qs, PerBatch&& per_batch) {
    check_cols(qs);
    if (!has_spheres_ || !filter_.ready()) raise_invalid("the sphere filter is not set up");
    const auto lock = lock_with_gil(mutex_);
    const double* lanes[kBatch];
    for (Eigen::Index s = 0; s < qs.rows(); s += kBatch) {
      const int m = static_cast<int>(std::min<Eigen::Index>(kBatch, qs.rows() - s));
      for (int l = 0; l < kBatch; ++l) lanes[l] = qs.row(s + std::min(l, m - 1)).data();
      filter_.load_q(lanes);
      defer_kinematics(lanes);
      per_batch(s, m, filter_.run((1u << m) - 1u, kBatch));
    }
  }

  // Joint placements data_.oMi for q: a loop over the joints for models whose joints are
  // all revolute or prismatic about x, y or z (Pinocchio's RX/RY/RZ/PX/PY/PZ, the Panda's),
  // Pinocchio's forwardKinematics otherwise (same placements up to rounding).
  void setup_kinematics() {
    fk_.clear();
    batch_pose_.clear();  // kinematics_batch sets the universe's placement again
    fast_fk_ = true;
    for (pinocchio::JointIndex j = 1; j < static_cast<pinocchio::JointIndex>(model_.njoints); ++j) {
      const std::string type = model_.joints[j].shortname();
      FkJoint f;
      f.parent = static_cast<int>(model_.parents[j]);
      f.idx_q = model_.joints[j].idx_q();
      f.R0 = model_.jointPlacements[j].rotation();
      f.t0 = model_.jointPlacements[j].translation();
      for (int k = 0; k < 3; ++k) {
        for (int c = 0; c < 3; ++c) f.R0c[3 * c + k] = f.R0(k, c);
        f.t0c[k] = f.t0[k];
      }
      if (type == "JointModelRX" || type == "JointModelRY" || type == "JointModelRZ") {
        f.kind = 0;
        f.axis = type.back() - 'X';
        f.turn[0] = (f.axis + 1) % 3;
        f.turn[1] = (f.axis + 2) % 3;
      } else if (type == "JointModelPX" || type == "JointModelPY" || type == "JointModelPZ") {
        f.kind = 1;
        f.axis = type.back() - 'X';
      } else {
        fast_fk_ = false;
      }
      fk_.push_back(f);
    }
  }

  template <typename Vec>
  void kinematics(const Eigen::MatrixBase<Vec>& q) {
    if (!fast_fk_) {
      pinocchio::forwardKinematics(model_, data_, q);
      return;
    }
    // the sines and cosines first: independent of each other, their latencies overlap
    // (computed inside the joint chain they waited for the parent's placement)
    fk_cos_.resize(fk_.size());
    fk_sin_.resize(fk_.size());
    for (std::size_t k = 0; k < fk_.size(); ++k)
      if (fk_[k].kind == 0) {
        fk_cos_[k] = std::cos(q[fk_[k].idx_q]);
        fk_sin_[k] = std::sin(q[fk_[k].idx_q]);
      }
    for (std::size_t k = 0; k < fk_.size(); ++k) {
      const FkJoint& f = fk_[k];
      const auto& P = data_.oMi[f.parent];
      auto& M = data_.oMi[k + 1];
      const double v = q[f.idx_q];
      // placement of the joint frame: parent * jointPlacement, then the joint's motion
      coal::Matrix3s R = P.rotation() * f.R0;
      const coal::Vec3s t = P.rotation() * f.t0 + P.translation();
      if (f.kind == 0) {
        const double c = fk_cos_[k], s = fk_sin_[k];
        const int a = f.axis, b = (a + 1) % 3, d = (a + 2) % 3;
        const coal::Vec3s cb = R.col(b), cd = R.col(d);
        R.col(b) = c * cb + s * cd;
        R.col(d) = c * cd - s * cb;
        M.rotation(R);
        M.translation(t);
      } else {
        M.rotation(R);
        M.translation(t + v * R.col(f.axis));
      }
    }
  }

  // Bit o set when the sphere (c, sqrt(r2)) touches static box o (of ns, a multiple of
  // kBoxLanes): the box tests kBoxLanes at a time in vector operations (the same arithmetic
  // per box as one at a time: the distance per axis max(lo - c, c - hi, 0), then the squared
  // distance compared with r2). Two lanes: one SSE2 register in the portable build (the
  // measurements, four lanes included, are in the commit that introduced them, 7d87f43).
  static constexpr int kBoxLanes = 2;
  typedef double BoxLanes __attribute__((vector_size(kBoxLanes * sizeof(double))));
  std::uint64_t link_box_mask(const coal::Vec3s& c, double r2, std::size_t ns) const {
    std::uint64_t mask = 0;
    const BoxLanes zero = {};
    for (std::size_t o = 0; o < ns; o += kBoxLanes) {
      BoxLanes d2 = zero;
      for (int a = 0; a < 3; ++a) {
        BoxLanes lo, hi;
        std::memcpy(&lo, static_box_[a].data() + o, sizeof(lo));
        std::memcpy(&hi, static_box_[3 + a].data() + o, sizeof(hi));
        const BoxLanes below = lo - c[a], above = c[a] - hi;
        BoxLanes d = below > above ? below : above;
        d = d > zero ? d : zero;
        d2 += d * d;
      }
      for (int k = 0; k < kBoxLanes; ++k)
        mask |= static_cast<std::uint64_t>(d2[k] <= r2) << (o + k);
    }
    return mask;
  }

  // ------------------------------------------------------------ batched sphere checks
  // kBatch configurations at once (VAMP-style, Thomason, Kingston and Kavraki, ICRA 2024, in
  // double precision): the joint placements of the batch in structure-of-arrays form (one
  // lane per configuration: each product of the joint chain is one vector operation for the
  // whole batch), then the sphere tests configuration after configuration, in the given
  // order, stopping at the first collision. The arithmetic per lane is the scalar
  // kinematics' (same products and sums, double precision), so the spheres need no extra
  // inflation. Used for the sphere checkers on models with the loop kinematics (fast_fk_):
  // edges (first_collision: rrt_connect's EXTEND, CONNECT and straight lines,
  // first_invalid_on_edge) and collisions_with.
  // Then (set_sphere_filter, default mode 2) the single-precision filter of sphere_batch.hpp
  // tests the 4 lanes at once (its own float placements from q, SphereFilter::load_q) and only
  // the lanes it cannot clear go through load_lane and the double test, in order; the batch's
  // double placements are computed then, once (defer_kinematics: most batches never need
  // them). See first_collision and sphere_batch.hpp (the rounding bound, the hierarchy).
  static constexpr int kBatch = 4;
  // 16-byte alignment (not the vector's 32): the AVX2 kinematics then load unaligned, since
  // the vectors holding BatchPose (batch_pose_) guarantee 16 bytes only (seen: vmovapd faults)
  typedef double Batch __attribute__((vector_size(kBatch * sizeof(double)), aligned(16)));
  typedef std::uint64_t BatchBits
      __attribute__((vector_size(kBatch * sizeof(std::uint64_t)), aligned(16)));
  struct BatchPose {
    Batch R[9];  // R[r + 3 * c]
    Batch t[3];
  };

  // Sines and cosines of the lanes of x, all lanes at once (libm's sincos cost about as much
  // as the rest of the batch's kinematics): x = j pi/2 + r with j the nearest integer and
  // |r| <= pi/4 (pi/2 in two parts, fdlibm's: j pi/2 is exact for |j| < 2^20), then Cephes'
  // polynomials of sin and cos on [-pi/4, pi/4] (sin.c: relative error about 1e-16) and the
  // quadrant j mod 4. Lanes beyond |x| < 1e5 (or not finite) take std::sin / std::cos.
  __attribute__((always_inline)) static inline void batch_sincos(const Batch& x, Batch& s,
                                                                 Batch& c) {
    constexpr double kTwoOverPi = 6.36619772367581382433e-01;
    constexpr double kPio2Hi = 1.57079632673412561417e+00;  // first 33 bits of pi/2
    constexpr double kPio2Lo = 6.07710050650619224932e-11;  // pi/2 - kPio2Hi
    constexpr double kRound = 6755399441055744.0;           // 1.5 * 2^52: round to nearest
    bool plain = true;
    for (int l = 0; l < kBatch; ++l) plain = plain && std::abs(x[l]) < 1e5;
    if (!plain) {
      for (int l = 0; l < kBatch; ++l) {
        s[l] = std::sin(x[l]);
        c[l] = std::cos(x[l]);
      }
      return;
    }
    // y = x 2/pi + 1.5 2^52 holds the nearest integer j in its low mantissa bits (ulp 1, the
    // mantissa 2^51 + j for |j| < 2^51): its two lowest bits are j mod 4 (two's complement)
    const Batch y = x * kTwoOverPi + kRound;
    const Batch j = y - kRound;
    const Batch r = (x - j * kPio2Hi) - j * kPio2Lo;
    const Batch z = r * r;
    Batch ps = z * 1.58962301576546568060e-10 - 2.50507477628578072866e-8;
    ps = ps * z + 2.75573136213857245213e-6;
    ps = ps * z - 1.98412698295895385996e-4;
    ps = ps * z + 8.33333333332211858878e-3;
    ps = ps * z - 1.66666666666666307295e-1;
    const Batch sr = r + r * z * ps;
    Batch pc = z * -1.13585365213876817300e-11 + 2.08757008419747316778e-9;
    pc = pc * z - 2.75573141792967388112e-7;
    pc = pc * z + 2.48015872888517045348e-5;
    pc = pc * z - 1.38888888888730564116e-3;
    pc = pc * z + 4.16666666666665929218e-2;
    const Batch cr = (1.0 - 0.5 * z) + z * z * pc;
    // quadrant q = j mod 4: (sin, cos) = (sr, cr), (cr, -sr), (-sr, -cr), (-cr, sr) for
    // q = 0..3, selected with bit operations on all lanes at once (a switch per lane
    // mispredicted; a scalar loop over the lanes cost a fifth of the batch's kinematics)
    BatchBits q, bs, bc;
    std::memcpy(&q, &y, sizeof q);
    std::memcpy(&bs, &sr, sizeof bs);
    std::memcpy(&bc, &cr, sizeof bc);
    q &= 3u;
    const BatchBits swap = BatchBits{} - (q & 1u);  // all ones for q = 1, 3
    const BatchBits os = ((bs & ~swap) | (bc & swap)) ^ ((q & 2u) << 62);
    const BatchBits oc = ((bc & ~swap) | (bs & swap)) ^ (((q + 1u) & 2u) << 62);
    std::memcpy(&s, &os, sizeof s);
    std::memcpy(&c, &oc, sizeof c);
  }

  // Joint placements of kBatch configurations (lane l: the nq coordinates at q[l]).
  // Compiled twice: for SSE2 (the portable baseline) and for AVX2 (one register per Batch of
  // 4 doubles instead of two), chosen at run time (simd_ >= 2; see processor_simd_level).
  // Both run the same IEEE operations in the same order (no FMA: the target is "avx2"
  // alone), so their placements are bit-identical (tested).
  void kinematics_batch(const double* const* q) {
    batch_pending_ = false;
#ifdef TASKSPACE_SIMD_X86
    if (simd_ >= 2) {
      kinematics_batch_avx2(q);
      return;
    }
#endif
    kinematics_batch_body(q);
  }
#ifdef TASKSPACE_SIMD_X86
  __attribute__((target("avx2"))) void kinematics_batch_avx2(const double* const* q) {
    kinematics_batch_body(q);
  }
#endif
  // The SIMD level of the kernel's batched checks (1 SSE2, 2 AVX2 with FMA, 3 AVX-512; the
  // batch kinematics use AVX2 from 2 on, the sphere filter the build of the level), at most
  // the processor's: a higher level asked for gives the processor's.
  void set_simd(int level) {
    if (level < 1 || level > 3)
      raise_invalid("simd level must be 1 (SSE2), 2 (AVX2 with FMA) or 3 (AVX-512)");
    const auto lock = lock_with_gil(mutex_);
    simd_ = std::min(level, processor_simd_level());
    filter_.set_level(simd_);
  }
  static int max_simd() { return processor_simd_level(); }
  int simd() const { return simd_; }
  __attribute__((always_inline)) inline void kinematics_batch_body(const double* const* q) {
    const std::size_t nj = fk_.size() + 1;
    if (batch_pose_.size() != nj) {  // the universe's placement (never written below) once
      batch_pose_.resize(nj);
      const auto& O = data_.oMi[0];
      for (int r = 0; r < 3; ++r) {
        for (int c = 0; c < 3; ++c)
          for (int l = 0; l < kBatch; ++l) batch_pose_[0].R[r + 3 * c][l] = O.rotation()(r, c);
        for (int l = 0; l < kBatch; ++l) batch_pose_[0].t[r][l] = O.translation()[r];
      }
    }
    for (std::size_t k = 0; k < fk_.size(); ++k) {
      const FkJoint& f = fk_[k];
      const BatchPose& P = batch_pose_[f.parent];
      BatchPose& M = batch_pose_[k + 1];
      Batch v;
      for (int l = 0; l < kBatch; ++l) v[l] = q[l][f.idx_q];
      // parent * jointPlacement (R0 and t0 are the same for every lane): the sums of
      // P.R[r + 3 k] * R0(k, c) over k = 0, 1, 2 in that order (Eigen's order: the scalar
      // kinematics' values but for the sign of a zero, as a product with an entry 0 adds +-0),
      // all nine products (no branch per term: the Panda's joint placements have entries
      // 6e-17 beside their 0 and 1, so products with 0 or 1 are rare and not worth a test)
      for (int c = 0; c < 3; ++c)
        for (int r = 0; r < 3; ++r)
          M.R[r + 3 * c] = (P.R[r] * f.R0c[3 * c] + P.R[r + 3] * f.R0c[3 * c + 1]) +
                           P.R[r + 6] * f.R0c[3 * c + 2];
      for (int r = 0; r < 3; ++r)
        M.t[r] = ((P.R[r] * f.t0c[0] + P.R[r + 3] * f.t0c[1]) + P.R[r + 6] * f.t0c[2]) + P.t[r];
      if (f.kind == 0) {  // revolute: columns b and d turn about the axis
        Batch c, s;
        batch_sincos(v, s, c);
        const int b = f.turn[0], d = f.turn[1];
        for (int r = 0; r < 3; ++r) {
          const Batch cb = M.R[r + 3 * b], cd = M.R[r + 3 * d];
          M.R[r + 3 * b] = c * cb + s * cd;
          M.R[r + 3 * d] = c * cd - s * cb;
        }
      } else {  // prismatic: along the axis column
        for (int r = 0; r < 3; ++r) M.t[r] = M.t[r] + v * M.R[r + 3 * f.axis];
      }
    }
  }

  // The batch q (kBatch lanes, valid until the batch is done) whose double placements
  // (kinematics_batch) are computed only when a lane needs them (load_lane): the filter
  // (load_q, single precision) clears most batches entirely.
  void defer_kinematics(const double* const* q) {
    for (int l = 0; l < kBatch; ++l) batch_q_[l] = q[l];
    batch_pending_ = true;
  }

  // data_.oMi of lane l of the last kinematics_batch (or of the deferred batch).
  void load_lane(int l) {
    if (batch_pending_) kinematics_batch(batch_q_);
    for (std::size_t j = 1; j < batch_pose_.size(); ++j) {
      const BatchPose& B = batch_pose_[j];
      coal::Matrix3s R;
      for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 3; ++c) R(r, c) = B.R[r + 3 * c][l];
      data_.oMi[j].rotation(R);
      data_.oMi[j].translation(coal::Vec3s(B.t[0][l], B.t[1][l], B.t[2][l]));
    }
  }

  bool batched(int checker) const { return checker != kMesh && fast_fk_ && has_spheres_; }

  // Index j of the first colliding point x_j = a + t[j] * b (j = 0..count-1, checked in that
  // order), or -1 when all are free. stop() is called before each point's check; when it
  // returns true the point counts as colliding (the planner's convention: a stopped plan
  // treats the motion as blocked). The sphere checkers check the points in batches of
  // kBatch (kinematics_batch); the mesh checker one at a time.
  template <typename Stop>
  int first_collision(const double* a, const double* b, const double* t, int count, int checker,
                      Stop&& stop) {
    const int n = model_.nq;
    return first_collision_at(
        count, checker,
        [a, b, t, n](int j, double* x) {
          for (int k = 0; k < n; ++k) x[k] = a[k] + t[j] * b[k];
        },
        stop);
  }

  // The same for the points fill(j, x) (x: nq values) of any lines, e.g. the fine points of
  // several edges in one list (RRTConnect::verify), so that the batches are full.
  template <typename Fill, typename Stop>
  int first_collision_at(int count, int checker, Fill&& fill, Stop&& stop) {
    const int n = model_.nq;
    if (!batched(checker)) {
      edge_x_.resize(n);
      for (int j = 0; j < count; ++j) {
        fill(j, edge_x_.data());
        if (stop() || collides(edge_x_, checker)) return j;
      }
      return -1;
    }
    edge_buf_.resize(static_cast<std::size_t>(kBatch) * n);
    const double* lanes[kBatch];
    const bool filter = sphere_filter();
    const bool trust = filter && filter_mode_ == 2 && checker == kSpheresOnly;
    for (int s = 0; s < count; s += kBatch) {
      const int m = std::min(kBatch, count - s);
      for (int l = 0; l < kBatch; ++l) {
        double* x = edge_buf_.data() + static_cast<std::size_t>(l) * n;
        fill(s + std::min(l, m - 1), x);  // unused lanes repeat the last point
        lanes[l] = x;
      }
      if (!filter) {
        kinematics_batch(lanes);
        for (int l = 0; l < m; ++l) {
          if (stop()) return s + l;
          ++checks_;
          load_lane(l);
          if (spheres_placed(checker)) return s + l;
        }
        continue;
      }
      // the filter, stopping when the first lane not yet decided may collide: that lane is
      // checked exactly (colliding: done; free: the filter again on the later lanes); lanes
      // the filter clears are free, the others are checked exactly, in order
      filter_.load_q(lanes);
      defer_kinematics(lanes);
      const unsigned all = (1u << m) - 1u;
      unsigned decided = 0;
      for (int first = 0; first < m;) {
        const unsigned maybe = filter_.run(all & ~decided, first);
        if ((maybe >> first) & 1u) {
          if (stop()) return s + first;
          ++checks_;
          if (trust && ((filter_.sure() >> first) & 1u)) return s + first;
          if (spheres_lane(first, checker)) return s + first;
          decided |= 1u << first;
          ++first;
          continue;
        }
        for (int l = first; l < m; ++l) {
          if (stop()) return s + l;
          ++checks_;
          if (!((maybe >> l) & 1u)) continue;
          if (trust && ((filter_.sure() >> l) & 1u)) return s + l;
          if (spheres_lane(l, checker)) return s + l;
        }
        break;
      }
    }
    return -1;
  }

  // Collision flags of rows [begin, end) of qs into out (batched sphere checks).
  void flags_batched(const Eigen::Ref<const RowMatrixXd>& qs, int checker, Eigen::VectorXi& out) {
    const double* lanes[kBatch];
    const bool filter = sphere_filter();  // (the double test's answers: no trusted lanes)
    for (Eigen::Index s = 0; s < qs.rows(); s += kBatch) {
      const int m = static_cast<int>(std::min<Eigen::Index>(kBatch, qs.rows() - s));
      for (int l = 0; l < kBatch; ++l) lanes[l] = qs.row(s + std::min(l, m - 1)).data();
      unsigned maybe = (1u << m) - 1u;  // without the filter: every lane in double
      if (filter) {
        filter_.load_q(lanes);
        defer_kinematics(lanes);
        maybe = filter_.run(maybe, kBatch);
      } else {
        kinematics_batch(lanes);
      }
      for (int l = 0; l < m; ++l) {
        ++checks_;
        out[s + l] = 0;
        if (!((maybe >> l) & 1u)) continue;
        if (filter) {
          out[s + l] = spheres_lane(l, checker) ? 1 : 0;
          continue;
        }
        load_lane(l);
        out[s + l] = spheres_placed(checker) ? 1 : 0;
      }
    }
  }

  bool has_spheres() const { return has_spheres_; }
  // The spheres' volume certificate margin [m] (0: none; see set_spheres).
  double certified_margin() const { return certified_margin_; }
  bool spheres_certified() const { return has_spheres_ && certified_margin_ > 0.0; }
  // Counters of the sphere checker (for profiling): bounding-sphere passes, leaf hits and
  // exact narrow-phase calls, self pairs then static pairs.
  bp::tuple sphere_stats() const {
    return bp::make_tuple(stat_[0], stat_[1], stat_[2], stat_[3], stat_[4], stat_[5]);
  }
  void reset_sphere_stats() { std::fill(std::begin(stat_), std::end(stat_), 0L); }
  int sphere_count() const { return static_cast<int>(sph_local_.size()); }

  // Sphere check of q (kSpheres or kSpheresOnly, see collides). Kinematics only (the joint
  // placements, no geometry placements); per moving object: its bounding sphere against the
  // union box of its static partners, then pair by pair the bounding sphere against the
  // partner's box and shape (or the partner's bounding sphere), then its spheres against the
  // partner's shape (or spheres); where they touch, coal's exact narrow phase (kSpheres) or
  // "colliding" (kSpheresOnly). Every test is conservative (the security margin of the pair
  // and swept-sphere radii included), so "free" here means free for the exact check.
  template <typename Vec>
  bool collides_spheres(const Eigen::MatrixBase<Vec>& q, int checker) {
    if (!has_spheres_) throw std::logic_error("collides_spheres without spheres");
    ++checks_;
    kinematics(q);
    return spheres_placed(checker);
  }

  // A new configuration for leaves().
  void next_stamp() {
    ++stamp_;
    if (stamp_ == 0) {  // wrapped: invalidate every stamp
      std::fill(stamp_of_.begin(), stamp_of_.end(), 0u);
      stamp_ = 1;
    }
  }

  // spheres_placed for lane l of the last filter run (in its mask): the pairs the filter
  // cannot clear for that lane only (filter_.first_pair, next_pair), each with the double
  // test of spheres_placed (sphere_pair_hits). Every other pair is free for that test (the
  // filter's eps bound), so the answer is spheres_placed's; a pair that collides joins the
  // pair cache as there (the cache orders spheres_placed's pairs, the filter its own).
  bool spheres_lane(int l, int checker) {
    load_lane(l);
    next_stamp();
    for (int j = filter_.first_pair(l); j >= 0; j = filter_.next_pair()) {
      const GroupPair& gp = group_pairs_[j];
      const std::size_t a = pair_object_[j];
      place_bound(a);
      if (!gp.partner_static) place_bound(gp.partner);
      if (sphere_pair_hits(a, gp.partner, gp.pair, gp.partner_static, checker)) {
        remember(gp.pair);
        return true;
      }
    }
    return false;
  }

  // Object i's bounding sphere centre, world frame (bound_world_).
  void place_bound(std::size_t i) {
    const auto& M = data_.oMi[geom_.geometryObjects[i].parentJoint];
    bound_world_[i].noalias() = M.rotation() * bound_local_[i];
    bound_world_[i] += M.translation();
  }

  // The sphere check of the configuration whose joint placements are in data_.oMi
  // (collides_spheres after the kinematics; the batched checks after load_lane).
  bool spheres_placed(int checker) {
    next_stamp();
    // (static_box_ holds whole blocks of kBoxLanes boxes: the padding never touches)
    const std::size_t ns = static_box_[0].size();
    for (Link& l : links_) {  // the link's bounding sphere against every static box
      const auto& M = data_.oMi[l.joint];
      const coal::Vec3s c = M.rotation() * l.center + M.translation();
      l.mask = link_box_mask(c, l.radius * l.radius, ns);
      l.world = c;
    }
    for (std::size_t i : moving_) {
      const auto& M = data_.oMi[geom_.geometryObjects[i].parentJoint];
      bound_world_[i].noalias() = M.rotation() * bound_local_[i];
      bound_world_[i] += M.translation();
    }
    for (std::size_t k = 0; k < cache_.size(); ++k) {
      const pinocchio::PairIndex p = cache_[k];
      const auto& pair = geom_.collisionPairs[p];
      const bool first_moves = geom_.geometryObjects[pair.first].parentJoint != 0;
      const std::size_t a = first_moves ? pair.first : pair.second;
      const std::size_t b = first_moves ? pair.second : pair.first;
      if (sphere_pair_hits(a, b, p, geom_.geometryObjects[b].parentJoint == 0, checker)) {
        std::rotate(cache_.begin(), cache_.begin() + k, cache_.begin() + k + 1);
        return true;
      }
    }
    for (const Group& g : groups_) {
      const std::size_t i = g.object;
      if (geom_.geometryObjects[i].parentJoint == 0) {  // two static objects: exact, as is
        for (std::size_t j = g.begin; j < g.end; ++j)
          if (pinocchio::computeCollision(geom_, gdata_, group_pairs_[j].pair)) return true;
        continue;
      }
      const SphereGroup& sg = sphere_groups_[&g - groups_.data()];
      // static partners whose box the link's bounding sphere touches (set bits only)
      std::uint64_t m = links_[link_of_[i]].mask & sg.bits;
      while (m != 0) {
        const int bit = __builtin_ctzll(m);
        m &= m - 1;
        const GroupPair& gp = group_pairs_[sg.by_bit[bit]];
        if (sphere_pair_hits(i, gp.partner, gp.pair, true, checker)) {
          remember(gp.pair);
          return true;
        }
      }
      for (std::size_t j : sg.others) {  // static partners beyond 64 bits, moving partners
        const GroupPair& gp = group_pairs_[j];
        if (!gp.partner_static) {
          const double reach = bound_r_[i] + bound_r_[gp.partner] + pair_margin_[j];
          if ((bound_world_[i] - bound_world_[gp.partner]).squaredNorm() > reach * reach) continue;
        }
        if (sphere_pair_hits(i, gp.partner, gp.pair, gp.partner_static, checker)) {
          remember(gp.pair);
          return true;
        }
      }
    }
    return false;
  }


  // ------------------------------------------------------ edge clearance certificates
  // Conservative advancement over a straight edge x(t) = a + t b with the spheres (#22 items
  // 4 and 5). Two facts make one sphere check certify a whole interval of t:
  //  (1) Motion bound. For link l (links_) and coordinate k, mb_[l, k] bounds, over every
  //      configuration, the speed [m per unit of q_k] of any sphere centre of l when q_k moves
  //      alone: for a revolute joint k the centre's distance to k's axis, for a prismatic
  //      one 1 (0 when k is not an ancestor of l). Along the edge the centre of a sphere of l
  //      then moves at most rho_l = sum_k mb_[l, k] |b_k| per unit of t. The sphere is rigid:
  //      the set it covers is its centre's translate, so the centre's displacement bounds
  //      every point's (no radius term). setup_motion_bounds derives mb_ from the joint
  //      placements by the triangle inequality along the chain (see there).
  //  (2) Lipschitz clearances. The clearance of a sphere to an obstacle (the exact distance
  //      of its centre to a box, sphere, cylinder or capsule, or coal's distance to any other
  //      shape, minus radius, pair margin and swept radius) is 1-Lipschitz in the centre. The
  //      clearance of two spheres of links la, lb (|c_a - c_b| - r_a - r_b - margin) changes
  //      only through the joints that move one link and not the other: a joint that moves
  //      both turns or shifts c_a - c_b rigidly (d|r|/dt = r.(w x r) / |r| = 0), so its rate
  //      is at most rho_ab = sum over the other joints of mb_[owner, k] |b_k|.
  // So a configuration x(t) whose sphere clearances are c_p > 0 is the centre of a certified
  // interval |t' - t| < min_p c_p / rho_p (spheres_clearance): every configuration in it is
  // free for the "spheres_only" checker, hence, with the sphere model's volume certificate,
  // for the exact meshes (the proof at RRTConnect::recheck). certify_edge covers [t0, t1]
  // with such intervals: the end point first, then the midpoints of the uncovered gaps in
  // breadth-first order; an interval narrower than s_min (a configuration within about
  // s_min |b| of touching, in the metric) blocks the edge (conservative).

  // mb_ and the self-pair rates from the kinematic chain (models with the loop kinematics).
  // For a sphere centre c of link l: in the frame of joint m its coordinates c_m satisfy
  // |c_l| <= D_l = max over l's spheres of |c| and, for the parent k of m,
  // c_k = t0_m + R0_m Rot_m(q_m) c_m (revolute m) or t0_m + R0_m (v e + c_m) (prismatic m, v
  // within the joint's limits), hence |c_k| <= D_k = |t0_m| + (|v|max) + D_m. The speed of c
  // when revolute joint k moves is its distance to k's axis (through the origin of frame k,
  // direction e_k): |P_k c_k| <= |P_k t0_m| + (|v|max) + D_m with P_k the projection
  // orthogonal to e_k; for l's own joint exactly max |P_l c|. False (no certificates) for
  // other models or a prismatic joint with infinite limits.
  void setup_motion_bounds() {
    motion_bounds_ok_ = false;
    const int nq = model_.nq;
    const std::size_t nl = links_.size();
    mb_.assign(nl * nq, 0.0);
    anc_.assign(nl * nq, 0);
    pair_rate_.assign(nl * nl * nq, 0.0);
    if (!fast_fk_) return;
    auto perp = [](const coal::Vec3s& v, int axis) {
      coal::Vec3s p = v;
      p[axis] = 0.0;
      return p.norm();
    };
    for (std::size_t li = 0; li < nl; ++li) {
      const Link& l = links_[li];
      double D = 0.0, own = 0.0;
      const FkJoint& fj = fk_[l.joint - 1];
      for (std::size_t i : l.objects)
        for (int s = sph_begin_[i]; s < sph_begin_[i + 1]; ++s) {
          D = std::max(D, sph_local_[s].norm());
          own = std::max(own, perp(sph_local_[s], fj.axis));
        }
      mb_[li * nq + fj.idx_q] = fj.kind == 0 ? own : 1.0;
      anc_[li * nq + fj.idx_q] = 1;
      int m = l.joint;
      while (model_.parents[m] != 0) {
        const int k = static_cast<int>(model_.parents[m]);
        const FkJoint& fm = fk_[m - 1];
        const FkJoint& fk = fk_[k - 1];
        double extra = 0.0;
        if (fm.kind == 1) {
          extra = std::max(std::abs(model_.lowerPositionLimit[fm.idx_q]),
                           std::abs(model_.upperPositionLimit[fm.idx_q]));
          if (!std::isfinite(extra)) return;
        }
        mb_[li * nq + fk.idx_q] = fk.kind == 0 ? perp(fm.t0, fk.axis) + extra + D : 1.0;
        anc_[li * nq + fk.idx_q] = 1;
        D += fm.t0.norm() + extra;
        m = k;
      }
    }
    for (std::size_t la = 0; la < nl; ++la)
      for (std::size_t lb = 0; lb < nl; ++lb)
        for (int k = 0; k < nq; ++k) {
          const bool in_a = anc_[la * nq + k] != 0, in_b = anc_[lb * nq + k] != 0;
          pair_rate_[(la * nl + lb) * nq + k] =
              in_a && !in_b ? mb_[la * nq + k] : (in_b && !in_a ? mb_[lb * nq + k] : 0.0);
        }
    rho_link_.assign(nl, 0.0);
    rho_pair_.assign(nl * nl, 0.0);
    motion_bounds_ok_ = true;
  }

  bool motion_bounds_ok() const { return has_spheres_ && motion_bounds_ok_; }

  // Rates rho_l and rho_ab of the edge direction b (per unit of t).
  void set_direction(const double* b) {
    const int nq = model_.nq;
    const std::size_t nl = links_.size();
    abs_b_.resize(nq);
    for (int k = 0; k < nq; ++k) abs_b_[k] = std::abs(b[k]);
    for (std::size_t l = 0; l < nl; ++l) {
      double r = 0.0;
      for (int k = 0; k < nq; ++k) r += mb_[l * nq + k] * abs_b_[k];
      rho_link_[l] = r;
    }
    for (std::size_t p = 0; p < nl * nl; ++p) {
      double r = 0.0;
      for (int k = 0; k < nq; ++k) r += pair_rate_[p * nq + k] * abs_b_[k];
      rho_pair_[p] = r;
    }
  }

  // Certified radius (in units of t, at most cap) of the configuration whose joint placements
  // are in data_.oMi, for the direction of the last set_direction: every configuration
  // within it along the edge is free for "spheres_only"; 0 when spheres touch (colliding).
  // Pairs whose bounding spheres cannot lower the radius below the current one are skipped
  // (the link's bounding sphere against the static boxes within its reach, then the object's
  // bounding sphere, then its spheres), so the work shrinks with cap.
  double spheres_clearance(double cap) {
    ++stamp_;
    if (stamp_ == 0) {
      std::fill(stamp_of_.begin(), stamp_of_.end(), 0u);
      stamp_ = 1;
    }
    const std::size_t ns = static_box_[0].size();
    const std::size_t nl = links_.size();
    for (std::size_t li = 0; li < nl; ++li) {
      Link& l = links_[li];
      const auto& M = data_.oMi[l.joint];
      const coal::Vec3s c = M.rotation() * l.center + M.translation();
      const double reach = l.radius + cap * rho_link_[li];
      l.mask = link_box_mask(c, reach * reach, ns);
      l.world = c;
    }
    for (std::size_t i : moving_) {
      const auto& M = data_.oMi[geom_.geometryObjects[i].parentJoint];
      bound_world_[i].noalias() = M.rotation() * bound_local_[i];
      bound_world_[i] += M.translation();
    }
    double s = cap;
    for (const Group& g : groups_) {
      const std::size_t i = g.object;
      if (geom_.geometryObjects[i].parentJoint == 0) {  // two static objects: exact, as is
        for (std::size_t j = g.begin; j < g.end; ++j)
          if (pinocchio::computeCollision(geom_, gdata_, group_pairs_[j].pair)) return 0.0;
        continue;
      }
      const SphereGroup& sg = sphere_groups_[&g - groups_.data()];
      const int li = link_of_[i];
      const double rho = rho_link_[li];
      std::uint64_t m = links_[li].mask & sg.bits;
      while (m != 0) {
        const int bit = __builtin_ctzll(m);
        m &= m - 1;
        const std::size_t j = sg.by_bit[bit];
        s = static_clearance(i, group_pairs_[j].partner, pair_margin_[j], rho, s);
        if (s <= 0.0) return 0.0;
      }
      for (std::size_t j : sg.others) {
        const GroupPair& gp = group_pairs_[j];
        s = gp.partner_static
                ? static_clearance(i, gp.partner, pair_margin_[j], rho, s)
                : self_clearance(i, gp.partner, pair_margin_[j],
                                 rho_pair_[li * nl + link_of_[gp.partner]], s);
        if (s <= 0.0) return 0.0;
      }
    }
    return s;
  }

  // Whether the edge a + t b, t in [t0, t1], is certified free for "spheres_only" (see
  // above): the end point first, then the midpoints of the gaps, breadth first; false at a
  // configuration whose certified radius is <= s_min (colliding or within s_min of
  // touching) or when stop() returns true (called before each check). Each check counts
  // in checks (and clearance_checks).
  template <typename Stop>
  bool certify_edge(const double* a, const double* b, double t0, double t1, double s_min,
                    double s_max, Stop&& stop) {
    const int n = model_.nq;
    set_direction(b);
    edge_x_.resize(n);
    auto radius = [&](double t, double cap) {
      for (int k = 0; k < n; ++k) edge_x_[k] = a[k] + t * b[k];
      ++checks_;
      ++clearance_checks_;
      kinematics(edge_x_);
      return spheres_clearance(std::max(std::min(cap, s_max) * (1.0 + 1e-9), 2.0 * s_min));
    };
    if (stop()) return false;
    double s = radius(t1, t1 - t0);
    if (s <= s_min) return false;
    if (s > t1 - t0) return true;
    // (a radius below the interval's half: the cap s_max or an obstacle; both split)
    gaps_.clear();
    gaps_.push_back({t0, t1 - s});
    for (std::size_t h = 0; h < gaps_.size(); ++h) {
      const auto [lo, hi] = gaps_[h];
      const double mid = 0.5 * (lo + hi), half = 0.5 * (hi - lo);
      if (stop()) return false;
      s = radius(mid, half);
      if (s <= s_min) return false;
      if (s > half) continue;
      gaps_.push_back({lo, mid - s});
      gaps_.push_back({mid + s, hi});
    }
    return true;
  }

  // For the tests: (certified, checks) of the edge q0 -> q1 (t in [0, 1]) with
  // s_min = min_step / |q1 - q0| and s_max = max_step / |q1 - q0| (steps in the metric of q).
  bp::tuple certify_edge_py(const VectorXd& q0, const VectorXd& q1, double min_step,
                            double max_step) {
    if (q0.size() != model_.nq || q1.size() != model_.nq)
      raise_invalid("q0 and q1 must have size nq = " + std::to_string(model_.nq));
    if (!(min_step > 0.0) || !(max_step >= min_step) || !std::isfinite(max_step))
      raise_invalid("min_step and max_step must be finite, 0 < min_step <= max_step");
    if (!q0.allFinite() || !q1.allFinite()) raise_invalid("q0 and q1 must be finite");
    require_motion_bounds();
    const auto lock = lock_with_gil(mutex_);
    const VectorXd dir = q1 - q0;
    const double len = dir.norm();
    const long c0 = clearance_checks_;
    bool free;
    if (len == 0.0) {
      free = !collides_spheres(q0, kSpheresOnly);
    } else {
      free = certify_edge(q0.data(), dir.data(), 0.0, 1.0, min_step / len, max_step / len,
                          [] { return false; });
    }
    return bp::make_tuple(free, clearance_checks_ - c0);
  }

  // Self pairs whose spheres touch at every configuration of qs (rows) while their geometries
  // (the exact checker's test) are apart at one of them at least: "spheres_only" then tests
  // them as "spheres" does (coal's narrow phase where the spheres touch) instead of counting
  // every touch a collision. Neighbouring links whose spheres' margin closes the gap between
  // them (the Unitree Z1's) would otherwise make every configuration collide for
  // "spheres_only". The answers stay conservative for the other pairs and are exact for these.
  // Returns the pairs marked (collision pair indices); each call replaces the marks.
  bp::list mark_exact_pairs(const Eigen::Ref<const RowMatrixXd>& qs) {
    if (!has_spheres_) raise_invalid("mark_exact_pairs needs set_spheres first");
    if (qs.cols() != model_.nq || qs.rows() == 0 || !qs.allFinite())
      raise_invalid("qs must be finite rows of size nq = " + std::to_string(model_.nq));
    const auto lock = lock_with_gil(mutex_);
    const std::vector<char> before = exact_pair_;
    std::fill(exact_pair_.begin(), exact_pair_.end(), 0);
    // per group pair: 1 spheres touch at every row so far, 2 and the geometries apart at one
    std::vector<char> state(group_pairs_.size(), 1);
    for (Eigen::Index r = 0; r < qs.rows(); ++r) {
      kinematics(qs.row(r).transpose());
      next_stamp();
      for (std::size_t i : moving_) place_bound(i);
      for (const Group& g : groups_) {
        if (geom_.geometryObjects[g.object].parentJoint == 0) continue;
        for (std::size_t j = g.begin; j < g.end; ++j) {
          const GroupPair& gp = group_pairs_[j];
          if (gp.partner_static || !state[j]) {
            state[j] = 0;
            continue;
          }
          if (!sphere_pair_hits(g.object, gp.partner, gp.pair, false, kSpheresOnly))
            state[j] = 0;
          else if (!sphere_pair_hits(g.object, gp.partner, gp.pair, false, kSpheres))
            state[j] = 2;
        }
      }
    }
    bp::list out;
    for (std::size_t j = 0; j < group_pairs_.size(); ++j)
      if (state[j] == 2) {
        exact_pair_[group_pairs_[j].pair] = 1;
        out.append(group_pairs_[j].pair);
      }
    // the filter's items carry the marks: set up again when they changed (set_spheres set it
    // up with the marks it left, none; a scene's set-up marks none on most robots)
    if (exact_pair_ != before) setup_filter();
    return out;
  }

  // For the tests: the certified radius of q along direction (t units, at most cap).
  double clearance_py(const VectorXd& q, const VectorXd& direction, double cap) {
    if (q.size() != model_.nq || direction.size() != model_.nq)
      raise_invalid("q and direction must have size nq = " + std::to_string(model_.nq));
    if (!(cap > 0.0) || !std::isfinite(cap)) raise_invalid("cap must be finite and > 0");
    require_motion_bounds();
    const auto lock = lock_with_gil(mutex_);
    set_direction(direction.data());
    kinematics(q);
    return spheres_clearance(cap);
  }

  // For the tests: (joint of each link, motion bounds mb_ as a links x nq matrix).
  bp::tuple motion_bounds_py() {
    require_motion_bounds();
    const int nq = model_.nq;
    Eigen::VectorXi joints(links_.size());
    MatrixXd mb(links_.size(), nq);
    for (std::size_t l = 0; l < links_.size(); ++l) {
      joints[l] = links_[l].joint;
      for (int k = 0; k < nq; ++k) mb(l, k) = mb_[l * nq + k];
    }
    return bp::make_tuple(joints, mb);
  }

  void require_motion_bounds() const {
    if (!has_spheres_) raise_invalid("edge certificates need set_spheres first");
    if (!motion_bounds_ok_)
      raise_invalid("edge certificates need a model of revolute or prismatic joints about x, y "
                    "or z with finite prismatic limits");
  }

  long clearance_checks() const { return clearance_checks_; }

  // Index of the first colliding configuration q0 + (k / n) (q1 - q0), k = 1..n-1, in
  // bisection order (coarse to fine), or -1: one edge checked in one call, stopping at the
  // first collision.
  long first_invalid_on_edge(const VectorXd& q0, const VectorXd& q1, int n, int checker) {
    if (q0.size() != model_.nq || q1.size() != model_.nq)
      raise_invalid("q0 and q1 must have size nq = " + std::to_string(model_.nq));
    if (n < 1) raise_invalid("n must be >= 1");
    check_checker(checker);
    const auto lock = lock_with_gil(mutex_);
    const std::vector<int> order = bisection_order(n);
    std::vector<double> t(order.size());
    for (std::size_t j = 0; j < order.size(); ++j) t[j] = double(order[j]) / n;
    const VectorXd dir = q1 - q0;
    const int j = first_collision(q0.data(), dir.data(), t.data(), static_cast<int>(t.size()),
                                  checker, [] { return false; });
    return j < 0 ? -1 : order[j];
  }

  void check_checker(int checker) {
    if (checker < kMesh || checker > kSpheresOnly)
      raise_invalid("checker must be 0 (mesh), 1 (spheres) or 2 (spheres only), got " +
                    std::to_string(checker));
    if (checker != kMesh && !has_spheres_)
      raise_invalid("the sphere checker needs set_spheres first");
  }

  // Collision flags of every row with the given checker.
  Eigen::VectorXi collisions_with(const Eigen::Ref<const RowMatrixXd>& qs, int checker) {
    check_cols(qs);
    check_checker(checker);
    const auto lock = lock_with_gil(mutex_);
    Eigen::VectorXi out(qs.rows());
    if (batched(checker)) {
      flags_batched(qs, checker, out);
      return out;
    }
    for (Eigen::Index i = 0; i < qs.rows(); ++i)
      out[i] = collides(qs.row(i).transpose(), checker) ? 1 : 0;
    return out;
  }

 private:
  static double point_box_distance(const coal::Vec3s& c, const coal::AABB& box) {
    const coal::Vec3s d = (box.min_ - c).cwiseMax(c - box.max_).cwiseMax(0.0);
    return d.norm();
  }

  // Distance from world point c to static object i's shape (0 inside); -1 when the shape is
  // not a primitive.
  double point_static_distance(std::size_t i, const coal::Vec3s& c) const {
    const Primitive& P = prim_[i];
    if (P.type == kGeneric) return -1.0;
    const coal::Vec3s l = P.R.transpose() * (c - P.t);
    switch (P.type) {
      case kBox:
        return (l.cwiseAbs() - P.half).cwiseMax(0.0).norm();
      case kBall:
        return std::max(0.0, l.norm() - P.radius);
      case kCylinder: {
        const double dr = std::max(0.0, std::sqrt(l[0] * l[0] + l[1] * l[1]) - P.radius);
        const double dz = std::max(0.0, std::abs(l[2]) - P.half_length);
        return std::sqrt(dr * dr + dz * dz);
      }
      default: {  // capsule
        const double z = std::clamp(l[2], -P.half_length, P.half_length);
        return std::max(0.0, (l - coal::Vec3s(0.0, 0.0, z)).norm() - P.radius);
      }
    }
  }

  // World centers of object i's spheres (once per configuration).
  void leaves(std::size_t i) {
    if (stamp_of_[i] == stamp_) return;
    stamp_of_[i] = stamp_;
    const auto& M = data_.oMi[geom_.geometryObjects[i].parentJoint];
    for (int s = sph_begin_[i]; s < sph_begin_[i + 1]; ++s) {
      sph_world_[s].noalias() = M.rotation() * sph_local_[s];
      sph_world_[s] += M.translation();
    }
  }

  // Pair p of moving object a and partner b (static or not): may they touch?
  bool sphere_pair_hits(std::size_t a, std::size_t b, pinocchio::PairIndex p, bool b_static,
                        int checker) {
    const double margin = std::max(0.0, gdata_.collisionRequests[p].security_margin);
    const coal::Vec3s& ca = bound_world_[a];
    const double ra = bound_r_[a] + margin;
    bool hit = false;
    if (b_static) {
      if (point_box_distance(ca, boxes_[b]) > ra) return false;
      const Primitive& P = prim_[b];
      if (P.type != kGeneric) {
        if (point_static_distance(b, ca) > ra + P.swept) return false;
        ++stat_[3];
        leaves(a);
        for (int s = sph_begin_[a]; s < sph_begin_[a + 1] && !hit; ++s)
          hit = point_static_distance(b, sph_world_[s]) <= sph_r_[s] + margin + P.swept;
      } else {
        leaves(a);
        coal::CollisionRequest req;  // contact on (EPA), threshold as the exact checker's
        req.security_margin = margin;
        req.collision_distance_threshold = std::max(req.collision_distance_threshold, req.gjk_tolerance);
        const coal::CollisionGeometry* geo = geom_.geometryObjects[b].geometry.get();
        for (int s = sph_begin_[a]; s < sph_begin_[a + 1] && !hit; ++s) {
          if (point_box_distance(sph_world_[s], boxes_[b]) > sph_r_[s] + margin) continue;
          const coal::Sphere ball(sph_r_[s]);
          coal::CollisionResult res;
          coal::Transform3s tf;
          tf.setTranslation(sph_world_[s]);
          hit = coal::collide(&ball, tf, geo, P.tf, req, res) > 0;
        }
      }
    } else {
      const double reach = ra + bound_r_[b];
      if ((ca - bound_world_[b]).squaredNorm() > reach * reach) return false;
      ++stat_[0];
      leaves(a);
      leaves(b);
      for (int s = sph_begin_[a]; s < sph_begin_[a + 1] && !hit; ++s)
        for (int t = sph_begin_[b]; t < sph_begin_[b + 1] && !hit; ++t)
          hit = (sph_world_[s] - sph_world_[t]).squaredNorm() <=
                (sph_r_[s] + sph_r_[t] + margin) * (sph_r_[s] + sph_r_[t] + margin);
    }
    if (!hit) return false;
    ++stat_[b_static ? 4 : 1];
    if (checker == kSpheresOnly && !(p < exact_pair_.size() && exact_pair_[p])) return true;
    ++stat_[b_static ? 5 : 2];
    place(a);
    if (!b_static) place(b);
    if (separated(a, b)) return false;  // the oriented boxes, as the exact checker does
    return pinocchio::computeCollision(geom_, gdata_, p);
  }

  // static_clearance / self_clearance: the certified radius s lowered by pair (a, b) (see
  // spheres_clearance), 0 when the pair's spheres touch; rho: the pair's rate per unit of t.
  double static_clearance(std::size_t a, std::size_t b, double margin, double rho, double s) {
    const double ra = bound_r_[a] + margin;
    if (point_box_distance(bound_world_[a], boxes_[b]) - ra > s * rho) return s;
    const Primitive& P = prim_[b];
    if (P.type != kGeneric) {
      if (point_static_distance(b, bound_world_[a]) - ra - P.swept > s * rho) return s;
      leaves(a);
      for (int k = sph_begin_[a]; k < sph_begin_[a + 1]; ++k) {
        const double c = point_static_distance(b, sph_world_[k]) - sph_r_[k] - margin - P.swept;
        if (c <= 0.0) return 0.0;
        if (c < s * rho) s = c / rho;
      }
      return s;
    }
    leaves(a);
    const coal::CollisionGeometry* geo = geom_.geometryObjects[b].geometry.get();
    for (int k = sph_begin_[a]; k < sph_begin_[a + 1]; ++k) {
      if (point_box_distance(sph_world_[k], boxes_[b]) - sph_r_[k] - margin > s * rho) continue;
      const coal::Sphere ball(sph_r_[k]);
      coal::Transform3s tf;
      tf.setTranslation(sph_world_[k]);
      coal::DistanceRequest req;
      coal::DistanceResult res;
      coal::distance(&ball, tf, geo, P.tf, req, res);
      // coal's distance to within GJK's tolerance: take that off (conservative)
      const double c = res.min_distance - req.gjk_tolerance - margin;
      if (c <= 0.0) return 0.0;
      if (c < s * rho) s = c / rho;
    }
    return s;
  }

  double self_clearance(std::size_t a, std::size_t b, double margin, double rho, double s) {
    const double reach = bound_r_[a] + bound_r_[b] + margin + s * rho;
    if ((bound_world_[a] - bound_world_[b]).squaredNorm() > reach * reach) return s;
    leaves(a);
    leaves(b);
    for (int i = sph_begin_[a]; i < sph_begin_[a + 1]; ++i) {
      // sphere i against b's bounding sphere first
      const double near = sph_r_[i] + bound_r_[b] + margin + s * rho;
      if ((sph_world_[i] - bound_world_[b]).squaredNorm() > near * near) continue;
      for (int j = sph_begin_[b]; j < sph_begin_[b + 1]; ++j) {
        const double r = sph_r_[i] + sph_r_[j] + margin;
        const double d2 = (sph_world_[i] - sph_world_[j]).squaredNorm();
        const double far = r + s * rho;
        if (d2 > far * far) continue;
        const double c = std::sqrt(d2) - r;
        if (c <= 0.0) return 0.0;
        if (c < s * rho) s = c / rho;
      }
    }
    return s;
  }

  // Geometry placement of moving object i from the joint placements, and the centre of its
  // oriented box (for the exact test).
  void place(std::size_t i) {
    const auto& obj = geom_.geometryObjects[i];
    gdata_.oMg[i] = data_.oMi[obj.parentJoint] * obj.placement;
    centers_[i].noalias() = gdata_.oMg[i].rotation() * local_center_[i];
    centers_[i] += gdata_.oMg[i].translation();
  }

  struct Primitive {
    int type = kGeneric;
    coal::Matrix3s R = coal::Matrix3s::Identity();
    coal::Vec3s t = coal::Vec3s::Zero(), half = coal::Vec3s::Zero();
    double radius = 0.0, half_length = 0.0, swept = 0.0;
    coal::Transform3s tf;
  };
  static constexpr int kGeneric = 0, kBox = 1, kBall = 2, kCylinder = 3, kCapsule = 4;
  struct Link {
    int joint;
    std::vector<std::size_t> objects;
    coal::Vec3s center;  // bounding sphere of the link's spheres, joint frame
    double radius;
    coal::Vec3s world;
    std::uint64_t mask;  // static partners (bits) whose box the bounding sphere touches
  };
  std::vector<Link> links_;
  std::vector<int> link_of_, static_bit_;
  std::vector<double> static_box_[6];  // min x, y, z, max x, y, z of the static partners
  struct FkJoint {
    int parent = 0, idx_q = 0, kind = 0, axis = 2;  // kind 0 revolute, 1 prismatic
    int turn[2] = {0, 1};                           // (axis + 1) % 3, (axis + 2) % 3
    coal::Matrix3s R0;
    coal::Vec3s t0;
    double R0c[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1};  // R0 column by column: R0(k, c) at 3 c + k
    double t0c[3] = {0, 0, 0};
  };

  std::vector<FkJoint> fk_;
  std::vector<double> fk_cos_, fk_sin_;
  std::vector<BatchPose> batch_pose_;     // kinematics_batch: joint placements, lanes
  const double* batch_q_[kBatch] = {};      // defer_kinematics: the batch's configurations
  bool batch_pending_ = false;            // batch_pose_ not yet computed for batch_q_
  std::vector<double> edge_buf_;          // first_collision: the batch's configurations
  VectorXd edge_x_;                       // first_collision: one configuration
  bool fast_fk_ = false;
  SphereFilters filter_;  // single-precision filter (setup_filter)
  int filter_mode_ = initial_filter_mode();
  int simd_ = initial_simd_level();
  static int initial_filter_mode() {
    const char* v = std::getenv("TASKSPACE_SPHERE_FILTER");
    if (v && (v[0] == '0' || v[0] == '1' || v[0] == '2') && v[1] == 0) return v[0] - '0';
    return 2;
  }
  struct SphereGroup {  // a group's pairs for the sphere checker
    std::uint64_t bits = 0;            // bits of its static partners
    std::vector<std::size_t> by_bit;   // group pair (index into group_pairs_) of each bit
    std::vector<std::size_t> others;   // its other pairs
  };
  std::vector<SphereGroup> sphere_groups_;
  std::vector<int> pair_bit_;        // per group pair: the static partner's bit (or -1)
  std::vector<std::size_t> pair_object_;  // per group pair: its moving object (setup_filter)
  std::vector<double> pair_margin_;  // per group pair: its security margin (>= 0)
  bool has_spheres_ = false;
  std::vector<char> exact_pair_;  // per collision pair: "spheres_only" tests it as "spheres"
  double certified_margin_ = 0.0;
  // edge clearance certificates (setup_motion_bounds): per link x coordinate the motion bound
  // and the ancestor flag; per link pair x coordinate the rate of their spheres' distance;
  // the rates of the current direction; the gaps of certify_edge
  bool motion_bounds_ok_ = false;
  std::vector<double> mb_, pair_rate_, rho_link_, rho_pair_, abs_b_;
  std::vector<char> anc_;
  std::vector<std::pair<double, double>> gaps_;
  long clearance_checks_ = 0;
  long stat_[6] = {0, 0, 0, 0, 0, 0};
  double max_margin_ = 0.0;
  std::vector<int> sph_begin_;
  std::vector<coal::Vec3s> sph_local_, sph_world_, bound_local_, bound_world_;
  std::vector<double> sph_r_, bound_r_;
  std::vector<unsigned> stamp_of_;
  unsigned stamp_ = 0;
  std::vector<Primitive> prim_;

 public:
  // Broad phase over the list of active collision pairs, from the joint placements (collides:
  // kinematics). Per moving object the bounding sphere of its inflated oriented box (centre
  // from the joint placement: no geometry placement) is tested first, against the union box
  // of its group's static partners, each static partner's box, or a moving partner's sphere;
  // only an object whose sphere touches something is placed (place_box: Pinocchio's
  // geometry placement, coal's AABB of CollisionObject::computeAABB, inflated as Pinocchio's
  // managers do), then the tests of before: world boxes overlap, oriented boxes not
  // separated, Pinocchio's computeCollision (coal's narrow phase). Each test is conservative
  // (a pair is skipped only when bounding volumes of the inflated objects are disjoint), so
  // the answer is the narrow phase's on the pairs that may touch, as with every object placed.
  // The static objects' placements and boxes are computed once (constructor).
  bool collides_pairs() {
    if (++mesh_stamp_ == 0) {  // wrapped: invalidate every stamp
      std::fill(placed_.begin(), placed_.end(), 0u);
      mesh_stamp_ = 1;
    }
    for (std::size_t i : moving_) {
      const auto& M = data_.oMi[geom_.geometryObjects[i].parentJoint];
      box_world_center_[i].noalias() = M.rotation() * box_joint_center_[i];
      box_world_center_[i] += M.translation();
    }
    for (std::size_t k = 0; k < cache_.size(); ++k) {
      const pinocchio::PairIndex p = cache_[k];
      const auto& pair = geom_.collisionPairs[p];
      if (mesh_pair_hits(pair.first, pair.second, p)) {
        std::rotate(cache_.begin(), cache_.begin() + k, cache_.begin() + k + 1);
        return true;
      }
    }
    // the links' spheres against the static partners' boxes (bits)
    const std::size_t ns = mesh_static_box_[0].size();
    for (MeshLink& l : mesh_links_) {
      const auto& M = data_.oMi[l.joint];
      const coal::Vec3s c = M.rotation() * l.center + M.translation();
      l.mask = box_mask(mesh_static_box_, c, l.radius * l.radius, ns);
    }
    for (std::size_t gi = 0; gi < groups_.size(); ++gi) {
      const Group& g = groups_[gi];
      const std::size_t i = g.object;
      if (geom_.geometryObjects[i].parentJoint == 0) {  // two static objects: boxes as built
        for (std::size_t j = g.begin; j < g.end; ++j) {
          const GroupPair& gp = group_pairs_[j];
          if (!boxes_[i].overlap(boxes_[gp.partner])) continue;
          if (separated(i, gp.partner)) continue;
          if (pinocchio::computeCollision(geom_, gdata_, gp.pair)) {
            remember(gp.pair);
            return true;
          }
        }
        continue;
      }
      const MeshGroup& mg = mesh_groups_[gi];
      const coal::Vec3s& c = box_world_center_[i];
      const double r = box_radius_[i];
      // static partners whose box the link's sphere touches (set bits only)
      std::uint64_t m = mesh_links_[mesh_link_of_[i]].mask & mg.bits;
      while (m != 0) {
        const int bit = __builtin_ctzll(m);
        m &= m - 1;
        const GroupPair& gp = group_pairs_[mg.by_bit[bit]];
        if (!sphere_touches_box(c, r, boxes_[gp.partner])) continue;
        place_box(i);
        if (!boxes_[i].overlap(boxes_[gp.partner]) || separated(i, gp.partner)) continue;
        if (pinocchio::computeCollision(geom_, gdata_, gp.pair)) {
          remember(gp.pair);
          return true;
        }
      }
      for (std::size_t j : mg.others) {  // moving partners, static partners beyond 64 bits
        const GroupPair& gp = group_pairs_[j];
        const std::size_t b = gp.partner;
        if (gp.partner_static) {
          if (!sphere_touches_box(c, r, boxes_[b])) continue;
        } else {
          const double reach = r + box_radius_[b];
          if ((c - box_world_center_[b]).squaredNorm() > reach * reach) continue;
          place_box(b);
        }
        place_box(i);
        if (!boxes_[i].overlap(boxes_[b]) || separated(i, b)) continue;
        if (pinocchio::computeCollision(geom_, gdata_, gp.pair)) {
          remember(gp.pair);
          return true;
        }
      }
    }
    return false;
  }

 private:
  // Pair p of objects a and b (collides_pairs' cached pairs): the tests of collides_pairs.
  bool mesh_pair_hits(std::size_t a, std::size_t b, pinocchio::PairIndex p) {
    const bool a_moves = geom_.geometryObjects[a].parentJoint != 0;
    const bool b_moves = geom_.geometryObjects[b].parentJoint != 0;
    if (a_moves && b_moves) {
      const double reach = box_radius_[a] + box_radius_[b];
      if ((box_world_center_[a] - box_world_center_[b]).squaredNorm() > reach * reach)
        return false;
    } else if (a_moves && !sphere_touches_box(box_world_center_[a], box_radius_[a], boxes_[b])) {
      return false;
    } else if (b_moves && !sphere_touches_box(box_world_center_[b], box_radius_[b], boxes_[a])) {
      return false;
    }
    if (a_moves) place_box(a);
    if (b_moves) place_box(b);
    return boxes_[a].overlap(boxes_[b]) && !separated(a, b) &&
           pinocchio::computeCollision(geom_, gdata_, p);
  }

  // Moving object i placed for this check (once): its geometry placement as Pinocchio's
  // updateGeometryPlacements computes it, coal's AABB (inflated) and its oriented box's centre.
  void place_box(std::size_t i) {
    if (placed_[i] == mesh_stamp_) return;
    placed_[i] = mesh_stamp_;
    const auto& obj = geom_.geometryObjects[i];
    gdata_.oMg[i] = data_.oMi[obj.parentJoint] * obj.placement;
    coal::CollisionObject& co = *objects_[i];
    co.setTransform(pinocchio::toCoalTransform3s(gdata_.oMg[i]));
    co.computeAABB();
    boxes_[i] = co.getAABB();
    boxes_[i].expand(inflation_[i]);
    centers_[i].noalias() = gdata_.oMg[i].rotation() * local_center_[i];
    centers_[i] += gdata_.oMg[i].translation();
  }

  // The sphere (c, r) may touch the box: false only when the distance from c to the box is
  // above r (NaN or an infinite radius: true).
  __attribute__((always_inline)) static bool sphere_touches_box(const coal::Vec3s& c, double r,
                                                                 const coal::AABB& box) {
    const coal::Vec3s d = (box.min_ - c).cwiseMax(c - box.max_).cwiseMax(0.0);
    return !(d.squaredNorm() > r * r);
  }

  // Link level of collides_pairs: per moving joint a bounding sphere of its objects' spheres
  // and the static partners (at most 64, one bit each) whose boxes it touches; per group
  // its static partners by bit and its other pairs.
  void setup_mesh_links() {
    const std::size_t ng = geom_.geometryObjects.size();
    mesh_link_of_.assign(ng, -1);
    mesh_links_.clear();
    for (std::size_t i : moving_) {
      const int j = static_cast<int>(geom_.geometryObjects[i].parentJoint);
      auto it = std::find_if(mesh_links_.begin(), mesh_links_.end(),
                             [j](const MeshLink& l) { return l.joint == j; });
      if (it == mesh_links_.end()) {
        mesh_links_.push_back(MeshLink{j, {}, coal::Vec3s::Zero(), 0.0, 0});
        it = mesh_links_.end() - 1;
      }
      it->objects.push_back(i);
      mesh_link_of_[i] = static_cast<int>(it - mesh_links_.begin());
    }
    for (MeshLink& l : mesh_links_) {
      coal::Vec3s lo = coal::Vec3s::Constant(std::numeric_limits<double>::infinity());
      coal::Vec3s hi = -lo;
      for (std::size_t i : l.objects) {
        lo = lo.cwiseMin(box_joint_center_[i] - coal::Vec3s::Constant(box_radius_[i]));
        hi = hi.cwiseMax(box_joint_center_[i] + coal::Vec3s::Constant(box_radius_[i]));
      }
      l.center = 0.5 * (lo + hi);
      l.radius = 0.0;
      for (std::size_t i : l.objects)
        l.radius = std::max(l.radius, (box_joint_center_[i] - l.center).norm() + box_radius_[i]);
      l.radius = l.radius * (1.0 + 1e-12) + 1e-9;
      if (!l.center.allFinite() || !std::isfinite(l.radius)) {  // an object without a box
        l.center.setZero();
        l.radius = std::numeric_limits<double>::infinity();
      }
    }
    std::vector<int> bit_of(ng, -1);
    for (int a = 0; a < 6; ++a) mesh_static_box_[a].clear();
    for (const GroupPair& gp : group_pairs_) {
      if (!gp.partner_static || bit_of[gp.partner] >= 0) continue;
      const int bit = static_cast<int>(mesh_static_box_[0].size());
      if (bit >= 64) break;  // more: the partners without a bit are always tested
      bit_of[gp.partner] = bit;
      for (int a = 0; a < 3; ++a) {
        mesh_static_box_[a].push_back(boxes_[gp.partner].min_[a]);
        mesh_static_box_[3 + a].push_back(boxes_[gp.partner].max_[a]);
      }
    }
    // whole blocks of kBoxLanes (at most 64 bits): padding boxes at +inf never touch
    while (mesh_static_box_[0].size() % kMeshLanes != 0)
      for (int a = 0; a < 6; ++a)
        mesh_static_box_[a].push_back(std::numeric_limits<double>::infinity());
    mesh_groups_.assign(groups_.size(), MeshGroup{});
    for (std::size_t gi = 0; gi < groups_.size(); ++gi) {
      MeshGroup& mg = mesh_groups_[gi];
      mg.by_bit.assign(64, 0);
      for (std::size_t j = groups_[gi].begin; j < groups_[gi].end; ++j) {
        const GroupPair& gp = group_pairs_[j];
        const int bit = gp.partner_static ? bit_of[gp.partner] : -1;
        if (bit >= 0 && !((mg.bits >> bit) & 1u)) {
          mg.bits |= std::uint64_t{1} << bit;
          mg.by_bit[bit] = j;
        } else {
          mg.others.push_back(j);
        }
      }
    }
  }

  // Bit o set when the sphere (c, sqrt(r2)) may touch box o of boxes (ns boxes, a multiple of
  // kMeshLanes; NaN: set), kMeshLanes boxes at a time in vector operations.
  static constexpr int kMeshLanes = 2;
  typedef double MeshLanes __attribute__((vector_size(kMeshLanes * sizeof(double))));
  static std::uint64_t box_mask(const std::vector<double> (&boxes)[6], const coal::Vec3s& c,
                                double r2, std::size_t ns) {
    std::uint64_t mask = 0;
    const MeshLanes zero = {};
    for (std::size_t o = 0; o < ns; o += kMeshLanes) {
      MeshLanes d2 = zero;
      for (int a = 0; a < 3; ++a) {
        MeshLanes lo, hi;
        std::memcpy(&lo, boxes[a].data() + o, sizeof(lo));
        std::memcpy(&hi, boxes[3 + a].data() + o, sizeof(hi));
        const MeshLanes below = lo - c[a], above = c[a] - hi;
        MeshLanes d = below > above ? below : above;
        d = d > zero ? d : zero;
        d2 += d * d;
      }
      for (int k = 0; k < kMeshLanes; ++k)
        mask |= static_cast<std::uint64_t>(!(d2[k] > r2)) << (o + k);
    }
    return mask;
  }

  struct MeshLink {
    int joint;
    std::vector<std::size_t> objects;
    coal::Vec3s center;  // bounding sphere of the objects' box spheres, joint frame
    double radius;
    std::uint64_t mask;  // static partners (bits) whose box the sphere may touch
  };
  struct MeshGroup {
    std::uint64_t bits = 0;           // bits of its static partners
    std::vector<std::size_t> by_bit;  // group pair (index into group_pairs_) of each bit
    std::vector<std::size_t> others;  // its other pairs
  };
  std::vector<MeshLink> mesh_links_;
  std::vector<int> mesh_link_of_;
  std::vector<MeshGroup> mesh_groups_;
  std::vector<double> mesh_static_box_[6];  // min x, y, z, max x, y, z of the static partners
  std::vector<coal::Vec3s> box_joint_center_, box_world_center_;  // oriented box's centre
  std::vector<double> box_radius_;  // bounding sphere of the inflated oriented box (inf: none)
  std::vector<unsigned> placed_;    // place_box's stamp per object
  unsigned mesh_stamp_ = 0;

 public:
  // True if the oriented boxes of objects a and b (their local AABBs, inflated, at their
  // placements) are disjoint (coal::obbDisjoint, separating-axis test): the objects, which
  // lie inside, cannot touch. False when either box is not finite.
  bool separated(std::size_t a, std::size_t b) const {
    if (!obb_ok_[a] || !obb_ok_[b]) return false;
    const auto& Ra = gdata_.oMg[a].rotation();
    const auto& Rb = gdata_.oMg[b].rotation();
    // as coal's OBB::overlap: box a in the frame of box b, b's half sizes first
    const coal::Matrix3s B = Rb.transpose() * Ra;
    const coal::Vec3s T = Rb.transpose() * (centers_[a] - centers_[b]);
    return coal::obbDisjoint(B, T, half_[b], half_[a]);
  }

  void remember(pinocchio::PairIndex p) {
    if (cache_size_ <= 0) return;
    if (std::find(cache_.begin(), cache_.end(), p) != cache_.end()) return;
    cache_.insert(cache_.begin(), p);
    if (static_cast<int>(cache_.size()) > cache_size_) cache_.pop_back();
  }

  // Collision flags (1 = in collision) of every row, shape (n, nq).
  Eigen::VectorXi collisions(const Eigen::Ref<const RowMatrixXd>& qs) {
    check_cols(qs);
    const auto lock = lock_with_gil(mutex_);
    Eigen::VectorXi out(qs.rows());
    for (Eigen::Index i = 0; i < qs.rows(); ++i) out[i] = collides(qs.row(i).transpose()) ? 1 : 0;
    return out;
  }

  // Index of the first colliding row, or -1 (rows evaluated in order).
  long first_invalid(const Eigen::Ref<const RowMatrixXd>& qs) {
    check_cols(qs);
    const auto lock = lock_with_gil(mutex_);
    for (Eigen::Index i = 0; i < qs.rows(); ++i)
      if (collides(qs.row(i).transpose())) return static_cast<long>(i);
    return -1;
  }

 private:
  void check_cols(const Eigen::Ref<const RowMatrixXd>& qs) const {
    if (qs.cols() != model_.nq)
      raise_invalid("configurations must have nq = " + std::to_string(model_.nq) +
                    " columns, got " + std::to_string(qs.cols()));
  }

 public:
  // Serializes the queries and plans on this kernel (its Pinocchio and coal data are shared by
  // them): one thread at a time, the others wait (see lock_with_gil).
  std::timed_mutex& mutex() { return mutex_; }

 private:
  // The parts of Pinocchio's GeometryData(geom) the kernel uses: placements, active pairs,
  // collision requests, results and functors (computeCollision, the broad-phase managers and
  // their callback read nothing else), the same values as GeometryData(geom) gives them.
  // Without the distance and contact-patch requests, results and functors it also builds
  // (a GJK solver in each functor): a third of its work and memory per collision pair. A
  // scene's set-up built and freed them for every pair (MotionBenchMaker Panda: 156-380 pairs).
  static std::unique_ptr<GeometryData> lean_geometry_data(const GeometryModel& geom) {
    auto gd = std::make_unique<GeometryData>();
    const std::size_t np = geom.collisionPairs.size();
    gd->oMg.resize(geom.geometryObjects.size());
    gd->activeCollisionPairs.assign(np, true);
    coal::CollisionRequest request(coal::NO_REQUEST, 1);
    request.enable_cached_gjk_guess = true;  // (as GeometryData; the constructor turns it off)
    gd->collisionRequests.assign(np, request);
    gd->collisionResults.resize(np);
    gd->collisionPairIndex = 0;
    gd->collision_functors.reserve(np);
    for (const auto& pair : geom.collisionPairs)
      gd->collision_functors.emplace_back(geom.geometryObjects[pair.first],
                                          geom.geometryObjects[pair.second]);
    gd->fillInnerOuterObjectMaps(geom);
    return gd;
  }

  std::timed_mutex mutex_;

  bp::object py_[4];
  std::unique_ptr<GeometryData> own_gdata_;  // (declared before gdata_: it may refer to it)
  const Model& model_;
  Data& data_;
  const GeometryModel& geom_;
  GeometryData& gdata_;
  std::unique_ptr<Manager> manager_;
  std::vector<pinocchio::PairIndex> cache_;
  int cache_size_ = 0;
  int mode_ = kPairs;
  long checks_ = 0;
  std::vector<pinocchio::PairIndex> pairs_;
  std::vector<std::size_t> moving_;
  std::vector<double> inflation_;
  std::vector<std::unique_ptr<coal::CollisionObject>> objects_;
  std::vector<coal::AABB> boxes_;
  std::vector<coal::Vec3s> local_center_, half_, centers_;  // oriented boxes (separated)
  std::vector<char> obb_ok_;
  struct GroupPair {
    std::size_t partner;
    pinocchio::PairIndex pair;
    bool partner_static;  // the partner does not move (universe joint)
  };
  struct Group {
    std::size_t object, begin, end;
    coal::AABB partners_box;  // union of the static partners' boxes
  };
  std::vector<GroupPair> group_pairs_;
  std::vector<Group> groups_;
};

// ---------------------------------------------------------------------------- check orders
// Interior indices 1..n-1 of n segments in bisection (breadth-first midpoint) order, as
// taskspace.planning.configuration_space.bisection_order.
std::vector<int> bisection_order(int n) {
  std::vector<int> out;
  std::vector<std::pair<int, int>> queue{{0, n}};
  if (n > 1) {  // (n - 1 points, at most 2 (n - 1) + 1 intervals: no reallocation)
    out.reserve(static_cast<std::size_t>(n) - 1);
    queue.reserve(2 * static_cast<std::size_t>(n));
  }
  for (std::size_t h = 0; h < queue.size(); ++h) {
    const int a = queue[h].first, b = queue[h].second;
    if (b - a < 2) continue;
    const int mid = (a + b) / 2;
    out.push_back(mid);
    queue.push_back({a, mid});
    queue.push_back({mid, b});
  }
  return out;
}

// Orders of at most kOrderCache segments are kept per thread across plans (a plan asked for
// the same dozen or so again, each built with its vectors at every plan), for at most
// kOrderStrides coarse strides; longer lines are built per plan. At most about 4 MB per
// stride and 2 MB of bisection orders per thread (every n up to the cap; a plan uses a few).
constexpr int kOrderCache = 1024;
constexpr std::size_t kOrderStrides = 4;

// Entry n of a table of kept values, made by make() on first use (unique_ptr: an entry stays
// where it is when the table grows).
template <class T, class Make>
const T& kept_entry(std::vector<std::unique_ptr<const T>>& table, int n, Make&& make) {
  if (n >= static_cast<int>(table.size())) table.resize(static_cast<std::size_t>(n) + 1);
  std::unique_ptr<const T>& entry = table[static_cast<std::size_t>(n)];
  if (!entry) entry = make();
  return *entry;
}

// bisection_order(n), the thread's kept copy for n <= kOrderCache, else built into scratch.
const std::vector<int>& bisection_order_kept(int n, std::vector<int>& scratch) {
  if (n > kOrderCache) {
    scratch = bisection_order(n);
    return scratch;
  }
  thread_local std::vector<std::unique_ptr<const std::vector<int>>> kept;
  return kept_entry(kept, n,
                    [n] { return std::make_unique<const std::vector<int>>(bisection_order(n)); });
}

// Coarse and fine passes of n segments (nested_orders of the Python module).
struct Orders {
  std::vector<double> pattern;  // EXTEND fractions: 1 (end point), then coarse k / n
  std::vector<double> fine;     // fine fractions k / n (k not a multiple of the stride), increasing
};

class LinePlanner {
 public:
  LinePlanner(double alpha, double delta, double delta_c) : alpha(alpha), delta(delta) {
    stride = std::max(1, static_cast<int>(std::floor(delta_c / delta + 1e-9)));
    lazy = stride > 1;
    full_n = segments(alpha);
  }

  int segments(double length) const {
    return std::max(1, static_cast<int>(std::ceil(length / delta - 1e-12)));
  }

  // The orders of n segments: for n <= kOrderCache the thread's kept ones for this stride
  // (built once per thread and stride, for at most kOrderStrides strides), else this
  // planner's. Nothing kept is ever moved or freed before the thread ends, so the reference
  // stays valid (also if a Python signal handler polled during the plan plans in this thread).
  const Orders& orders(int n) {
    thread_local std::map<int, std::vector<std::unique_ptr<const Orders>>> kept;
    std::vector<std::unique_ptr<const Orders>>* table = nullptr;
    if (n <= kOrderCache) {
      const auto it = kept.find(stride);
      if (it != kept.end()) table = &it->second;
      else if (kept.size() < kOrderStrides) table = &kept[stride];
    }
    if (table == nullptr) {  // a long line, or too many strides in this thread
      std::unique_ptr<const Orders>& o = own_[n];
      if (!o) o = build(n);
      return *o;
    }
    return kept_entry(*table, n, [this, n] { return build(n); });
  }

  double alpha, delta;
  int stride, full_n;
  bool lazy;

 private:
  std::unique_ptr<const Orders> build(int n) const {
    auto o = std::make_unique<Orders>();
    const int n_coarse = std::max(1, (n + stride - 1) / stride);
    o->pattern.reserve(static_cast<std::size_t>(n_coarse));
    o->pattern.push_back(1.0);
    for (int k : bisection_order(n_coarse)) o->pattern.push_back(double(k * stride) / n);
    if (stride > 1) {
      o->fine.reserve(static_cast<std::size_t>(n));
      for (int k = 1; k < n; ++k)
        if (k % stride != 0) o->fine.push_back(double(k) / n);
    }
    return o;
  }
  std::map<int, std::unique_ptr<const Orders>> own_;  // orders this thread does not keep
};

// ---------------------------------------------------------------------------- trees
struct Tree {
  // Nearest-neighbour layout: blocks of kLanes nodes with coordinate k of the block's nodes
  // contiguous (cols[(b * d + k) * kLanes + lane]), so that the squared distances of a block
  // are computed with vector operations; unused lanes and removed nodes hold +inf (never
  // nearer than a node). An exact linear scan, as before: the same nearest node (the lowest
  // index among equal distances), about twice as fast (cage: 1.8 -> 0.9 ns per node).
  static constexpr int kLanes = 8;
  int d;
  std::vector<double> q;  // node coordinates, row after row
  std::vector<double> cols;
  std::vector<int> parent, segments;
  std::vector<char> pending, alive;

  Tree(const VecRef& root) : d(static_cast<int>(root.size())) {
    // room for a typical plan's tree (tens of nodes) without reallocations
    constexpr std::size_t kNodes = 64;
    q.reserve(kNodes * static_cast<std::size_t>(d));
    cols.reserve(kNodes * static_cast<std::size_t>(d));
    parent.reserve(kNodes);
    segments.reserve(kNodes);
    pending.reserve(kNodes);
    alive.reserve(kNodes);
    add(root.data(), -1, 0, false);
  }

  int size() const { return static_cast<int>(parent.size()); }
  const double* node(int i) const { return q.data() + static_cast<std::size_t>(i) * d; }

  int add(const double* x, int par, int seg, bool pend) {
    const int i = size();
    q.insert(q.end(), x, x + d);
    if (i % kLanes == 0)
      cols.resize(cols.size() + static_cast<std::size_t>(d) * kLanes,
                  std::numeric_limits<double>::infinity());
    set_cols(i, x);
    parent.push_back(par);
    segments.push_back(seg);
    pending.push_back(pend);
    alive.push_back(1);
    return i;
  }

  // Coordinates of node i in the block layout (x = nullptr: +inf, the node is removed).
  void set_cols(int i, const double* x) {
    double* c = cols.data() + static_cast<std::size_t>(i / kLanes) * d * kLanes + i % kLanes;
    for (int k = 0; k < d; ++k)
      c[k * kLanes] = x ? x[k] : std::numeric_limits<double>::infinity();
  }

  // Nearest alive node to x: (index, distance), the lowest index among equal distances.
  // Per block the 8 squared distances sum (x_k - c_k)^2 over k = 0..d-1 in that order, lane
  // by lane (the same IEEE operations in the SSE2 and AVX2 versions: the same node and
  // distance); AVX2 is chosen at run time as for the batch kinematics (TASKSPACE_SIMD=sse2
  // forces SSE2). Intrinsics with the 8 lanes in 4 or 2 registers: one vector of 8 doubles
  // in GCC's vector extension went through memory at every coordinate.
  std::pair<int, double> nearest(const double* x) const {
#ifdef TASKSPACE_SIMD_X86
    if (initial_simd_level() >= 2) return nearest_avx2(x);
    return nearest_sse2(x);
#else
    return nearest_generic(x);
#endif
  }

 private:
  // The lanes of block b (squared distances acc) after the block minimum m: the nearest so far.
  void scan_block(int b, const double* acc, double m, int& best, double& best_d2) const {
    if (!(m < best_d2)) return;
    for (int l = 0; l < kLanes; ++l) {
      if (acc[l] < best_d2) {
        best_d2 = acc[l];
        best = b * kLanes + l;
      }
    }
  }
#ifdef TASKSPACE_SIMD_X86
  std::pair<int, double> nearest_sse2(const double* x) const {
    int best = -1;
    double best_d2 = std::numeric_limits<double>::infinity();
    const int nb = (size() + kLanes - 1) / kLanes;
    const double* c = cols.data();
    alignas(16) double acc[kLanes];
    for (int b = 0; b < nb; ++b, c += static_cast<std::size_t>(d) * kLanes) {
      __m128d a0 = _mm_setzero_pd(), a1 = a0, a2 = a0, a3 = a0;
      for (int k = 0; k < d; ++k) {
        const double* ck = c + k * kLanes;
        const __m128d xk = _mm_set1_pd(x[k]);
        const __m128d t0 = _mm_sub_pd(_mm_loadu_pd(ck), xk);
        const __m128d t1 = _mm_sub_pd(_mm_loadu_pd(ck + 2), xk);
        const __m128d t2 = _mm_sub_pd(_mm_loadu_pd(ck + 4), xk);
        const __m128d t3 = _mm_sub_pd(_mm_loadu_pd(ck + 6), xk);
        a0 = _mm_add_pd(a0, _mm_mul_pd(t0, t0));
        a1 = _mm_add_pd(a1, _mm_mul_pd(t1, t1));
        a2 = _mm_add_pd(a2, _mm_mul_pd(t2, t2));
        a3 = _mm_add_pd(a3, _mm_mul_pd(t3, t3));
      }
      __m128d m = _mm_min_pd(_mm_min_pd(a0, a1), _mm_min_pd(a2, a3));
      m = _mm_min_sd(m, _mm_unpackhi_pd(m, m));
      _mm_store_pd(acc, a0);
      _mm_store_pd(acc + 2, a1);
      _mm_store_pd(acc + 4, a2);
      _mm_store_pd(acc + 6, a3);
      scan_block(b, acc, _mm_cvtsd_f64(m), best, best_d2);
    }
    return {best, std::sqrt(best_d2)};
  }
  __attribute__((target("avx2"))) std::pair<int, double> nearest_avx2(const double* x) const {
    int best = -1;
    double best_d2 = std::numeric_limits<double>::infinity();
    const int nb = (size() + kLanes - 1) / kLanes;
    const double* c = cols.data();
    alignas(32) double acc[kLanes];
    for (int b = 0; b < nb; ++b, c += static_cast<std::size_t>(d) * kLanes) {
      __m256d a0 = _mm256_setzero_pd(), a1 = a0;
      for (int k = 0; k < d; ++k) {
        const double* ck = c + k * kLanes;
        const __m256d xk = _mm256_set1_pd(x[k]);
        const __m256d t0 = _mm256_sub_pd(_mm256_loadu_pd(ck), xk);
        const __m256d t1 = _mm256_sub_pd(_mm256_loadu_pd(ck + 4), xk);
        a0 = _mm256_add_pd(a0, _mm256_mul_pd(t0, t0));
        a1 = _mm256_add_pd(a1, _mm256_mul_pd(t1, t1));
      }
      const __m256d m4 = _mm256_min_pd(a0, a1);
      __m128d m = _mm_min_pd(_mm256_castpd256_pd128(m4), _mm256_extractf128_pd(m4, 1));
      m = _mm_min_sd(m, _mm_unpackhi_pd(m, m));
      _mm256_store_pd(acc, a0);
      _mm256_store_pd(acc + 4, a1);
      scan_block(b, acc, _mm_cvtsd_f64(m), best, best_d2);
    }
    return {best, std::sqrt(best_d2)};
  }
#else
  std::pair<int, double> nearest_generic(const double* x) const {
    int best = -1;
    double best_d2 = std::numeric_limits<double>::infinity();
    const int nb = (size() + kLanes - 1) / kLanes;
    const double* c = cols.data();
    double acc[kLanes];
    for (int b = 0; b < nb; ++b, c += static_cast<std::size_t>(d) * kLanes) {
      for (int l = 0; l < kLanes; ++l) acc[l] = 0.0;
      for (int k = 0; k < d; ++k)
        for (int l = 0; l < kLanes; ++l) {
          const double t = c[k * kLanes + l] - x[k];
          acc[l] += t * t;
        }
      double m = acc[0];
      for (int l = 1; l < kLanes; ++l) m = std::min(m, acc[l]);
      scan_block(b, acc, m, best, best_d2);
    }
    return {best, std::sqrt(best_d2)};
  }
#endif

 public:
  std::vector<int> path_indices(int i) const {  // i up to the root
    std::vector<int> out{i};
    while (parent[out.back()] >= 0) out.push_back(parent[out.back()]);
    return out;
  }

  // Remove node i and its descendants (children have larger indices); returns the count.
  int remove_subtree(int i) {
    std::vector<char> dead(size(), 0);
    dead[i] = 1;
    int count = 1;
    for (int j = i + 1; j < size(); ++j) {
      if (parent[j] >= 0 && dead[parent[j]]) {
        dead[j] = 1;
        ++count;
      }
    }
    for (int j = i; j < size(); ++j) {
      if (!dead[j]) continue;
      parent[j] = -1;
      pending[j] = 0;
      alive[j] = 0;
      set_cols(j, nullptr);
    }
    return count;
  }
};

// Failed regions (a retry after a failed certificate, taskspace.planning.certify.FailedRegions):
// the certifier of certify_kernel.hpp, defined after this namespace; certify_segment (defined
// there too) tells whether the segment q0 -> q1 is certified free (the caller has released the
// GIL: gil polls the signal handlers; interrupted: a handler raised).
class PathCertifier;
bool certify_segment(PathCertifier& certifier, const VectorXd& q0, const VectorXd& q1,
                     double tolerance, double time_left, double near, double far,
                     GilRelease& gil, bool& interrupted);
// The PathCertifier held by a Python object, of nq coordinates (else InvalidInputError).
PathCertifier* path_certifier(const bp::object& certifier, long nq);

struct Result {
  int status = kIterationLimit;
  long iterations = 0, edge_checks = 0, rejections = 0, removed = 0, trapped_turns = 0;
  long exact_checks = 0;      // checks of the exact re-validation (sphere checkers)
  bool recheck_failed = false;  // the exact re-validation found a collision: no path
  std::vector<double> path;
  double path_length = std::numeric_limits<double>::infinity();  // sum of |q_{i+1} - q_i|
  long fallback_iteration = -1;  // iteration at which "spheres_only" became "spheres" (or -1)
  long region_certifications = 0, region_rejections = 0;  // failed regions: edge parts certified, refused
  bool path_certified = false;   // kClearance: every edge of the path certified (no fallback)
  // Wall time of the phases [s] (for profiling; a few clock reads per iteration): the whole
  // run, the endpoint checks, the straight start-goal line, the nearest-neighbour scans,
  // the lazy fine pass (verify) and the exact re-check of the returned path; the tree growth
  // (EXTEND and CONNECT checks, sampling) is the rest.
  double t_run = 0, t_endpoints = 0, t_line = 0, t_nearest = 0, t_verify = 0, t_recheck = 0;
  // The nearest-neighbour scans and the fine pass, timed in ticks of phase_ticks (a few per
  // iteration: a clock read each cost 2 % of a plan) and turned into seconds at the end in
  // proportion to the whole run (RRTConnect::run).
  std::uint64_t tk_nearest = 0, tk_verify = 0;
};

// A cheap monotonic tick counter for the phase times: the time-stamp counter on x86-64
// (constant rate on the processors that run this), else the steady clock.
inline std::uint64_t phase_ticks() {
#if defined(__x86_64__) && defined(__GNUC__)
  return __rdtsc();
#else
  return static_cast<std::uint64_t>(std::chrono::steady_clock::now().time_since_epoch().count());
#endif
}

// The planner's random stream: xoshiro256++ (Blackman and Vigna, "Scrambled linear pseudorandom
// number generators", ACM TOMS 2021), its state from the seed by splitmix64 as its authors
// advise; unit() the top 53 bits (every double of [0, 1) that is a multiple of 2^-53, each
// equally likely), below(n) Lemire's multiply-shift with rejection (exactly uniform),
// normal() Marsaglia's polar method on unit() (the second value of a pair kept). Seeding is
// four splitmix64 steps (std::mt19937_64 fills and twists 312 words first, and
// std::uniform_real_distribution divides in long double per draw).
class PlanRng {
 public:
  explicit PlanRng(std::uint64_t seed) {
    for (std::uint64_t& w : s_) {
      seed += 0x9e3779b97f4a7c15ULL;
      std::uint64_t z = seed;
      z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
      z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
      w = z ^ (z >> 31);
    }
  }
  std::uint64_t next() {
    const std::uint64_t r = rotl(s_[0] + s_[3], 23) + s_[0];
    const std::uint64_t t = s_[1] << 17;
    s_[2] ^= s_[0];
    s_[3] ^= s_[1];
    s_[1] ^= s_[2];
    s_[0] ^= s_[3];
    s_[2] ^= t;
    s_[3] = rotl(s_[3], 45);
    return r;
  }
  double unit() { return static_cast<double>(next() >> 11) * 0x1.0p-53; }
  // uniform in {0, ..., n - 1} (n >= 1)
  int below(int n) {
    const std::uint64_t range = static_cast<std::uint64_t>(n);
    unsigned __int128 m = static_cast<unsigned __int128>(next()) * range;
    std::uint64_t low = static_cast<std::uint64_t>(m);
    if (low < range) {
      const std::uint64_t floor = (0 - range) % range;  // 2^64 mod n
      while (low < floor) {
        m = static_cast<unsigned __int128>(next()) * range;
        low = static_cast<std::uint64_t>(m);
      }
    }
    return static_cast<int>(m >> 64);
  }
  double normal() {
    if (has_spare_) {
      has_spare_ = false;
      return spare_;
    }
    double u, v, r2;
    do {
      u = 2.0 * unit() - 1.0;
      v = 2.0 * unit() - 1.0;
      r2 = u * u + v * v;
    } while (r2 >= 1.0 || r2 == 0.0);
    const double f = std::sqrt(-2.0 * std::log(r2) / r2);
    spare_ = v * f;
    has_spare_ = true;
    return u * f;
  }

 private:
  static std::uint64_t rotl(std::uint64_t x, int k) { return (x << k) | (x >> (64 - k)); }
  std::uint64_t s_[4];
  double spare_ = 0.0;
  bool has_spare_ = false;
};

class RRTConnect {
 public:
  RRTConnect(CollisionKernel& ck, const VecRef& lower, const VecRef& upper, double alpha,
             double delta, double delta_c, double local, double sigma, double trapped,
             std::uint64_t seed, int checker = kMesh, long fallback = -1,
             int validator = kMesh)
      : checker_(checker == kClearance ? kSpheresOnly : checker), certify_(checker == kClearance),
        fallback_(fallback), validator_(checker == kMesh ? kMesh : validator), ck_(ck), lower_(lower), upper_(upper), lines_(alpha, delta, delta_c), local_(local),
        sigma_(sigma), trapped_(trapped), rng_(seed), d_(static_cast<int>(lower.size())) {
    a_.resize(d_);
    b_.resize(d_);
    x_.resize(d_);
    cq0_.resize(d_);
    cdelta_.resize(d_);
    // (one allocation each instead of the doublings of a plan's first extensions and fine pass)
    ts_.reserve(32);
    vedges_.reserve(32);
    vlines_.reserve(64 * static_cast<std::size_t>(d_));
    vpts_.reserve(512);
  }

  // True once the plan must stop: the time limit has passed, or a Python signal handler raised
  // (Ctrl-C: interrupted = true, the exception pending). Called before every collision check
  // and iteration; the clock is read every 16 calls, the signal handlers run every
  // kPollInterval (gil: the released GIL; nullptr = no polling).
  // Every kNearestSample-th nearest-neighbour query is timed (two time-stamp reads cost about
  // as much as a query on a small tree); the log's nearest time is their sum times
  // kNearestSample (an estimate).
  static constexpr unsigned kNearestSample = 8;
  bool timed_nearest() { return ++nearest_calls_ % kNearestSample == 0; }

  bool stop() {
    if (stopped_) return true;
    if ((++ticks_ & 15) != 0) return false;
    const auto now = clock::now();
    if (limited_ && now > deadline_) {
      stopped_ = true;
    } else if (gil_ != nullptr && now >= next_poll_) {
      next_poll_ = now + kPollInterval;
      if (gil_->poll()) stopped_ = interrupted = true;
    }
    return stopped_;
  }

  // A collision check, or true (blocked) once the plan must stop: the callers treat the
  // motion as blocked, so that the trees only ever hold checked nodes.
  bool collides_or_stop(const VectorXd& q) { return stop() || ck_.collides(q, checker_); }

  // The exact checker's verdict on the returned path (sphere checkers): every node and the
  // interior points of every edge at the full resolution (bisection order), as the edges
  // were checked; with fine_done (a lazy plan's path: verify checked the fine points of every
  // edge with the exact checker), only the coarse points are left. A tree edge's coarse points
  // are the multiples of the stride counted from its parent: from the path's first point of
  // the edge for the start tree, from its last for the goal tree (whose edges the path runs
  // child to parent), so both are re-checked: k or n - k a multiple of the stride (counting
  // from the first point only left the goal tree's coarse points of an edge with n not a
  // multiple of the stride, e.g. every full step, unchecked by the exact checker).
  // False on the first collision.
  bool path_valid_exact(bool fine_done) {
    const std::size_t n_nodes = res.path.size() / d_;
    for (std::size_t i = 0; i < n_nodes; ++i) {
      const auto p0 = Eigen::Map<const VectorXd>(res.path.data() + i * d_, d_);
      ++res.exact_checks;
      if (ck_.collides(p0, kMesh)) return false;
      if (i + 1 == n_nodes) break;
      const auto p1 = Eigen::Map<const VectorXd>(res.path.data() + (i + 1) * d_, d_);
      const int n = lines_.segments((p1 - p0).norm());
      ts_.clear();
      for (int k : bisection_order_kept(n, order_scratch_)) {
        if (fine_done && k % lines_.stride != 0 && (n - k) % lines_.stride != 0)
          continue;  // a fine point from either end: checked exactly by verify
        ts_.push_back(double(k) / n);
      }
      dir_ = p1 - p0;
      const int j = ck_.first_collision(p0.data(), dir_.data(), ts_.data(),
                                        static_cast<int>(ts_.size()), kMesh,
                                        [] { return false; });
      res.exact_checks += j < 0 ? static_cast<long>(ts_.size()) : j + 1;
      if (j >= 0) return false;
    }
    return true;
  }

  // Straight line q0 -> q1 free at the full resolution (interior points, bisection order).
  bool motion_valid(const VecRef& q0, const VecRef& q1) {
    const VectorXd dir = q1 - q0;
    if (certifying() && !root_colliding_[0] && !root_colliding_[1])
      return dir.norm() == 0.0 || edge_certified(q0.data(), dir.data(), 0.0, 1.0);
    const int n = lines_.segments((q1 - q0).norm());
    ts_.clear();
    for (int k : bisection_order_kept(n, order_scratch_)) ts_.push_back(double(k) / n);
    return points_free(q0.data(), dir.data());
  }

  // The points a + ts_[j] * b free, checked in the order of ts_ (batched for the sphere
  // checkers: CollisionKernel::first_collision), stopping at the first collision; a stopped
  // plan counts as a collision (collides_or_stop).
  bool points_free(const double* a, const double* b) {
    return ck_.first_collision(a, b, ts_.data(), static_cast<int>(ts_.size()), checker_,
                               [this] { return stop(); }) < 0;
  }

  // kClearance before any fallback: edges are certified whole (certify_edge), no fine pass.
  // An edge at a tree's root that collides for the spheres (a goal closer to an obstacle
  // than the spheres' margin, found free by the exact endpoint check) cannot be certified:
  // it is checked at points as with "spheres_only" (coarse, then the validator's fine pass).
  bool certifying() const { return certify_ && checker_ == kSpheresOnly; }
  bool certifying_from(const Tree& t, int node) const {
    return certifying() && !(node == 0 && root_colliding_[&t == goal_.get() ? 1 : 0]);
  }

  // a + t b for t in [t0, t1] certified free (CollisionKernel::certify_edge; s_min: the
  // resolution's g_min_step_fraction in the metric); a stopped plan counts as blocked.
  bool edge_certified(const double* a, const double* b, double t0, double t1) {
    double norm2 = 0.0;
    for (int k = 0; k < d_; ++k) norm2 += b[k] * b[k];
    const double len = std::sqrt(norm2);
    const double s_min = g_min_step_fraction.load() * lines_.delta / len;
    const double s_max = std::max(s_min, g_max_step_fraction.load() * lines_.delta / len);
    return ck_.certify_edge(a, b, t0, t1, s_min, s_max, [this] { return stop(); });
  }

  // Failed regions of earlier attempts' certificates (Python: certify.FailedRegions): balls of
  // radius `radius` around the rows of `centers` (k x d); an edge whose part inside a ball is
  // not certified free by `certifier` (tolerance, near, far: the Python caller's) is refused,
  // so a re-plan never returns a motion through a region unless it is proven free there.
  void set_regions(const Eigen::Ref<const RowMatrixXd>& centers, double radius,
                   PathCertifier* certifier, double tolerance, double near, double far) {
    regions_.assign(centers.data(), centers.data() + centers.size());
    region_r2_ = radius * radius;
    certifier_ = certifier;
    region_tol_ = tolerance;
    region_near_ = near;
    region_far_ = far;
  }

  // The edge a + t b, t in [t0, t1], allowed by the failed regions: every part of it inside a
  // ball (the exact chord of the segment with the ball) certified free. True at once without
  // regions (the plans of certify=False and first attempts: one test per edge).
  bool regions_allow(const double* a, const double* b, double t0, double t1) {
    if (regions_.empty()) return true;
    double bb = 0.0;
    for (int k = 0; k < d_; ++k) bb += b[k] * b[k];
    if (!(bb > 0.0)) return true;
    for (std::size_t r = 0; r < regions_.size(); r += d_) {
      const double* c = regions_.data() + r;
      double tc = 0.0;  // the closest point of the line to c
      for (int k = 0; k < d_; ++k) tc += (c[k] - a[k]) * b[k];
      tc /= bb;
      double e2 = 0.0;
      for (int k = 0; k < d_; ++k) {
        const double e = a[k] + tc * b[k] - c[k];
        e2 += e * e;
      }
      if (!(e2 < region_r2_)) continue;
      const double h = std::sqrt((region_r2_ - e2) / bb);
      const double lo = std::max(t0, tc - h), hi = std::min(t1, tc + h);
      if (!(lo <= hi)) continue;
      VectorXd q0(d_), q1(d_);
      for (int k = 0; k < d_; ++k) {
        q0[k] = a[k] + lo * b[k];
        q1[k] = a[k] + hi * b[k];
      }
      double left = std::numeric_limits<double>::infinity();
      if (limited_) left = std::max(0.0, seconds(clock::now(), deadline_));
      bool raised = false;
      ++res.region_certifications;
      const bool ok = gil_ != nullptr && certifier_ != nullptr &&
                      certify_segment(*certifier_, q0, q1, region_tol_, left, region_near_,
                                      region_far_, *gil_, raised);
      if (raised) stopped_ = interrupted = true;
      if (!ok) {
        ++res.region_rejections;
        return false;
      }
    }
    return true;
  }

  // EXTEND(T, target): new node index or -1.
  int extend(Tree& t, const double* target) {
    const bool timed = timed_nearest();
    const std::uint64_t t_n = timed ? phase_ticks() : 0;
    auto [i_near, dist] = t.nearest(target);
    if (timed) res.tk_nearest += phase_ticks() - t_n;
    if (dist == 0.0) return -1;
    ++res.edge_checks;
    const double alpha = lines_.alpha;
    const int n_seg = dist > alpha ? lines_.full_n : lines_.segments(dist);
    const double step = std::min(1.0, alpha / dist);
    const double* qn = t.node(i_near);
    for (int k = 0; k < d_; ++k) {
      a_[k] = qn[k];
      b_[k] = target[k] - qn[k];
    }
    const bool cert = certifying_from(t, i_near);
    const bool pend = lines_.lazy && !cert;
    if (cert) {
      if (!edge_certified(a_.data(), b_.data(), 0.0, step)) return -1;
    } else {
      ts_.clear();
      for (double u : lines_.orders(n_seg).pattern) ts_.push_back(u * step);
      if (!points_free(a_.data(), b_.data())) return -1;
    }
    if (!regions_.empty() && !regions_allow(a_.data(), b_.data(), 0.0, step)) return -1;
    if (dist > alpha) {
      x_ = a_ + step * b_;
      return t.add(x_.data(), i_near, n_seg, pend);
    }
    return t.add(target, i_near, n_seg, pend);
  }

  // CONNECT(T, target): steps of length alpha from node i_near along the line to target (a
  // free node of the other tree); returns (last node added, target reached).
  std::pair<int, bool> connect(Tree& t, int i_near, const double* target, double dist) {
    const double alpha = lines_.alpha;
    const int whole = std::max(1, static_cast<int>(std::ceil(dist / alpha - 1e-12)));
    const int n_full = whole - 1;
    const double last = dist - n_full * alpha;
    VectorXd& q0 = cq0_;  // (members: no allocation per call)
    VectorXd& delta = cdelta_;
    q0 = Eigen::Map<const VectorXd>(t.node(i_near), d_);
    delta = Eigen::Map<const VectorXd>(target, d_) - q0;
    int par = i_near;
    for (int s = 0; s < whole; ++s) {
      const bool final_step = s == n_full;
      const int n = final_step ? lines_.segments(last) : lines_.full_n;
      const double start = s * alpha, len = final_step ? last : alpha;
      const bool cert = certifying_from(t, s == 0 ? i_near : par);
      const bool pend = lines_.lazy && !cert;
      if (cert) {
        if (!edge_certified(q0.data(), delta.data(), start / dist, (start + len) / dist))
          return {par, false};
      } else {
        const std::vector<double>& pattern = lines_.orders(n).pattern;
        // the target is a free node: its own check is skipped
        ts_.clear();
        for (std::size_t j = final_step ? 1 : 0; j < pattern.size(); ++j)
          ts_.push_back((start + pattern[j] * len) / dist);
        if (!points_free(q0.data(), delta.data())) return {par, false};
      }
      if (!regions_.empty() &&
          !regions_allow(q0.data(), delta.data(), start / dist, (start + len) / dist))
        return {par, false};
      if (final_step) {
        par = t.add(target, par, n, pend);
      } else {
        x_ = q0 + ((s + 1) * alpha / dist) * delta;
        par = t.add(x_.data(), par, n, pend);
      }
    }
    return {par, true};
  }

  // Fine points of the pending edges on the root paths of the leaves (tree after tree, root
  // outwards). On a collision, the child of the colliding edge and its subtree are removed.
  bool verify(Tree& t1, int leaf1, Tree& t2, int leaf2) {
    // The fine points of all pending edges go into one list, in the order of checking edge
    // after edge (tree 1's root outwards, then tree 2's), so that the batches of the sphere
    // checkers are full across edges; each edge's in increasing order (Orders::fine: a batch's
    // configurations are neighbours, 0.03 rad apart instead of spread over the edge, so the
    // filter's union spheres are tight and its tests prune more: fine pass median -13 %;
    // which edge collides first does not depend on the order within an edge); first_collision_at checks in the list's order and
    // stops at the first collision, so the colliding point, the checks counted and the
    // edges cleared are those of checking edge after edge.
    Tree* trees[2] = {&t1, &t2};
    int leaves[2] = {leaf1, leaf2};
    vedges_.clear();
    vlines_.clear();
    vpts_.clear();
    for (int h = 0; h < 2; ++h) {
      Tree& t = *trees[h];
      std::vector<int> ids = t.path_indices(leaves[h]);
      for (auto it = ids.rbegin(); it != ids.rend(); ++it) {
        const int i = *it;
        if (!t.pending[i]) continue;
        const double* p0 = t.node(t.parent[i]);
        const double* p1 = t.node(i);
        const std::size_t e = vedges_.size();
        for (int k = 0; k < d_; ++k) vlines_.push_back(p0[k]);
        for (int k = 0; k < d_; ++k) vlines_.push_back(p1[k] - p0[k]);
        // the validator (also with a sphere checker: the fine points of the path are then
        // checked once, here, and path_valid_exact checks the coarse ones)
        for (double u : lines_.orders(t.segments[i]).fine) vpts_.push_back({u, e});
        vedges_.push_back({h, i, vpts_.size()});
      }
    }
    const int d = d_;
    const double* lines = vlines_.data();
    const auto* pts = vpts_.data();
    bool stopped = false;
    const int j = ck_.first_collision_at(
        static_cast<int>(vpts_.size()), validator_,
        [lines, pts, d](int q, double* x) {
          const double* a = lines + 2 * d * pts[q].edge;
          const double* b = a + d;
          const double u = pts[q].t;
          for (int k = 0; k < d; ++k) x[k] = a[k] + u * b[k];
        },
        [this, &stopped] { return stopped = stop(); });
    for (const VerifyEdge& e : vedges_) {
      Tree& t = *trees[e.tree];
      if (j >= 0 && static_cast<std::size_t>(j) < e.end) {
        if (stopped) return false;  // the plan ends: nothing is removed
        ++res.rejections;
        res.removed += t.remove_subtree(e.node);
        return false;
      }
      t.pending[e.node] = 0;
    }
    return true;
  }

  // Plan (the GIL released: gil polls the signal handlers; nullptr: no polling). time_limit
  // [s]: negative or +inf = none; the deadline saturates (a limit beyond the clock's range,
  // about 292 years, is no limit) instead of overflowing.
  void run(const VecRef& qs, const VecRef& qg, long max_iterations, double time_limit,
           GilRelease* gil) {
    const std::uint64_t tk0 = phase_ticks();
    plan(qs, qg, max_iterations, time_limit, gil);
    const std::uint64_t tk_run = phase_ticks() - tk0;
    // the phases timed in ticks, in seconds: their share of the run's ticks times t_run
    const double per_tick = tk_run > 0 ? res.t_run / static_cast<double>(tk_run) : 0.0;
    res.t_nearest = per_tick * static_cast<double>(kNearestSample * res.tk_nearest);
    res.t_verify = per_tick * static_cast<double>(res.tk_verify);
  }

  // run() without the phases' conversion.
  void plan(const VecRef& qs, const VecRef& qg, long max_iterations, double time_limit,
            GilRelease* gil) {
    const auto t0 = clock::now();
    gil_ = gil;
    next_poll_ = t0 + kPollInterval;
    const double horizon =
        0.5 * std::chrono::duration<double>(clock::time_point::max() - t0).count();
    limited_ = time_limit >= 0.0 && time_limit < horizon;  // false for +inf
    deadline_ = limited_ ? t0 + std::chrono::duration_cast<clock::duration>(
                                    std::chrono::duration<double>(time_limit))
                         : clock::time_point::max();
    start_ = std::make_unique<Tree>(qs);
    goal_ = std::make_unique<Tree>(qg);
    const bool start_ok = endpoint_valid(qs);
    const bool goal_ok = start_ok && endpoint_valid(qg);
    res.t_endpoints = seconds(t0, clock::now());
    if (!start_ok || !goal_ok) {
      res.status = start_ok ? kGoalInvalid : kStartInvalid;
      res.t_run = seconds(t0, clock::now());
      return;
    }
    if (certify_) {
      root_colliding_[0] = ck_.collides(qs, kSpheresOnly);
      root_colliding_[1] = ck_.collides(qg, kSpheresOnly);
    }
    ++res.edge_checks;
    const auto t_l = clock::now();
    bool direct = motion_valid(qs, qg);
    if (direct && !regions_.empty()) {
      const VectorXd line = qg - qs;
      direct = regions_allow(qs.data(), line.data(), 0.0, 1.0);
    }
    res.t_line = seconds(t_l, clock::now());
    if (direct) {
      direct_ = true;
      res.status = kSolved;
      res.path.assign(qs.data(), qs.data() + d_);
      res.path.insert(res.path.end(), qg.data(), qg.data() + d_);
      recheck();
      res.t_run = seconds(t0, clock::now());
      return;
    }
    Tree* ta = start_.get();
    Tree* tb = goal_.get();
    VectorXd target(d_);
    while (res.iterations < max_iterations) {  // no overflow at max_iterations = LONG_MAX
      if ((res.iterations & 3) == 0) ticks_ |= 15;  // the clock every 4 iterations (and 16 checks)
      if (stop()) break;
      ++res.iterations;
      if (checker_ == kSpheresOnly && fallback_ >= 0 && res.iterations > fallback_) {
        // The conservative spheres have not connected the trees: they may close a narrow
        // passage. The trees stay (their nodes and coarse points are free for the spheres,
        // hence free); the plan goes on with the exact narrow phase where spheres touch.
        checker_ = kSpheres;
        res.fallback_iteration = res.iterations;
      }
      if (trapped_ > 0.0 && 4 * tb->size() < ta->size() && rng_.unit() < trapped_) {
        std::swap(ta, tb);  // the trapped tree takes the big tree's turn (swapped back below)
        ++res.trapped_turns;
      }
      if (local_ > 0.0 && 4 * ta->size() < tb->size() && rng_.unit() < local_) {
        // T_a is trapped (typically in a tight goal region): aim near one of its nodes.
        const double* node = ta->node(rng_.below(ta->size()));
        for (int k = 0; k < d_; ++k)
          target[k] = std::clamp(node[k] + sigma_ * rng_.normal(), lower_[k], upper_[k]);
      } else {
        for (int k = 0; k < d_; ++k) target[k] = lower_[k] + (upper_[k] - lower_[k]) * rng_.unit();
      }
      const int a_new = extend(*ta, target.data());
      if (a_new >= 0) {
        const double* q_new = ta->node(a_new);
        const bool timed = timed_nearest();
        const std::uint64_t t_n = timed ? phase_ticks() : 0;
        auto [j_near, gap] = tb->nearest(q_new);
        if (timed) res.tk_nearest += phase_ticks() - t_n;
        int b_new = j_near;
        bool reached = true;
        if (gap != 0.0) {
          ++res.edge_checks;
          std::tie(b_new, reached) = connect(*tb, j_near, q_new, gap);
        }
        if (reached) {
          bool ok = true;
          if (lines_.lazy) {
            const std::uint64_t t_v = phase_ticks();
            ok = ta == goal_.get() ? verify(*ta, a_new, *tb, b_new) : verify(*tb, b_new, *ta, a_new);
            res.tk_verify += phase_ticks() - t_v;
          }
          if (ok) {
            std::vector<int> ia = ta->path_indices(a_new);  // a_new .. root
            std::vector<int> ib = tb->path_indices(b_new);
            std::vector<int> order;  // rows of the path from T_a's root to T_b's root
            std::vector<Tree*> owner;
            for (auto r = ia.rbegin(); r != ia.rend(); ++r) {
              order.push_back(*r);
              owner.push_back(ta);
            }
            for (std::size_t j = 1; j < ib.size(); ++j) {
              order.push_back(ib[j]);
              owner.push_back(tb);
            }
            if (ta == goal_.get()) {
              std::reverse(order.begin(), order.end());
              std::reverse(owner.begin(), owner.end());
            }
            for (std::size_t j = 0; j < order.size(); ++j) {
              const double* x = owner[j]->node(order[j]);
              res.path.insert(res.path.end(), x, x + d_);
            }
            res.status = kSolved;
            break;
          }
        }
      }
      std::swap(ta, tb);
    }
    if (res.status != kSolved && stopped_) res.status = kTimeLimit;
    recheck();
    res.t_run = seconds(t0, clock::now());
  }

  // A solved plan with a sphere checker: the exact checker's verdict on the path (none when
  // it finds a collision, recheck_failed set); then the length of a path that stays.
  // The re-check is the exact mesh checker; with validator_ == kSpheres the fine points
  // were checked by the spheres (then the narrow phase), so they are re-checked too.
  // No re-check when the spheres carry sphere_model's volume certificate
  // (CollisionKernel::spheres_certified): every point of the path was then checked by the
  // mesh checker (endpoints; the fine points with validator_ == kMesh) or by a sphere
  // checker, and a sphere checker's "free" implies the mesh checker's. Proof: each moving
  // object's convex hull H lies inside the union of its spheres shrunk by the margin
  // epsilon (certify_cover in sphere_model.py). (a) Obstacle pairs: the spheres are tested
  // against the obstacle's exact volume (point distance to a box / sphere / cylinder /
  // capsule, coal's sphere-vs-shape test otherwise) inflated by the pair's security margin;
  // no sphere within it means every point of H is more than epsilon + margin away, so the
  // exact narrow phase (same placements up to the kinematics' rounding, ~1e-15 m; GJK
  // tolerance 1e-6 m) finds no collision. (b) Self pairs: likewise, each point of H_a lies
  // in a sphere of a, each point of H_b in a sphere of b; no touching spheres means no
  // common point. (c) The link and object bounding spheres contain the spheres, so their
  // culling is part of the same test. "spheres" answers exactly where spheres touch
  // (coal's narrow phase on the pair, as the mesh checker). Tested against Pinocchio's
  // computeCollisions near contact (tests/planning/test_planning_sphere_checker.py).
  void recheck() {
    const auto t_r = clock::now();
    if (res.status == kSolved && checker_ != kMesh && !ck_.spheres_certified() &&
        !path_valid_exact(lines_.lazy && !direct_ && validator_ == kMesh)) {
      res.recheck_failed = true;
      res.status = kIterationLimit;
      res.path.clear();
    }
    res.t_recheck = seconds(t_r, clock::now());
    if (res.status != kSolved) return;
    // (free for the spheres everywhere; for the meshes with the spheres' volume certificate)
    res.path_certified = certify_ && ck_.spheres_certified() && res.fallback_iteration < 0 &&
                         !root_colliding_[0] && !root_colliding_[1];
    double length = 0.0;
    const std::size_t n_nodes = res.path.size() / d_;
    for (std::size_t i = 0; i + 1 < n_nodes; ++i)
      length += (Eigen::Map<const VectorXd>(res.path.data() + (i + 1) * d_, d_) -
                 Eigen::Map<const VectorXd>(res.path.data() + i * d_, d_))
                    .norm();
    res.path_length = length;
  }

  // A start or goal: finite, inside the bounds and free for the exact checker (one check).
  bool endpoint_valid(const VecRef& q) {
    if (!q.allFinite()) return false;
    if ((q.array() < lower_.array()).any() || (q.array() > upper_.array()).any()) return false;
    return !ck_.collides(q, kMesh);
  }

  Result res;
  int checker_;
  bool certify_;    // kClearance: certified edges until a fallback
  bool root_colliding_[2] = {false, false};  // kClearance: start / goal collide for the spheres
  long fallback_;  // kSpheresOnly: iterations before switching to kSpheres (< 0: never)
  // Checker of the fine pass and of the returned path (sphere checkers): kMesh (default),
  // or kSpheres (the same answers, tested against Pinocchio; trusts the sphere model's
  // conservativeness where it says "free", as the "spheres" checker does).
  int validator_;
  std::unique_ptr<Tree> start_, goal_;
  bool interrupted = false;  // a signal handler raised (the Python exception is pending)

 private:
  using clock = std::chrono::steady_clock;
  static double seconds(clock::time_point a, clock::time_point b) {
    return std::chrono::duration<double>(b - a).count();
  }
  GilRelease* gil_ = nullptr;
  bool limited_ = false, stopped_ = false, direct_ = false;
  std::vector<double> regions_;  // failed regions: centres, row after row (set_regions)
  double region_r2_ = 0.0, region_tol_ = 0.0, region_near_ = 0.0, region_far_ = 0.0;
  PathCertifier* certifier_ = nullptr;
  unsigned ticks_ = 0;
  unsigned nearest_calls_ = 0;  // (timed_nearest)
  clock::time_point deadline_, next_poll_;
  CollisionKernel& ck_;
  VectorXd lower_, upper_;
  LinePlanner lines_;
  std::vector<int> order_scratch_;  // bisection_order_kept of a line longer than the cache's
  double local_, sigma_, trapped_;
  PlanRng rng_;
  int d_;
  VectorXd a_, b_, x_, dir_, cq0_, cdelta_;  // (cq0_, cdelta_: connect's)
  std::vector<double> ts_;  // fractions of the points of the line being checked
  struct VerifyPoint {
    double t;          // fraction on the edge
    std::size_t edge;  // index in vedges_
  };
  struct VerifyEdge {
    int tree, node;   // the edge parent(node) -> node of tree 0 (t1) or 1 (t2)
    std::size_t end;  // end (exclusive) of its points in vpts_
  };
  std::vector<VerifyEdge> vedges_;  // verify: the pending edges, in checking order
  std::vector<double> vlines_;      // verify: per edge its start p0 then p1 - p0
  std::vector<VerifyPoint> vpts_;   // verify: the fine points of all pending edges
};

BOOST_PYTHON_MEMBER_FUNCTION_OVERLOADS(set_spheres_overloads, CollisionKernel::set_spheres, 4, 5)

// A new C-ordered float64 array of shape (rows, d) holding `flat` (row after row), always
// 2-D (eigenpy turns a one-row matrix into a 1-D array: a one-node tree had shape (d,)).
bp::object rows_array(const std::vector<double>& flat, int d) {
  npy_intp dims[2] = {static_cast<npy_intp>(flat.size()) / d, d};
  PyObject* a = eigenpy::call_PyArray_SimpleNew(2, dims, NPY_DOUBLE);
  if (a == nullptr) bp::throw_error_already_set();
  if (!flat.empty())
    std::memcpy(PyArray_DATA(reinterpret_cast<PyArrayObject*>(a)), flat.data(),
                sizeof(double) * static_cast<std::size_t>(dims[0]) * d);
  return bp::object(bp::handle<>(a));
}

// (nodes (n, d) float64, parents (n,) int64) of a tree, as taskspace's Tree holds them.
bp::tuple tree_tuple(const Tree& t) {
  npy_intp n = t.size();
  PyObject* a = eigenpy::call_PyArray_SimpleNew(1, &n, NPY_INT64);
  if (a == nullptr) bp::throw_error_already_set();
  bp::object parents{bp::handle<>(a)};
  auto* out = static_cast<std::int64_t*>(PyArray_DATA(reinterpret_cast<PyArrayObject*>(a)));
  for (npy_intp i = 0; i < n; ++i) out[i] = t.parent[i];
  return bp::make_tuple(rows_array(t.q, t.d), parents);
}

// The keys of rrt_connect's log, in order (rrt_connect.py's _NATIVE_LOG_KEYS; the module's
// RRT_CONNECT_LOG_KEYS, tested equal): the kernel's numbers with limit_log's three fields
// (stopped_by, costs, cost_times: set in Python, which has their values) at kLogLimitAt.
constexpr const char* kLogKeys[] = {
    "start_tree_nodes", "goal_tree_nodes", "lazy_rejections", "nodes_removed", "trapped_turns",
    "native", "checker", "validator", "exact_recheck_checks", "sphere_recheck_failed",
    "spheres_fallback", "spheres_fallback_iteration", "path_certified", "stopped_by", "costs",
    "cost_times", "kernel_run_us", "kernel_endpoints_us", "kernel_line_us", "kernel_nearest_us",
    "kernel_fine_pass_us", "kernel_recheck_us"};
constexpr int kLogSize = sizeof(kLogKeys) / sizeof(kLogKeys[0]);
constexpr int kLogLimitAt = 13, kLogLimitFields = 3;

// kLogKeys as interned Python strings, made once (at import, with the GIL held) and kept.
PyObject* const* log_keys() {
  static PyObject* const* keys = [] {
    auto* out = new PyObject*[kLogSize];
    for (int i = 0; i < kLogSize; ++i) {
      out[i] = PyUnicode_InternFromString(kLogKeys[i]);
      if (out[i] == nullptr) bp::throw_error_already_set();
    }
    return out;
  }();
  return keys;
}

// A dict of kLogKeys (in order) to None, made once (at import) and kept: each plan's log is
// a copy (a copy of a small dict copies its table, faster than inserting the keys one by one).
PyObject* log_template() {
  static PyObject* const tmpl = [] {
    PyObject* dict = PyDict_New();
    if (dict == nullptr) bp::throw_error_already_set();
    PyObject* const* keys = log_keys();
    for (int i = 0; i < kLogSize; ++i)
      if (PyDict_SetItem(dict, keys[i], Py_None) < 0) bp::throw_error_already_set();
    return dict;
  }();
  return tmpl;
}

// kLogKeys as a tuple of str (the module's RRT_CONNECT_LOG_KEYS).
bp::tuple log_key_tuple() {
  bp::list out;
  for (int i = 0; i < kLogSize; ++i)
    out.append(bp::object(bp::handle<>(bp::borrowed(log_keys()[i]))));
  return bp::tuple(out);
}

// Plan with RRT-Connect; returns (status, path (m, d), iterations, edge_checks, checks (the
// collision checks of this plan, as CollisionKernel.checks counts them), (start nodes (n, d),
// start parents (n,) int64), (goal nodes, goal parents), path_length,
// (region_certifications, region_rejections): the edge parts inside failed regions certified
// and refused, the log (a new dict, keys kLogKeys in order; floats: tree sizes, lazy
// rejections, nodes removed, trapped turns, 1 (native), checker, validator, exact re-check
// checks, re-check failed, fallback (0/1) and its iteration (-1: none), path certified
// (checker kClearance: every edge of the returned path certified free by
// CollisionKernel::certify_edge, i.e. no fallback), then None for stopped_by, costs and
// cost_times, then phase times in us (run, endpoints, straight line, nearest, fine pass,
// re-check)). regions (None: none): (centers (k, d), radius, certifier, tolerance, near, far)
// of the failed regions of earlier certificates (RRTConnect::set_regions).
// checker kClearance (3): "spheres_only" with whole edges certified by clearance instead of
// points (no lazy fine pass; after a fallback the plan goes on with kSpheres' point checks).
// The start and goal are validated first
// (finite, inside the bounds, free for the exact checker; status kStartInvalid / kGoalInvalid
// otherwise, with no plan). fallback_iterations (checker kSpheresOnly, >= 0): after that many
// iterations without a path the plan goes on with kSpheres (fallback_iteration: when; -1 if
// not). validator (sphere checkers): the checker of the lazy fine pass and of the returned
// path, kMesh (default) or kSpheres (RRTConnect::validator_). Collision checks
// are counted by the kernel (CollisionKernel.checks). time_limit [s]: negative or +inf = no
// limit. Every other argument is checked (InvalidInputError); the plan runs with the GIL released
// and the kernel locked (other threads may plan on other kernels meanwhile), polling Python's
// signal handlers every kPollInterval: Ctrl-C stops it and raises KeyboardInterrupt.
bp::tuple rrt_connect(CollisionKernel& ck, const VecRef& start, const VecRef& goal,
                      const VecRef& lower, const VecRef& upper, double alpha, double delta,
                      double delta_c, double local, double sigma, double trapped,
                      long max_iterations, double time_limit, unsigned long seed,
                      int checker, long fallback_iterations, int validator,
                      const bp::object& regions) {
  const long d = ck.nq();
  if (checker == kClearance) ck.require_motion_bounds();
  else ck.check_checker(checker);
  if (validator != kMesh && validator != kSpheres)
    raise_invalid("validator must be 0 (mesh) or 1 (spheres), got " + std::to_string(validator));
  if (checker != kMesh) ck.check_checker(validator);  // (ignored by the mesh checker)
  if (start.size() != d || goal.size() != d || lower.size() != d || upper.size() != d)
    raise_invalid("start, goal, lower and upper must have size nq = " + std::to_string(d));
  if (!lower.allFinite() || !upper.allFinite()) raise_invalid("lower and upper must be finite");
  if (!(lower.array() <= upper.array()).all()) raise_invalid("lower must be <= upper");
  if (!(alpha > 0.0) || !(delta > 0.0) || !(sigma > 0.0) || !std::isfinite(alpha) ||
      !std::isfinite(delta) || !std::isfinite(sigma) || std::isnan(delta_c))
    raise_invalid("alpha, delta and sigma must be finite and > 0, delta_c not NaN");
  if (!(trapped >= 0.0 && trapped <= 1.0) || !(local >= 0.0 && local <= 1.0))
    raise_invalid("local and trapped must be probabilities (in [0, 1])");
  if (max_iterations < 0) raise_invalid("max_iterations must be >= 0");
  if (std::isnan(time_limit)) raise_invalid("time_limit must not be NaN (negative: no limit)");
  // Every line is cut into at most diameter / min(alpha, delta) pieces: keep them countable
  // by an int (and the check patterns in memory).
  const double diameter = (upper - lower).norm();
  const double cap = std::ldexp(1.0, 30);
  if (diameter / std::min(alpha, delta) > cap || std::max(delta_c, delta) / delta > cap ||
      alpha / delta > cap)
    raise_invalid("alpha and delta are too small for the bounds: a line of the space would "
                  "need more than 2^30 steps or checks");
  RRTConnect planner(ck, lower, upper, alpha, delta, std::max(delta, delta_c), local, sigma,
                     trapped, static_cast<std::uint64_t>(seed), checker, fallback_iterations,
                     validator);
  if (!regions.is_none()) {  // (centers (k, d), radius, certifier, tolerance, near, far)
    const bp::tuple r = bp::extract<bp::tuple>(regions);
    if (bp::len(r) != 6)
      raise_invalid("regions must be (centers, radius, certifier, tolerance, near, far)");
    const RowMatrixXd centers = bp::extract<RowMatrixXd>(r[0]);
    const double radius = bp::extract<double>(r[1]);
    PathCertifier* certifier = path_certifier(r[2], d);
    const double tol = bp::extract<double>(r[3]);
    const double near = bp::extract<double>(r[4]), far = bp::extract<double>(r[5]);
    if (centers.cols() != d || !centers.allFinite())
      raise_invalid("region centers must be finite, of " + std::to_string(d) + " columns");
    if (!(radius > 0.0) || !std::isfinite(radius) || !(tol > 0.0) || !std::isfinite(tol) ||
        !(near >= 0.0) || !(far >= 0.0))
      raise_invalid("region radius and tolerance must be finite and > 0, near and far >= 0");
    planner.set_regions(centers, radius, certifier, tol, near, far);
  }
  long checks = 0;  // the checks of this plan (the kernel is locked: no other plan counts)
  {
    std::unique_lock<std::timed_mutex> lock = lock_with_gil(ck.mutex());
    const long checks0 = ck.checks();
    GilRelease gil;
    planner.run(start, goal, max_iterations, time_limit, &gil);
    checks = ck.checks() - checks0;
  }
  if (planner.interrupted) bp::throw_error_already_set();
  const Result& r = planner.res;
  // the result's log: the numbers as floats, keys in the order of kLogKeys (= rrt_connect.py's
  // _NATIVE_LOG_KEYS); stopped_by, costs and cost_times are None (rrt_connect.py sets them)
  const bool solved = r.status == kSolved;
  const double numbers[] = {
      static_cast<double>(planner.start_->size()),  // start_tree_nodes (run made both trees)
      static_cast<double>(planner.goal_->size()),   // goal_tree_nodes
      static_cast<double>(r.rejections),                                   // lazy_rejections
      static_cast<double>(r.removed),                                      // nodes_removed
      static_cast<double>(r.trapped_turns),                                // trapped_turns
      1.0,                                                                 // native
      static_cast<double>(checker),                                        // checker
      static_cast<double>(checker == kMesh ? kMesh : validator),           // validator
      static_cast<double>(r.exact_checks),           // exact_recheck_checks
      static_cast<double>(r.recheck_failed),         // sphere_recheck_failed
      r.fallback_iteration >= 0 ? 1.0 : 0.0,         // spheres_fallback
      static_cast<double>(r.fallback_iteration),     // spheres_fallback_iteration
      r.path_certified && solved ? 1.0 : 0.0,        // path_certified
      1e6 * r.t_run, 1e6 * r.t_endpoints, 1e6 * r.t_line, 1e6 * r.t_nearest,  // [us]
      1e6 * r.t_verify, 1e6 * r.t_recheck};
  static_assert(sizeof(numbers) / sizeof(numbers[0]) + kLogLimitFields == kLogSize,
                "one number per key of kLogKeys but the three limit fields");
  bp::object log{bp::handle<>(PyDict_Copy(log_template()))};  // (keys interned, values None)
  PyObject* const* keys = log_keys();
  for (int i = 0, k = 0; i < kLogSize; ++i) {
    if (i == kLogLimitAt) i += kLogLimitFields;  // (left None)
    bp::handle<> x(PyFloat_FromDouble(numbers[k++]));
    if (PyDict_SetItem(log.ptr(), keys[i], x.get()) < 0) bp::throw_error_already_set();
  }
  return bp::make_tuple(r.status, rows_array(r.path, static_cast<int>(d)), r.iterations,
                        r.edge_checks, checks, tree_tuple(*planner.start_),
                        tree_tuple(*planner.goal_), r.path_length,
                        bp::make_tuple(r.region_certifications, r.region_rejections), log);
}

// The module's rrt_connect: a plain CPython function (vectorcall) in front of the Boost.Python
// function above (the module's _rrt_connect_checked), whose dispatch converted the 18
// arguments in about 1 us per plan. The usual call (rrt_connect.py's: 18 positional
// arguments, a CollisionKernel, 1-D float64 arrays of native byte order, aligned and
// contiguous, exact floats and ints in range, regions anything) is converted here and calls
// rrt_connect; every other call (keywords, fewer arguments, other types or layouts) goes to
// the Boost.Python function unchanged, with its conversions and errors.
PyObject* g_rrt_connect_checked = nullptr;  // the Boost.Python function (set at import)
PyObject* g_ndarray = nullptr;              // numpy.ndarray (set at import)

// An exact numpy.ndarray of shape (n,), float64 in native order, aligned, contiguous.
bool fast_vector(PyObject* o, const double*& data, Eigen::Index& size) {
  if (Py_TYPE(o) != reinterpret_cast<PyTypeObject*>(g_ndarray)) return false;
  auto* a = reinterpret_cast<PyArrayObject*>(o);
  if (PyArray_NDIM(a) != 1 || PyArray_TYPE(a) != NPY_DOUBLE || !PyArray_ISNOTSWAPPED(a) ||
      !PyArray_ISALIGNED(a) || PyArray_STRIDE(a, 0) != static_cast<npy_intp>(sizeof(double)))
    return false;
  data = static_cast<const double*>(PyArray_DATA(a));
  size = PyArray_DIM(a, 0);
  return true;
}

bool fast_double(PyObject* o, double& x) {
  if (!PyFloat_CheckExact(o)) return false;
  x = PyFloat_AS_DOUBLE(o);
  return true;
}

bool fast_long(PyObject* o, long& x) {
  if (!PyLong_CheckExact(o)) return false;  // (bool and other int types: Boost.Python)
  int overflow = 0;
  x = PyLong_AsLongAndOverflow(o, &overflow);
  if (x == -1 && PyErr_Occurred()) {  // (not for an exact int: cleared for the other path)
    PyErr_Clear();
    return false;
  }
  return overflow == 0;
}

bool fast_int(PyObject* o, int& x) {
  long v = 0;
  if (!fast_long(o, v) || v < std::numeric_limits<int>::min() ||
      v > std::numeric_limits<int>::max())
    return false;
  x = static_cast<int>(v);
  return true;
}

bool fast_unsigned_long(PyObject* o, unsigned long& x) {
  if (!PyLong_CheckExact(o)) return false;
  x = PyLong_AsUnsignedLong(o);  // (negative or too large: OverflowError, cleared)
  if (x == static_cast<unsigned long>(-1) && PyErr_Occurred()) {
    PyErr_Clear();
    return false;
  }
  return true;
}

PyObject* rrt_connect_fast(PyObject*, PyObject* const* args, Py_ssize_t nargsf,
                           PyObject* kwnames) {
  const Py_ssize_t n = PyVectorcall_NARGS(nargsf);
  const double* data[4] = {};
  Eigen::Index size[4] = {};
  double reals[7] = {};  // alpha, delta, delta_c, local, sigma, trapped, time_limit
  long max_iterations = 0, fallback = 0;
  unsigned long seed = 0;
  int checker = 0, validator = 0;
  void* ck = nullptr;
  bool usual = kwnames == nullptr && n == 18;
  for (int i = 0; usual && i < 4; ++i) usual = fast_vector(args[1 + i], data[i], size[i]);
  for (int i = 0; usual && i < 6; ++i) usual = fast_double(args[5 + i], reals[i]);
  usual = usual && fast_long(args[11], max_iterations) && fast_double(args[12], reals[6]) &&
          fast_unsigned_long(args[13], seed) && fast_int(args[14], checker) &&
          fast_long(args[15], fallback) && fast_int(args[16], validator);
  if (usual) {
    ck = bp::converter::get_lvalue_from_python(
        args[0], bp::converter::registered<CollisionKernel>::converters);
    usual = ck != nullptr;
  }
  if (!usual) return PyObject_Vectorcall(g_rrt_connect_checked, args, nargsf, kwnames);
  try {
    using Map = Eigen::Map<const VectorXd>;
    const bp::object regions{bp::handle<>(bp::borrowed(args[17]))};
    bp::tuple out = rrt_connect(
        *static_cast<CollisionKernel*>(ck), VecRef(Map(data[0], size[0])),
        VecRef(Map(data[1], size[1])), VecRef(Map(data[2], size[2])),
        VecRef(Map(data[3], size[3])), reals[0], reals[1], reals[2], reals[3], reals[4],
        reals[5], max_iterations, reals[6], seed, checker, fallback, validator, regions);
    return bp::incref(out.ptr());
  } catch (...) {
    bp::handle_exception();  // (Boost.Python's translation, as for its own functions)
    return nullptr;
  }
}

PyMethodDef kRRTConnectMethods[] = {
    {"rrt_connect", reinterpret_cast<PyCFunction>(reinterpret_cast<void (*)()>(rrt_connect_fast)),
     METH_FASTCALL | METH_KEYWORDS,
     "rrt_connect(checker, start, goal, lower, upper, alpha, delta, delta_c, local, sigma, "
     "trapped, max_iterations, time_limit, seed, collision_checker=0, fallback_iterations=-1, "
     "validator=0, regions=None) -> (status, path, iterations, edge_checks, checks, "
     "(start nodes, parents), (goal nodes, parents), path_length, (region certifications, "
     "rejections), log): see _rrt_connect_checked (the same function, any argument types)."},
    {nullptr, nullptr, 0, nullptr}};

// Benchmarks: the certified edges' min and max steps in units of the resolution (see
// g_min_step_fraction); returns the previous values.
bp::tuple set_clearance_tuning(double min_fraction, double max_fraction) {
  if (!(min_fraction > 0.0) || !(max_fraction >= min_fraction) || !std::isfinite(max_fraction))
    raise_invalid("need finite fractions, 0 < min_fraction <= max_fraction");
  const double a = g_min_step_fraction.exchange(min_fraction);
  const double b = g_max_step_fraction.exchange(max_fraction);
  return bp::make_tuple(a, b);
}

// Nearest node (Tree::nearest) of every query row in the tree whose nodes are the rows of
// `nodes` (row 0 the root, every other row a child of the root) after the removal of the rows
// in `removed` (> 0, with their subtrees: none here). For the tests (against a brute force).
// The planner's random stream (PlanRng) from seed, for the tests: (n raw 64-bit draws as
// Python ints, n unit() draws, n below(bound) draws, n normal() draws), each from a new
// stream of that seed.
bp::tuple plan_rng_draws(unsigned long seed, int n, int bound) {
  if (n < 0 || bound < 1) raise_invalid("need n >= 0 and bound >= 1");
  bp::list raw, unit, below, normal;
  PlanRng a(seed), b(seed), c(seed), d(seed);
  for (int i = 0; i < n; ++i) {
    raw.append(static_cast<unsigned long long>(a.next()));
    unit.append(b.unit());
    below.append(c.below(bound));
    normal.append(d.normal());
  }
  return bp::make_tuple(raw, unit, below, normal);
}

Eigen::VectorXi tree_nearest(const Eigen::Ref<const RowMatrixXd>& nodes,
                             const Eigen::VectorXi& removed,
                             const Eigen::Ref<const RowMatrixXd>& queries) {
  if (nodes.rows() < 1 || queries.cols() != nodes.cols())
    throw std::invalid_argument("nodes (at least one row) and queries need the same columns");
  Tree t(nodes.row(0).transpose());
  for (Eigen::Index i = 1; i < nodes.rows(); ++i) {
    const VectorXd x = nodes.row(i).transpose();
    t.add(x.data(), 0, 1, false);
  }
  for (Eigen::Index j = 0; j < removed.size(); ++j) {
    if (removed[j] <= 0 || removed[j] >= t.size()) throw std::invalid_argument("bad removed row");
    if (t.alive[removed[j]]) t.remove_subtree(removed[j]);
  }
  Eigen::VectorXi out(queries.rows());
  for (Eigen::Index i = 0; i < queries.rows(); ++i) {
    const VectorXd x = queries.row(i).transpose();
    out[i] = t.nearest(x.data()).first;
  }
  return out;
}

}  // namespace

// Certified paths (certify_kernel.hpp): the class PathCertifier.
#include "certify_kernel.hpp"

namespace {

bool certify_segment(PathCertifier& certifier, const VectorXd& q0, const VectorXd& q1,
                     double tolerance, double time_left, double near, double far,
                     GilRelease& gil, bool& interrupted) {
  return certifier.certify_released(q0, q1, tolerance, time_left, near, far, gil, interrupted);
}

PathCertifier* path_certifier(const bp::object& certifier, long nq) {
  bp::extract<PathCertifier&> got(certifier);
  if (!got.check()) raise_invalid("regions need a PathCertifier");
  PathCertifier& c = got();
  if (c.nq() != nq)
    raise_invalid("the PathCertifier has nq = " + std::to_string(c.nq()) + ", the plan " +
                  std::to_string(nq));
  return &c;
}

}  // namespace

// Dubins and Reeds-Shepp curves (curves.cpp): plain CPython functions added to this module.
int taskspace_register_curves(PyObject* module);
// Batched Ferrari-Canny epsilon (grasp_epsilon.cpp): plain CPython functions added to this module.
int taskspace_register_grasp_epsilon(PyObject* module);

BOOST_PYTHON_MODULE(_planning_kernel) {
  eigenpy::enableEigenPy();
  if (taskspace_register_curves(bp::scope().ptr()) < 0) bp::throw_error_already_set();
  if (taskspace_register_grasp_epsilon(bp::scope().ptr()) < 0) bp::throw_error_already_set();
  bp::scope().attr("PINOCCHIO_VERSION") = std::string(PINOCCHIO_VERSION);
  bp::scope().attr("RRT_CONNECT_LOG_KEYS") = log_key_tuple();
  (void)log_template();  // made at import (not at a first plan, which may race another)
  bp::scope().attr("SOLVED") = kSolved;
  bp::scope().attr("TIME_LIMIT") = kTimeLimit;
  bp::scope().attr("ITERATION_LIMIT") = kIterationLimit;
  bp::scope().attr("START_INVALID") = kStartInvalid;
  bp::scope().attr("GOAL_INVALID") = kGoalInvalid;
  bp::class_<CollisionKernel, boost::noncopyable>(
      "CollisionKernel",
      bp::init<bp::object, bp::object, bp::object, bp::object, int>(bp::args(
          "self", "model", "data", "geometry_model", "geometry_data", "cache_size")))
      .add_property("nq", &CollisionKernel::nq)
      .add_property("checks", &CollisionKernel::checks)
      .add_property("ngeoms", &CollisionKernel::ngeoms)
      .add_property("npairs", &CollisionKernel::npairs)
      .def("reset_checks", &CollisionKernel::reset_checks)
      .def("set_cache_size", &CollisionKernel::set_cache_size)
      .add_property("mode", &CollisionKernel::mode, &CollisionKernel::set_mode)
      .def("collisions", &CollisionKernel::collisions)
      .def("first_invalid", &CollisionKernel::first_invalid)
      .def("set_spheres", &CollisionKernel::set_spheres,
           set_spheres_overloads(
               bp::args("self", "centers", "radii", "joints", "geometries", "certified_margin")))
      .add_property("has_spheres", &CollisionKernel::has_spheres)
      .add_property("certified_margin", &CollisionKernel::certified_margin)
      .add_property("sphere_count", &CollisionKernel::sphere_count)
      .def("sphere_stats", &CollisionKernel::sphere_stats)
      .def("mark_exact_pairs", &CollisionKernel::mark_exact_pairs, bp::args("self", "qs"))
      .def("set_sphere_filter", &CollisionKernel::set_sphere_filter, bp::args("self", "mode"))
      .def("sphere_filter", &CollisionKernel::sphere_filter)
      .add_property("sphere_filter_mode", &CollisionKernel::sphere_filter_mode)
      .def("set_simd", &CollisionKernel::set_simd, bp::args("self", "level"))
      .add_property("simd", &CollisionKernel::simd)
      .add_static_property("max_simd", &CollisionKernel::max_simd)
      .def("sphere_filter_eps", &CollisionKernel::sphere_filter_eps)
      .def("sphere_filter_bound", &CollisionKernel::sphere_filter_bound)
      .def("sphere_filter_units", &CollisionKernel::sphere_filter_units)
      .def("sphere_filter_flags", &CollisionKernel::sphere_filter_flags, bp::args("self", "qs"))
      .def("sphere_filter_pairs", &CollisionKernel::sphere_filter_pairs, bp::args("self", "qs"))
      .def("sphere_filter_placements", &CollisionKernel::sphere_filter_placements,
           bp::args("self", "qs"))
      .def("reset_sphere_stats", &CollisionKernel::reset_sphere_stats)
      .def("collisions_with", &CollisionKernel::collisions_with,
           bp::args("self", "configurations", "checker"))
      .def("first_invalid_on_edge", &CollisionKernel::first_invalid_on_edge,
           bp::args("self", "q0", "q1", "n", "checker"))
      .def("certify_edge", &CollisionKernel::certify_edge_py,
           bp::args("self", "q0", "q1", "min_step", "max_step"))
      .def("clearance", &CollisionKernel::clearance_py, bp::args("self", "q", "direction", "cap"))
      .def("motion_bounds", &CollisionKernel::motion_bounds_py)
      .add_property("clearance_checks", &CollisionKernel::clearance_checks);
  bp::scope().attr("CHECKER_MESH") = kMesh;
  bp::scope().attr("CHECKER_SPHERES") = kSpheres;
  bp::scope().attr("CHECKER_SPHERES_ONLY") = kSpheresOnly;
  bp::scope().attr("CHECKER_CLEARANCE") = kClearance;
  register_path_certifier();
  bp::def("tree_nearest", &tree_nearest, bp::args("nodes", "removed", "queries"));
  bp::def("plan_rng_draws", &plan_rng_draws, bp::args("seed", "n", "bound"));
  bp::def("set_clearance_tuning", &set_clearance_tuning,
          bp::args("min_fraction", "max_fraction"));
  bp::def("_rrt_connect_checked", &rrt_connect,
          (bp::arg("checker"), bp::arg("start"), bp::arg("goal"), bp::arg("lower"),
           bp::arg("upper"), bp::arg("alpha"), bp::arg("delta"), bp::arg("delta_c"),
           bp::arg("local"), bp::arg("sigma"), bp::arg("trapped"), bp::arg("max_iterations"),
           bp::arg("time_limit"), bp::arg("seed"), bp::arg("collision_checker") = kMesh,
           bp::arg("fallback_iterations") = -1L, bp::arg("validator") = kMesh,
           bp::arg("regions") = bp::object()));
  // the module's rrt_connect: the fast entry in front of _rrt_connect_checked
  g_rrt_connect_checked = bp::incref(bp::object(bp::scope().attr("_rrt_connect_checked")).ptr());
  g_ndarray = bp::incref(bp::object(bp::import("numpy").attr("ndarray")).ptr());
  if (PyModule_AddFunctions(bp::scope().ptr(), kRRTConnectMethods) < 0)
    bp::throw_error_already_set();
}
