// Fixed-size spatial algebra (Featherstone, "Rigid Body Dynamics Algorithms", 2008, ch. 2).
//
// Conventions
//   Motion  V = [w; v]  angular part first; v is the velocity of the point at the frame origin.
//   Force   F = [n; f]  n is the moment about the frame origin.
//   Transform X_AB is the pose of frame B in frame A (Drake monogram): R_AB rotates B coordinates
//   into A coordinates and p_AB is B's origin in A. X_AB.act(V_B) re-expresses a motion given in B
//   coordinates in A coordinates; X_AB.inv_act(V_A) goes the other way. Note the direction: this is
//   the inverse of Featherstone's Xup (parent -> child coordinates).
//   Units: SI throughout (m, kg, s, rad, N, N*m).
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cmath>

namespace coopdyn {

using Vec3 = Eigen::Vector3d;
using Mat3 = Eigen::Matrix3d;
using Vec6 = Eigen::Matrix<double, 6, 1>;
using Mat6 = Eigen::Matrix<double, 6, 6>;
using Quat = Eigen::Quaterniond;

inline Mat3 skew(const Vec3& a) {
  Mat3 S;
  S << 0, -a.z(), a.y(), a.z(), 0, -a.x(), -a.y(), a.x(), 0;
  return S;
}

// crm(v) m: motion cross motion (RBDA eq. 2.31).
inline Vec6 cross_motion(const Vec6& v, const Vec6& m) {
  Vec6 r;
  const Vec3 w = v.head<3>(), vl = v.tail<3>();
  r.head<3>() = w.cross(m.head<3>());
  r.tail<3>() = w.cross(m.tail<3>()) + vl.cross(m.head<3>());
  return r;
}

// crf(v) f = -crm(v)^T f: motion cross force (RBDA eq. 2.32).
inline Vec6 cross_force(const Vec6& v, const Vec6& f) {
  Vec6 r;
  const Vec3 w = v.head<3>(), vl = v.tail<3>();
  r.head<3>() = w.cross(f.head<3>()) + vl.cross(f.tail<3>());
  r.tail<3>() = w.cross(f.tail<3>());
  return r;
}

// Rotation matrix exp([w]x) (Rodrigues), accurate for small angles.
inline Mat3 exp_so3(const Vec3& w) {
  const double th2 = w.squaredNorm();
  const double th = std::sqrt(th2);
  double a, b;  // sin(th)/th, (1-cos th)/th^2
  if (th < 1e-4) {
    a = 1.0 - th2 / 6.0;
    b = 0.5 - th2 / 24.0;
  } else {
    a = std::sin(th) / th;
    b = (1.0 - std::cos(th)) / th2;
  }
  const Mat3 W = skew(w);
  return Mat3::Identity() + a * W + b * W * W;
}

// Rotation vector of R (inverse of exp_so3), valid for angles in [0, pi).
inline Vec3 log_so3(const Mat3& R) {
  const double c = std::max(-1.0, std::min(1.0, 0.5 * (R.trace() - 1.0)));
  const double th = std::acos(c);
  const Vec3 v(R(2, 1) - R(1, 2), R(0, 2) - R(2, 0), R(1, 0) - R(0, 1));
  if (th < 1e-6) return 0.5 * v;  // sin(th) ~ th
  if (M_PI - th < 1e-6) {
    // near pi: axis from the largest diagonal of (R + I)/2
    const Mat3 B = 0.5 * (R + Mat3::Identity());
    int i;
    B.diagonal().maxCoeff(&i);
    Vec3 axis = B.col(i) / std::sqrt(std::max(B(i, i), 1e-300));
    return th * axis.normalized();
  }
  return th / (2.0 * std::sin(th)) * v;
}

struct Transform {
  Mat3 R = Mat3::Identity();
  Vec3 p = Vec3::Zero();

  Transform() = default;
  Transform(const Mat3& R_, const Vec3& p_) : R(R_), p(p_) {}
  static Transform Identity() { return Transform(); }

  // X_AC = X_AB * X_BC
  Transform operator*(const Transform& o) const { return Transform(R * o.R, p + R * o.p); }
  Transform inverse() const { return Transform(R.transpose(), -(R.transpose() * p)); }

  // motion in B coordinates -> A coordinates
  Vec6 act(const Vec6& m) const {
    Vec6 r;
    r.head<3>() = R * m.head<3>();
    r.tail<3>() = R * m.tail<3>() + p.cross(r.head<3>());
    return r;
  }
  // motion in A coordinates -> B coordinates
  Vec6 inv_act(const Vec6& m) const {
    Vec6 r;
    r.head<3>() = R.transpose() * m.head<3>();
    r.tail<3>() = R.transpose() * (m.tail<3>() - p.cross(m.head<3>()));
    return r;
  }
  // force in B coordinates -> A coordinates
  Vec6 act_force(const Vec6& f) const {
    Vec6 r;
    r.tail<3>() = R * f.tail<3>();
    r.head<3>() = R * f.head<3>() + p.cross(r.tail<3>());
    return r;
  }
  // force in A coordinates -> B coordinates
  Vec6 inv_act_force(const Vec6& f) const {
    Vec6 r;
    r.tail<3>() = R.transpose() * f.tail<3>();
    r.head<3>() = R.transpose() * (f.head<3>() - p.cross(f.tail<3>()));
    return r;
  }
  // 6x6 matrix of act() (Ad_X).
  Mat6 motion_matrix() const {
    Mat6 X;
    X.topLeftCorner<3, 3>() = R;
    X.topRightCorner<3, 3>().setZero();
    X.bottomLeftCorner<3, 3>() = skew(p) * R;
    X.bottomRightCorner<3, 3>() = R;
    return X;
  }
};

inline Transform rot_x(double a) { return Transform(Eigen::AngleAxisd(a, Vec3::UnitX()).toRotationMatrix(), Vec3::Zero()); }
inline Transform rot_z(double a) { return Transform(Eigen::AngleAxisd(a, Vec3::UnitZ()).toRotationMatrix(), Vec3::Zero()); }
inline Transform trans(double x, double y, double z) { return Transform(Mat3::Identity(), Vec3(x, y, z)); }
// Roll-pitch-yaw as in URDF: R = Rz(yaw) * Ry(pitch) * Rx(roll).
inline Mat3 rpy_matrix(const Vec3& rpy) {
  return (Eigen::AngleAxisd(rpy.z(), Vec3::UnitZ()) * Eigen::AngleAxisd(rpy.y(), Vec3::UnitY()) *
          Eigen::AngleAxisd(rpy.x(), Vec3::UnitX()))
      .toRotationMatrix();
}

// Error of pose X_BA (frame A seen from frame B), expressed in A: [rotation vector; position], so
// that its time derivative is, to first order, the velocity of A relative to B in A coordinates.
inline Vec6 pose_error(const Transform& X_BA) {
  Vec6 e;
  e.head<3>() = log_so3(X_BA.R);
  e.tail<3>() = X_BA.R.transpose() * X_BA.p;
  return e;
}

// Spatial inertia of a rigid body: mass m, centre of mass c and rotational inertia Ic about the
// centre of mass, both in the body frame (kg, m, kg*m^2).
struct Inertia {
  double m = 0.0;
  Vec3 c = Vec3::Zero();
  Mat3 Ic = Mat3::Zero();

  Inertia() = default;
  Inertia(double m_, const Vec3& c_, const Mat3& Ic_) : m(m_), c(c_), Ic(Ic_) {}

  // Rotational inertia about the frame origin.
  Mat3 I_origin() const { return Ic + m * (c.squaredNorm() * Mat3::Identity() - c * c.transpose()); }

  // F = I * V (RBDA eq. 2.63)
  Vec6 operator*(const Vec6& V) const {
    const Vec3 w = V.head<3>(), v = V.tail<3>();
    const Vec3 h = m * c;
    Vec6 F;
    F.head<3>() = Ic * w + m * c.cross(w.cross(c)) + h.cross(v);
    F.tail<3>() = m * v - h.cross(w);
    return F;
  }
  // This inertia (given in B coordinates) expressed in A coordinates, X = X_AB.
  Inertia transformed(const Transform& X) const { return Inertia(m, X.R * c + X.p, X.R * Ic * X.R.transpose()); }
  // Sum of two inertias given in the same frame.
  Inertia& operator+=(const Inertia& o) {
    const double mt = m + o.m;
    if (mt <= 0.0) {
      Ic += o.Ic;
      return *this;
    }
    const Vec3 ct = (m * c + o.m * o.c) / mt;
    const Vec3 d1 = c - ct, d2 = o.c - ct;
    Ic = Ic + m * (d1.squaredNorm() * Mat3::Identity() - d1 * d1.transpose()) + o.Ic +
         o.m * (d2.squaredNorm() * Mat3::Identity() - d2 * d2.transpose());
    m = mt;
    c = ct;
    return *this;
  }
  Mat6 matrix() const {
    Mat6 I;
    const Mat3 C = skew(c);
    I.topLeftCorner<3, 3>() = I_origin();
    I.topRightCorner<3, 3>() = m * C;
    I.bottomLeftCorner<3, 3>() = -m * C;
    I.bottomRightCorner<3, 3>() = m * Mat3::Identity();
    return I;
  }
};

// The same rigid-body inertia in the form the recursive algorithms use (RBDA s.2.13): mass m,
// first moment h = m c and rotational inertia Io about the frame origin. All three add directly, and
// I*V costs two 3x3 products; Data keeps one per body and the composites in this form.
struct RigidInertia {
  double m = 0.0;
  Vec3 h = Vec3::Zero();
  Mat3 Io = Mat3::Zero();

  RigidInertia() = default;
  explicit RigidInertia(const Inertia& I) : m(I.m), h(I.m * I.c), Io(I.I_origin()) {}

  Vec6 operator*(const Vec6& V) const {
    const Vec3 w = V.head<3>(), v = V.tail<3>();
    Vec6 F;
    F.head<3>() = Io * w + h.cross(v);
    F.tail<3>() = m * v - h.cross(w);
    return F;
  }
  // this inertia (given in B coordinates) in A coordinates, X = X_AB:
  //   h_A = R h + m p,  Io_A = R Io R^T + 2 (g.p) I - g p^T - p g^T  with g = R h + m p / 2
  // (the parallel-axis terms of RBDA eq. 2.66 in first-moment form); only the symmetric half is computed.
  RigidInertia transformed(const Transform& X) const { return transformed(X.R, X.p); }
  // the same with X = (R, p) given by parts
  RigidInertia transformed(const Mat3& R, const Vec3& p) const {
    RigidInertia r;
    transform_into(R, p, r);
    return r;
  }
  // the same written into r entry by entry (r must not be this): no temporary to copy
  void transform_into(const Mat3& R, const Vec3& p, RigidInertia& r) const {
    const Vec3 hR = R * h;
    r.m = m;
    const Vec3 rh = hR + m * p;
    r.h.x() = rh.x();
    r.h.y() = rh.y();
    r.h.z() = rh.z();
    const Vec3 g = hR + (0.5 * m) * p;
    const double c = 2.0 * g.dot(p);
    Mat3 T;
    T.noalias() = R * Io;
    for (int i = 0; i < 3; ++i)
      for (int j = i; j < 3; ++j) {
        double a = T(i, 0) * R(j, 0) + T(i, 1) * R(j, 1) + T(i, 2) * R(j, 2) - g[i] * p[j] - p[i] * g[j];
        if (i == j) a += c;
        r.Io(i, j) = a;
        r.Io(j, i) = a;
      }
  }
  RigidInertia& operator+=(const RigidInertia& o) {
    m += o.m;
    h += o.h;
    Io += o.Io;
    return *this;
  }
};

}  // namespace coopdyn
