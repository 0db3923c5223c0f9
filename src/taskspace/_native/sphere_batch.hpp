// Single-precision sphere filter for batches of configurations (#22 item 4; VAMP-style:
// Thomason, Kingston and Kavraki, ICRA 2024). Included by planning_kernel.cpp.
//
// What it answers. For kLanes configurations (q, one lane per configuration; load_q computes
// their joint placements in single precision through the same chain as the kernel's
// kinematics_batch, whose double placements the kernel then computes only for a batch with a
// lane in the mask), a bit mask of the lanes that MAY collide for the robot's spheres (the
// kernel's sphere checkers). A lane outside the mask is certainly free for the double-precision
// sphere test of the kernel (spheres_placed): every test below is that test's, on the same
// pairs, with the same margins, in single precision with every radius inflated by eps_ (the
// bound on the rounding error below). The kernel then runs its exact double-precision check
// (spheres_placed's per-pair test, with coal's narrow phase for the "spheres" checker) on the
// lanes in the mask only, in the order of the edge, and there only on the pairs the filter
// cannot clear for that lane (first_pair, next_pair: the same bound holds pair by pair, each
// pair's float tests being that pair's double tests inflated), so the answers are the scalar
// path's answers exactly; the filter only decides which configurations and pairs need that
// check.
//
// Hierarchy, every level lane-wise (4 configurations in one SSE register; no branch per lane):
//  1. per link and active lane: the link's bounding sphere against the static obstacles'
//     world boxes (the kernel's boxes_, inflated as Pinocchio's managers do), 4 obstacles per
//     vector operation (link_obstacles); then the (link, obstacle) units of the touched
//     obstacles only (a batch often has 1-2 active lanes: testing every unit for 4 lanes cost
//     10-20 % more kernel time in the planner);
//     (each link only against the obstacles it can reach at all: make_reach)
//  1b. per object group of the unit (a link's neighbouring objects under one sphere, e.g. a
//     hand, each finger: make_groups): the group's sphere against the box and the primitive
//     (self pairs: against the other link's sphere); its objects only when it passes;
//  2. per moving object of the unit: its bounding sphere against the box and against the
//     primitive (box, ball, cylinder, capsule: exact point distance in the obstacle's frame);
//     the centres of its clusters (kCluster neighbouring spheres with their bounding sphere)
//     are computed only when its bounding sphere passes (once per load: most objects the
//     link level reaches stop here);
//  3. per cluster of the object: its bounding sphere against the primitive (or the box),
//     its sphere centres computed only when it passes (once per load);
//  4. per sphere of the cluster: against the primitive (or the box for other shapes: the
//     kernel then asks coal);
//  self pairs: per (link, link) unit the two links' bounding spheres, per object pair the
//  objects' bounding spheres, then per cluster of a against b's bounding sphere and b's
//  clusters, then sphere against sphere.
// The unit that last made the first lane "maybe" is tested first (as the kernel's pair cache).
// run() stops as soon as the lane given as `stop_lane` is in the mask (an edge needs its first
// colliding configuration only: the kernel checks that lane exactly, returns when it collides,
// else runs the filter again on the remaining lanes).
//
// Rounding error bound (eps_). u = 2^-24 (float's unit roundoff); S >= 1 m bounds the absolute
// value of every coordinate, radius and half-size involved (setup: the obstacles' translations
// and extents; the links' reach: the sum of the joint placements' translations, a prismatic
// joint's travel (its limits) included, plus the largest extent of a sphere about its joint).
// Higham's gamma_n = n u / (1 - n u) < 1.01 n u for n u < 0.01; norms are Euclidean
// (Frobenius for matrices), which a rotation preserves. n: the depth of the chain (moving
// joints from the universe to the deepest joint; the Panda's 7).
//  - Sine and cosine (sincos4): the reduction in double (error below 1e-15), r rounded to
//    float (u |r|), Cephes' polynomials (about 1.5 u with their rounding): within 2 u each
//    (tested on a dense grid).
//  - Joint rotation R_k = R_{k-1} R0_k Rz(q_k), per joint at most e_R = 21 u added (Frobenius):
//    the product with R0 (rounded to float: 3 u; 9 entries within gamma_3: 9.1 u; a signed
//    permutation, the Panda's, is exact), the turn of columns b, d: c cb + s cd within
//    gamma_2 (|c||cb| + |s||cd|) <= 2.02 u |(cb, cd)| per entry (Cauchy-Schwarz), 2.86 u over
//    the two columns, plus the sine and cosine errors: 2 * 2 u * 2 = 8 u. The error carried
//    from the parent is not amplified (times rotations; their own deviation from orthogonal,
//    below 200 u, changes it by a relative 1e-5). Depth d: within 21 d u.
//  - Joint translation t_k = R_{k-1} t0_k + t_{k-1} (+ q R e_axis, prismatic): the carried
//    rotation error times |t0_k|, plus t0 rounded (u |t0|) and the sums and products
//    (gamma_4 per coordinate on |t0| + S, sqrt 3 over three: 7 u (|t0| + S)): per joint
//    (d-1) e_R |t0_k| + 8 u |t0_k| + 7 u S (twice for a prismatic joint's two steps). Summed,
//    with sum |t0| <= S: depth d within (21 d + 14 d + 8) u S = (35 d + 8) u S.
//  - Sphere centre c = R p + t in float: n e_R |p| + (the translation) + p rounded and the
//    products and sums (sqrt 3 (u + gamma_3 2) S < 12.3 u S); with |p| + sum |t0| <= S:
//    |c_float - c| < (21 n + 14 n + 20.3) u S = (35 n + 20.3) u S =: C.
//  - Obstacle frame and distance (the old chain after the centre, with the centre's error
//    now C: a rotation preserves it): l = R_o^T (c - t_o) within C + 67 u S, the distance
//    to the primitive within C + 130 u S (the per-coordinate terms of 67 u S, sqrt 3 over
//    the norm, the squared sums' gamma_4 on both sides of d^2 <= R^2: 5 u S).
//  - Sphere-sphere tests (self pairs): two centres, each within C: 2 C + 10 u S.
// Total < 2 C + 130 u S = (70 n + 170.6) u S; eps_ = (140 n + 342) u S, twice the bound (the
// Panda, n = 7, S = 1.52 m on the MotionBenchMaker scenes: 0.12 mm; the measured errors of
// the placements are about 4 u (rotation) and 4 u m (translation), tests/planning/
// test_planning_float_kinematics.py). Over it,
// a lane the double test finds colliding (distance <= r) has float distance < r + eps_: never
// "free"; a lane whose float distance is below r - eps_ has double distance below r: colliding
// for the double test too (sure(), the trusted "spheres only" lanes).
// tests/planning/test_planning_sphere_batch.py checks it on configurations bisected to within
// 1e-9 of first contact (without the inflation those fail).
// Included three times by planning_kernel.cpp: the plain build (namespace
// taskspace_sphere_batch) and the same code under `#pragma GCC target` for x86-64-v3 (AVX2,
// FMA) and x86-64-v4 (AVX-512) in namespaces taskspace_sphere_batch_avx2 / _avx512 (the
// macro TASKSPACE_SPHERE_BATCH_NS), chosen at run time by the kernel. GCC fuses a * b + c
// where FMA is enabled: one rounding instead of two, within every step of the bound above
// (each fused step's error bound is at most the unfused one's), so every build's float tests
// keep the bound, and the kernel's answers (the double test decides every lane the filter
// does not clear) are the same. The set-up types (Input, Obstacle, bounding_sphere) are
// defined once.
#ifndef TASKSPACE_SPHERE_BATCH_NS
#define TASKSPACE_SPHERE_BATCH_NS taskspace_sphere_batch
#endif
#ifndef TASKSPACE_SPHERE_BATCH_COMMON
#define TASKSPACE_SPHERE_BATCH_COMMON

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <vector>

#if defined(__SSE__) || defined(__x86_64__)
#include <xmmintrin.h>
#define TASKSPACE_SPHERE_BATCH_SSE 1
#endif

namespace taskspace_sphere_batch {

// The bounding sphere of n spheres, sphere(q) giving the q-th as {x, y, z, r}: centre (mid) the
// middle of their axis-aligned box, radius the largest distance from it plus the sphere's
// radius (each sphere inside). The kernel's objects (set_spheres) and the filter's clusters.
template <typename Sphere>
double bounding_sphere(int n, Sphere&& sphere, double mid[3]) {
  double lo[3], hi[3];
  for (int a = 0; a < 3; ++a) {
    lo[a] = std::numeric_limits<double>::infinity();
    hi[a] = -lo[a];
  }
  for (int q = 0; q < n; ++q) {
    const std::array<double, 4> s = sphere(q);
    for (int a = 0; a < 3; ++a) {
      lo[a] = std::min(lo[a], s[a] - s[3]);
      hi[a] = std::max(hi[a], s[a] + s[3]);
    }
  }
  for (int a = 0; a < 3; ++a) mid[a] = 0.5 * (lo[a] + hi[a]);
  double radius = 0.0;
  for (int q = 0; q < n; ++q) {
    const std::array<double, 4> s = sphere(q);
    const double dx = s[0] - mid[0], dy = s[1] - mid[1], dz = s[2] - mid[2];
    radius = std::max(radius, std::sqrt(dx * dx + dy * dy + dz * dz) + s[3]);
  }
  return radius;
}

// Static obstacle (a static partner of a moving object), as the kernel describes it.
struct Obstacle {
  int type = 0;  // 0 other shape (its box only), 1 box, 2 ball, 3 cylinder, 4 capsule
  double R[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1};  // rotation, R[r + 3 c]
  double t[3] = {0, 0, 0};
  double half[3] = {0, 0, 0};
  double radius = 0.0, half_length = 0.0, swept = 0.0;
  double lo[3] = {0, 0, 0}, hi[3] = {0, 0, 0};  // world box (the kernel's boxes_)
};

// Set-up input: per moving object its link (index into links), its bounding sphere and its
// spheres (joint frame); per link its joint and bounding sphere; the pairs (moving object a,
// partner b, margin, b static?).
struct Input {
  struct Link {
    int joint;
    double center[3];
    double radius;
  };
  struct Object {
    int geometry;
    int link;
    double center[3];
    double radius;
    std::vector<double> sph;  // x, y, z, r per sphere
  };
  struct Pair {
    int a, b;  // indices into objects (a) and objects or obstacles (b)
    bool b_static;
    double margin;
    bool exact = false;  // the kernel tests it exactly: its touching spheres are not "sure"
  };
  std::vector<Link> links;
  std::vector<Object> objects;
  std::vector<Obstacle> obstacles;
  std::vector<Pair> pairs;
  double scale = 1.0;  // S of the error bound (>= 1 m)
  // The joint chain (joints 1..n; joint 0, the universe, at the identity): per joint its
  // parent, kind (0 revolute, 1 prismatic) about or along axis (0 x, 1 y, 2 z), its
  // coordinate in q and its placement in the parent (R0[r + 3 c], t0): the kernel's
  // kinematics_batch, whose placements load_q computes in single precision.
  struct Joint {
    int parent, kind, axis, idx_q;
    double R0[9], t0[3];
  };
  std::vector<Joint> chain;
};

}  // namespace taskspace_sphere_batch
#endif  // TASKSPACE_SPHERE_BATCH_COMMON

namespace TASKSPACE_SPHERE_BATCH_NS {

using taskspace_sphere_batch::bounding_sphere;
using taskspace_sphere_batch::Input;
using taskspace_sphere_batch::Obstacle;

constexpr int kLanes = 4;
typedef float F4 __attribute__((vector_size(kLanes * sizeof(float))));
typedef int I4 __attribute__((vector_size(kLanes * sizeof(int))));
typedef double D4 __attribute__((vector_size(kLanes * sizeof(double)), aligned(16)));

inline unsigned lanes_of(I4 m) {
#ifdef TASKSPACE_SPHERE_BATCH_SSE
  __m128 v;
  __builtin_memcpy(&v, &m, sizeof v);
  return static_cast<unsigned>(_mm_movemask_ps(v));
#else
  unsigned b = 0;
  for (int l = 0; l < kLanes; ++l) b |= (m[l] != 0 ? 1u : 0u) << l;
  return b;
#endif
}
inline F4 splat(float x) { return F4{x, x, x, x}; }
// kLaneMask[m]: all ones in the lanes of bit mask m
constexpr I4 kLaneMask[16] = {
    {0, 0, 0, 0},   {-1, 0, 0, 0},   {0, -1, 0, 0},   {-1, -1, 0, 0},
    {0, 0, -1, 0},  {-1, 0, -1, 0},  {0, -1, -1, 0},  {-1, -1, -1, 0},
    {0, 0, 0, -1},  {-1, 0, 0, -1},  {0, -1, 0, -1},  {-1, -1, 0, -1},
    {0, 0, -1, -1}, {-1, 0, -1, -1}, {0, -1, -1, -1}, {-1, -1, -1, -1}};
inline F4 vmax(F4 a, F4 b) { return a > b ? a : b; }
inline F4 vmin(F4 a, F4 b) { return a < b ? a : b; }
inline F4 vabs(F4 a) { return vmax(a, -a); }
inline F4 vsqrt(F4 x) {
#ifdef TASKSPACE_SPHERE_BATCH_SSE
  __m128 v;
  __builtin_memcpy(&v, &x, sizeof v);
  v = _mm_sqrt_ps(v);
  F4 r;
  __builtin_memcpy(&r, &v, sizeof r);
  return r;
#else
  F4 r;
  for (int l = 0; l < kLanes; ++l) r[l] = std::sqrt(x[l]);
  return r;
#endif
}
inline F4 to_float(const D4& d) { return __builtin_convertvector(d, F4); }

class SphereFilter {
 public:
  bool ready() const { return ready_; }
  double eps() const { return eps_; }
  double scale() const { return scale_; }  // S of the bound

  void setup(const Input& in) {
    ready_ = false;
    links_.clear();
    objects_.clear();
    clusters_.clear();
    obs_.clear();
    sph_.clear();
    static_units_.clear();
    self_units_.clear();
    last_unit_ = -1;
    const double u = std::ldexp(1.0, -24);
    // the chain's depth n (moving joints from the universe to the deepest joint): the bound
    // of the header grows with it
    joints_.clear();
    std::vector<int> depth(in.chain.size() + 1, 0);
    int n = 0;
    for (std::size_t k = 0; k < in.chain.size(); ++k) {
      const Input::Joint& j = in.chain[k];
      JointF f;
      f.parent = j.parent;
      f.kind = j.kind;
      f.axis = j.axis;
      f.idx_q = j.idx_q;
      for (int a = 0; a < 3; ++a) f.t0[a] = splat(static_cast<float>(j.t0[a]));
      // a signed permutation (entries within 1e-12 of 0 or +-1, the Panda's rpy of multiples
      // of pi/2 with their 6e-17): column c is +-column src[c] of the parent, exactly
      f.perm = true;
      for (int c = 0; c < 3; ++c) {
        int ones = 0;
        for (int r = 0; r < 3; ++r) {
          const double x = j.R0[r + 3 * c];
          if (std::abs(std::abs(x) - 1.0) < 1e-12) {
            ++ones;
            f.src[c] = r;
            f.sign[c] = splat(x > 0 ? 1.0f : -1.0f);
          } else if (std::abs(x) >= 1e-12) {
            f.perm = false;
          }
        }
        if (ones != 1) f.perm = false;
      }
      for (int e = 0; e < 9; ++e) f.R0[e] = splat(static_cast<float>(j.R0[e]));
      joints_.push_back(f);
      depth[k + 1] = depth[j.parent] + 1;
      n = std::max(n, depth[k + 1]);
    }
    poses_.assign(in.chain.size() + 1, PoseF{});
    motion_.assign(2 * in.chain.size(), F4{});
    serial_ = true;
    for (std::size_t k = 0; k < in.chain.size(); ++k)
      serial_ = serial_ && in.chain[k].parent == static_cast<int>(k);
    for (int a = 0; a < 3; ++a) poses_[0].R[4 * a] = splat(1.0f);
    scale_ = std::max(1.0, in.scale);
    depth_ = n;
    eps_ = (140.0 * n + 342.0) * u * scale_;
    for (const auto& l : in.links)
      links_.push_back(LinkF{l.joint, f3(l.center), static_cast<float>(l.radius), {}});
    for (const auto& o : in.objects) {
      ObjectF of;
      of.link = o.link;
      of.center = f3(o.center);
      of.radius = static_cast<float>(o.radius);
      of.begin = static_cast<int>(sph_.size());
      // the spheres in order along the axis of their centres' largest spread, cut into
      // clusters of kCluster neighbours, each with its bounding sphere (double, as the
      // object's): a cluster away from the obstacle skips its spheres (same answers: a lane
      // hits where any of the object's spheres hits, in any order)
      const int n = static_cast<int>(o.sph.size() / 4);
      std::vector<int> order(n);
      double lo[3] = {0, 0, 0}, hi[3] = {0, 0, 0};
      for (int k = 0; k < n; ++k) {
        order[k] = k;
        for (int a = 0; a < 3; ++a) {
          const double x = o.sph[4 * k + a];
          lo[a] = k == 0 ? x : std::min(lo[a], x);
          hi[a] = k == 0 ? x : std::max(hi[a], x);
        }
      }
      int axis = 0;
      for (int a = 1; a < 3; ++a)
        if (hi[a] - lo[a] > hi[axis] - lo[axis]) axis = a;
      std::stable_sort(order.begin(), order.end(), [&o, axis](int i, int j) {
        return o.sph[4 * i + axis] < o.sph[4 * j + axis];
      });
      of.cbegin = static_cast<int>(clusters_.size());
      for (int c0 = 0; c0 < n; c0 += kCluster) {
        const int c1 = std::min(n, c0 + kCluster);
        double mid[3];
        const double radius = bounding_sphere(
            c1 - c0,
            [&o, &order, c0](int q) {
              const double* sp = &o.sph[4 * order[c0 + q]];
              return std::array<double, 4>{sp[0], sp[1], sp[2], sp[3]};
            },
            mid);
        ClusterF cf{f3(mid), static_cast<float>(radius), static_cast<int>(sph_.size()), 0};
        for (int q = c0; q < c1; ++q) {
          const double* sp = &o.sph[4 * order[q]];
          sph_.push_back(SphF{{static_cast<float>(sp[0]), static_cast<float>(sp[1]),
                               static_cast<float>(sp[2])},
                              static_cast<float>(sp[3])});
        }
        cf.end = static_cast<int>(sph_.size());
        clusters_.push_back(cf);
      }
      of.cend = static_cast<int>(clusters_.size());
      of.end = static_cast<int>(sph_.size());
      objects_.push_back(of);
    }
    for (const auto& o : in.obstacles) {
      ObsF f;
      f.type = o.type;
      // (every value broadcast to the lanes once here, not at each test)
      for (int k = 0; k < 9; ++k) f.R[k] = splat(static_cast<float>(o.R[k]));
      for (int a = 0; a < 3; ++a) {
        f.t[a] = splat(static_cast<float>(o.t[a]));
        f.half[a] = splat(static_cast<float>(o.half[a]));
        f.lo[a] = splat(static_cast<float>(o.lo[a]));
        f.hi[a] = splat(static_cast<float>(o.hi[a]));
      }
      f.radius = static_cast<float>(o.radius);
      f.half_length = static_cast<float>(o.half_length);
      f.radius4 = splat(f.radius);
      f.half_length4 = splat(f.half_length);
      f.swept = static_cast<float>(o.swept);
      obs_.push_back(f);
    }
    const float e = static_cast<float>(eps_);
    // units: (link, obstacle) and (link, link), each with its object pairs
    for (int pair = 0; pair < static_cast<int>(in.pairs.size()); ++pair) {
      const Input::Pair& p = in.pairs[pair];
      const int la = objects_[p.a].link;
      if (p.b_static) {
        StaticUnit* unit = nullptr;
        for (auto& s : static_units_)
          if (s.link == la && s.obstacle == p.b) unit = &s;
        if (!unit) {
          static_units_.push_back(StaticUnit{la, p.b, 0.0f, {}, {}});
          unit = &static_units_.back();
        }
        unit->items.push_back(Item{p.a, -1, static_cast<float>(p.margin) + e,
                                   static_cast<float>(p.margin) - e, pair, p.exact});
        unit->margin = std::max(unit->margin, static_cast<float>(p.margin) + e);
      } else {
        const int l0 = std::min(la, objects_[p.b].link), l1 = std::max(la, objects_[p.b].link);
        SelfUnit* unit = nullptr;
        for (auto& s : self_units_)
          if (s.la == l0 && s.lb == l1) unit = &s;
        if (!unit) {
          self_units_.push_back(SelfUnit{l0, l1, 0.0f, {}, {}});
          unit = &self_units_.back();
        }
        unit->items.push_back(Item{p.a, p.b, static_cast<float>(p.margin) + e,
                                   static_cast<float>(p.margin) - e, pair, p.exact});
        unit->margin = std::max(unit->margin, static_cast<float>(p.margin) + e);
      }
    }
    make_groups(in, e);
    // per link and obstacle its static unit; obstacle boxes in blocks of 4 (at most 64)
    by_link_ = obs_.size() <= 64;
    unit_of_.assign(links_.size() * obs_.size(), -1);
    for (int a = 0; a < 3; ++a) {
      blo_[a].assign((obs_.size() + 3) / 4, splat(std::numeric_limits<float>::infinity()));
      bhi_[a].assign((obs_.size() + 3) / 4, splat(-std::numeric_limits<float>::infinity()));
    }
    binfl_.assign((obs_.size() + 3) / 4, F4{});
    for (std::size_t k = 0; k < static_units_.size(); ++k) {
      const StaticUnit& u = static_units_[k];
      unit_of_[u.link * obs_.size() + u.obstacle] = static_cast<int>(k);
      const std::size_t b = u.obstacle / 4, lane = u.obstacle % 4;
      for (int a = 0; a < 3; ++a) {
        blo_[a][b][lane] = obs_[u.obstacle].lo[a][0];
        bhi_[a][b][lane] = obs_[u.obstacle].hi[a][0];
      }
      const float infl = u.margin + obs_[u.obstacle].swept;
      if (infl > binfl_[b][lane]) binfl_[b][lane] = infl;
    }
    make_reach(in);
    bound_stamp_.assign(objects_.size(), 0u);
    sph_stamp_.assign(objects_.size(), 0u);
    clu_stamp_.assign(clusters_.size(), 0u);
    grp_stamp_.assign(groups_.size(), 0u);
    grp_world_.assign(groups_.size(), V3{});
    clu_world_.assign(clusters_.size(), V3{});
    obj_world_.assign(objects_.size(), V3{});
    sph_world_.assign(sph_.size(), V3{});
    ready_ = true;
  }

  // The joint placements of kLanes configurations (lane l: the coordinates at q[l]) in
  // single precision through the chain (parent * joint placement * joint motion, as the
  // kernel's kinematics_batch in double; the header's bound), and the links' bounding sphere
  // centres.
  void load_q(const double* const* q) {
    ++stamp_;
    if (stamp_ == 0) {
      std::fill(bound_stamp_.begin(), bound_stamp_.end(), 0u);
      std::fill(sph_stamp_.begin(), sph_stamp_.end(), 0u);
      std::fill(clu_stamp_.begin(), clu_stamp_.end(), 0u);
      std::fill(grp_stamp_.begin(), grp_stamp_.end(), 0u);
      stamp_ = 1;
    }
    // the joints' motions first (they do not depend on the chain): sines and cosines of the
    // revolute joints, the float coordinate of the prismatic ones
    const std::size_t nj = joints_.size();
    std::size_t k = 0;
    typedef Lanes<2 * kLanes> L2;
    for (; k + 1 < nj; k += 2) {  // two revolute joints in one vector
      const JointF& f = joints_[k];
      const JointF& g = joints_[k + 1];
      if (f.kind != 0 || g.kind != 0) break;
      typename L2::D v;
      for (int l = 0; l < kLanes; ++l) {
        v[l] = q[l][f.idx_q];
        v[l + kLanes] = q[l][g.idx_q];
      }
      typename L2::F s, c;
      sincos_n<2 * kLanes>(v, s, c);
      __builtin_memcpy(&motion_[2 * k], &s, sizeof(F4));
      __builtin_memcpy(&motion_[2 * k + 1], &c, sizeof(F4));
      __builtin_memcpy(&motion_[2 * k + 2], reinterpret_cast<const float*>(&s) + kLanes, sizeof(F4));
      __builtin_memcpy(&motion_[2 * k + 3], reinterpret_cast<const float*>(&c) + kLanes, sizeof(F4));
    }
    for (; k < nj; ++k) {
      const JointF& f = joints_[k];
      D4 v;
      for (int l = 0; l < kLanes; ++l) v[l] = q[l][f.idx_q];
      if (f.kind == 0) {
        sincos4(v, motion_[2 * k], motion_[2 * k + 1]);
      } else {
        motion_[2 * k] = to_float(v);
      }
    }
    if (serial_) {
      chain_serial();
    } else {
      for (std::size_t k = 0; k < nj; ++k) {
        const JointF& f = joints_[k];
        const PoseF& P = poses_[f.parent];
        PoseF& M = poses_[k + 1];
        joint_step(f, P.R, P.t, M.R, M.t, motion_[2 * k], motion_[2 * k + 1]);
      }
    }
    for (LinkF& l : links_) l.world = place(l, l.center);
  }

  // Lane l of joint j's placement of the last load_q: R (R[r + 3 c]) then t. Tests.
  std::array<float, 12> placement(int j, int l) const {
    std::array<float, 12> out{};
    for (int k = 0; k < 9; ++k) out[k] = poses_[j].R[k][l];
    for (int a = 0; a < 3; ++a) out[9 + a] = poses_[j].t[a][l];
    return out;
  }
  int joints() const { return static_cast<int>(poses_.size()); }
  int depth() const { return depth_; }  // n of the bound: moving joints on the longest chain

  // Sines and cosines of the lanes of x in single precision: x = j pi/2 + r reduced in double
  // (j the nearest integer, pi/2 in two parts, fdlibm's: j pi/2 exact for |j| < 2^20, r
  // within 1e-16 |r|), r rounded to float, then Cephes' sinf / cosf polynomials on
  // [-pi/4, pi/4] and the quadrant j mod 4. Absolute error below 2 u (u = 2^-24; tested
  // against double on a dense grid). Lanes beyond |x| < 1e5 (or not finite) take std::sin /
  // std::cos in double, rounded.
  static void sincos4(const D4& x, F4& s, F4& c) { sincos_n<kLanes>(x, s, c); }
  // sincos4 on N lanes at once (the same operations lane by lane: the same values; the
  // joints of load_q two at a time, 8 lanes).
  template <int N>
  struct Lanes {
    typedef double D __attribute__((vector_size(N * sizeof(double))));
    typedef float F __attribute__((vector_size(N * sizeof(float))));
    typedef std::uint64_t U __attribute__((vector_size(N * sizeof(std::uint64_t))));
    typedef unsigned V __attribute__((vector_size(N * sizeof(unsigned))));
  };
  template <int N>
  static void sincos_n(const typename Lanes<N>::D& x, typename Lanes<N>::F& s,
                       typename Lanes<N>::F& c) {
    typedef typename Lanes<N>::D DN;
    typedef typename Lanes<N>::F FN;
    typedef typename Lanes<N>::U UN;
    typedef typename Lanes<N>::V VN;
    constexpr double kTwoOverPi = 6.36619772367581382433e-01;
    constexpr double kPio2Hi = 1.57079632673412561417e+00;  // first 33 bits of pi/2
    constexpr double kPio2Lo = 6.07710050650619224932e-11;  // pi/2 - kPio2Hi
    constexpr double kRound = 6755399441055744.0;           // 1.5 * 2^52: round to nearest
    bool plain = true;
    for (int l = 0; l < N; ++l) plain = plain && std::abs(x[l]) < 1e5;
    if (!plain) {
      for (int l = 0; l < N; ++l) {
        s[l] = static_cast<float>(std::sin(x[l]));
        c[l] = static_cast<float>(std::cos(x[l]));
      }
      return;
    }
    const DN y = x * kTwoOverPi + kRound;  // j in the low mantissa bits (see kinematics_batch)
    const DN j = y - kRound;
    const FN r = __builtin_convertvector((x - j * kPio2Hi) - j * kPio2Lo, FN);
    const FN z = r * r;
    const FN sr = ((-1.9515295891e-4f * z + 8.3321608736e-3f) * z - 1.6666654611e-1f) * z * r + r;
    const FN cr = ((2.443315711809948e-5f * z - 1.388731625493765e-3f) * z +
                   4.166664568298827e-2f) *
                      z * z -
                  0.5f * z + 1.0f;
    UN yb;
    __builtin_memcpy(&yb, &y, sizeof yb);
    const VN q = __builtin_convertvector(yb, VN) & 3u;
    VN bs, bc;
    __builtin_memcpy(&bs, &sr, sizeof bs);
    __builtin_memcpy(&bc, &cr, sizeof bc);
    // (sin, cos) = (sr, cr), (cr, -sr), (-sr, -cr), (-cr, sr) for q = 0..3
    const VN swap = VN{} - (q & 1u);
    const VN os = ((bs & ~swap) | (bc & swap)) ^ ((q & 2u) << 30);
    const VN oc = ((bc & ~swap) | (bs & swap)) ^ (((q + 1u) & 2u) << 30);
    __builtin_memcpy(&s, &os, sizeof s);
    __builtin_memcpy(&c, &oc, sizeof c);
  }

  // Lanes (bits) of `active` that may collide; stops when `stop_lane` is among them. For each
  // lane of the mask the run keeps where it entered the mask (first_pair, next_pair).
  unsigned run(unsigned active, int stop_lane) {
    unsigned maybe = 0;
    sure_ = 0;
    const unsigned stop_bit = 1u << stop_lane;
    const int ns = static_cast<int>(static_units_.size());
    const int nu = ns + static_cast<int>(self_units_.size());
    first_unit_ = last_unit_ >= 0 && last_unit_ < nu ? last_unit_ : -1;
    if (first_unit_ >= 0) {
      maybe |= unit_hits(first_unit_, active);
      enter(maybe, 0, 0, 0, first_unit_);
      if (maybe & stop_bit) return maybe;
    }
    if (by_link_) {
      // static units: per link and active lane, the obstacles whose (inflated) box its
      // bounding sphere touches, 4 obstacles per vector operation; then the units of those
      for (std::size_t li = 0; li < links_.size(); ++li) {
        const unsigned act = active & ~maybe;
        if (!act) continue;
        // one lane: its obstacle bits; several: the obstacles the lanes' union sphere
        // touches (a superset of every lane's), then lane-wise per such obstacle
        const bool one = (act & (act - 1)) == 0;
        std::uint64_t any =
            one ? link_obstacles(li, __builtin_ctz(act)) : link_union_obstacles(li, act);
        while (any) {
          const int ob = __builtin_ctzll(any);
          any &= any - 1;
          const int k = unit_of_[li * obs_.size() + ob];
          if (k < 0 || k == first_unit_) continue;
          const unsigned near = one ? act : link_obstacle_lanes(li, ob) & act;
          const unsigned h = static_leaves(k, near & active & ~maybe);
          if (!h) continue;
          enter(h, 1, static_cast<int>(li), ob, k);
          maybe |= h;
          if (maybe & stop_bit) {
            last_unit_ = k;
            return maybe;
          }
          if (maybe == active) return maybe;
        }
      }
    }
    for (int k = by_link_ ? ns : 0; k < nu; ++k) {
      if (k == first_unit_) continue;
      const unsigned h = unit_hits(k, active & ~maybe);
      if (!h) continue;
      enter(h, 2, 0, k, k);
      maybe |= h;
      if (maybe & stop_bit) {
        last_unit_ = k;
        return maybe;
      }
      if (maybe == active) return maybe;
    }
    return maybe;
  }

  // The pairs (indices into Input::pairs) that lane `lane` of the last run's mask may collide
  // on: first_pair gives the pair that put the lane in the mask, each next_pair the next pair
  // whose tests (as run's, in run's order, from that point on, for this lane alone) pass, -1
  // when none is left. Every pair of the lane never given is free for the double test: the run
  // or the walk cleared it with the tests of the header (the eps_ bound), as run clears a lane
  // (tests: the double test of the given pairs only has the double test's answers). Valid
  // until the next run or load; one lane at a time (the walk's state is the filter's).
  int first_pair(int lane) {
    walk_ = mark_[lane];
    walk_lane_ = lane;
    if (walk_.phase == 1) {  // the link's other obstacles after this one, as run
      const std::uint64_t bits = link_obstacles(static_cast<std::size_t>(walk_.li), lane);
      walk_.rest = walk_.pos >= 63 ? 0 : bits & (~std::uint64_t{0} << (walk_.pos + 1));
    }
    return items_of(walk_.unit)[walk_.item].pair;
  }
  int next_pair() {
    const unsigned bit = 1u << walk_lane_;
    const int ns = static_cast<int>(static_units_.size());
    const int nu = ns + static_cast<int>(self_units_.size());
    Walk& w = walk_;
    for (;;) {
      if (w.unit >= 0) {  // the rest of the unit's items
        const std::vector<Item>& items = items_of(w.unit);
        for (++w.item; w.item < static_cast<int>(items.size()); ++w.item) {
          const Item& it = items[w.item];
          const unsigned h = w.unit < ns
                                 ? static_item(obs_[static_units_[w.unit].obstacle], it, bit)
                                 : self_item(it, bit);
          if (h) return it.pair;
        }
        w.unit = -1;
      }
      // the next unit whose link level passes for the lane
      if (w.phase == 0) {  // after the run's first unit: the link walk from its start
        w.phase = 1;
        w.li = 0;
        w.rest = by_link_ && !links_.empty() ? link_obstacles(0, walk_lane_) : 0;
      }
      if (w.phase == 1) {
        while (by_link_ && w.unit < 0 && w.li < static_cast<int>(links_.size())) {
          if (!w.rest) {
            if (++w.li < static_cast<int>(links_.size()))
              w.rest = link_obstacles(static_cast<std::size_t>(w.li), walk_lane_);
            continue;
          }
          const int ob = __builtin_ctzll(w.rest);
          w.rest &= w.rest - 1;
          const int k = unit_of_[static_cast<std::size_t>(w.li) * obs_.size() + ob];
          if (k < 0 || k == first_unit_) continue;
          w.unit = k;
          w.item = -1;
        }
        if (w.unit >= 0) continue;
        w.phase = 2;
        w.pos = by_link_ ? ns - 1 : -1;  // the unit loop of run, from its start
      }
      while (w.unit < 0 && ++w.pos < nu)
        if (w.pos != first_unit_ && unit_near(w.pos, bit)) {
          w.unit = w.pos;
          w.item = -1;
        }
      if (w.unit < 0) return -1;
    }
  }

  int units() const { return static_cast<int>(static_units_.size() + self_units_.size()); }
  // Lanes of the last run's mask found by a sphere test on a primitive or a self pair (not by
  // the box of another shape, not by a pair marked exact) that passes with the radii reduced
  // by eps_ too (Item::inner): their spheres overlap by more than the bound, so the double
  // test finds them colliding (the same answer).
  unsigned sure() const { return sure_; }

 private:
  // Where a lane entered the mask (run) or where the walk of a lane is (next_pair): phase 0 the
  // run's first unit, 1 the link walk (link li, obstacle bit pos; rest: the link's obstacle
  // bits still to visit), 2 the unit loop (unit index pos); unit and item: the current unit
  // (-1 between units) and item.
  struct Walk {
    int phase = 0, li = 0, pos = 0, unit = -1, item = 0;
    std::uint64_t rest = 0;
  };
  // The lanes h entered the mask at unit k (item: item_at_ of the lane).
  void enter(unsigned h, int phase, int li, int pos, int k) {
    for (unsigned m = h; m; m &= m - 1) {
      const int l = __builtin_ctz(m);
      Walk& w = mark_[l];
      w.phase = phase;
      w.li = li;
      w.pos = pos;
      w.unit = k;
      w.item = item_at_[l];
    }
  }
  struct V3 {
    F4 x, y, z;
  };
  struct PoseF {
    F4 R[9], t[3];  // R[r + 3 c]
  };
  struct JointF {
    int parent, kind, axis, idx_q;
    bool perm;           // R0 a signed permutation: column c = sign[c] * column src[c]
    int src[3] = {0, 1, 2};
    F4 sign[3] = {{1, 1, 1, 1}, {1, 1, 1, 1}, {1, 1, 1, 1}};
    F4 R0[9], t0[3];
  };

  // One joint of the chain: M = P * (R0, t0) * motion (s, c: the sine and cosine of a revolute
  // joint's angle; s: the coordinate of a prismatic joint), the operations of the header's
  // bound (a signed permutation R0: its columns copied with their signs, exactly).
  static inline void joint_step(const JointF& f, const F4* PR, const F4* Pt, F4* MR, F4* Mt,
                                const F4& s, const F4& c) {
    if (f.perm) {
      for (int col = 0; col < 3; ++col) {
        const int src = f.src[col];
        const F4 sign = f.sign[col];
        for (int r = 0; r < 3; ++r)
          MR[r + 3 * col] = sign * (src == 0 ? PR[r] : src == 1 ? PR[r + 3] : PR[r + 6]);
      }
    } else {
      for (int col = 0; col < 3; ++col)
        for (int r = 0; r < 3; ++r)
          MR[r + 3 * col] = (PR[r] * f.R0[3 * col] + PR[r + 3] * f.R0[3 * col + 1]) +
                            PR[r + 6] * f.R0[3 * col + 2];
    }
    for (int r = 0; r < 3; ++r)
      Mt[r] = ((PR[r] * f.t0[0] + PR[r + 3] * f.t0[1]) + PR[r + 6] * f.t0[2]) + Pt[r];
    if (f.kind == 0) {  // revolute: columns b and d turn about the axis
      switch (f.axis) {
        case 0: turn<1, 2>(MR, s, c); break;
        case 1: turn<2, 0>(MR, s, c); break;
        default: turn<0, 1>(MR, s, c); break;
      }
    } else {  // prismatic: along the axis column
      for (int r = 0; r < 3; ++r) Mt[r] = Mt[r] + s * MR[r + 3 * f.axis];
    }
  }
  template <int B, int D>
  static inline void turn(F4* MR, const F4& s, const F4& c) {
    for (int r = 0; r < 3; ++r) {
      const F4 cb = MR[r + 3 * B], cd = MR[r + 3 * D];
      MR[r + 3 * B] = c * cb + s * cd;
      MR[r + 3 * D] = c * cd - s * cb;
    }
  }
  // The chain when every joint's parent is the joint before it (serial_): the running pose in
  // locals (registers) instead of reloaded from poses_ at each joint; the same operations.
  void chain_serial() {
    F4 R[9], t[3];
    for (int e = 0; e < 9; ++e) R[e] = poses_[0].R[e];
    for (int a = 0; a < 3; ++a) t[a] = poses_[0].t[a];
    const std::size_t nj = joints_.size();
    for (std::size_t k = 0; k < nj; ++k) {
      F4 MR[9], Mt[3];
      joint_step(joints_[k], R, t, MR, Mt, motion_[2 * k], motion_[2 * k + 1]);
      PoseF& M = poses_[k + 1];
      for (int e = 0; e < 9; ++e) M.R[e] = R[e] = MR[e];
      for (int a = 0; a < 3; ++a) M.t[a] = t[a] = Mt[a];
    }
  }
  struct F3 {
    float v[3];
  };
  struct LinkF {
    int joint;
    F3 center;
    float radius;
    V3 world;  // its bounding sphere's centre (its joint's placement: poses_)
  };
  struct ObjectF {
    int link;
    F3 center;
    float radius;
    int begin, end;    // its spheres (sph_), cluster after cluster
    int cbegin, cend;  // its clusters (clusters_)
  };
  struct ClusterF {
    F3 center;
    float radius;
    int begin, end;  // its spheres (sph_)
  };
  static constexpr int kCluster = 4;
  struct SphF {
    float p[3];
    float r;
  };
  struct ObsF {
    int type;
    F4 R[9], t[3], half[3], lo[3], hi[3];
    F4 radius4, half_length4;
    float radius, half_length, swept;
  };
  struct Item {
    int a, b;      // object, partner object (self pairs) or -1
    float margin;  // the pair's margin + eps
    float inner;   // the pair's margin - eps (sure(): colliding for the double test too)
    int pair;      // index into Input::pairs
    bool exact;    // Input::Pair::exact: lanes it finds are not sure()
  };
  // A run of a unit's items whose grouped object lies in object group `group` (-1: no group
  // test), `margin` the largest margin of its items (with eps): run tests the group's sphere
  // before the items (a lane it clears is clear for every item of the span); self units:
  // against the bounding sphere of link `other` (the unit's link that is not the group's).
  struct Span {
    int group, begin, end;
    float margin;
    int other = -1;
  };
  struct StaticUnit {
    int link, obstacle;
    float margin;  // largest item margin (with eps)
    std::vector<Item> items;
    std::vector<Span> spans;
  };
  // Neighbouring objects of one link under one bounding sphere (joint frame; the radius
  // rounded up and increased by eps_): the level between a unit's link and its items.
  struct GroupF {
    int link;
    F3 center;
    float radius;
  };
  struct SelfUnit {
    int la, lb;
    float margin;
    std::vector<Item> items;
    std::vector<Span> spans;
  };

  static F3 f3(const double* d) {
    return F3{{static_cast<float>(d[0]), static_cast<float>(d[1]), static_cast<float>(d[2])}};
  }

  V3 place(const LinkF& l, const float* p) const {
    const PoseF& P = poses_[l.joint];
    V3 c;
    c.x = P.R[0] * p[0] + P.R[3] * p[1] + P.R[6] * p[2] + P.t[0];
    c.y = P.R[1] * p[0] + P.R[4] * p[1] + P.R[7] * p[2] + P.t[1];
    c.z = P.R[2] * p[0] + P.R[5] * p[1] + P.R[8] * p[2] + P.t[2];
    return c;
  }
  V3 place(const LinkF& l, const F3& p) const { return place(l, p.v); }

  // Group g's centre (once per load).
  void place_group(int g) {
    if (grp_stamp_[g] == stamp_) return;
    grp_stamp_[g] = stamp_;
    grp_world_[g] = place(links_[groups_[g].link], groups_[g].center);
  }

  // Object groups of each link with several objects (a hand with its fingers on the last
  // joint: a unit of that link otherwise tests every object's bounding sphere whenever the
  // link's sphere is near the obstacle): agglomerative, always merging the two groups of
  // smallest common bounding sphere, while more than kGroups remain or one group's sphere
  // contains the other's. Then each unit's items ordered by group (stable: the order of the
  // pairs within a group), in spans; a self item is grouped by its object on a link with
  // groups (its first object's link first), tested against the other link's sphere.
  static constexpr int kGroups = 4;
  void make_groups(const Input& in, float e) {
    groups_.clear();
    group_of_.assign(objects_.size(), -1);
    struct G {
      double c[3], r;
      std::vector<int> objs;
    };
    for (int li = 0; li < static_cast<int>(links_.size()); ++li) {
      std::vector<G> gs;
      for (int o = 0; o < static_cast<int>(objects_.size()); ++o)
        if (objects_[o].link == li) {
          G g;
          for (int a = 0; a < 3; ++a) g.c[a] = in.objects[o].center[a];
          g.r = in.objects[o].radius;
          g.objs = {o};
          gs.push_back(g);
        }
      if (gs.size() < 2) continue;
      auto merged = [](const G& a, const G& b, double c[3]) {
        double d2 = 0.0;
        for (int k = 0; k < 3; ++k) d2 += (b.c[k] - a.c[k]) * (b.c[k] - a.c[k]);
        const double d = std::sqrt(d2);
        if (d + b.r <= a.r) {
          for (int k = 0; k < 3; ++k) c[k] = a.c[k];
          return a.r;
        }
        if (d + a.r <= b.r) {
          for (int k = 0; k < 3; ++k) c[k] = b.c[k];
          return b.r;
        }
        const double r = 0.5 * (d + a.r + b.r);
        for (int k = 0; k < 3; ++k) c[k] = a.c[k] + (r - a.r) / d * (b.c[k] - a.c[k]);
        return r;
      };
      for (;;) {
        std::size_t bi = 0, bj = 0;
        double best = std::numeric_limits<double>::infinity(), bc[3] = {0, 0, 0};
        for (std::size_t i = 0; i < gs.size(); ++i)
          for (std::size_t j = i + 1; j < gs.size(); ++j) {
            double c[3];
            const double r = merged(gs[i], gs[j], c);
            if (r < best) {
              best = r;
              bi = i;
              bj = j;
              for (int k = 0; k < 3; ++k) bc[k] = c[k];
            }
          }
        const bool nested = best <= std::max(gs[bi].r, gs[bj].r);
        if (gs.size() <= 1 || (static_cast<int>(gs.size()) <= kGroups && !nested)) break;
        for (int k = 0; k < 3; ++k) gs[bi].c[k] = bc[k];
        // (the merged sphere a hair larger: it contains both in exact arithmetic)
        gs[bi].r = best * (1.0 + 1e-12) + 1e-12;
        gs[bi].objs.insert(gs[bi].objs.end(), gs[bj].objs.begin(), gs[bj].objs.end());
        gs.erase(gs.begin() + static_cast<std::ptrdiff_t>(bj));
      }
      if (gs.size() < 2) continue;
      for (const G& g : gs) {
        GroupF f{li, {{static_cast<float>(g.c[0]), static_cast<float>(g.c[1]),
                       static_cast<float>(g.c[2])}},
                 0.0f};
        // float rounding of the centre (below 1e-7 |c|) and radius within eps_
        f.radius = static_cast<float>(g.r) + e;
        for (int o : g.objs) group_of_[o] = static_cast<int>(groups_.size());
        groups_.push_back(f);
      }
    }
    auto spans_of = [](std::vector<Item>& items, auto&& key, std::vector<Span>& spans) {
      std::stable_sort(items.begin(), items.end(),
                       [&key](const Item& a, const Item& b) { return key(a) < key(b); });
      spans.clear();
      for (int i = 0; i < static_cast<int>(items.size()); ++i) {
        const int g = key(items[i]);
        if (spans.empty() || spans.back().group != g)
          spans.push_back(Span{g, i, i, 0.0f, -1});
        spans.back().end = i + 1;
        spans.back().margin = std::max(spans.back().margin, items[i].margin);
      }
      // a span of one item: its own bounding sphere test is as good as the group's
      for (Span& sp : spans)
        if (sp.end - sp.begin < 2) sp.group = -1;
    };
    for (StaticUnit& u : static_units_)
      spans_of(u.items, [this](const Item& it) { return group_of_[it.a]; }, u.spans);
    for (SelfUnit& u : self_units_) {
      auto key = [this](const Item& it) {
        return group_of_[it.a] >= 0 ? group_of_[it.a] : group_of_[it.b];
      };
      spans_of(u.items, key, u.spans);
      for (Span& sp : u.spans)
        if (sp.group >= 0) sp.other = groups_[sp.group].link == u.la ? u.lb : u.la;
    }
  }

  // Per link, the obstacles its bounding sphere can reach at any configuration (link_reach_)
  // and the blocks of 4 obstacles holding one (link_blocks_): box_bits tests only those. The
  // link's bounding centre is within D = |its centre| + the sum of |t0| of the joints from its
  // own up to (not including) the chain's first joint, whose origin p0 (its t0: its parent is
  // the universe, at the identity) no revolute joint moves; an obstacle whose inflated box
  // (binfl_) is farther than D + the link's radius from p0 is never touched (2 eps_ + 1 um
  // over the float rounding of the centres). Chains with a prismatic joint: every obstacle.
  void make_reach(const Input& in) {
    const std::size_t nb = blo_[0].size();
    link_reach_.assign(links_.size(), 0);
    link_blocks_.assign(links_.size(), {});
    for (std::size_t li = 0; li < links_.size(); ++li) {
      double D = 0.0;
      for (int a = 0; a < 3; ++a) D += double(in.links[li].center[a]) * in.links[li].center[a];
      D = std::sqrt(D);
      bool bounded = true;
      const double* p0 = nullptr;
      for (int j = in.links[li].joint; j > 0;) {
        const Input::Joint& J = in.chain[j - 1];
        if (J.kind != 0) bounded = false;
        if (J.parent == 0) {
          p0 = J.t0;
          break;
        }
        D += std::sqrt(J.t0[0] * J.t0[0] + J.t0[1] * J.t0[1] + J.t0[2] * J.t0[2]);
        j = J.parent;
      }
      if (!p0) bounded = false;
      const double reach = D + in.links[li].radius + 2.0 * eps_ + 1e-6;
      for (std::size_t ob = 0; ob < obs_.size() && ob < 64; ++ob) {
        const std::size_t b = ob / 4, lane = ob % 4;
        bool near = !bounded;
        if (bounded) {
          double d2 = 0.0;
          for (int a = 0; a < 3; ++a) {
            const double lo = blo_[a][b][lane], hi = bhi_[a][b][lane];
            const double x = p0[a] < lo ? lo - p0[a] : (p0[a] > hi ? p0[a] - hi : 0.0);
            d2 += x * x;
          }
          const double r = reach + binfl_[b][lane];
          near = d2 <= r * r;
        }
        if (near) link_reach_[li] |= std::uint64_t{1} << ob;
      }
      for (std::size_t b = 0; b < nb; ++b)
        if ((link_reach_[li] >> (4 * b)) & 15u) link_blocks_[li].push_back(static_cast<int>(b));
    }
  }

  // Object o's bounding centre (once per load).
  void place_bound(int o) {
    if (bound_stamp_[o] == stamp_) return;
    bound_stamp_[o] = stamp_;
    obj_world_[o] = place(links_[objects_[o].link], objects_[o].center);
  }
  // Object o's cluster centres (once per load), only for an object whose bounding sphere
  // passed a test: most objects reached by the link level stop at their bounding sphere.
  void place_clusters(int o) {
    if (sph_stamp_[o] == stamp_) return;
    sph_stamp_[o] = stamp_;
    const ObjectF& ob = objects_[o];
    const LinkF& l = links_[ob.link];
    for (int c = ob.cbegin; c < ob.cend; ++c) clu_world_[c] = place(l, clusters_[c].center);
  }
  // The sphere centres of cluster c of object o (once per load).
  void place_cluster_spheres(int o, int c) {
    if (clu_stamp_[c] == stamp_) return;
    clu_stamp_[c] = stamp_;
    const LinkF& l = links_[objects_[o].link];
    for (int s = clusters_[c].begin; s < clusters_[c].end; ++s)
      sph_world_[s] = place(l, sph_[s].p);
  }

  // Lanes where the sphere (c, r) touches obstacle o's world box.
  static unsigned box_hits(const ObsF& o, const V3& c, float r) {
    const F4 zero = {};
    const F4 dx = vmax(vmax(o.lo[0] - c.x, c.x - o.hi[0]), zero);
    const F4 dy = vmax(vmax(o.lo[1] - c.y, c.y - o.hi[1]), zero);
    const F4 dz = vmax(vmax(o.lo[2] - c.z, c.z - o.hi[2]), zero);
    return lanes_of(dx * dx + dy * dy + dz * dz <= splat(r * r));
  }

  // Lanes where the sphere (c, r) touches the primitive (r includes margin, swept, eps);
  // other shapes: their box.
  static unsigned prim_hits(const ObsF& o, const V3& c, float r) {
    if (o.type == 0) return box_hits(o, c, r);
    const F4 dx = c.x - o.t[0], dy = c.y - o.t[1], dz = c.z - o.t[2];
    if (o.type == 2) {
      const float rr = r + o.radius;
      return lanes_of(dx * dx + dy * dy + dz * dz <= splat(rr * rr));
    }
    const F4 lx = o.R[0] * dx + o.R[1] * dy + o.R[2] * dz;  // R^T (c - t)
    const F4 ly = o.R[3] * dx + o.R[4] * dy + o.R[5] * dz;
    const F4 lz = o.R[6] * dx + o.R[7] * dy + o.R[8] * dz;
    const F4 zero = {};
    if (o.type == 1) {
      const F4 ex = vmax(vabs(lx) - o.half[0], zero);
      const F4 ey = vmax(vabs(ly) - o.half[1], zero);
      const F4 ez = vmax(vabs(lz) - o.half[2], zero);
      return lanes_of(ex * ex + ey * ey + ez * ez <= splat(r * r));
    }
    if (o.type == 3) {
      const F4 dr = vmax(vsqrt(lx * lx + ly * ly) - o.radius4, zero);
      const F4 dh = vmax(vabs(lz) - o.half_length4, zero);
      return lanes_of(dr * dr + dh * dh <= splat(r * r));
    }
    const F4 z = vmin(vmax(lz, -o.half_length4), o.half_length4);
    const F4 ez = lz - z;
    const float rr = r + o.radius;
    return lanes_of(lx * lx + ly * ly + ez * ez <= splat(rr * rr));
  }

  static unsigned ball_hits(const V3& a, const V3& b, float r) {
    const F4 dx = a.x - b.x, dy = a.y - b.y, dz = a.z - b.z;
    return lanes_of(dx * dx + dy * dy + dz * dz <= splat(r * r));
  }

  const std::vector<Item>& items_of(int k) const {
    const int ns = static_cast<int>(static_units_.size());
    return k < ns ? static_units_[k].items : self_units_[k - ns].items;
  }

  // Lanes of m where static item it (obstacle o) may touch: its object's bounding sphere against
  // the box and the primitive, then its spheres against the primitive (or the box of another
  // shape).
  unsigned static_item(const ObsF& o, const Item& it, unsigned m) {
    place_bound(it.a);
    const ObjectF& ob = objects_[it.a];
    const float rs = it.margin + o.swept;
    m &= box_hits(o, obj_world_[it.a], ob.radius + rs);
    if (!m) return 0;
    if (o.type != 0) m &= prim_hits(o, obj_world_[it.a], ob.radius + rs);
    if (!m) return 0;
    place_clusters(it.a);
    unsigned hit = 0;
    for (int c = ob.cbegin; c < ob.cend && m; ++c) {
      const ClusterF& cl = clusters_[c];
      unsigned mc = m & prim_hits(o, clu_world_[c], cl.radius + rs);
      if (!mc) continue;
      place_cluster_spheres(it.a, c);
      for (int s = cl.begin; s < cl.end && mc; ++s) {
        const unsigned h = mc & prim_hits(o, sph_world_[s], sph_[s].r + rs);
        if (h && o.type != 0 && !it.exact) {
          const float inner = sph_[s].r + it.inner + o.swept;
          if (inner >= 0.0f) item_sure_ |= h & prim_hits(o, sph_world_[s], inner);
        }
        hit |= h;
        mc &= ~h;
        m &= ~h;
      }
    }
    return hit;
  }

  // Lanes of m where self item it may touch: the objects' bounding spheres, per cluster of a
  // against b's bounding sphere and clusters, then sphere pairs.
  unsigned self_item(const Item& it, unsigned m) {
    place_bound(it.a);
    place_bound(it.b);
    const ObjectF& oa = objects_[it.a];
    const ObjectF& ob = objects_[it.b];
    m &= ball_hits(obj_world_[it.a], obj_world_[it.b], oa.radius + ob.radius + it.margin);
    if (!m) return 0;
    place_clusters(it.a);
    place_clusters(it.b);
    unsigned hit = 0;
    // Spheres s of cluster A and t of cluster B within r_s + r_t + margin of each other have
    // centres of A and B within R_A + R_B + margin (each sphere inside its cluster's bounding
    // sphere: |c_A - c_s| <= R_A - r_s); eps_ covers the float rounding of the placed centres
    // (far below it), so the clusters tested out hold no touching pair (same answers).
    const float e = static_cast<float>(eps_);
    for (int ca = oa.cbegin; ca < oa.cend && m; ++ca) {
      const ClusterF& A = clusters_[ca];
      unsigned ma = m & ball_hits(clu_world_[ca], obj_world_[it.b],
                                  A.radius + ob.radius + it.margin + e);
      for (int cb = ob.cbegin; cb < ob.cend && ma; ++cb) {
        const ClusterF& B = clusters_[cb];
        unsigned mab =
            ma & ball_hits(clu_world_[ca], clu_world_[cb], A.radius + B.radius + it.margin + e);
        if (!mab) continue;
        place_cluster_spheres(it.a, ca);
        place_cluster_spheres(it.b, cb);
        for (int s = A.begin; s < A.end && mab; ++s)
          for (int t = B.begin; t < B.end && mab; ++t) {
            const unsigned h =
                mab & ball_hits(sph_world_[s], sph_world_[t], sph_[s].r + sph_[t].r + it.margin);
            if (h && !it.exact) {
              const float inner = sph_[s].r + sph_[t].r + it.inner;
              if (inner >= 0.0f) item_sure_ |= h & ball_hits(sph_world_[s], sph_world_[t], inner);
            }
            hit |= h;
            mab &= ~h;
            ma &= ~h;
            m &= ~h;
          }
      }
    }
    return hit;
  }

  // The object and sphere levels of static unit k for the lanes `near` (the link level passed);
  // item_at_: the item where each lane hit.
  unsigned static_leaves(int k, unsigned near) {
    if (!near) return 0;
    const StaticUnit& u = static_units_[k];
    const ObsF& o = obs_[u.obstacle];
    if (o.type != 0) {  // the link's sphere against the primitive (the link level: its box)
      const LinkF& L = links_[u.link];
      near &= prim_hits(o, L.world, L.radius + u.margin + o.swept);
      if (!near) return 0;
    }
    unsigned hit = 0;
    for (const Span& sp : u.spans) {
      unsigned m = near & ~hit;
      if (sp.group >= 0) {  // the group's sphere against the box and the primitive
        place_group(sp.group);
        const float r = groups_[sp.group].radius + sp.margin + o.swept;
        m &= box_hits(o, grp_world_[sp.group], r);
        if (m && o.type != 0) m &= prim_hits(o, grp_world_[sp.group], r);
        if (!m) continue;
      }
      for (int i = sp.begin; i < sp.end && m; ++i) {
        item_sure_ = 0;
        const unsigned h = static_item(o, u.items[i], m);
        if (!h) continue;
        hit |= h;
        m &= ~h;
        sure_ |= item_sure_;
        for (unsigned b = h; b; b &= b - 1) item_at_[__builtin_ctz(b)] = i;
      }
      if (hit == near) break;
    }
    return hit;
  }

  // Bit b set when link li's bounding sphere in lane l touches obstacle b's box, inflated by
  // the largest margin of its units and its swept radius (bits of obstacles without a unit of
  // the link are ignored by the caller).
  std::uint64_t link_obstacles(std::size_t li, int l) const {
    const LinkF& L = links_[li];
    return box_bits(li, L.world.x[l], L.world.y[l], L.world.z[l], L.radius);
  }

  // Bit b set when the sphere (c, radius + binfl_ of b) touches obstacle b's box, 4 obstacles
  // per vector operation.
  std::uint64_t box_bits(std::size_t li, float x, float y, float z, float radius) const {
    const F4 cx = splat(x), cy = splat(y), cz = splat(z);
    return range_bits(li, cx, cy, cz, cx, cy, cz, radius);
  }

  // Bit b set when a sphere of the given radius centred anywhere in the box [lo, hi] (every
  // coordinate splat over the lanes) touches obstacle b's box inflated by binfl_ of b: the
  // distance between the two boxes (box_bits: lo = hi, a point).
  std::uint64_t range_bits(std::size_t li, F4 lx, F4 ly, F4 lz, F4 hx, F4 hy, F4 hz,
                           float radius) const {
    const F4 zero = {};
    std::uint64_t bits = 0;
    for (const int b : link_blocks_[li]) {
      const F4 dx = vmax(vmax(blo_[0][b] - hx, lx - bhi_[0][b]), zero);
      const F4 dy = vmax(vmax(blo_[1][b] - hy, ly - bhi_[1][b]), zero);
      const F4 dz = vmax(vmax(blo_[2][b] - hz, lz - bhi_[2][b]), zero);
      const F4 rr = radius + binfl_[b];
      const unsigned m = lanes_of(dx * dx + dy * dy + dz * dz <= rr * rr);
      bits |= static_cast<std::uint64_t>(m) << (4 * b);
    }
    return bits & link_reach_[li];
  }

  // Bits of the obstacles whose inflated box link li's bounding sphere touches in some lane of
  // `act`: the sphere anywhere in the box of the lanes' centres (range_bits). Every bit
  // link_obstacles(li, l) sets for a lane l of act is set here: per axis the gap between the
  // boxes is at most the gap from lane l's centre (the box's bounds are lanes' coordinates,
  // exactly), and the float operations are monotone, so the squared distance is at most lane
  // l's, exactly.
  std::uint64_t link_union_obstacles(std::size_t li, unsigned act) const {
    const LinkF& L = links_[li];
    const I4 in = kLaneMask[act & 15u];
    const F4 inf = splat(std::numeric_limits<float>::infinity());
    // the lanes' smallest and largest coordinates (exact), splat
    auto lo = [&](const F4& v) {
      const F4 m = in ? v : inf;
      return splat(std::min(std::min(m[0], m[1]), std::min(m[2], m[3])));
    };
    auto hi = [&](const F4& v) {
      const F4 m = in ? v : -inf;
      return splat(std::max(std::max(m[0], m[1]), std::max(m[2], m[3])));
    };
    return range_bits(li, lo(L.world.x), lo(L.world.y), lo(L.world.z), hi(L.world.x),
                      hi(L.world.y), hi(L.world.z), L.radius);
  }

  // Lanes where link li's bounding sphere touches obstacle ob's inflated box: link_obstacles'
  // test (the same operations on the same values, lane-wise over configurations instead of
  // obstacles), so bit l here is bit ob of link_obstacles(li, l).
  unsigned link_obstacle_lanes(std::size_t li, int ob) const {
    const LinkF& L = links_[li];
    const std::size_t b = static_cast<std::size_t>(ob) / 4, j = static_cast<std::size_t>(ob) % 4;
    const F4 zero = {};
    const V3& c = L.world;
    const F4 dx = vmax(vmax(splat(blo_[0][b][j]) - c.x, c.x - splat(bhi_[0][b][j])), zero);
    const F4 dy = vmax(vmax(splat(blo_[1][b][j]) - c.y, c.y - splat(bhi_[1][b][j])), zero);
    const F4 dz = vmax(vmax(splat(blo_[2][b][j]) - c.z, c.z - splat(bhi_[2][b][j])), zero);
    const F4 rr = splat(L.radius + binfl_[b][j]);
    return lanes_of(dx * dx + dy * dy + dz * dz <= rr * rr);
  }

  // Lanes of `active` where unit k's link level passes: the link's bounding sphere against the
  // obstacle's box, or the two links' bounding spheres.
  unsigned unit_near(int k, unsigned active) const {
    const int ns = static_cast<int>(static_units_.size());
    if (k < ns) {
      const StaticUnit& u = static_units_[k];
      const ObsF& o = obs_[u.obstacle];
      const LinkF& l = links_[u.link];
      // (the boxes with the swept radius too: whether coal's box includes it or not)
      return box_hits(o, l.world, l.radius + u.margin + o.swept) & active;
    }
    const SelfUnit& u = self_units_[k - ns];
    const LinkF& la = links_[u.la];
    const LinkF& lb = links_[u.lb];
    return ball_hits(la.world, lb.world, la.radius + lb.radius + u.margin) & active;
  }

  unsigned unit_hits(int k, unsigned active) {
    if (!active) return 0;
    const int ns = static_cast<int>(static_units_.size());
    const unsigned near = unit_near(k, active);
    if (k < ns) return static_leaves(k, near);
    if (!near) return 0;
    const SelfUnit& u = self_units_[k - ns];
    unsigned hit = 0;
    for (const Span& sp : u.spans) {
      unsigned m = near & ~hit;
      if (sp.group >= 0) {  // the group's sphere against the other link's
        place_group(sp.group);
        const LinkF& L = links_[sp.other];
        m &= ball_hits(grp_world_[sp.group], L.world, groups_[sp.group].radius + L.radius + sp.margin);
        if (!m) continue;
      }
      for (int i = sp.begin; i < sp.end && m; ++i) {
        item_sure_ = 0;
        const unsigned h = self_item(u.items[i], m);
        if (!h) continue;
        hit |= h;
        m &= ~h;
        sure_ |= item_sure_;
        for (unsigned b = h; b; b &= b - 1) item_at_[__builtin_ctz(b)] = i;
      }
      if (hit == active) break;
    }
    return hit;
  }

  bool ready_ = false;
  double eps_ = 0.0, scale_ = 1.0;
  int depth_ = 0;
  std::vector<LinkF> links_;
  std::vector<JointF> joints_;  // the chain (Input::chain)
  std::vector<PoseF> poses_;    // load_q: joint placements, lanes
  std::vector<F4> motion_;      // load_q: per joint its sine and cosine (prismatic: coordinate)
  bool serial_ = false;         // every joint's parent is the joint before it (chain_serial)
  std::vector<ObjectF> objects_;
  std::vector<SphF> sph_;
  std::vector<ObsF> obs_;
  std::vector<StaticUnit> static_units_;
  std::vector<SelfUnit> self_units_;
  std::vector<unsigned> bound_stamp_, sph_stamp_;  // load of the last place_bound / place_clusters
  std::vector<V3> obj_world_, sph_world_;
  std::vector<ClusterF> clusters_;
  std::vector<GroupF> groups_;       // object groups (make_groups)
  std::vector<int> group_of_;        // per object: its group, or -1 (its link has one group)
  std::vector<unsigned> grp_stamp_;  // load of the last place_group
  std::vector<V3> grp_world_;        // group centres (place_group)
  std::vector<unsigned> clu_stamp_;  // load of the last place_cluster_spheres
  std::vector<V3> clu_world_;        // cluster centres (place_clusters)
  bool by_link_ = false;
  std::vector<int> unit_of_;             // static unit of (link, obstacle), or -1
  std::vector<std::uint64_t> link_reach_;        // make_reach: obstacles a link can touch
  std::vector<std::vector<int>> link_blocks_;    // make_reach: blocks with such an obstacle
  std::vector<F4> blo_[3], bhi_[3], binfl_;  // obstacle boxes, 4 per block (link_obstacles)
  unsigned stamp_ = 0, sure_ = 0;
  unsigned item_sure_ = 0;  // static_item, self_item: lanes of a sphere hit within the inner margin
  int last_unit_ = -1;
  int first_unit_ = -1;      // the unit run tested first (last_unit_ then)
  int item_at_[kLanes] = {};  // static_leaves, unit_hits: the item where a lane hit
  Walk mark_[kLanes];        // where each lane of the last run's mask entered it
  Walk walk_;                // first_pair, next_pair
  int walk_lane_ = 0;
};

}  // namespace TASKSPACE_SPHERE_BATCH_NS
#undef TASKSPACE_SPHERE_BATCH_NS
