// Batched Ferrari-Canny epsilon (L1, and L-infinity) of grasps, part of the _planning_kernel
// module (plain CPython functions, registered by planning_kernel.cpp like curves.cpp).
//
// The L1 grasp wrench space is P = conv{w_k} (6-D) and its epsilon is the distance from the
// origin to the boundary of P: min_j b_j over the facets u_j . w <= b_j (|u_j| = 1), or
// equivalently min over unit u of the support h_P(u) = max_k u . w_k. The NumPy/qhull path in
// taskspace/grasping/epsilon.py (_epsilon_generated, _epsilon_full) is the reference; this is
// the same column generation with its own hull, one grasp after the other in one call:
//
// * S starts as a simplex of wrenches (greedy volume, the supports along the 12 +-coordinate
//   axes first) and the other axis supports; conv S is kept as a simplicial hull
//   (beneath-beyond: the facets visible from a new point are removed, the horizon ridges are
//   coned to it, the new facets' neighbours matched by their shared 4-vertex sets).
// * Each step takes the nearest facet (u, b) of conv S (least offset; negative while the
//   origin is outside conv S) and the support point s = argmax_k u . w_k of all wrenches.
//   When u . s <= b + support_tol it stops; otherwise s joins S (an EPA-style expansion).
// * Certificate, as _hull_certified: the facets close up (every neighbour link alive and
//   reciprocal) and every point of S is inside every facet plane to cert_tol. Then the facets
//   are the boundary of conv S and b = eps(conv S) <= eps(P) (conv S is inside P), while
//   eps(P) <= h_P(u) <= b + support_tol (the ball of radius eps(P) is inside P). A margin
//   b + support_tol <= margin_tol is 0 by the upper bound alone (no hull certificate needed).
//
// Whenever it cannot certify (fewer than 7 affinely independent wrenches, a facet too thin to
// give a normal, a point of S found outside a facet, unmatched ridges, a failed certificate,
// too many steps), the grasp's status is <= 0 and the Python wrapper answers it with the
// qhull path. Tolerances are passed from Python (epsilon.py's constants). Wrenches are scaled
// per grasp to a largest entry of 1 here, as in Python; the result is scaled back.
//
//   epsilon_l1(W, support_tol, cert_tol, margin_tol, corrupt=0)
//       -> (eps (B,), status (B,) int8, sizes (B, 2) int32: points in S, facets ever made)
//
// The L-infinity wrench space (epsilon_linf below) is the Minkowski sum of the contacts'
// conv({0} u W_c); only its support function is used (the support point is the sum of each
// contact's best row), so its vertices, whose number is the product of the contacts', are
// never enumerated.
//
// W: float64 (B, K, 6). status: 1 certified hull value, 2 zero (a separating direction or the
// support bound), <= 0 not certified (the reasons: the k* constants below). corrupt (tests
// only): 1 moves the nearest facet inwards by 1e-6, 2 unlinks one neighbour, before the
// certificate, which must then refuse. The GIL is released during the computation.

#define PY_SSIZE_T_CLEAN
#include <Python.h>

#define PY_ARRAY_UNIQUE_SYMBOL TASKSPACE_GRASP_EPSILON_ARRAY_API
#define NPY_NO_DEPRECATED_API NPY_1_7_API_VERSION
#include <numpy/arrayobject.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <functional>
#include <utility>
#include <vector>

namespace {

using Vec = Eigen::Matrix<double, 6, 1>;

constexpr int kCertified = 1;
constexpr int kZero = 2;
constexpr int kFlat = 0;          // no 7 affinely independent wrenches
constexpr int kThin = -1;         // a new facet too thin for a normal, or origin-side unclear
constexpr int kRepeated = -2;     // a point of S above a facet of conv S
constexpr int kUnmatched = -3;    // the new facets' ridges do not pair up
constexpr int kUncertified = -4;  // the final certificate failed
constexpr int kSteps = -5;        // more steps than wrenches

constexpr double kThinTolerance = 1e-12;  // least |R_ii| of a facet's edge matrix (scale 1)
constexpr double kOnPlane = 1e-14;  // a rotated plane's largest vertex residual (scale 1)

struct Facet {
  int v[6];   // vertices (indices into S)
  int nb[6];  // nb[i]: the facet across the ridge without v[i]
  Vec u;      // outward unit normal
  double b;   // offset: u . x <= b inside
  double dist;  // u . x - b of the point being added (valid with the stamps)
  int visible_stamp;
  int hidden_stamp;
  bool alive;
};

struct Ridge {
  std::uint64_t key;  // the 4 vertices of a new facet's sub-ridge other than the apex
  int facet;
  int slot;
};

class Hull {
 public:
  std::vector<Vec> S;
  std::vector<Facet> F;
  std::vector<std::pair<double, int>> heap;  // min-heap of (b, facet), lazily cleaned
  Vec interior = Vec::Zero();
  double visible_tol = 0.0;
  int stamp = 0;
  int status = kCertified;

  void reset(double tol) {
    S.clear();
    F.clear();
    heap.clear();
    stamp = 0;
    status = kCertified;
    visible_tol = tol;
  }

  // Plane through the 6 points of f.v, oriented away from `interior`; false when too thin.
  bool plane(Facet& f) const {
    Eigen::Matrix<double, 6, 5> M;
    const Vec& p0 = S[f.v[0]];
    for (int j = 0; j < 5; ++j) M.col(j) = S[f.v[j + 1]] - p0;
    Eigen::HouseholderQR<Eigen::Matrix<double, 6, 5>> qr(M);
    if (qr.matrixQR().diagonal().cwiseAbs().minCoeff() < kThinTolerance) return false;
    Vec n = qr.householderQ() * Vec::Unit(5);
    n.normalize();
    double side = n.dot(p0 - interior);
    if (std::abs(side) < kThinTolerance) return false;
    if (side < 0) n = -n;
    double b = 0.0;
    for (int j = 0; j < 6; ++j) b += n.dot(S[f.v[j]]);
    f.u = n;
    f.b = b / 6.0;
    return true;
  }

  // Plane of f (a horizon ridge between visible g and hidden h, coned to the new point
  // x) by rotating g's plane about the ridge: u = d_g u_h - d_h u_g (d = u . x - b) is normal
  // to the ridge and to x - ridge, and outward (d_g > 0 >= d_h, approximately). Accepted
  // when its 6 vertices are on it to kOnPlane; otherwise false (then plane() by QR).
  bool rotated(Facet& f, const Facet& g, const Facet& h) const {
    Vec n = g.dist * h.u - h.dist * g.u;
    const double norm = n.norm();
    if (!(norm > 0)) return false;
    n /= norm;
    double v[6];
    double b = 0.0;
    for (int j = 0; j < 6; ++j) b += (v[j] = n.dot(S[f.v[j]]));
    b /= 6.0;
    for (int j = 0; j < 6; ++j)
      if (std::abs(v[j] - b) > kOnPlane) return false;
    if (n.dot(interior) >= b) return false;
    f.u = n;
    f.b = b;
    return true;
  }

  void push(int id) {
    heap.emplace_back(F[id].b, id);
    std::push_heap(heap.begin(), heap.end(), std::greater<>());
  }

  // The alive facet of least offset (-1 when none).
  int nearest() {
    while (!heap.empty()) {
      int id = heap.front().second;
      if (F[id].alive) return id;
      std::pop_heap(heap.begin(), heap.end(), std::greater<>());
      heap.pop_back();
    }
    return -1;
  }

  // Simplex of 7 points of P (rows of W), greedy volume; false when W is flat.
  bool simplex(const Eigen::Ref<const Eigen::Matrix<double, Eigen::Dynamic, 6, Eigen::RowMajor>>& W,
               const std::vector<int>& first, std::vector<int>& chosen) {
    const int K = static_cast<int>(W.rows());
    Eigen::Matrix<double, 6, 6> basis;
    int rank = 0;
    int p0 = first.empty() ? 0 : first[0];
    chosen.assign(1, p0);
    for (int step = 0; step < 6; ++step) {
      double best = 0.0;
      int arg = -1;
      auto consider = [&](int k) {
        Vec r = W.row(k).transpose() - W.row(p0).transpose();
        for (int j = 0; j < rank; ++j) r -= basis.col(j).dot(r) * basis.col(j);
        double n = r.norm();
        if (n > best) {
          best = n;
          arg = k;
        }
      };
      for (int k : first) consider(k);
      if (best < 1e-3) {  // the axis supports are flat: look at every wrench
        for (int k = 0; k < K; ++k) consider(k);
      }
      if (arg < 0 || best < 1e-9) return false;
      Vec r = W.row(arg).transpose() - W.row(p0).transpose();
      for (int j = 0; j < rank; ++j) r -= basis.col(j).dot(r) * basis.col(j);
      for (int j = 0; j < rank; ++j) r -= basis.col(j).dot(r) * basis.col(j);  // twice is enough
      basis.col(rank++) = r.normalized();
      chosen.push_back(arg);
    }
    return true;
  }

  // Hull of the 7 points S[0..6] (the simplex): 7 facets, each without one vertex.
  bool start() {
    interior.setZero();
    for (int i = 0; i < 7; ++i) interior += S[i];
    interior /= 7.0;
    F.resize(7);
    for (int i = 0; i < 7; ++i) {
      Facet& f = F[i];
      int j = 0;
      for (int k = 0; k < 7; ++k) {
        if (k == i) continue;
        f.v[j] = k;
        f.nb[j] = k;  // across the ridge without vertex k: the facet without vertex k
        ++j;
      }
      f.alive = true;
      f.visible_stamp = f.hidden_stamp = 0;
      if (!plane(f)) return false;
      push(i);
    }
    return true;
  }

  // Adds point S[p] (above facet `seed` by more than visible_tol); false on failure (status).
  bool add(int p, int seed) {
    ++stamp;
    std::vector<int>& visible = visible_;
    visible.clear();
    visible.push_back(seed);
    F[seed].visible_stamp = stamp;
    const Vec& x = S[p];
    F[seed].dist = F[seed].u.dot(x) - F[seed].b;
    for (std::size_t q = 0; q < visible.size(); ++q) {
      const int g = visible[q];
      for (int i = 0; i < 6; ++i) {
        const int h = F[g].nb[i];
        Facet& fh = F[h];
        if (fh.visible_stamp == stamp || fh.hidden_stamp == stamp) continue;
        fh.dist = fh.u.dot(x) - fh.b;
        if (fh.dist > visible_tol) {
          fh.visible_stamp = stamp;
          visible.push_back(h);
        } else {
          fh.hidden_stamp = stamp;
        }
      }
    }
    ridges_.clear();
    for (const int g : visible) {
      for (int i = 0; i < 6; ++i) {
        const int h = F[g].nb[i];
        if (F[h].visible_stamp == stamp) continue;
        // horizon ridge: g's vertices without v[i], shared with h; new facet = ridge + p
        Facet f;
        std::copy(F[g].v, F[g].v + 6, f.v);
        f.v[i] = p;
        std::fill(f.nb, f.nb + 6, -1);
        f.nb[i] = h;
        f.alive = true;
        f.visible_stamp = f.hidden_stamp = 0;
        if (!rotated(f, F[g], F[h]) && !plane(f)) {
          status = kThin;
          return false;
        }
        const int id = static_cast<int>(F.size());
        F.push_back(f);
        push(id);
        Facet& fh = F[h];
        int j = 0;
        while (j < 6 && fh.nb[j] != g) ++j;
        if (j == 6) {
          status = kUnmatched;
          return false;
        }
        fh.nb[j] = id;
        // the ridge's 5 vertices, sorted (insertion sort, with their slots); each sub-ridge
        // key leaves one out and stays sorted
        int w[5], ws[5];
        int n = 0;
        for (int l = 0; l < 6; ++l) {
          if (l == i) continue;
          int m = n++;
          while (m > 0 && w[m - 1] > f.v[l]) {
            w[m] = w[m - 1];
            ws[m] = ws[m - 1];
            --m;
          }
          w[m] = f.v[l];
          ws[m] = l;
        }
        for (int out = 0; out < 5; ++out) {
          std::uint64_t key = 0;
          for (int l = 0; l < 5; ++l)
            if (l != out) key = (key << 16) | static_cast<std::uint64_t>(w[l]);
          ridges_.push_back({key, id, ws[out]});
        }
      }
    }
    for (const int g : visible) F[g].alive = false;
    // pair the new facets' sub-ridges (each 4-vertex key exactly twice) in a hash table
    if (ridges_.size() > kTableSize / 2) {  // keeps the linear probing short (and finite)
      status = kUnmatched;
      return false;
    }
    ++table_stamp_;
    int open = 0;
    for (const Ridge& r : ridges_) {
      std::size_t slot = (r.key * 0x9E3779B97F4A7C15ULL) >> (64 - kTableBits);
      while (true) {
        Entry& e = table_[slot];
        if (e.stamp != table_stamp_) {  // empty: first of the pair
          e = {r.key, r.facet, r.slot, table_stamp_, false};
          ++open;
          break;
        }
        if (e.key == r.key) {
          if (e.paired) {  // a third facet on one sub-ridge
            status = kUnmatched;
            return false;
          }
          e.paired = true;
          --open;
          F[e.facet].nb[e.slot] = r.facet;
          F[r.facet].nb[r.slot] = e.facet;
          break;
        }
        slot = (slot + 1) & (kTableSize - 1);
      }
    }
    if (open != 0) {
      status = kUnmatched;
      return false;
    }
    return true;
  }

  // Closed surface, every point of S inside every facet plane to tol.
  bool certified(double tol) const {
    for (std::size_t id = 0; id < F.size(); ++id) {
      const Facet& f = F[id];
      if (!f.alive) continue;
      for (int i = 0; i < 6; ++i) {
        const int h = f.nb[i];
        if (h < 0 || h >= static_cast<int>(F.size()) || !F[h].alive) return false;
        const Facet& fh = F[h];
        int back = 0;
        for (int j = 0; j < 6; ++j) back += fh.nb[j] == static_cast<int>(id);
        if (back != 1) return false;
      }
      for (const Vec& x : S)
        if (f.u.dot(x) - f.b > tol) return false;
    }
    return true;
  }

  std::vector<int> visible_;
  std::vector<Ridge> ridges_;

  struct Entry {
    std::uint64_t key;
    int facet;
    int slot;
    int stamp;
    bool paired;
  };
  static constexpr int kTableBits = 13;
  static constexpr std::size_t kTableSize = std::size_t{1} << kTableBits;
  std::vector<Entry> table_ = std::vector<Entry>(kTableSize, Entry{0, 0, 0, 0, false});
  int table_stamp_ = 0;
};

using Rows = Eigen::Matrix<double, Eigen::Dynamic, 6, Eigen::RowMajor>;

// The separating directions of epsilon.py's _separated (W scaled to a largest entry of 1).
bool separated(const Rows& W, double margin_tol) {
  const double t = -margin_tol;
  const Vec lo = W.colwise().minCoeff().transpose();
  const Vec hi = W.colwise().maxCoeff().transpose();
  if ((lo.array() >= t).any() || (hi.array() <= -t).any()) return true;
  const Vec c = W.colwise().sum().transpose();
  const double norm = c.norm();
  return norm > 0 && (W * c).minCoeff() >= t * norm;
}

// Epsilon of one grasp (W scaled); sets status.
double epsilon_one(Hull& hull, const Rows& W, double support_tol, double cert_tol,
                   double margin_tol, int corrupt, int* status) {
  const int K = static_cast<int>(W.rows());
  hull.reset(0.5 * cert_tol);
  if (K <= 6 || separated(W, margin_tol)) {
    *status = kZero;
    return 0.0;
  }
  std::vector<int> in_s(K, -1);
  // supports along the +-coordinate axes, in order, without repeats
  std::vector<int> axes;
  for (int j = 0; j < 6; ++j) {
    Eigen::Index hi, lo;
    W.col(j).maxCoeff(&hi);
    W.col(j).minCoeff(&lo);
    for (int k : {static_cast<int>(hi), static_cast<int>(lo)})
      if (std::find(axes.begin(), axes.end(), k) == axes.end()) axes.push_back(k);
  }
  std::vector<int> chosen;
  if (!hull.simplex(W, axes, chosen)) {
    *status = kFlat;
    return 0.0;
  }
  for (int k : chosen) {
    in_s[k] = static_cast<int>(hull.S.size());
    hull.S.push_back(W.row(k).transpose());
  }
  if (!hull.start()) {
    *status = kThin;
    return 0.0;
  }
  for (int step = 0; step <= K; ++step) {
    const int f = hull.nearest();
    if (f < 0) {
      *status = kUnmatched;
      return 0.0;
    }
    const Vec u = hull.F[f].u;
    const double b = hull.F[f].b;
    Eigen::Index arg;
    const double h = (W * u).maxCoeff(&arg);
    if (h - b <= support_tol) {
      if (b + support_tol <= margin_tol) {
        *status = kZero;
        return 0.0;
      }
      if (corrupt == 1) hull.F[f].b -= 1e-6;
      if (corrupt == 2) hull.F[f].nb[0] = f;
      if (!hull.certified(cert_tol)) {
        *status = kUncertified;
        return 0.0;
      }
      *status = kCertified;
      return hull.F[f].b > margin_tol ? hull.F[f].b : 0.0;
    }
    if (in_s[arg] >= 0) {
      *status = kRepeated;
      return 0.0;
    }
    in_s[arg] = static_cast<int>(hull.S.size());
    hull.S.push_back(W.row(arg).transpose());
    if (!hull.add(in_s[arg], f)) {
      *status = hull.status;
      return 0.0;
    }
  }
  *status = kSteps;
  return 0.0;
}

// The batch loop of epsilon_l1 and epsilon_linf, GIL released: each grasp's wrenches (K, 6)
// scaled by their largest entry, one(hull, W, &status) -> the scaled set's epsilon; an empty
// or all-zero set is kZero. Takes arr's reference; returns (eps (B,), status (B,) int8,
// sizes (B, 2) int32) or nullptr with a Python error set.
template <class One>
PyObject* epsilon_batch(PyArrayObject* arr, const One& one) {
  const npy_intp* shape = PyArray_DIMS(arr);
  const npy_intp B = shape[0], K = shape[1];
  npy_intp dims[1] = {B};
  npy_intp dims2[2] = {B, 2};
  PyArrayObject* out = reinterpret_cast<PyArrayObject*>(PyArray_ZEROS(1, dims, NPY_DOUBLE, 0));
  PyArrayObject* st = reinterpret_cast<PyArrayObject*>(PyArray_ZEROS(1, dims, NPY_INT8, 0));
  PyArrayObject* sz = reinterpret_cast<PyArrayObject*>(PyArray_ZEROS(2, dims2, NPY_INT32, 0));
  if (out == nullptr || st == nullptr || sz == nullptr) {
    Py_XDECREF(out);
    Py_XDECREF(st);
    Py_XDECREF(sz);
    Py_DECREF(arr);
    return nullptr;
  }
  const double* data = static_cast<const double*>(PyArray_DATA(arr));
  double* eps = static_cast<double*>(PyArray_DATA(out));
  std::int8_t* status = static_cast<std::int8_t*>(PyArray_DATA(st));
  std::int32_t* sizes = static_cast<std::int32_t*>(PyArray_DATA(sz));
  Py_BEGIN_ALLOW_THREADS;
  Hull hull;
  Rows W(K, 6);
  for (npy_intp g = 0; g < B; ++g) {
    const Eigen::Map<const Rows> raw(data + g * K * 6, K, 6);
    const double scale = K > 0 ? raw.cwiseAbs().maxCoeff() : 0.0;
    if (!(scale > 0)) {
      eps[g] = 0.0;
      status[g] = kZero;
      continue;
    }
    W = raw / scale;
    int s = kUncertified;
    const double e = one(hull, W, &s);
    status[g] = static_cast<std::int8_t>(s);
    sizes[2 * g] = static_cast<std::int32_t>(hull.S.size());
    sizes[2 * g + 1] = static_cast<std::int32_t>(hull.F.size());
    eps[g] = s == kCertified ? e * scale : 0.0;
  }
  Py_END_ALLOW_THREADS;
  Py_DECREF(arr);
  return Py_BuildValue("(NNN)", out, st, sz);
}

PyObject* py_epsilon_l1(PyObject* /*self*/, PyObject* args) {
  PyObject* obj = nullptr;
  double support_tol = 0.0, cert_tol = 0.0, margin_tol = 0.0;
  int corrupt = 0;
  if (!PyArg_ParseTuple(args, "Oddd|i", &obj, &support_tol, &cert_tol, &margin_tol, &corrupt))
    return nullptr;
  PyArrayObject* arr = reinterpret_cast<PyArrayObject*>(
      PyArray_FROMANY(obj, NPY_DOUBLE, 3, 3, NPY_ARRAY_IN_ARRAY));
  if (arr == nullptr) return nullptr;
  const npy_intp* shape = PyArray_DIMS(arr);
  if (shape[2] != 6 || shape[1] >= 65000) {  // S indices (< K + 7) fit the 16-bit ridge keys
    Py_DECREF(arr);
    PyErr_SetString(PyExc_ValueError, "epsilon_l1: W must be (B, K < 65000, 6)");
    return nullptr;
  }
  return epsilon_batch(arr, [&](Hull& hull, const Rows& W, int* s) {
    return epsilon_one(hull, W, support_tol, cert_tol, margin_tol, corrupt, s);
  });
}

// The L-infinity wrench space P = sum_c conv({0} u W_c) (W_c: the rows of contact c) is
// given by its support only: h(u) = sum_c max(0, max_{w in W_c} u . w), attained at the sum
// of each contact's best row (none when all are negative). The same expansion and
// certificate as epsilon_one; a point of S is identified by its choice of rows.
class LinfSupport {
 public:
  LinfSupport(const Rows& W, const std::vector<int>& owner, int contacts)
      : W_(W), owner_(owner), contacts_(contacts) {}

  double support(const Vec& u, Vec& x, std::vector<int>& pick) {
    values_.noalias() = W_ * u;
    best_.assign(contacts_, 0.0);
    pick.assign(contacts_, -1);
    for (Eigen::Index k = 0; k < W_.rows(); ++k) {
      const int c = owner_[k];
      if (values_[k] > best_[c]) {
        best_[c] = values_[k];
        pick[c] = static_cast<int>(k);
      }
    }
    x.setZero();
    double h = 0.0;
    for (int c = 0; c < contacts_; ++c) {
      if (pick[c] < 0) continue;
      x += W_.row(pick[c]).transpose();
      h += best_[c];
    }
    return h;
  }

 private:
  const Rows& W_;
  const std::vector<int>& owner_;
  int contacts_;
  Eigen::VectorXd values_;
  std::vector<double> best_;
};

double epsilon_linf_one(Hull& hull, const Rows& W, const std::vector<int>& owner, int contacts,
                        double support_tol, double cert_tol, double margin_tol, int corrupt,
                        int max_steps, int* status) {
  hull.reset(0.5 * cert_tol);
  LinfSupport oracle(W, owner, contacts);
  // supports along the 12 +-axes first, then along the 60 +-(e_i +- e_j)
  std::vector<Vec> dirs;
  for (int j = 0; j < 6; ++j)
    for (double sgn : {1.0, -1.0}) dirs.push_back(sgn * Vec::Unit(j));
  for (int i = 0; i < 6; ++i)
    for (int j = i + 1; j < 6; ++j)
      for (double a : {1.0, -1.0})
        for (double c : {1.0, -1.0})
          dirs.push_back((a * Vec::Unit(i) + c * Vec::Unit(j)).normalized());
  Rows cand(static_cast<Eigen::Index>(dirs.size()), 6);
  std::vector<std::vector<int>> picks(dirs.size());
  Vec x;
  for (std::size_t q = 0; q < dirs.size(); ++q) {
    oracle.support(dirs[q], x, picks[q]);
    cand.row(static_cast<Eigen::Index>(q)) = x.transpose();
  }
  std::vector<int> first;
  for (int q = 0; q < 12; ++q) first.push_back(q);
  std::vector<int> chosen;
  if (!hull.simplex(cand, first, chosen)) {
    *status = kFlat;
    return 0.0;
  }
  std::vector<std::vector<int>> seen;
  for (int q : chosen) {
    hull.S.push_back(cand.row(q).transpose());
    seen.push_back(picks[q]);
  }
  if (!hull.start()) {
    *status = kThin;
    return 0.0;
  }
  std::vector<int> pick;
  for (int step = 0; step < max_steps; ++step) {
    const int f = hull.nearest();
    if (f < 0) {
      *status = kUnmatched;
      return 0.0;
    }
    const Vec u = hull.F[f].u;
    const double b = hull.F[f].b;
    const double h = oracle.support(u, x, pick);
    if (h - b <= support_tol) {
      if (b + support_tol <= margin_tol) {
        *status = kZero;
        return 0.0;
      }
      if (corrupt == 1) hull.F[f].b -= 1e-6;
      if (corrupt == 2) hull.F[f].nb[0] = f;
      if (!hull.certified(cert_tol)) {
        *status = kUncertified;
        return 0.0;
      }
      *status = kCertified;
      return hull.F[f].b > margin_tol ? hull.F[f].b : 0.0;
    }
    if (std::find(seen.begin(), seen.end(), pick) != seen.end()) {
      *status = kRepeated;
      return 0.0;
    }
    seen.push_back(pick);
    hull.S.push_back(x);
    if (!hull.add(static_cast<int>(hull.S.size()) - 1, f)) {
      *status = hull.status;
      return 0.0;
    }
  }
  *status = kSteps;
  return 0.0;
}

// epsilon_linf(W, owner, support_tol, cert_tol, margin_tol, max_steps, corrupt=0)
//     -> (eps (B,), status (B,) int8, sizes (B, 2) int32)
// owner: int (K,) contact index of each row, 0 .. C-1.
PyObject* py_epsilon_linf(PyObject* /*self*/, PyObject* args) {
  PyObject* obj = nullptr;
  PyObject* own = nullptr;
  double support_tol = 0.0, cert_tol = 0.0, margin_tol = 0.0;
  int max_steps = 0, corrupt = 0;
  if (!PyArg_ParseTuple(args, "OOdddi|i", &obj, &own, &support_tol, &cert_tol, &margin_tol,
                        &max_steps, &corrupt))
    return nullptr;
  PyArrayObject* arr = reinterpret_cast<PyArrayObject*>(
      PyArray_FROMANY(obj, NPY_DOUBLE, 3, 3, NPY_ARRAY_IN_ARRAY));
  if (arr == nullptr) return nullptr;
  PyArrayObject* owners =
      reinterpret_cast<PyArrayObject*>(PyArray_FROMANY(own, NPY_INT32, 1, 1, NPY_ARRAY_IN_ARRAY));
  if (owners == nullptr) {
    Py_DECREF(arr);
    return nullptr;
  }
  const npy_intp* shape = PyArray_DIMS(arr);
  const npy_intp K = shape[1];
  std::vector<int> owner(static_cast<std::size_t>(K), -1);
  int contacts = 0;
  bool ok = shape[2] == 6 && PyArray_DIMS(owners)[0] == K && max_steps > 0 && max_steps < 60000;
  if (ok) {
    const std::int32_t* o = static_cast<const std::int32_t*>(PyArray_DATA(owners));
    for (npy_intp k = 0; k < K; ++k) {
      ok = ok && o[k] >= 0 && o[k] < K;
      owner[k] = o[k];
      contacts = std::max(contacts, o[k] + 1);
    }
  }
  Py_DECREF(owners);
  if (!ok) {
    Py_DECREF(arr);
    PyErr_SetString(PyExc_ValueError,
                    "epsilon_linf: W must be (B, K, 6), owner (K,) ints in [0, K), "
                    "0 < max_steps < 60000");
    return nullptr;
  }
  return epsilon_batch(arr, [&](Hull& hull, const Rows& W, int* s) {
    return epsilon_linf_one(hull, W, owner, contacts, support_tol, cert_tol, margin_tol, corrupt,
                            max_steps, s);
  });
}

PyMethodDef kMethods[] = {
    {"epsilon_l1", py_epsilon_l1, METH_VARARGS,
     "Ferrari-Canny L1 epsilon of (B, K, 6) wrenches (W, support_tol, cert_tol, margin_tol"
     "[, corrupt]) -> (eps (B,), status (B,) int8: 1 certified, 2 zero, <= 0 not certified, "
     "sizes (B, 2) int32: points in S and facets made)."},
    {"epsilon_linf", py_epsilon_linf, METH_VARARGS,
     "Ferrari-Canny L-infinity epsilon of (B, K, 6) wrenches of contacts owner (K,) (W, owner, "
     "support_tol, cert_tol, margin_tol, max_steps[, corrupt]) -> (eps, status, sizes) as "
     "epsilon_l1."},
    {nullptr, nullptr, 0, nullptr}};

}  // namespace

// Adds the epsilon function to the module being initialised (_planning_kernel).
int taskspace_register_grasp_epsilon(PyObject* module) {
  if (_import_array() < 0) return -1;
  return PyModule_AddFunctions(module, kMethods);
}
