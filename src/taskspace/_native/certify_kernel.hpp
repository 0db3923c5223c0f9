// Certified paths in C++: taskspace.planning.certify.certify_path for the compiled kernel's
// robots (#22 item 5). Included from planning_kernel.cpp after its anonymous namespace (which
// this file re-opens: raise_invalid, GilRelease, lock_with_gil, kPollInterval);
// register_path_certifier() adds the class PathCertifier to the module.
//
// The question is the Python certifier's: is every configuration of the straight segments
// q(t) = q_s + t (q_{s+1} - q_s), t in [0, 1], free, and does every distance evaluated stay at
// or above `tolerance`? The answer comes from conservative advancement (Schwarzer, Saha and
// Latombe 2005), here per collision pair and along the whole path rather than per segment:
//
//  * Motion bound. For a moving link l (a joint with geometry) and a velocity coordinate k,
//    W[l][k] bounds the speed of every point of l's geometry (its convex hull, and the
//    centres of its spheres) per unit of |dq_k|, over every configuration: 1 for a prismatic
//    k, the point's distance to k's axis for a revolute k (see link_weights: the set of
//    positions a point can take below k is bounded by a ball, propagated up the chain). A
//    pair's distance then changes at most at rate
//        rho_p = sum_k Wp[k] |dq_k|
//    where Wp = W[l] for a link against a static object and, for two moving links, W[la] on
//    the joints above la only plus W[lb] on the joints above lb only (a joint above both
//    moves them rigidly together: their distance does not change). Along the path a pair
//    moves through a "budget" C_p(u) = sum of rho_p over the path up to u (u = s + t).
//  * Lower bounds. At a configuration the pair's distance is bounded from below by, in
//    increasing cost: the bounding sphere of the moving object's hull against the obstacle
//    (exact point distance to a box, sphere, cylinder or capsule, else its box) or against
//    the other object's bounding sphere; the robot's spheres (sphere_model's certified
//    cover: the hull lies inside their union, so min over spheres of the centre's distance
//    minus the radius bounds the hull's distance); coal's distance between the two
//    geometries, minus GJK's tolerance (the exact answer).
//  * Advancement. A pair whose distance at u0 is at least d > 0 is free on every u with
//    C_p(u) - C_p(u0) < d; at that u it is evaluated again. The cheap bounds are accepted
//    when they reach `tolerance` and either cover the rest of the path or exceed `near`
//    (the sphere bound) / `far` (the bounding sphere); otherwise the exact distance is
//    taken, and an exact distance below `tolerance` stops the certification: that segment
//    and t are reported (never "free" there). Evaluation points are taken in path order
//    (the least position where a budget runs out), so the failure reported is the first
//    along the path; at each point every pair within `early` (a fraction) of its own step
//    from running out is evaluated too, so that pairs share the kinematics.
//    min_distance: the least exact distance evaluated, or (certified paths) the exact
//    distance of the pair whose lower bound was least, where it was taken: a distance met
//    on the path.
//    Pairs of two static objects are checked once (>= tolerance); pairs of two robot
//    geometries on one joint (rigid) once at the first waypoint (> 0), as in Python.
//
// Every evaluation point of every pair is at least `tolerance` from contact and between two
// evaluations the pair's distance stays positive, so a certified path is free everywhere.
// The joint types: revolute and prismatic about x, y or z (Pinocchio's RX, RY, RZ, PX, PY,
// PZ; prismatic joints need finite limits or take their reach from the path); other models
// use the Python certifier.

#pragma once

#include <coal/BVH/BVH_model.h>

#include <utility>

namespace {

class PathCertifier {
 public:
  // model, geometry model: Python objects (kept alive); spheres: rows of centres (joint frame
  // of the geometry's parent), radii and geometry indices (M = 0: none); certified_margin > 0
  // is required to use them (sphere_model's volume certificate). robot_geometries: the
  // number of robot geometries (the first ones; the others are obstacles).
  PathCertifier(bp::object model, bp::object geom, const Eigen::Ref<const RowMatrixXd>& centers,
                const VectorXd& radii, const Eigen::VectorXi& geometries,
                double certified_margin, int robot_geometries)
      : py_{model, geom},
        model_(bp::extract<const Model&>(model)),
        geom_(bp::extract<const GeometryModel&>(geom)),
        data_(model_) {
    if (model_.nq != model_.nv) raise_invalid("the compiled certifier needs nq == nv");
    const int nq = model_.nq;
    const int nj = static_cast<int>(model_.njoints);
    axis_.assign(nj, -1);
    prismatic_.assign(nj, 0);
    for (int j = 1; j < nj; ++j) {
      const std::string type = model_.joints[j].shortname();
      if (type == "JointModelRX" || type == "JointModelRY" || type == "JointModelRZ") {
        axis_[j] = type.back() - 'X';
      } else if (type == "JointModelPX" || type == "JointModelPY" || type == "JointModelPZ") {
        axis_[j] = type.back() - 'X';
        prismatic_[j] = 1;
      } else {
        raise_invalid("the compiled certifier handles revolute and prismatic joints about x, y "
                      "or z; joint '" + model_.names[j] + "' is a " + type);
      }
    }
    const std::size_t ng = geom_.geometryObjects.size();
    if (centers.cols() != 3 || radii.size() != centers.rows() ||
        geometries.size() != centers.rows())
      raise_invalid("centers (M, 3), radii and geometries (M,) must have M rows");
    if (!centers.allFinite() || !radii.allFinite() || (radii.array() < 0.0).any())
      raise_invalid("sphere centers and radii must be finite, radii >= 0");
    if (robot_geometries < 0 || static_cast<std::size_t>(robot_geometries) > ng)
      raise_invalid("robot_geometries out of range");
    // objects
    obj_.resize(ng);
    std::vector<std::vector<Eigen::Index>> rows(ng);
    if (certified_margin > 0.0 && std::isfinite(certified_margin)) {
      for (Eigen::Index k = 0; k < centers.rows(); ++k) {
        const int g = geometries[k];
        if (g < 0 || static_cast<std::size_t>(g) >= ng)
          raise_invalid("sphere geometry index " + std::to_string(g) + " out of range");
        rows[g].push_back(k);
      }
    }
    for (std::size_t i = 0; i < ng; ++i) {
      const auto& go = geom_.geometryObjects[i];
      Object& o = obj_[i];
      o.joint = static_cast<int>(go.parentJoint);
      o.geometry = go.geometry.get();
      o.placement = go.placement;
      o.robot = static_cast<int>(i) < robot_geometries;
      o.points = hull_points(go);
      o.sph_begin = static_cast<int>(sph_c_.size());
      for (Eigen::Index k : rows[i]) {
        sph_c_.push_back(centers.row(k).transpose());
        sph_r_.push_back(radii[k]);
      }
      o.sph_end = static_cast<int>(sph_c_.size());
      // bounding sphere of the hull (joint frame): centre of the points' box, radius to the
      // farthest point plus the pad
      coal::Vec3s lo = coal::Vec3s::Constant(std::numeric_limits<double>::infinity()), hi = -lo;
      for (const coal::Vec3s& p : o.points.first) {
        lo = lo.cwiseMin(p);
        hi = hi.cwiseMax(p);
      }
      o.center = 0.5 * (lo + hi);
      double r = 0.0;
      for (const coal::Vec3s& p : o.points.first) r = std::max(r, (p - o.center).norm());
      o.radius = (r + o.points.second) * (1.0 + 1e-12) + 1e-12;
      if (!o.center.allFinite() || !std::isfinite(o.radius)) {
        o.center.setZero();
        o.radius = std::numeric_limits<double>::infinity();
      }
      if (o.joint == 0) setup_static(i);
    }
    // links: moving joints with geometry
    link_of_joint_.assign(nj, -1);
    for (std::size_t i = 0; i < ng; ++i) {
      const int j = obj_[i].joint;
      if (j == 0 || link_of_joint_[j] >= 0) continue;
      link_of_joint_[j] = static_cast<int>(link_joint_.size());
      link_joint_.push_back(j);
    }
    nl_ = link_joint_.size();
    ancestors_.assign(nl_ * nq, 0);
    for (std::size_t l = 0; l < nl_; ++l)
      for (int j = link_joint_[l]; j > 0; j = static_cast<int>(model_.parents[j]))
        ancestors_[l * nq + model_.joints[j].idx_v()] = 1;
    // pairs (as Pinocchio's computeDistances: every pair without a disabled object)
    for (std::size_t p = 0; p < geom_.collisionPairs.size(); ++p) {
      const auto& cp = geom_.collisionPairs[p];
      const auto& g1 = geom_.geometryObjects[cp.first];
      const auto& g2 = geom_.geometryObjects[cp.second];
      if (g1.disableCollision || g2.disableCollision) continue;
      std::size_t a = cp.first, b = cp.second;
      if (obj_[a].joint == 0) std::swap(a, b);  // a moves when one does
      Pair pr{a, b, 0, 0};
      if (obj_[a].joint == 0) {
        pr.kind = kConstant;
      } else if (obj_[a].joint == obj_[b].joint) {
        pr.kind = obj_[a].robot && obj_[b].robot ? kRigid : kConstant;
      } else {
        pr.kind = obj_[b].joint == 0 ? kStatic : kSelf;
        pr.rate_class = rate_class(obj_[a].joint, obj_[b].joint);
      }
      pairs_.push_back(pr);
    }
  }

  bool has_spheres() const { return !sph_c_.empty(); }

  // For profiling: (object a, object b, kind, evaluations in the last certify) per pair.
  bp::list pair_evaluations() const {
    bp::list out;
    for (std::size_t p = 0; p < pairs_.size(); ++p)
      out.append(bp::make_tuple(pairs_[p].a, pairs_[p].b, pairs_[p].kind,
                                p < pair_evals_.size() ? pair_evals_[p] : 0L));
    return out;
  }
  int pair_count() const { return static_cast<int>(pairs_.size()); }
  int nq() const { return model_.nq; }

  // certify() of the one segment q0 -> q1 for a compiled planner that has released the GIL
  // (gil polls the signal handlers; interrupted: a handler raised): true when certified.
  bool certify_released(const VectorXd& q0, const VectorXd& q1, double tolerance,
                        double time_left, double near, double far, GilRelease& gil,
                        bool& interrupted) {
    std::unique_lock<std::timed_mutex> lock(mutex_);
    RowMatrixXd path(2, model_.nq);
    path.row(0) = q0.transpose();
    path.row(1) = q1.transpose();
    const Outcome out = run(path, tolerance, 100000, time_left, near, far, 0.5, gil);
    interrupted = out.interrupted;
    return out.certified;
  }

  // (certified, min_distance, failed_segment, failed_t, distance_queries, timed_out,
  //  pair_evaluations, exact_distances): see the header comment. time_left [s]: the clock
  // is read before each evaluation point and none starts after it (inf: no deadline).
  bp::tuple certify(const Eigen::Ref<const RowMatrixXd>& path, double tolerance,
                    long max_queries, double time_left, double near, double far,
                    double early = 0.5) {
    const int nq = model_.nq;
    if (path.cols() != nq || path.rows() == 0)
      raise_invalid("path must have shape (m, " + std::to_string(nq) + ")");
    if (!path.allFinite()) raise_invalid("path must be finite");
    if (!(tolerance > 0.0) || !std::isfinite(tolerance)) raise_invalid("tolerance must be > 0");
    if (max_queries < 1) raise_invalid("max_queries must be >= 1");
    if (!(near >= 0.0) || !(far >= 0.0)) raise_invalid("near and far must be >= 0");
    if (!(early >= 0.0) || !(early < 1.0)) raise_invalid("early must be in [0, 1)");
    if (std::isnan(time_left)) raise_invalid("time_left must not be NaN");
    const auto lock = lock_with_gil(mutex_);
    Outcome out;
    {
      GilRelease gil;
      out = run(path, tolerance, max_queries, time_left, near, far, early, gil);
    }
    if (out.interrupted) bp::throw_error_already_set();
    if (out.error) raise_invalid(out.message);
    return bp::make_tuple(out.certified, out.least, out.segment, out.t, out.queries,
                          out.timed_out, out.evaluations, out.exact);
  }

  // For the tests: W (links x nv) and the joint of each link.
  bp::tuple weights_py(const Eigen::Ref<const RowMatrixXd>& path) {
    std::string message;
    const std::vector<double> W = link_weights(path, message);
    if (!message.empty()) raise_invalid(message);
    const int nv = model_.nv;
    MatrixXd out(nl_, nv);
    Eigen::VectorXi joints(nl_);
    for (std::size_t l = 0; l < nl_; ++l) {
      joints[l] = link_joint_[l];
      for (int k = 0; k < nv; ++k) out(l, k) = W[l * nv + k];
    }
    return bp::make_tuple(joints, out);
  }

  // For the tests (the halved-bound mutant): every W multiplied by factor (1 by default).
  void set_weight_factor(double factor) {
    if (!(factor > 0.0) || !std::isfinite(factor)) raise_invalid("factor must be > 0");
    weight_factor_ = factor;
  }

 private:
  using clock = std::chrono::steady_clock;
  static constexpr int kConstant = 0, kRigid = 1, kStatic = 2, kSelf = 3;
  static constexpr int kGeneric = 0, kBox = 1, kBall = 2, kCylinder = 3, kCapsule = 4;

  struct Object {
    int joint = 0;
    bool robot = false;
    const coal::CollisionGeometry* geometry = nullptr;
    pinocchio::SE3 placement;
    std::pair<std::vector<coal::Vec3s>, double> points;  // hull points (joint frame), pad
    coal::Vec3s center = coal::Vec3s::Zero();             // bounding sphere, joint frame
    double radius = 0.0;
    int sph_begin = 0, sph_end = 0;
    // static objects: world transform, box, primitive
    int type = kGeneric;
    coal::Transform3s tf;
    coal::Matrix3s R = coal::Matrix3s::Identity();
    coal::Vec3s t = coal::Vec3s::Zero(), half = coal::Vec3s::Zero();
    double prim_radius = 0.0, half_length = 0.0, swept = 0.0;
    coal::AABB box;
  };
  struct Pair {
    std::size_t a, b;  // a moves unless the pair is constant
    int kind;
    int rate_class;  // link index (static pairs) or nl + index of a link pair (self pairs)
  };
  struct Outcome {
    bool certified = false, timed_out = false, interrupted = false, error = false;
    double least = std::numeric_limits<double>::infinity();
    long segment = -1;
    double t = 1.0;
    long queries = 0, evaluations = 0, exact = 0;
    std::string message;
  };

  // Points whose convex hull contains the geometry (joint frame) and a pad added to every
  // distance from them: a convex's vertices, a mesh's vertices, else the 8 corners of the
  // local box; the pad is the swept-sphere radius of a shape.
  static std::pair<std::vector<coal::Vec3s>, double> hull_points(
      const pinocchio::GeometryObject& go) {
    std::vector<coal::Vec3s> local;
    double pad = 0.0;
    const coal::CollisionGeometry* geo = go.geometry.get();
    if (const auto* cv = dynamic_cast<const coal::ConvexBase*>(geo); cv && cv->points) {
      local.assign(cv->points->begin(), cv->points->begin() + cv->num_points);
    } else if (const auto* bvh = dynamic_cast<const coal::BVHModelBase*>(geo);
               bvh && bvh->vertices) {
      local.assign(bvh->vertices->begin(), bvh->vertices->begin() + bvh->num_vertices);
    }
    if (const auto* shape = dynamic_cast<const coal::ShapeBase*>(geo))
      pad = shape->getSweptSphereRadius();
    if (local.empty()) {
      go.geometry->computeLocalAABB();
      const coal::AABB& b = go.geometry->aabb_local;
      for (int c = 0; c < 8; ++c)
        local.emplace_back(c & 1 ? b.max_[0] : b.min_[0], c & 2 ? b.max_[1] : b.min_[1],
                           c & 4 ? b.max_[2] : b.min_[2]);
    }
    for (coal::Vec3s& p : local) p = go.placement.act(p);
    return {std::move(local), pad};
  }

  void setup_static(std::size_t i) {
    Object& o = obj_[i];
    const auto& go = geom_.geometryObjects[i];
    // universe's placement is the identity: the world placement is the object's placement
    o.R = go.placement.rotation();
    o.t = go.placement.translation();
    o.tf = pinocchio::toCoalTransform3s(go.placement);
    coal::CollisionObject co(go.geometry, o.tf, true);
    o.box = co.getAABB();
    const coal::CollisionGeometry* geo = o.geometry;
    if (const auto* b = dynamic_cast<const coal::Box*>(geo)) {
      o.type = kBox;
      o.half = b->halfSide;
    } else if (const auto* sp = dynamic_cast<const coal::Sphere*>(geo)) {
      o.type = kBall;
      o.prim_radius = sp->radius;
    } else if (const auto* cy = dynamic_cast<const coal::Cylinder*>(geo)) {
      o.type = kCylinder;
      o.prim_radius = cy->radius;
      o.half_length = cy->halfLength;
    } else if (const auto* ca = dynamic_cast<const coal::Capsule*>(geo)) {
      o.type = kCapsule;
      o.prim_radius = ca->radius;
      o.half_length = ca->halfLength;
    }
    if (const auto* shape = dynamic_cast<const coal::ShapeBase*>(geo))
      o.swept = shape->getSweptSphereRadius();
  }

  // Rate class of a pair of objects on joints ja (moving) and jb (0: static).
  int rate_class(int ja, int jb) {
    const int la = link_of_joint_[ja];
    if (jb == 0) return la;
    const int lb = link_of_joint_[jb];
    const std::pair<int, int> key{std::min(la, lb), std::max(la, lb)};
    for (std::size_t c = 0; c < link_pairs_.size(); ++c)
      if (link_pairs_[c] == key) return static_cast<int>(nl_ + c);
    link_pairs_.push_back(key);
    return static_cast<int>(nl_ + link_pairs_.size() - 1);
  }

  // Lower bound of the distance from world point c to static object i (0 inside).
  double point_static_distance(const Object& o, const coal::Vec3s& c) const {
    if (o.type == kGeneric) {
      const coal::Vec3s d = (o.box.min_ - c).cwiseMax(c - o.box.max_).cwiseMax(0.0);
      return d.norm();
    }
    const coal::Vec3s l = o.R.transpose() * (c - o.t);
    double d;
    switch (o.type) {
      case kBox:
        d = (l.cwiseAbs() - o.half).cwiseMax(0.0).norm();
        break;
      case kBall:
        d = std::max(0.0, l.norm() - o.prim_radius);
        break;
      case kCylinder: {
        const double dr = std::max(0.0, std::sqrt(l[0] * l[0] + l[1] * l[1]) - o.prim_radius);
        const double dz = std::max(0.0, std::abs(l[2]) - o.half_length);
        d = std::sqrt(dr * dr + dz * dz);
        break;
      }
      default: {  // capsule
        const double z = std::clamp(l[2], -o.half_length, o.half_length);
        d = std::max(0.0, (l - coal::Vec3s(0.0, 0.0, z)).norm() - o.prim_radius);
      }
    }
    return d - o.swept;
  }

  // W (links x nv): the speed bound of every point of each link's hull and of its sphere
  // centres per unit |dq_k|. A point x fixed in the frame of joint m lies, for all values of
  // the joints between m and the link, in a ball B(c, r) of frame m (at the link: c = x,
  // r = the pad). Its speed when revolute m moves is its distance to m's axis (through m's
  // origin): at most |P_m c| + r (P_m: projection orthogonal to the axis). Under m's motion
  // the ball sweeps a set inside B((c.e) e, r + |P_m c|) (a rotation about e fixes
  // (c.e) e and keeps distances) for a revolute m, inside B(c + mid e, r + half) for a
  // prismatic m moving within [mid - half, mid + half]; in the parent's frame the ball is
  // moved by m's fixed placement. So W[l][m] = max over the link's points of |P_m c| + r,
  // computed joint by joint up the chain (1 for a prismatic m). A prismatic joint's range
  // is its limits, or, when a limit is not finite, the range of its coordinate on the path.
  std::vector<double> link_weights(const Eigen::Ref<const RowMatrixXd>& path,
                                   std::string& message) const {
    const int nv = model_.nv;
    std::vector<double> W(nl_ * nv, 0.0);
    const int nj = static_cast<int>(model_.njoints);
    std::vector<double> mid(nj, 0.0), half(nj, 0.0);
    for (int j = 1; j < nj; ++j) {
      if (!prismatic_[j]) continue;
      const int iq = model_.joints[j].idx_q();
      double lo = model_.lowerPositionLimit[iq], hi = model_.upperPositionLimit[iq];
      if (!std::isfinite(lo) || !std::isfinite(hi) || lo > hi) {
        if (path.rows() == 0) {
          message = "prismatic joint '" + model_.names[j] +
                    "' has no finite limits: give the path so its reach can be taken from it";
          return W;
        }
        lo = path.col(iq).minCoeff();
        hi = path.col(iq).maxCoeff();
      } else if (path.rows() > 0) {  // limits and the path's range: the union
        lo = std::min(lo, path.col(iq).minCoeff());
        hi = std::max(hi, path.col(iq).maxCoeff());
      }
      mid[j] = 0.5 * (lo + hi);
      half[j] = 0.5 * (hi - lo);
    }
    for (std::size_t l = 0; l < nl_; ++l) {
      double* w = W.data() + l * nv;
      auto visit = [&](coal::Vec3s c, double r) {
        for (int m = link_joint_[l]; m > 0; m = static_cast<int>(model_.parents[m])) {
          const int a = axis_[m], k = model_.joints[m].idx_v();
          if (prismatic_[m]) {
            w[k] = 1.0;
            c[a] += mid[m];
            r += half[m];
          } else {
            coal::Vec3s p = c;
            p[a] = 0.0;
            const double rp = p.norm();
            w[k] = std::max(w[k], rp + r);
            r += rp;
            c -= p;  // (c.e) e
          }
          c = model_.jointPlacements[m].act(c);
        }
      };
      for (std::size_t i = 0; i < obj_.size(); ++i) {
        const Object& o = obj_[i];
        if (o.joint != link_joint_[l]) continue;
        for (const coal::Vec3s& p : o.points.first) visit(p, o.points.second);
      }
      for (int k = 0; k < nv; ++k) w[k] = w[k] * (1.0 + 1e-12) * weight_factor_;
    }
    return W;
  }

  // The distance lower bound of pair p at the current placements (data_.oMi), the exact one
  // when the cheaper ones do not reach `want` (tolerance and the budget wanted); *exact set
  // when coal's distance was taken.
  double bound(const Pair& pr, double tolerance, double want, double near, double far,
               bool& exact) {
    const Object& A = obj_[pr.a];
    const Object& B = obj_[pr.b];
    exact = false;
    const pinocchio::SE3& Ma = data_.oMi[A.joint];
    const coal::Vec3s ca = Ma.act(A.center);
    double lb;
    if (pr.kind == kStatic) {
      lb = point_static_distance(B, ca) - A.radius;
    } else {
      const coal::Vec3s cb = data_.oMi[B.joint].act(B.center);
      lb = (ca - cb).norm() - A.radius - B.radius;
    }
    if (lb >= tolerance && (lb >= want || lb >= far)) return lb;
    const bool spheres = A.sph_end > A.sph_begin &&
                         (pr.kind == kStatic || B.sph_end > B.sph_begin);
    if (spheres) {
      double s = std::numeric_limits<double>::infinity();
      const coal::Vec3s* wa = world_spheres(pr.a);
      if (pr.kind == kStatic) {
        for (int i = A.sph_begin; i < A.sph_end; ++i)
          s = std::min(s, point_static_distance(B, wa[i - A.sph_begin]) - sph_r_[i]);
      } else {
        const coal::Vec3s* wb = world_spheres(pr.b);
        for (int i = A.sph_begin; i < A.sph_end; ++i) {
          const coal::Vec3s& c = wa[i - A.sph_begin];
          for (int j = B.sph_begin; j < B.sph_end; ++j) {
            const double r = sph_r_[i] + sph_r_[j], reach = s + r;
            const double d2 = (c - wb[j - B.sph_begin]).squaredNorm();
            if (reach > 0.0 && d2 >= reach * reach) continue;  // cannot lower s
            s = std::min(s, std::sqrt(d2) - r);
          }
        }
      }
      lb = std::max(lb, s);
      if (lb >= tolerance && (lb >= want || lb >= near)) return lb;
    }
    exact = true;
    return exact_distance(A, B, pr.kind == kStatic || pr.kind == kConstant);
  }

  // World centres of object i's spheres at the current evaluation point (once per point).
  const coal::Vec3s* world_spheres(std::size_t i) {
    const Object& o = obj_[i];
    if (sph_stamp_[i] != point_) {
      sph_stamp_[i] = point_;
      const pinocchio::SE3& M = data_.oMi[o.joint];
      for (int k = o.sph_begin; k < o.sph_end; ++k) sph_w_[k] = M.act(sph_c_[k]);
    }
    return sph_w_.data() + o.sph_begin;
  }

  double exact_distance(const Object& A, const Object& B, bool b_static) {
    const coal::Transform3s ta = pinocchio::toCoalTransform3s(data_.oMi[A.joint] * A.placement);
    const coal::Transform3s tb =
        b_static ? B.tf : pinocchio::toCoalTransform3s(data_.oMi[B.joint] * B.placement);
    coal::DistanceRequest req(false, true);
    req.gjk_initial_guess = coal::GJKInitialGuess::DefaultGuess;
    coal::DistanceResult res;
    coal::distance(A.geometry, ta, B.geometry, tb, req, res);
    // GJK stops within its (relative) tolerance of the distance: take it off
    const double d = res.min_distance;
    return d - req.gjk_tolerance * std::max(1.0, std::abs(d));
  }

  Outcome run(const Eigen::Ref<const RowMatrixXd>& path, double tolerance, long max_queries,
              double time_left, double near, double far, double early, GilRelease& gil) {
    Outcome out;
    const int nq = model_.nq;
    const Eigen::Index m = path.rows();
    const int S = static_cast<int>(m > 1 ? m - 1 : 0);  // segments
    const bool timed = std::isfinite(time_left);
    const auto start = clock::now();
    const auto deadline =
        timed ? start + std::chrono::duration_cast<clock::duration>(
                            std::chrono::duration<double>(std::max(0.0, time_left)))
              : clock::time_point::max();
    auto next_poll = start + kPollInterval;
    // false: stop (out filled)
    auto may_query = [&](long s, double t) {
      const auto now = clock::now();
      if (timed && now > deadline) {
        out.timed_out = true;
        out.segment = s;
        out.t = t;
        return false;
      }
      if (now >= next_poll) {
        next_poll = now + kPollInterval;
        if (gil.poll()) {
          out.interrupted = true;
          return false;
        }
      }
      if (out.queries >= max_queries) {
        out.segment = s;
        out.t = t;
        return false;
      }
      ++out.queries;
      return true;
    };
    // W from the limits (computed once) unless a prismatic coordinate of the path leaves
    // them or a limit is not finite (then from the limits and the path's range)
    bool within = true;
    for (int j = 1; j < static_cast<int>(model_.njoints) && within; ++j) {
      if (!prismatic_[j]) continue;
      const int iq = model_.joints[j].idx_q();
      const double lo = model_.lowerPositionLimit[iq], hi = model_.upperPositionLimit[iq];
      within = std::isfinite(lo) && std::isfinite(hi) && lo <= hi &&
               path.col(iq).minCoeff() >= lo && path.col(iq).maxCoeff() <= hi;
    }
    std::string message;
    if (within && (W_limits_.empty() || W_factor_ != weight_factor_)) {
      W_limits_ = link_weights(path.topRows(0), message);
      W_factor_ = weight_factor_;
    }
    const std::vector<double> W = within ? W_limits_ : link_weights(path, message);
    if (!message.empty()) {
      out.error = true;
      out.message = message;
      return out;
    }
    // rigid pairs (> 0) and constant pairs (>= tolerance): their distances do not depend
    // on the configuration, so they are computed once per certifier (at the first waypoint
    // of the first path, as Python does at every path's first waypoint)
    if (!fixed_done_) {
      if (!may_query(0, 0.0)) return out;
      pinocchio::forwardKinematics(model_, data_, path.row(0).transpose());
      for (const Pair& pr : pairs_) {
        if (pr.kind != kRigid && pr.kind != kConstant) continue;
        ++out.evaluations;
        ++out.exact;
        const double d = exact_distance(obj_[pr.a], obj_[pr.b], obj_[pr.b].joint == 0);
        double& least = pr.kind == kRigid ? rigid_least_ : constant_least_;
        least = std::min(least, d);
      }
      fixed_done_ = true;
    }
    out.least = std::min({out.least, rigid_least_, constant_least_});
    if (!(rigid_least_ > 0.0) || !(constant_least_ >= tolerance)) {
      out.segment = 0;
      out.t = 0.0;
      return out;
    }
    // rates per class and segment, cumulated
    const std::size_t nc = nl_ + link_pairs_.size();
    std::vector<double> wc(nc * nq, 0.0);
    for (std::size_t l = 0; l < nl_; ++l)
      for (int k = 0; k < nq; ++k) wc[l * nq + k] = W[l * nq + k];
    for (std::size_t c = 0; c < link_pairs_.size(); ++c) {
      const auto [la, lb] = link_pairs_[c];
      for (int k = 0; k < nq; ++k) {
        const bool in_a = ancestors_[la * nq + k] != 0, in_b = ancestors_[lb * nq + k] != 0;
        wc[(nl_ + c) * nq + k] =
            in_a && !in_b ? W[la * nq + k] : (in_b && !in_a ? W[lb * nq + k] : 0.0);
      }
    }
    std::vector<double> rate(nc * std::max(S, 1), 0.0), cum(nc * (S + 1), 0.0);
    for (int s = 0; s < S; ++s) {
      for (std::size_t c = 0; c < nc; ++c) {
        double r = 0.0;
        for (int k = 0; k < nq; ++k)
          r += wc[c * nq + k] * std::abs(path(s + 1, k) - path(s, k));
        rate[c * S + s] = r;
        cum[c * (S + 1) + s + 1] = cum[c * (S + 1) + s] + r;
      }
    }
    // position of budget exhaustion for class c from position (s, t) with budget d
    auto expiry = [&](std::size_t c, int s, double t, double d) {
      if (S == 0) return std::numeric_limits<double>::infinity();
      const double* C = cum.data() + c * (S + 1);
      const double target = C[s] + t * rate[c * S + s] + d;
      if (!(target < C[S])) return std::numeric_limits<double>::infinity();
      int k = s;
      while (!(target < C[k + 1])) ++k;
      const double r = rate[c * S + k];
      const double tt = std::min(1.0, std::max(0.0, (target - C[k]) / r));
      return k + tt;
    };
    auto remaining = [&](std::size_t c, int s, double t) {
      if (S == 0) return 0.0;
      const double* C = cum.data() + c * (S + 1);
      return C[S] - (C[s] + t * rate[c * S + s]);
    };
    // Per pair the position where its budget runs out (the next evaluation point is the
    // least of these) and the position from which it may be evaluated early (`early` of its
    // last step before that), so that pairs share evaluation points (one kinematics for
    // several); scanned linearly (a few hundred pairs, about a hundred points).
    std::vector<int> live;
    std::vector<double> ends, starts;
    for (std::size_t p = 0; p < pairs_.size(); ++p)
      if (pairs_[p].kind == kStatic || pairs_[p].kind == kSelf) {
        live.push_back(static_cast<int>(p));
        ends.push_back(0.0);
        starts.push_back(0.0);
      }
    pair_evals_.assign(pairs_.size(), 0);
    sph_w_.resize(sph_c_.size());
    sph_stamp_.assign(obj_.size(), 0);
    point_ = 0;
    VectorXd q(nq);
    const double end = static_cast<double>(S);
    bool first = true;
    // the least lower bound that was not an exact distance, its pair and position
    double low = std::numeric_limits<double>::infinity(), low_u = 0.0;
    int low_pair = -1;
    auto place = [&](double u) {
      const int s = std::min(static_cast<int>(u), std::max(S - 1, 0));
      const double t = S == 0 ? 0.0 : u - s;
      if (S == 0) {
        q = path.row(0).transpose();
      } else {
        for (int k = 0; k < nq; ++k) q[k] = path(s, k) + t * (path(s + 1, k) - path(s, k));
      }
      pinocchio::forwardKinematics(model_, data_, q);
      ++point_;
    };
    while (!live.empty()) {
      double u = ends[0];
      for (std::size_t i = 1; i < ends.size(); ++i) u = std::min(u, ends[i]);
      if (!first && !(u < end)) break;
      first = false;
      const int s = std::min(static_cast<int>(u), std::max(S - 1, 0));
      const double t = S == 0 ? 0.0 : u - s;
      if (!may_query(s, t)) return out;
      place(u);
      std::size_t kept = 0;
      for (std::size_t i = 0; i < live.size(); ++i) {
        const int p = live[i];
        if (starts[i] > u) {  // not due: keep
          live[kept] = p;
          ends[kept] = ends[i];
          starts[kept] = starts[i];
          ++kept;
          continue;
        }
        const Pair& pr = pairs_[p];
        const double want = remaining(pr.rate_class, s, t);
        bool exact = false;
        const double d = bound(pr, tolerance, want, near, far, exact);
        ++out.evaluations;
        ++pair_evals_[p];
        out.exact += exact ? 1 : 0;
        if (exact) {
          out.least = std::min(out.least, d);
        } else if (d < low) {  // a lower bound: made a distance at the end
          low = d;
          low_pair = p;
          low_u = u;
        }
        if (!(d >= tolerance)) {  // only the exact distance says so
          out.segment = s;
          out.t = t;
          return out;
        }
        const double next = expiry(pr.rate_class, s, t, d * (1.0 - 1e-12));
        if (next < end) {
          const double stop = std::max(next, std::nextafter(u, end));
          live[kept] = p;
          ends[kept] = stop;
          starts[kept] = stop - early * (stop - u);
          ++kept;
        }
      }
      live.resize(kept);
      ends.resize(kept);
      starts.resize(kept);
    }
    // min_distance is a distance met on the path (as the Python certifier's): the exact
    // distance of the pair whose lower bound was least, where it was taken, when below the
    // least exact distance evaluated
    if (low_pair >= 0 && low < out.least) {
      place(low_u);
      const Pair& pr = pairs_[low_pair];
      out.least = std::min(out.least, exact_distance(obj_[pr.a], obj_[pr.b], pr.kind == kStatic));
      ++out.exact;
    }
    out.certified = true;
    out.segment = -1;
    out.t = 1.0;
    return out;
  }

  bp::object py_[2];
  const Model& model_;
  const GeometryModel& geom_;
  Data data_;
  std::vector<int> axis_, link_of_joint_, link_joint_;
  std::vector<char> prismatic_, ancestors_;
  std::size_t nl_ = 0;
  std::vector<Object> obj_;
  std::vector<Pair> pairs_;
  std::vector<std::pair<int, int>> link_pairs_;
  std::vector<coal::Vec3s> sph_c_;
  std::vector<double> sph_r_;
  double weight_factor_ = 1.0;
  std::vector<double> W_limits_;  // W from the limits (link_weights without a path)
  double W_factor_ = 1.0;
  bool fixed_done_ = false;  // rigid_least_ and constant_least_ computed
  double rigid_least_ = std::numeric_limits<double>::infinity();
  double constant_least_ = std::numeric_limits<double>::infinity();
  std::vector<long> pair_evals_;
  std::vector<coal::Vec3s> sph_w_;  // world sphere centres (world_spheres)
  std::vector<long> sph_stamp_;
  long point_ = 0;
  std::timed_mutex mutex_;
};

void register_path_certifier() {
  bp::class_<PathCertifier, boost::noncopyable>(
      "PathCertifier",
      bp::init<bp::object, bp::object, const Eigen::Ref<const RowMatrixXd>&, const VectorXd&,
               const Eigen::VectorXi&, double, int>(
          bp::args("self", "model", "geometry_model", "centers", "radii", "geometries",
                   "certified_margin", "robot_geometries")))
      .add_property("has_spheres", &PathCertifier::has_spheres)
      .add_property("pair_count", &PathCertifier::pair_count)
      .def("certify", &PathCertifier::certify,
           (bp::arg("self"), bp::arg("path"), bp::arg("tolerance"), bp::arg("max_queries"),
            bp::arg("time_left"), bp::arg("near"), bp::arg("far"), bp::arg("early") = 0.5))
      .def("pair_evaluations", &PathCertifier::pair_evaluations)
      .def("weights", &PathCertifier::weights_py, bp::args("self", "path"))
      .def("set_weight_factor", &PathCertifier::set_weight_factor, bp::args("self", "factor"));
}

}  // namespace
