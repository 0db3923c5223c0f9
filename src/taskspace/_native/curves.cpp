// Compiled Dubins and Reeds-Shepp curves, part of the _planning_kernel module.
//
// The NumPy implementations in taskspace/planning/dubins.py, reeds_shepp.py and se2.py
// (CurvePath.pose_at) are the reference: the same closed forms (Dubins' six words; the eight
// base formulas of Reeds and Shepp with their time-flip, reflection and backwards symmetries,
// 44 evaluations covering the 48 words), the same validity tolerances, the same order of the
// words (the first of equally short words wins), so that the compiled and the NumPy answers
// agree to rounding. Where the expressions differ (one arc tangent for a sum of two, sin and
// cos from a ratio instead of a call, sqrt(x^2 + y^2) for hypot) the comments say so.
// tests/planning/test_planning_curves_native.py compares every word of every query with
// NumPy, and the distances and interpolated states with OMPL's.
//
// Speed. A single query is evaluated alone (no batching): the words are tried in an order
// and skipped, before their arc tangents, once a lower bound of their length exceeds the
// best word so far by 1e-9 (dubins_best, and the Reeds-Shepp formulas' `top`). Measured on
// 200,000 random queries in [-10, 10]^2 x [-pi, pi) (unit radius, CPU time per query on the
// 2-core machine, loaded, 2026-11-26): Reeds-Shepp 1.43 us without the bounds (28 arc
// tangents), 0.96 us with them (14); Dubins 0.21 and 0.175 us. glibc's hypot had been a
// quarter of the Reeds-Shepp time (2.0 us before any of this).
//
// The functions are plain CPython functions (METH_FASTCALL, no Boost.Python). Each one reads
// its arguments when they have the plain form the Python wrappers pass (poses: a tuple or
// list of three floats or ints, or a float64 array of shape (3,) or (N, 3); radius: a float
// or int > 0) and returns None otherwise; the Python wrapper then validates the arguments
// (raising taskspace's errors) and converts them, or falls back to NumPy. Nothing here
// raises for bad input.
//
//   dubins_distance(start, goal, radius)        -> float64 array (N,)
//   reeds_shepp_distance(start, goal, radius)   -> float64 array (N,)
//   dubins_shortest(start, goal, radius)        -> (start tuple, word index, lengths, radius)
//   reeds_shepp_shortest(start, goal, radius)   -> (start tuple, formula index, lengths,
//                                                   radius, signed word such as "L+R-L-")
//   curve_poses(start, word, lengths, radius, s) -> (3,) or (N, 3) poses along a CurvePath
//   curve_words(kind, x, y, phi)                -> every word's lengths (for the tests)
//
// Word indices are those of taskspace.planning.dubins.DUBINS_WORDS and
// taskspace.planning.reeds_shepp.RS_FORMULAS; lengths are signed and in metres.

#define PY_SSIZE_T_CLEAN
#include <Python.h>

#define PY_ARRAY_UNIQUE_SYMBOL TASKSPACE_CURVES_ARRAY_API
#define NPY_NO_DEPRECATED_API NPY_1_7_API_VERSION
#include <numpy/arrayobject.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>

namespace {

constexpr double kPi = 3.141592653589793;  // numpy.pi
constexpr double kTwoPi = 2.0 * kPi;
constexpr double kHalfPi = 0.5 * kPi;
constexpr double kInf = std::numeric_limits<double>::infinity();

// ------------------------------------------------------------------------ argument parsing
// A set of poses: one pose (n = 1, broadcast) or the rows of a float64 array.
struct Poses {
  const char* data = nullptr;
  npy_intp n = 1;
  npy_intp row = 0;  // byte strides
  npy_intp col = 0;
  bool single = true;  // a (3,) pose, a tuple or a list
  double own[3] = {0.0, 0.0, 0.0};

  double at(npy_intp i, int j) const {
    if (data == nullptr) return own[j];
    return *reinterpret_cast<const double*>(data + (single ? 0 : i * row) + j * col);
  }
};

bool read_number(PyObject* o, double* out) {
  if (PyFloat_Check(o)) {
    *out = PyFloat_AS_DOUBLE(o);
    return true;
  }
  if (PyLong_CheckExact(o)) {
    *out = PyLong_AsDouble(o);
    if (*out == -1.0 && PyErr_Occurred()) {
      PyErr_Clear();
      return false;
    }
    return true;
  }
  return false;
}

// False (no Python error set) when `o` is not a pose or pose array of the plain forms.
bool read_poses(PyObject* o, Poses* p, bool allow_rows) {
  if (PyTuple_Check(o) || PyList_Check(o)) {
    if (PySequence_Fast_GET_SIZE(o) != 3) return false;
    PyObject** items = PySequence_Fast_ITEMS(o);
    for (int j = 0; j < 3; ++j)
      if (!read_number(items[j], &p->own[j])) return false;
    return true;
  }
  if (!PyArray_Check(o)) return false;
  auto* a = reinterpret_cast<PyArrayObject*>(o);
  if (PyArray_TYPE(a) != NPY_DOUBLE || !PyArray_ISNOTSWAPPED(a)) return false;
  const int nd = PyArray_NDIM(a);
  const npy_intp* dims = PyArray_DIMS(a);
  const npy_intp* strides = PyArray_STRIDES(a);
  p->data = PyArray_BYTES(a);
  if (nd == 1 && dims[0] == 3) {
    p->col = strides[0];
    return true;
  }
  if (allow_rows && nd == 2 && dims[1] == 3) {
    p->single = false;
    p->n = dims[0];
    p->row = dims[0] == 1 ? 0 : strides[0];  // one row: broadcast against the other side
    p->col = strides[1];
    return true;
  }
  return false;
}

bool read_radius(PyObject* o, double* r) {
  return read_number(o, r) && std::isfinite(*r) && *r > 0.0;
}

bool finite_pose(const Poses& p) {
  return std::isfinite(p.at(0, 0)) && std::isfinite(p.at(0, 1)) && std::isfinite(p.at(0, 2));
}

PyObject* pose_tuple(const Poses& p) {
  return Py_BuildValue("(ddd)", p.at(0, 0), p.at(0, 1), p.at(0, 2));
}

// Goal in the frame of the start, divided by the radius (se2.to_local).
inline void to_local(const double* s, const double* g, double r, double* x, double* y,
                     double* phi) {
  const double dx = g[0] - s[0];
  const double dy = g[1] - s[1];
  const double c = std::cos(s[2]);
  const double sn = std::sin(s[2]);
  *x = (c * dx + sn * dy) / r;
  *y = (-sn * dx + c * dy) / r;
  *phi = g[2] - s[2];
}

// ------------------------------------------------------------------------------- Dubins
// numpy.mod (remainder with the sign of the divisor).
inline double np_mod(double a, double b) {
  // b > 0 here. Within two periods fmod is the identity or an exact subtraction of b
  // (Sterbenz), so these are fmod's results and the sign rule's, without fmod.
  if (a >= 0.0 && a < b) return a;
  if (a < 0.0 && a >= -b) return a + b;
  if (a >= b && a < 2.0 * b) return a - b;
  double m = std::fmod(a, b);
  if (m != 0.0) {
    if ((b < 0.0) != (m < 0.0)) m += b;
  } else {
    m = std::copysign(0.0, b);
  }
  return m;
}

// dubins._mod2pi: [0, 2 pi), values within 1e-10 of 2 pi snapped to 0.
inline double dmod2pi(double a) {
  const double m = np_mod(a, kTwoPi);
  return m > kTwoPi - 1e-10 ? 0.0 : m;
}

// reeds_shepp._mod2pi: fmod then one shift, into [-pi, pi] (fmod is exact: skip it in range).
inline double rmod2pi(double a) {
  if (a >= -kPi && a <= kPi) return a;
  // Up to 4 pi, fmod(a, 2 pi) and the shift are exact subtractions of 2 pi (Sterbenz):
  // the same result without fmod.
  if (a > kPi && a <= 2.0 * kTwoPi) {
    const double v = a - kTwoPi;
    return v > kPi ? v - kTwoPi : v;
  }
  if (a < -kPi && a >= -2.0 * kTwoPi) {
    const double v = a + kTwoPi;
    return v < -kPi ? v + kTwoPi : v;
  }
  double v = std::fmod(a, kTwoPi);
  if (v < -kPi) v += kTwoPi;
  if (v > kPi) v -= kTwoPi;
  return v;
}

// |(x, y)|: sqrt(x^2 + y^2), within an ulp or two of numpy.hypot (glibc's hypot, correctly
// rounded, took a quarter of the Reeds-Shepp time); hypot where the squares would overflow.
inline double norm2(double x, double y) {
  const double s = x * x + y * y;
  return s < 1e300 ? std::sqrt(s) : std::hypot(x, y);
}

inline double clip1(double c) { return std::min(std::max(c, -1.0), 1.0); }

// A word whose lower bound `bound` reaches top + kMargin is skipped (see the Reeds-Shepp formulas).
constexpr double kMargin = 1e-9;

inline bool beats(double bound, double top) { return bound < top + kMargin; }

struct DubinsWords {
  double len[6][3];
  bool valid[6];
};

// The shortest of the six words (dubins.dubins_word_lengths, then the first of the shortest
// valid words), unit radius; -1 when none exists. The word of least lower bound is evaluated
// first, and a word is skipped, before its arc tangent, when its bound (its middle
// segment p plus the least turn of its two outer arcs: t, q >= 0 with t +- q fixed modulo
// 2 pi by the heading change) exceeds the best word so far by kMargin: the skipped word's
// lengths are left unset (valid false), never the answer's. prune = false: every word.
int dubins_best(double x, double y, double phi, DubinsWords* w, double* total,
                bool prune = true) {
  // NumPy's angles are th = atan2(y, x), a = M(-th), b = M(phi - th). Here th is never
  // computed: sin and cos of a and b come from (x, y) / d and sin, cos of phi, and every
  // outer arc is th + (an arc tangent) computed as one arc tangent of the product with
  // (ct + i st); equal to rounding, one arc tangent less.
  const double d = norm2(x, y);
  const double ct = d > 0.0 ? x / d : 1.0, st = d > 0.0 ? y / d : 0.0;
  const double sp = std::sin(phi), cp = std::cos(phi);
  const double sa = -st, ca = ct;
  const double sb = sp * ct - cp * st, cb = cp * ct + sp * st;
  const double cab = ca * cb + sa * sb;
  // th + atan2(Y, X), and th - atan2(Y, X)
  auto plus_th = [&](double Y, double X) { return std::atan2(ct * Y + st * X, ct * X - st * Y); };
  auto minus_th = [&](double Y, double X) {
    return std::atan2(st * X - ct * Y, ct * X + st * Y);
  };
  // Middle segments p (no arc tangent yet) and lower bounds p + (least turn of t and q).
  double p[6], bound[6];
  bool exists[6];
  const double p2[4] = {2.0 + d * d - 2.0 * cab + 2.0 * d * (sa - sb),    // LSL
                        2.0 + d * d - 2.0 * cab + 2.0 * d * (sb - sa),    // RSR
                        -2.0 + d * d + 2.0 * cab + 2.0 * d * (sa + sb),   // LSR
                        -2.0 + d * d + 2.0 * cab - 2.0 * d * (sa + sb)};  // RSL
  const double turn[4] = {dmod2pi(phi), dmod2pi(-phi), std::abs(rmod2pi(phi)),
                          std::abs(rmod2pi(phi))};  // t + q = phi, -phi; t - q = +-phi
  for (int i = 0; i < 4; ++i) {
    exists[i] = p2[i] >= -1e-12;
    p[i] = exists[i] ? std::sqrt(std::max(p2[i], 0.0)) : 0.0;
  }
  // LSL and RSR: p2 is the sum of two squares; the norm keeps the straight segment exact when
  // start and goal nearly coincide (the expanded sum cancels: 4e-8 for a true 1e-10)
  p[0] = norm2(d + sa - sb, cb - ca);
  p[1] = norm2(d - sa + sb, ca - cb);
  for (int i = 0; i < 4; ++i) bound[i] = p[i] + turn[i];
  const double c[2] = {(6.0 - d * d + 2.0 * cab + 2.0 * d * (sa - sb)) / 8.0,   // RLR
                       (6.0 - d * d + 2.0 * cab + 2.0 * d * (sb - sa)) / 8.0};  // LRL
  for (int i = 4; i < 6; ++i) {
    exists[i] = std::abs(c[i - 4]) <= 1.0 + 1e-12;
    p[i] = exists[i] ? dmod2pi(kTwoPi - std::acos(clip1(c[i - 4]))) : 0.0;
  }
  bound[4] = p[4] + dmod2pi(p[4] - phi);  // t + q = p - phi (a - b = -phi)
  bound[5] = p[5] + dmod2pi(p[5] + phi);  // t + q = p + phi
  // The word of least bound first (often the answer, it prunes the others), then the others
  // in order; the answer is still the first shortest word in DUBINS_WORDS order.
  int first = 0;
  for (int i = 1; i < 6; ++i)
    if (exists[i] && (!exists[first] || bound[i] < bound[first])) first = i;
  int order[6] = {first, 0, 1, 2, 3, 4};
  for (int i = first + 1; i < 6; ++i) order[i] = i;  // {first, 0, .., first - 1, first + 1, ..}
  int best = -1;
  double top = kInf;
  for (bool& v : w->valid) v = false;
  for (int i : order) {
    if (!exists[i] || (prune && !beats(bound[i], top))) continue;
    double l0, l2, u;
    switch (i) {
      case 0:  // LSL: t = M(-a + tmp), q = M(b - tmp), tmp = atan2(cb - ca, d + sa - sb)
        u = plus_th(cb - ca, d + sa - sb);
        l0 = dmod2pi(u);
        l2 = dmod2pi(phi - u);
        break;
      case 1:  // RSR: t = M(a - tmp), q = M(-b + tmp), tmp = atan2(ca - cb, d - sa + sb)
        u = plus_th(ca - cb, d - sa + sb);
        l0 = dmod2pi(-u);
        l2 = dmod2pi(u - phi);
        break;
      case 2: {  // LSR: tmp = atan2(-ca - cb, d + sa + sb) - atan2(-2, p), as one arc tangent
        const double X = d + sa + sb, Y = -ca - cb;
        u = plus_th(Y * p[2] + 2.0 * X, X * p[2] - 2.0 * Y);
        l0 = dmod2pi(u);
        l2 = dmod2pi(u - phi);
        break;
      }
      case 3: {  // RSL: tmp = atan2(ca + cb, d - sa - sb) - atan2(2, p)
        const double X = d - sa - sb, Y = ca + cb;
        u = plus_th(Y * p[3] - 2.0 * X, X * p[3] + 2.0 * Y);
        l0 = dmod2pi(-u);
        l2 = dmod2pi(phi - u);
        break;
      }
      case 4:  // RLR: t = M(a - atan2(ca - cb, d - sa + sb) + p / 2), q = M(a - b - t + p)
        l0 = dmod2pi(-plus_th(ca - cb, d - sa + sb) + 0.5 * p[4]);
        l2 = dmod2pi(-phi - l0 + p[4]);
        break;
      default:  // LRL: t = M(-a - atan2(ca - cb, d + sa - sb) + p / 2), q = M(b - a - t + p)
        l0 = dmod2pi(minus_th(ca - cb, d + sa - sb) + 0.5 * p[5]);
        l2 = dmod2pi(phi - l0 + p[5]);
        break;
    }
    w->len[i][0] = l0;
    w->len[i][1] = p[i];
    w->len[i][2] = l2;
    w->valid[i] = true;
    const double s = l0 + p[i] + l2;
    if (s < top || (s == top && i < best)) {
      top = s;
      best = i;
    }
  }
  *total = top;
  return best;
}

// --------------------------------------------------------------------------- Reeds-Shepp
constexpr double kZero = 1e-10;

struct Triple {
  double t, u, v;
  bool ok;
};

inline void tau_omega(double u, double v, double xi, double eta, double phi, double* tau,
                      double* omega) {
  const double delta = rmod2pi(u - v);
  const double a = std::sin(u) - std::sin(delta);
  const double b = std::cos(u) - std::cos(delta) - 1.0;
  const double t1 = std::atan2(eta * a - xi * b, xi * a + eta * b);
  const double t2 = 2.0 * (std::cos(delta) - std::cos(v) - std::cos(u)) + 3.0;
  *tau = t2 < 0.0 ? rmod2pi(t1 + kPi) : rmod2pi(t1);
  *omega = rmod2pi(*tau - u + v - phi);
}

// The eight base formulas (reeds_shepp._lp_sp_lp ... _lp_rm_s_lm_rp); sp, cp = sin, cos(phi).
// `top` is the total length of the best word so far. A formula gives up (ok false) as soon as
// a lower bound of its total, `fixed + |M(turn)|`, reaches top + kMargin: `fixed` is the sum
// of the lengths known before the arc tangents (the straight segment, the pi/2 arcs, the
// equal arcs of CC|CC) and `turn` what the two remaining arcs t and v must turn together
// (the heading equation of the word: t +- v = phi - (turn of the known arcs), modulo 2 pi,
// so |t| + |v| >= |M(turn)|). A skipped word is longer than the best one by at least the
// margin (1e-9, far above the rounding of t and v), so the answer is the NumPy one. The
// sums of two arc tangents in 8.2 and 8.9 are computed as one (equal to rounding).
Triple lp_sp_lp(double x, double y, double phi, double sp, double cp, double top) {
  const double xx = x - sp, yy = y - 1.0 + cp;
  const double u = norm2(xx, yy);
  if (!beats(u + std::abs(rmod2pi(phi)), top)) return {0.0, 0.0, 0.0, false};  // t + v = phi
  const double t = std::atan2(yy, xx);
  const double v = rmod2pi(phi - t);
  return {t, u, v, (t >= -kZero) && (v >= -kZero)};
}

Triple lp_sp_rp(double x, double y, double phi, double sp, double cp, double top) {
  const double xx = x + sp, yy = y - 1.0 - cp;
  const double u1 = norm2(xx, yy);
  const double u1sq = u1 * u1;
  if (!(u1sq >= 4.0)) return {0.0, 0.0, 0.0, false};
  const double u = std::sqrt(std::max(u1sq - 4.0, 0.0));
  if (!beats(u + std::abs(rmod2pi(phi)), top)) return {0.0, 0.0, 0.0, false};  // t - v = phi
  // t = M(atan2(yy, xx) + atan2(2, u)) with one arc tangent: the angle of the product of
  // (xx + i yy) and (u + 2 i) (the same angle modulo 2 pi; M() is then the identity).
  const double t = rmod2pi(std::atan2(yy * u + 2.0 * xx, xx * u - 2.0 * yy));
  const double v = rmod2pi(t - phi);
  return {t, u, v, (t >= -kZero) && (v >= -kZero)};
}

Triple lp_rm_l(double x, double y, double phi, double sp, double cp, double top) {
  const double xi = x - sp, eta = y - 1.0 + cp;
  const double u1 = norm2(xi, eta);
  if (!(u1 <= 4.0)) return {0.0, 0.0, 0.0, false};
  const double u = -2.0 * std::asin(clip1(0.25 * u1));
  if (!beats(std::abs(u) + std::abs(rmod2pi(phi + u)), top))  // t + v = phi + u
    return {0.0, 0.0, 0.0, false};
  const double theta = std::atan2(eta, xi);
  const double t = rmod2pi(theta + 0.5 * u + kPi);
  const double v = rmod2pi(phi - t + u);
  return {t, u, v, (t >= -kZero) && (u <= kZero)};
}

Triple lp_rup_lum_rm(double x, double y, double phi, double sp, double cp, double top) {
  const double xi = x + sp, eta = y - 1.0 - cp;
  const double rho = 0.25 * (2.0 + norm2(xi, eta));
  if (!(rho <= 1.0)) return {0.0, 0.0, 0.0, false};
  const double u = std::acos(clip1(rho));
  // lengths t, u, -u, v; t - v = phi + 2 u
  if (!beats(2.0 * std::abs(u) + std::abs(rmod2pi(phi + 2.0 * u)), top))
    return {0.0, 0.0, 0.0, false};
  double t, v;
  tau_omega(u, -u, xi, eta, phi, &t, &v);
  return {t, u, v, (t >= -kZero) && (v <= kZero)};
}

Triple lp_rum_lum_rp(double x, double y, double phi, double sp, double cp, double top) {
  const double xi = x + sp, eta = y - 1.0 - cp;
  const double rho = (20.0 - xi * xi - eta * eta) / 16.0;
  if (!((rho >= 0.0) && (rho <= 1.0))) return {0.0, 0.0, 0.0, false};
  const double u = -std::acos(clip1(rho));
  // lengths t, u, u, v; t - v = phi
  if (!(u >= -kHalfPi) || !beats(2.0 * std::abs(u) + std::abs(rmod2pi(phi)), top))
    return {0.0, 0.0, 0.0, false};
  double t, v;
  tau_omega(u, u, xi, eta, phi, &t, &v);
  return {t, u, v, (t >= -kZero) && (v >= -kZero)};
}

Triple lp_rm_sm_lm(double x, double y, double phi, double sp, double cp, double top) {
  const double xi = x - sp, eta = y - 1.0 + cp;
  const double rho = norm2(xi, eta);
  if (!(rho >= 2.0)) return {0.0, 0.0, 0.0, false};
  const double r = std::sqrt(std::max(rho * rho - 4.0, 0.0));
  const double u = 2.0 - r;
  // lengths t, -pi/2, u, v; t +- v = phi - pi/2
  if (!(u <= kZero) || !beats(kHalfPi + std::abs(u) + std::abs(rmod2pi(phi - kHalfPi)), top))
    return {0.0, 0.0, 0.0, false};
  // t = M(atan2(eta, xi) + atan2(r, -2)): the angle of (xi + i eta)(-2 + i r).
  const double t = rmod2pi(std::atan2(xi * r - 2.0 * eta, -2.0 * xi - eta * r));
  const double v = rmod2pi(phi - kHalfPi - t);
  return {t, u, v, (t >= -kZero) && (v <= kZero)};
}

Triple lp_rm_sm_rm(double x, double y, double phi, double sp, double cp, double top) {
  const double xi = x + sp, eta = y - 1.0 - cp;
  const double rho = norm2(-eta, xi);
  if (!(rho >= 2.0)) return {0.0, 0.0, 0.0, false};
  const double u = 2.0 - rho;
  // lengths t, -pi/2, u, v; t +- v = phi - pi/2
  if (!(u <= kZero) || !beats(kHalfPi + std::abs(u) + std::abs(rmod2pi(phi - kHalfPi)), top))
    return {0.0, 0.0, 0.0, false};
  const double t = std::atan2(xi, -eta);
  const double v = rmod2pi(t + kHalfPi - phi);
  return {t, u, v, (t >= -kZero) && (v <= kZero)};
}

Triple lp_rm_s_lm_rp(double x, double y, double phi, double sp, double cp, double top) {
  const double xi = x + sp, eta = y - 1.0 - cp;
  const double rho = norm2(xi, eta);
  if (!(rho >= 2.0)) return {0.0, 0.0, 0.0, false};
  const double u = 4.0 - std::sqrt(std::max(rho * rho - 4.0, 0.0));
  // t - v = phi
  if (!(u <= kZero) || !beats(kPi + std::abs(u) + std::abs(rmod2pi(phi)), top))
    return {0.0, 0.0, 0.0, false};
  const double t =
      rmod2pi(std::atan2((4.0 - u) * xi - 2.0 * eta, -2.0 * xi + (u - 4.0) * eta));
  const double v = rmod2pi(t - phi);
  return {t, u, v, (t >= -kZero) && (v >= -kZero)};
}

struct Base {
  const char* word;  // letters before the symmetries
  int shape;         // 0: [t, u, v]; 1: [t, u, -u, v]; 2: [t, u, u, v];
                     // 3: [t, -pi/2, u, v]; 4: [t, -pi/2, u, -pi/2, v]
  bool backwards;
};

// In the order of reeds_shepp._BASES (the formulas are called in rs_evaluate).
constexpr Base kBases[8] = {
    {"LSL", 0, false},  {"LSR", 0, false},  {"LRL", 0, true},   {"LRLR", 1, false},
    {"LRLR", 2, false}, {"LRSL", 3, true},  {"LRSR", 3, true},  {"LRSLR", 4, false},
};

// One of the 44 evaluations (reeds_shepp.RS_FORMULAS, same order).
struct Evaluation {
  int base;
  bool timeflip, reflect, backwards;
  char word[6];
  int k;  // segments
};

struct Table {
  Evaluation e[44];
  Table() {
    int n = 0;
    for (int b = 0; b < 8; ++b) {
      for (int bw = 0; bw < (kBases[b].backwards ? 2 : 1); ++bw) {
        const bool flips[4][2] = {{false, false}, {true, false}, {false, true}, {true, true}};
        for (const auto& f : flips) {
          Evaluation& ev = e[n++];
          ev.base = b;
          ev.timeflip = f[0];
          ev.reflect = f[1];
          ev.backwards = bw == 1;
          ev.k = static_cast<int>(std::strlen(kBases[b].word));
          for (int i = 0; i < ev.k; ++i) {
            char c = kBases[b].word[i];
            if (ev.reflect) c = c == 'L' ? 'R' : (c == 'R' ? 'L' : c);
            ev.word[ev.backwards ? ev.k - 1 - i : i] = c;
          }
          ev.word[ev.k] = '\0';
        }
      }
    }
  }
};

const Table& table() {
  static const Table t;
  return t;
}

struct RSQuery {
  double x, y, phi, xb, yb, sp, cp;
  explicit RSQuery(double x_, double y_, double phi_) : x(x_), y(y_), phi(phi_) {
    sp = std::sin(phi);
    cp = std::cos(phi);
    xb = x * cp + y * sp;
    yb = x * sp - y * cp;
  }
};

// Evaluates formula index `i`; writes its k signed lengths; false when the word is invalid.
inline bool rs_evaluate(const RSQuery& q, const Evaluation& ev, double top, double* len) {
  const Base& b = kBases[ev.base];
  double x0 = ev.backwards ? q.xb : q.x;
  double y0 = ev.backwards ? q.yb : q.y;
  if (ev.timeflip) x0 = -x0;
  if (ev.reflect) y0 = -y0;
  const bool neg = ev.timeflip != ev.reflect;
  const double phi = neg ? -q.phi : q.phi;
  const double sp = neg ? -q.sp : q.sp;
  Triple r;
  switch (ev.base) {  // direct calls, inlined
    case 0: r = lp_sp_lp(x0, y0, phi, sp, q.cp, top); break;
    case 1: r = lp_sp_rp(x0, y0, phi, sp, q.cp, top); break;
    case 2: r = lp_rm_l(x0, y0, phi, sp, q.cp, top); break;
    case 3: r = lp_rup_lum_rm(x0, y0, phi, sp, q.cp, top); break;
    case 4: r = lp_rum_lum_rp(x0, y0, phi, sp, q.cp, top); break;
    case 5: r = lp_rm_sm_lm(x0, y0, phi, sp, q.cp, top); break;
    case 6: r = lp_rm_sm_rm(x0, y0, phi, sp, q.cp, top); break;
    default: r = lp_rm_s_lm_rp(x0, y0, phi, sp, q.cp, top); break;
  }
  if (!r.ok) return false;
  double l[5];
  switch (b.shape) {
    case 0: l[0] = r.t; l[1] = r.u; l[2] = r.v; break;
    case 1: l[0] = r.t; l[1] = r.u; l[2] = -r.u; l[3] = r.v; break;
    case 2: l[0] = r.t; l[1] = r.u; l[2] = r.u; l[3] = r.v; break;
    case 3: l[0] = r.t; l[1] = -kHalfPi; l[2] = r.u; l[3] = r.v; break;
    default: l[0] = r.t; l[1] = -kHalfPi; l[2] = r.u; l[3] = -kHalfPi; l[4] = r.v; break;
  }
  const int k = ev.k;
  for (int i = 0; i < k; ++i) {
    if (!std::isfinite(l[i])) return false;
    const double v = ev.timeflip ? -l[i] : l[i];
    len[ev.backwards ? k - 1 - i : i] = v;
  }
  return true;
}

// Shortest evaluation (first of the shortest), unit radius; -1 when none is valid.
int rs_best(double x, double y, double phi, double* best_len, double* total) {
  const RSQuery q(x, y, phi);
  const Table& tab = table();
  int best = -1;
  *total = kInf;
  double len[5];
  for (int i = 0; i < 44; ++i) {
    const Evaluation& ev = tab.e[i];
    if (!rs_evaluate(q, ev, *total, len)) continue;
    double s = 0.0;
    for (int j = 0; j < ev.k; ++j) s += std::abs(len[j]);
    if (s < *total) {
      *total = s;
      best = i;
      std::copy(len, len + ev.k, best_len);
    }
  }
  return best;
}

// ------------------------------------------------------------------------ Python functions
bool broadcast(const Poses& s, const Poses& g, npy_intp* n) {
  if (s.n == g.n || g.n == 1) {
    *n = s.n;
    return true;
  }
  if (s.n == 1) {
    *n = g.n;
    return true;
  }
  return false;
}

template <class Distance>
PyObject* distances(PyObject* const* args, Py_ssize_t nargs, Distance dist) {
  if (nargs != 3) Py_RETURN_NONE;
  Poses s, g;
  double r;
  npy_intp n;
  if (!read_poses(args[0], &s, true) || !read_poses(args[1], &g, true) ||
      !read_radius(args[2], &r) || !broadcast(s, g, &n))
    Py_RETURN_NONE;
  PyObject* out = PyArray_SimpleNew(1, &n, NPY_DOUBLE);
  if (out == nullptr) return nullptr;
  double* o = static_cast<double*>(PyArray_DATA(reinterpret_cast<PyArrayObject*>(out)));
  for (npy_intp i = 0; i < n; ++i) {
    const double sp[3] = {s.at(i, 0), s.at(i, 1), s.at(i, 2)};
    const double gp[3] = {g.at(i, 0), g.at(i, 1), g.at(i, 2)};
    double x, y, phi;
    to_local(sp, gp, r, &x, &y, &phi);
    o[i] = dist(x, y, phi) * r;
    if (!std::isfinite(o[i])) {  // NaN/inf poses (or coordinates too large): Python says why
      Py_DECREF(out);
      Py_RETURN_NONE;
    }
  }
  return out;
}

PyObject* py_dubins_distance(PyObject*, PyObject* const* args, Py_ssize_t nargs) {
  return distances(args, nargs, [](double x, double y, double phi) {
    DubinsWords w;
    double total;
    dubins_best(x, y, phi, &w, &total);
    return total;
  });
}

PyObject* py_reeds_shepp_distance(PyObject*, PyObject* const* args, Py_ssize_t nargs) {
  return distances(args, nargs, [](double x, double y, double phi) {
    double len[5];
    double total;
    rs_best(x, y, phi, len, &total);
    return total;
  });
}

bool single_query(PyObject* const* args, Py_ssize_t nargs, Poses* s, Poses* g, double* r) {
  return nargs == 3 && read_poses(args[0], s, false) && read_poses(args[1], g, false) &&
         read_radius(args[2], r) && finite_pose(*s) && finite_pose(*g);
}

PyObject* lengths_tuple(const double* len, int k, double r) {
  PyObject* t = PyTuple_New(k);
  if (t == nullptr) return nullptr;
  for (int i = 0; i < k; ++i) {
    PyObject* f = PyFloat_FromDouble(len[i] * r);
    if (f == nullptr) {
      Py_DECREF(t);
      return nullptr;
    }
    PyTuple_SET_ITEM(t, i, f);
  }
  return t;
}

PyObject* py_dubins_shortest(PyObject*, PyObject* const* args, Py_ssize_t nargs) {
  Poses s, g;
  double r;
  if (!single_query(args, nargs, &s, &g, &r)) Py_RETURN_NONE;
  const double sp[3] = {s.at(0, 0), s.at(0, 1), s.at(0, 2)};
  const double gp[3] = {g.at(0, 0), g.at(0, 1), g.at(0, 2)};
  double x, y, phi, total;
  to_local(sp, gp, r, &x, &y, &phi);
  DubinsWords w;
  const int best = dubins_best(x, y, phi, &w, &total);
  if (best < 0) Py_RETURN_NONE;  // the Python path raises SolverError
  PyObject* start = pose_tuple(s);
  PyObject* lens = lengths_tuple(w.len[best], 3, r);
  if (start == nullptr || lens == nullptr) {
    Py_XDECREF(start);
    Py_XDECREF(lens);
    return nullptr;
  }
  return Py_BuildValue("(NiNd)", start, best, lens, r);
}

PyObject* py_reeds_shepp_shortest(PyObject*, PyObject* const* args, Py_ssize_t nargs) {
  Poses s, g;
  double r;
  if (!single_query(args, nargs, &s, &g, &r)) Py_RETURN_NONE;
  const double sp[3] = {s.at(0, 0), s.at(0, 1), s.at(0, 2)};
  const double gp[3] = {g.at(0, 0), g.at(0, 1), g.at(0, 2)};
  double x, y, phi, total, len[5];
  to_local(sp, gp, r, &x, &y, &phi);
  const int best = rs_best(x, y, phi, len, &total);
  if (best < 0) Py_RETURN_NONE;
  const Evaluation& ev = table().e[best];
  char family[11];
  for (int i = 0; i < ev.k; ++i) {
    family[2 * i] = ev.word[i];
    family[2 * i + 1] = len[i] * r < 0.0 ? '-' : '+';  // reeds_shepp.signed_word
  }
  family[2 * ev.k] = '\0';
  PyObject* start = pose_tuple(s);
  PyObject* lens = lengths_tuple(len, ev.k, r);
  if (start == nullptr || lens == nullptr) {
    Py_XDECREF(start);
    Py_XDECREF(lens);
    return nullptr;
  }
  return Py_BuildValue("(NiNds)", start, best, lens, r, family);
}

// curve_words(kind, x, y, phi): every word of one normalised query (unit radius), without
// the pruning: a tuple with, for each word (DUBINS_WORDS or RS_FORMULAS order), its signed
// lengths, or None when it does not exist. For the tests (word by word against NumPy).
PyObject* py_curve_words(PyObject*, PyObject* const* args, Py_ssize_t nargs) {
  double x, y, phi;
  if (nargs != 4 || !PyUnicode_Check(args[0]) || !read_number(args[1], &x) ||
      !read_number(args[2], &y) || !read_number(args[3], &phi))
    Py_RETURN_NONE;
  const bool dubins = PyUnicode_CompareWithASCIIString(args[0], "dubins") == 0;
  if (!dubins && PyUnicode_CompareWithASCIIString(args[0], "reeds_shepp") != 0) Py_RETURN_NONE;
  const int n = dubins ? 6 : 44;
  PyObject* out = PyTuple_New(n);
  if (out == nullptr) return nullptr;
  DubinsWords w;
  double total;
  if (dubins) dubins_best(x, y, phi, &w, &total, false);
  const RSQuery q(x, y, phi);
  for (int i = 0; i < n; ++i) {
    PyObject* item;
    double len[5];
    int k = 3;
    bool ok;
    if (dubins) {
      ok = w.valid[i];
      std::copy(w.len[i], w.len[i] + 3, len);
    } else {
      ok = rs_evaluate(q, table().e[i], kInf, len);
      k = table().e[i].k;
    }
    if (ok) {
      item = lengths_tuple(len, k, 1.0);
      if (item == nullptr) {
        Py_DECREF(out);
        return nullptr;
      }
    } else {
      item = Py_None;
      Py_INCREF(item);
    }
    PyTuple_SET_ITEM(out, i, item);
  }
  return out;
}

// ------------------------------------------------------------------------- CurvePath poses
// se2.arc_pose for one pose (numpy.sinc as numpy computes it).
inline void arc_pose(const double* q, double k, double s, double* out) {
  const double half = 0.5 * k * s;
  const double th = q[2] + 2.0 * half;
  const double xs = half / kPi;
  const double ys = kPi * (xs == 0.0 ? 1.0e-20 : xs);
  const double chord = s * (std::sin(ys) / ys);
  const double mid = q[2] + half;
  out[0] = q[0] + chord * std::cos(mid);
  out[1] = q[1] + chord * std::sin(mid);
  out[2] = th;
}

// se2.wrap_angle, leaving angles already in [-pi, pi) unchanged (so that the start pose
// comes back exactly).
inline double wrap(double a) {
  if (a >= -kPi && a < kPi) return a;
  return np_mod(a + kPi, kTwoPi) - kPi;
}

constexpr int kMaxSegments = 16;

// curve_poses(start, word, lengths, radius, s): CurvePath.pose_at.
PyObject* py_curve_poses(PyObject*, PyObject* const* args, Py_ssize_t nargs) {
  if (nargs != 5) Py_RETURN_NONE;
  Poses st;
  double r;
  if (!read_poses(args[0], &st, false) || !read_radius(args[3], &r)) Py_RETURN_NONE;
  PyObject* word = args[1];
  PyObject* lengths = args[2];
  if (!PyTuple_Check(word) || !PyTuple_Check(lengths)) Py_RETURN_NONE;
  const Py_ssize_t k = PyTuple_GET_SIZE(word);
  if (k < 1 || k > kMaxSegments || PyTuple_GET_SIZE(lengths) != k) Py_RETURN_NONE;
  double curv[kMaxSegments], len[kMaxSegments], cum[kMaxSegments + 1];
  double starts[kMaxSegments + 1][3];
  starts[0][0] = st.at(0, 0);
  starts[0][1] = st.at(0, 1);
  starts[0][2] = st.at(0, 2);
  cum[0] = 0.0;
  double total = 0.0;
  for (Py_ssize_t i = 0; i < k; ++i) {
    PyObject* w = PyTuple_GET_ITEM(word, i);
    if (!PyUnicode_Check(w) || PyUnicode_GET_LENGTH(w) != 1) Py_RETURN_NONE;
    const Py_UCS4 c = PyUnicode_READ_CHAR(w, 0);
    const double sign = c == 'L' ? 1.0 : (c == 'R' ? -1.0 : (c == 'S' ? 0.0 : 2.0));
    if (sign == 2.0 || !read_number(PyTuple_GET_ITEM(lengths, i), &len[i])) Py_RETURN_NONE;
    curv[i] = sign / r;
    arc_pose(starts[i], curv[i], len[i], starts[i + 1]);
    total += std::abs(len[i]);
    cum[i + 1] = cum[i] + std::abs(len[i]);
  }
  // s: a float or a 1-D float64 array
  double one;
  const double* sv = nullptr;
  npy_intp n = 1, stride = 0;
  bool scalar = false;
  if (read_number(args[4], &one)) {
    scalar = true;
    sv = &one;
  } else if (PyArray_Check(args[4])) {
    auto* a = reinterpret_cast<PyArrayObject*>(args[4]);
    if (PyArray_TYPE(a) != NPY_DOUBLE || !PyArray_ISNOTSWAPPED(a) || PyArray_NDIM(a) != 1)
      Py_RETURN_NONE;
    n = PyArray_DIM(a, 0);
    stride = PyArray_STRIDE(a, 0);
    sv = reinterpret_cast<const double*>(PyArray_BYTES(a));
  } else {
    Py_RETURN_NONE;
  }
  npy_intp dims[2] = {n, 3};
  PyObject* out = scalar ? PyArray_SimpleNew(1, dims + 1, NPY_DOUBLE)
                         : PyArray_SimpleNew(2, dims, NPY_DOUBLE);
  if (out == nullptr) return nullptr;
  double* o = static_cast<double*>(PyArray_DATA(reinterpret_cast<PyArrayObject*>(out)));
  const char* base = reinterpret_cast<const char*>(sv);
  for (npy_intp j = 0; j < n; ++j) {
    double s = *reinterpret_cast<const double*>(base + j * stride);
    s = std::min(std::max(s, 0.0), total);  // numpy.clip
    // searchsorted(cum, s, side="right") - 1, clipped to [0, k - 1]
    Py_ssize_t idx = static_cast<Py_ssize_t>(std::upper_bound(cum, cum + k + 1, s) - cum) - 1;
    idx = std::min<Py_ssize_t>(std::max<Py_ssize_t>(idx, 0), k - 1);
    const double local = s - cum[idx];
    const double l = len[idx];
    const double sign = l > 0.0 ? 1.0 : (l < 0.0 ? -1.0 : 0.0);
    arc_pose(starts[idx], curv[idx], sign * local, o + 3 * j);
    o[3 * j + 2] = wrap(o[3 * j + 2]);
  }
  return out;
}

PyMethodDef kMethods[] = {
    {"dubins_distance", reinterpret_cast<PyCFunction>(reinterpret_cast<void (*)()>(py_dubins_distance)),
     METH_FASTCALL, "Dubins distances (start, goal, radius) -> (N,) array, or None."},
    {"reeds_shepp_distance",
     reinterpret_cast<PyCFunction>(reinterpret_cast<void (*)()>(py_reeds_shepp_distance)),
     METH_FASTCALL, "Reeds-Shepp distances (start, goal, radius) -> (N,) array, or None."},
    {"dubins_shortest",
     reinterpret_cast<PyCFunction>(reinterpret_cast<void (*)()>(py_dubins_shortest)),
     METH_FASTCALL,
     "Shortest Dubins word (start, goal, radius) -> (start, index, lengths, radius), or None."},
    {"reeds_shepp_shortest",
     reinterpret_cast<PyCFunction>(reinterpret_cast<void (*)()>(py_reeds_shepp_shortest)),
     METH_FASTCALL,
     "Shortest Reeds-Shepp word (start, goal, radius) -> (start, index, lengths, radius, "
     "family), or None."},
    {"curve_words", reinterpret_cast<PyCFunction>(reinterpret_cast<void (*)()>(py_curve_words)),
     METH_FASTCALL, "Every word of a normalised query (kind, x, y, phi), for the tests."},
    {"curve_poses", reinterpret_cast<PyCFunction>(reinterpret_cast<void (*)()>(py_curve_poses)),
     METH_FASTCALL, "Poses along a curve (start, word, lengths, radius, s), or None."},
    {nullptr, nullptr, 0, nullptr}};

}  // namespace

// Adds the curve functions to the module being initialised (_planning_kernel).
int taskspace_register_curves(PyObject* module) {
  if (_import_array() < 0) return -1;
  (void)table();
  return PyModule_AddFunctions(module, kMethods);
}
