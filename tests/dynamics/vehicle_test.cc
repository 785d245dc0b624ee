// Vehicles (in coopdynd_tests for its output_t part): the shipped four-wheel car and trike against hand statics, an inclined
// ground against a tilted gravity, the steady turn's lateral load transfer against the roll
// moment and the roll-stiffness distribution, and the contact report (friction needed,
// utilisation, slip and lift-off) at the moment the formulas say, also through output_t.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <sstream>
#include <memory>
#include <vector>

#include "service/dynamics/contacts.h"
#include "service/dynamics/integrators.h"
#include "service/io/codec/codec.h"
#include "tests/support/child_process.h"
#include "tests/support/test_util.h"

using namespace coopdyn;
using namespace coopdyn::testing;
using namespace coopdyn::daemon_test;

namespace {

constexpr double kG = 9.81;

// The shipped car's geometry (config/scenes/four_wheel_car.yaml)
constexpr double kLf = 1.05, kLr = 1.61, kL = kLf + kLr, kTrack = 1.565, kH = 0.65, kR = 0.31;
constexpr double kMc = 1430, kMw = 45, kIspin = 1.2;

int spec_of(const System& sys, const std::string& name) {
  for (size_t s = 0; s < sys.constraints.specs.size(); ++s)
    if (sys.constraints.specs[s].name == name) return static_cast<int>(s);
  ADD_FAILURE() << "no constraint " << name;
  return 0;
}

// ground force on the wheel [fx fy fz] in its contact frame
Vec3 contact(const System& sys, const Workspace& ws, const std::string& name) {
  const int s = spec_of(sys, name);
  return ws.lambda.segment<3>(sys.constraints.row_offset[static_cast<size_t>(s)]);
}

// A steady left turn of the car with Ackermann steering: the rear axle's midpoint on a circle of
// radius R about the turn centre (-lr, R) in chassis coordinates, at speed V. Every wheel rolls
// about the same centre; the chassis twist is constant in its own frame.
struct Turn {
  double R, V, Om, dl, dr;
};
Turn ackermann(double R, double V) {
  return {R, V, V / R, std::atan(kL / (R - kTrack / 2)), std::atan(kL / (R + kTrack / 2))};
}
void turn_state(const System& sys, const Turn& T, Eigen::VectorXd& q, Eigen::VectorXd& v) {
  const Model& m = sys.model;
  q = sys.q0;
  v = Eigen::VectorXd::Zero(m.nv());
  v.segment<6>(0) << 0, 0, T.Om, T.Om * T.R, T.Om * kLr, 0;  // chassis twist in the chassis frame
  const double w = kTrack / 2;
  v[velocity_index_of(sys, "fl_spin")] = T.Om * std::hypot(kL, T.R - w) / kR;
  v[velocity_index_of(sys, "fr_spin")] = T.Om * std::hypot(kL, T.R + w) / kR;
  v[velocity_index_of(sys, "rl_spin")] = T.Om * (T.R - w) / kR;
  v[velocity_index_of(sys, "rr_spin")] = T.Om * (T.R + w) / kR;
}

}  // namespace

TEST(Vehicle, StaticLoadsEqualHandStatics) {
  // car: the chassis' weight split by the lever rule, each wheel's own weight on its contact
  {
    const System sys = load("four_wheel_car");
    Workspace ws(sys);
    const Diagnostics& d = evaluate(sys, ws, sys.q0, sys.v0, Eigen::VectorXd::Zero(sys.model.nv()));
    ASSERT_EQ(d.status, Status::kIndeterminate);
    EXPECT_EQ(d.indeterminate, 3);  // diagonal normal transfer, lateral split front and rear
    const double front = (kMc * kG * kLr / kL + 2 * kMw * kG) / 2, rear = (kMc * kG * kLf / kL + 2 * kMw * kG) / 2;
    for (const char* w : {"fl", "fr"}) EXPECT_NEAR(contact(sys, ws, w).z(), front, 1e-9 * front) << w;
    for (const char* w : {"rl", "rr"}) EXPECT_NEAR(contact(sys, ws, w).z(), rear, 1e-9 * rear) << w;
    EXPECT_NEAR(front, 4686.857, 1e-3);  // the scene file's comment
    EXPECT_NEAR(rear, 3210.193, 1e-3);
    ContactData cts(sys);
    compute_contacts(sys, ws, cts);
    EXPECT_EQ(cts.worst, ContactState::kOk);
    for (size_t i = 0; i < cts.spec.size(); ++i) EXPECT_LT(cts.friction_needed[i], 1e-12);
  }
  // trike: three contacts, determinate normal loads
  {
    const System sys = load("trike");
    Workspace ws(sys);
    const Diagnostics& d = evaluate(sys, ws, sys.q0, sys.v0, Eigen::VectorXd::Zero(sys.model.nv()));
    ASSERT_NE(d.status, Status::kError);
    EXPECT_EQ(d.indeterminate, 1);  // only the rear wheels' lateral split
    const double front = 250 * kG * 0.7 / 1.8 + 8 * kG, rear = 250 * kG * 1.1 / 1.8 / 2 + 8 * kG;
    EXPECT_NEAR(contact(sys, ws, "f").z(), front, 1e-9 * front);
    EXPECT_NEAR(contact(sys, ws, "rl").z(), rear, 1e-9 * rear);
    EXPECT_NEAR(contact(sys, ws, "rr").z(), rear, 1e-9 * rear);
    EXPECT_NEAR(front, 1032.23, 5e-3);
    EXPECT_NEAR(rear, 827.855, 5e-3);
  }
}

TEST(Vehicle, InclinedGroundEqualsATiltedGravity) {
  // A 15 % grade rising towards +x: the car on the plane, pitched with it, released at rest with a
  // drive torque on the rear wheels, is the same system as the car on flat ground under gravity
  // turned into the plane's frame. Body-frame accelerations and contact-frame forces are equal.
  const double th = std::atan(0.15), s = std::sin(th), c = std::cos(th);
  char ground[160], grav[120];
  std::snprintf(ground, sizeof ground, "\nground: {normal: [%.17g, 0, %.17g], point: [0, 0, 0], mu: 0.85}\n", -s, c);
  std::snprintf(grav, sizeof grav, "gravity: [%.17g, 0, %.17g]", -kG * s, -kG * c);
  std::string incl = scene_text("four_wheel_car");
  incl = replace_once(incl, "ground: {normal: [0, 0, 1], point: [0, 0, 0], mu: 0.85}", ground + 1);
  // the chassis on the plane: its CG kH along the normal, pitched nose-up by th (Ry(-th) z = n)
  char pose[160];
  std::snprintf(pose, sizeof pose, "q: {xyz: [%.17g, 0, %.17g], rpy: [0, %.17g, 0]}", -s * kH, c * kH, -th);
  incl = replace_once(incl, "q: {xyz: [0, 0, 0.65]}", pose);
  const System a = load_scene_string(incl, scene_path("four_wheel_car"));
  const System b = load_scene_string(replace_once(scene_text("four_wheel_car"), "gravity: [0, 0, -9.81]", grav),
                                     scene_path("four_wheel_car"));
  Eigen::VectorXd tau = Eigen::VectorXd::Zero(a.model.nv());
  tau[velocity_index_of(a, "rl_spin")] = tau[velocity_index_of(a, "rr_spin")] = 600;  // N*m each
  Workspace wa(a), wb(b);
  wa.position_errors = true;
  ASSERT_NE(evaluate(a, wa, a.q0, a.v0, tau).status, Status::kError);
  ASSERT_NE(evaluate(b, wb, b.q0, b.v0, tau).status, Status::kError);
  EXPECT_LT(wa.cd.err.cwiseAbs().maxCoeff(), 1e-12);  // the loader put the car on the plane
  EXPECT_LT((wa.vdot - wb.vdot).cwiseAbs().maxCoeff(), 1e-9);
  EXPECT_LT((wa.lambda - wb.lambda).cwiseAbs().maxCoeff(), 1e-7);  // forces of ~5 kN
  // and the physics of the grade: the chassis accelerates along the plane by
  // (2 tau / r - m_total g sin th) / (m_total + 4 I / r^2), and the normal loads sum to m g cos th
  const double M = kMc + 4 * kMw;
  const double acc = (2 * 600 / kR - M * kG * s) / (M + 4 * kIspin / (kR * kR));
  EXPECT_NEAR(wa.vdot[3], acc, 1e-9);
  double N = 0;
  for (const char* w : {"fl", "fr", "rl", "rr"}) N += contact(a, wa, w).z();
  EXPECT_NEAR(N, M * kG * c, 1e-8 * N);
  std::printf("[ four_wheel_car ] 15 %% grade, 600 N*m per rear wheel: a = %.6f m/s^2 along the plane, normal loads %.3f N = m g cos\n",
              acc, N);
}

TEST(Vehicle, SteadyTurnLoadTransferFollowsRollStiffness) {
  // Ackermann steady turn, R = 40 m (rear axle midpoint), V = 12 m/s: nothing accelerates in the
  // body frame. The contact forces' moment about the ground point under the CG equals the
  // vehicle's rate of angular momentum there (every mass on its circle, the wheels' spin
  // precessing), and the compliance rule splits the lateral load transfer between the axles in
  // proportion to their roll stiffness (wheel rate k, K = k t^2 / 2): the textbook result.
  const Turn T = ackermann(40.0, 12.0);
  const System sys = car_with_steer(T.dl, T.dr);
  Eigen::VectorXd q, v;
  turn_state(sys, T, q, v);
  Workspace ws(sys);
  const Diagnostics& d = evaluate(sys, ws, q, v, Eigen::VectorXd::Zero(sys.model.nv()));
  ASSERT_NE(d.status, Status::kError);
  EXPECT_LT(ws.cd.Gv.cwiseAbs().maxCoeff(), 1e-12);  // the state rolls without slip
  EXPECT_LT(ws.vdot.cwiseAbs().maxCoeff(), 1e-9);    // and it is steady
  const Vec3 fl = contact(sys, ws, "fl"), fr = contact(sys, ws, "fr"), rl = contact(sys, ws, "rl"), rr = contact(sys, ws, "rr");
  // roll moment about the chassis x axis through the ground point under the CG: sum y_i N_i must
  // equal -sum m_i h_i a_y,i + sum (dH_i/dt)_x (lateral forces act at ground level: no moment)
  const double w = kTrack / 2, Om2 = T.Om * T.Om;
  double Mx = -kMc * kH * Om2 * T.R;  // chassis: a_y = Om^2 (R - 0)
  struct W {
    double x, y, delta, spin;
  };
  const W wheels[4] = {{kLf, w, T.dl, v[velocity_index_of(sys, "fl_spin")]},
                       {kLf, -w, T.dr, v[velocity_index_of(sys, "fr_spin")]},
                       {-kLr, w, 0, v[velocity_index_of(sys, "rl_spin")]},
                       {-kLr, -w, 0, v[velocity_index_of(sys, "rr_spin")]}};
  for (const W& e : wheels) {
    Mx += -kMw * kR * Om2 * (T.R - e.y);               // centripetal, at the wheel centre's height
    Mx += -kIspin * e.spin * T.Om * std::cos(e.delta);  // spin I psi_dot precessing at Om (z x axle)
  }
  const double contact_Mx = w * (fl.z() - fr.z()) + w * (rl.z() - rr.z());
  EXPECT_NEAR(contact_Mx, Mx, 1e-9 * std::abs(Mx));
  // the distribution: per axle dN = (outer - inner) / 2, dN_f t / (dN_r t) = K_f / K_r = k_f / k_r
  const double dNf = (fr.z() - fl.z()) / 2, dNr = (rr.z() - rl.z()) / 2;
  const double kf = 1 / 1.4044043441363e-5, kr = 1 / 2.1066065162045e-5;
  EXPECT_NEAR(dNf / dNr, kf / kr, 1e-9);
  EXPECT_NEAR(dNf * kTrack + dNr * kTrack, -Mx, 1e-9 * std::abs(Mx));
  // against the textbook total m a_y h / t with the whole car's mass at its CG height
  const double M = kMc + 4 * kMw, h_cg = (kMc * kH + 4 * kMw * kR) / M, ay = Om2 * T.R;
  const double textbook = M * ay * h_cg / kTrack;
  std::printf("[ four_wheel_car ] turn R %.0f m V %.0f m/s (a_y %.3f m/s^2): transfer front %.3f N, rear %.3f N (ratio %.6f = "
              "k_f/k_r %.6f); total %.3f N, textbook m a_y h / t %.3f N (%.2f %%: wheel spin precession and each "
              "mass on its own radius)\n",
              T.R, T.V, ay, dNf, dNr, dNf / dNr, kf / kr, dNf + dNr, textbook, 100 * (dNf + dNr - textbook) / textbook);
  EXPECT_NEAR(dNf + dNr, textbook, 0.03 * textbook);
  // lateral forces: their sum is the centripetal force of the whole car (chassis-y components,
  // the front wheels' lateral axes steered by delta)
  double Fy = rl.y() + rr.y() + fl.y() * std::cos(T.dl) + fr.y() * std::cos(T.dr);
  double may = kMc * Om2 * T.R;
  for (const W& e : wheels) may += kMw * Om2 * (T.R - e.y);
  EXPECT_NEAR(Fy, may, 1e-9 * may);
  // with the wheels' lateral force lines all through the turn centre, the rigid model cannot tell
  // the axles' shares: one more free direction than straight ahead, moving front and rear lateral
  WrenchData wd(sys);
  compute_wrenches(sys, ws, wd);
  int lateral = 0;
  for (int k = 0; k < wd.num_free; ++k) lateral += wd.free_class[static_cast<size_t>(k)] == FreeClass::kWheelLateral;
  EXPECT_EQ(wd.num_free, 3);
  EXPECT_EQ(lateral, 2);
  const double bike_f = may * kLr / kL, bike_r = may * kLf / kL;
  std::printf("[ four_wheel_car ] lateral front %.2f N, rear %.2f N (compliance rule); bicycle model b/L, a/L: %.2f, %.2f N\n",
              fl.y() * std::cos(T.dl) + fr.y() * std::cos(T.dr), rl.y() + rr.y(), bike_f, bike_r);
}

TEST(Vehicle, LiftOffAndSlipAreReportedWhereTheFormulasSay) {
  // At a fixed radius every force of the steady turn grows with V^2, so the inner front wheel's
  // normal force is N0 - c V^2 and it lifts off at V* = sqrt(N0 / c). Just below V* the report
  // says ok (or slip), just above lift_off, and output_t carries the same.
  const double R = 40.0;
  struct Eval {
    System sys;
    std::unique_ptr<Workspace> ws;
    std::unique_ptr<ContactData> c;
  };
  auto at = [&](double V) {
    const Turn T = ackermann(R, V);
    auto e = std::make_unique<Eval>();
    e->sys = car_with_steer(T.dl, T.dr);
    Eigen::VectorXd q, v;
    turn_state(e->sys, T, q, v);
    e->ws = std::make_unique<Workspace>(e->sys);
    EXPECT_NE(evaluate(e->sys, *e->ws, q, v, Eigen::VectorXd::Zero(e->sys.model.nv())).status, Status::kError);
    e->c = std::make_unique<ContactData>(e->sys);
    compute_contacts(e->sys, *e->ws, *e->c);
    return e;
  };
  // each wheel's normal force N0_i - c_i V^2; the first to reach zero lifts off first
  const System s0 = load("four_wheel_car");
  Workspace w0(s0);
  evaluate(s0, w0, s0.q0, s0.v0, Eigen::VectorXd::Zero(s0.model.nv()));
  ContactData rest(s0);
  compute_contacts(s0, w0, rest);
  const auto probe = at(10.0);
  double Vstar = INFINITY;
  size_t first = 0;
  for (size_t i = 0; i < 4; ++i) {
    const double ci = (rest.normal[i] - probe->c->normal[i]) / 100.0;
    if (ci > 0 && std::sqrt(rest.normal[i] / ci) < Vstar) {
      Vstar = std::sqrt(rest.normal[i] / ci);
      first = i;
    }
  }
  ASSERT_TRUE(std::isfinite(Vstar));
  const auto below = at(0.999 * Vstar);
  EXPECT_NE(below->c->worst, ContactState::kLiftOff);
  for (size_t i = 0; i < 4; ++i) EXPECT_GT(below->c->normal[i], 0) << i;
  const auto above = at(1.001 * Vstar);
  const ContactData& c1 = *above->c;
  EXPECT_LT(c1.normal[first], 0);
  EXPECT_EQ(c1.state[first], ContactState::kLiftOff);
  EXPECT_EQ(c1.worst, ContactState::kLiftOff);
  EXPECT_EQ(c1.friction_needed[first], -1.0);
  EXPECT_EQ(c1.utilisation[first], -1.0);
  // every wheel's state follows its forces: lift_off where N < 0, slip exactly where |f_t| > mu N
  for (size_t i = 0; i < 4; ++i) {
    const ContactState want = c1.normal[i] < 0                           ? ContactState::kLiftOff
                              : c1.tangential[i] > 0.85 * c1.normal[i] ? ContactState::kSlip
                                                                        : ContactState::kOk;
    EXPECT_EQ(c1.state[i], want) << i;
    if (c1.normal[i] > 0) {
      EXPECT_NEAR(c1.utilisation[i], c1.friction_needed[i] / 0.85, 1e-15);
    }
  }
  std::printf("[ four_wheel_car ] R %.0f m: wheel %s lifts off first, at V* = %.3f m/s (a_y = %.3f g; the rigid no-slip "
              "model holds the car to the road far beyond mu = 0.85, which the report flags as slip first)\n",
              R, s0.constraints.specs[static_cast<size_t>(rest.spec[first])].name.c_str(), Vstar, Vstar * Vstar / R / kG);
  // where the first wheel needs more than mu: the report says slip from that speed on
  double Vslip = INFINITY;
  for (size_t i = 0; i < 4; ++i) {
    // tangential and normal are both affine in V^2 (the lateral/longitudinal split is linear too)
    const double t1 = probe->c->tangential[i] / 100.0, ci = (rest.normal[i] - probe->c->normal[i]) / 100.0;
    const double V2 = 0.85 * rest.normal[i] / (t1 + 0.85 * ci);
    Vslip = std::min(Vslip, std::sqrt(V2));
  }
  EXPECT_EQ(at(0.999 * Vslip)->c->worst, ContactState::kOk);
  EXPECT_EQ(at(1.001 * Vslip)->c->worst, ContactState::kSlip);
  std::printf("[ four_wheel_car ] R %.0f m: the first wheel needs mu 0.85 at V = %.3f m/s (a_y = %.3f g)\n", R, Vslip,
              Vslip * Vslip / R / kG);
  const System* sys = &above->sys;
  const Workspace* ws = above->ws.get();
  // through output_t: the same numbers and states, and contact_status LIFT_OFF
  io::OutputEncoder enc(*sys);
  std::vector<uint8_t> buf(static_cast<size_t>(enc.max_size()));
  io::OutputFrame f;
  f.valid = true;
  f.ws = ws;
  ContactData contacts(*sys);  // computed by the loop, not the codec
  compute_contacts(*sys, *ws, contacts);
  f.contacts = &contacts;
  Eigen::VectorXd z = Eigen::VectorXd::Zero(sys->model.nv()), qq = sys->q0;
  f.q = &qq;
  f.v = &z;
  f.tau = &z;
  const int n = enc.encode(f, buf.data(), static_cast<int>(buf.size()));
  ASSERT_GT(n, 0);
  io::DecodedOutput o;
  ASSERT_TRUE(io::decode_output(buf.data(), n, &o));
  ASSERT_EQ(o.contact_names.size(), 4u);
  EXPECT_EQ(o.contact_names[0], "fl");
  EXPECT_EQ(o.contact_status, static_cast<int>(ContactState::kLiftOff));
  for (size_t i = 0; i < 4; ++i) {
    EXPECT_EQ(o.contact_normal[i], c1.normal[i]);
    EXPECT_EQ(o.contact_friction_needed[i], c1.friction_needed[i]);
    EXPECT_EQ(o.contact_utilisation[i], c1.utilisation[i]);
    EXPECT_EQ(o.contact_state[i], static_cast<int>(c1.state[i]));
  }
}

TEST(Vehicle, StraightAccelerationTransfersLoadAndSlipsAtThePredictedTorque) {
  // From rest on flat ground, drive torque tau on each rear wheel: the car accelerates by
  // a = (2 tau / r) / (M + 4 I / r^2); the pitch moment of the inertial forces about the ground,
  // sum m_i a h_i + 4 I a / r (the wheels' spin-up), moves M_pitch / L from the front axle to the
  // rear (the textbook m a h / L, with each mass at its own height). The rear wheels' friction
  // need fx / N grows with tau; it reaches mu = 0.85 at the torque where the report turns to slip.
  const System sys = load("four_wheel_car");
  const int rl = velocity_index_of(sys, "rl_spin"), rr = velocity_index_of(sys, "rr_spin");
  const double M = kMc + 4 * kMw, N0r = (kMc * kG * kLf / kL + 2 * kMw * kG) / 2, N0f = (kMc * kG * kLr / kL + 2 * kMw * kG) / 2;
  Workspace ws(sys);
  ContactData cts(sys);
  auto eval = [&](double tau) {
    Eigen::VectorXd t = Eigen::VectorXd::Zero(sys.model.nv());
    t[rl] = t[rr] = tau;
    EXPECT_NE(evaluate(sys, ws, sys.q0, sys.v0, t).status, Status::kError);
    compute_contacts(sys, ws, cts);
  };
  const double tau = 500;
  eval(tau);
  const double a = (2 * tau / kR) / (M + 4 * kIspin / (kR * kR));
  EXPECT_NEAR(ws.vdot[3], a, 1e-12);
  const double Mp = kMc * a * kH + 4 * kMw * a * kR + 4 * kIspin * a / kR;
  const Vec3 frl = contact(sys, ws, "rl"), ffl = contact(sys, ws, "fl");
  EXPECT_NEAR(frl.z() - N0r, Mp / kL / 2, 1e-9 * N0r);
  EXPECT_NEAR(N0f - ffl.z(), Mp / kL / 2, 1e-9 * N0f);
  EXPECT_NEAR(frl.x(), (tau - kIspin * a / kR) / kR, 1e-9 * frl.x());  // drive minus spin-up
  EXPECT_NEAR(ffl.x(), -kIspin * a / kR / kR, 1e-9);                      // the front wheels' spin-up
  const double textbook = M * a * ((kMc * kH + 4 * kMw * kR) / M) / kL;
  std::printf("[ four_wheel_car ] 500 N*m per rear wheel: a = %.6f m/s^2, rear axle gains %.3f N (textbook m a h / L %.3f N, "
              "%.2f %% from the wheels' spin-up)\n",
              a, Mp / kL, textbook, 100 * (Mp / kL - textbook) / textbook);
  // the friction need is affine in tau: fx = alpha tau, N = N0r + beta tau; slip at mu N = fx
  const double alpha = frl.x() / tau, beta = (frl.z() - N0r) / tau, tstar = 0.85 * N0r / (alpha - 0.85 * beta);
  eval(0.999 * tstar);
  EXPECT_EQ(cts.state[2], ContactState::kOk);
  EXPECT_EQ(cts.worst, ContactState::kOk);
  EXPECT_LT(cts.utilisation[2], 1.0);
  eval(1.001 * tstar);
  EXPECT_EQ(cts.state[2], ContactState::kSlip);
  EXPECT_EQ(cts.state[3], ContactState::kSlip);
  EXPECT_EQ(cts.worst, ContactState::kSlip);
  EXPECT_GT(cts.utilisation[2], 1.0);
  EXPECT_EQ(cts.state[0], ContactState::kOk);  // the front wheels only spin up
  std::printf("[ four_wheel_car ] rear wheels slip (mu 0.85) above %.1f N*m each: a = %.3f m/s^2 = %.3f g\n", tstar,
              (2 * tstar / kR) / (M + 4 * kIspin / (kR * kR)), (2 * tstar / kR) / (M + 4 * kIspin / (kR * kR)) / kG);
}

TEST(Vehicle, GroundAndFrictionErrorsNameThePlace) {
  const std::string base = scene_text("four_wheel_car");
  const std::string a = scene_error(replace_once(base, "mu: 0.85}", "mu: -1}"));
  EXPECT_NE(a.find("car.yaml:"), std::string::npos) << a;
  EXPECT_NE(a.find("mu must be > 0"), std::string::npos) << a;
  const std::string b = scene_error(replace_once(base, "normal: [0, 0, 1]", "normal: [0, 0, 0]"));
  EXPECT_NE(b.find("normal must be a nonzero vector"), std::string::npos) << b;
  const std::string c = scene_error(replace_once(base, "point: [0, 0, 0], mu", "pont: [0, 0, 0], mu"));
  EXPECT_NE(c.find("pont"), std::string::npos) << c;
}

TEST(Vehicle, SimReportsTheMomentAWheelStartsToSlip) {
  // coopdyn sim on the car, 1000 N*m per rear wheel (below the 1067.6 N*m where they slip, see
  // above), 100 N*m more from t = 0.5 s: the CSV's contact columns turn from ok to slip at that
  // row, and stderr says so once, with the time and the wheel.
  const std::string csv = tmp_path("vehicle_slip.csv");
  Child sim({COOPDYN_PATH, "sim", "--scene", scene_path("four_wheel_car"), "--duration", "1", "--dt", "0.01", "--torque",
             "rl_spin:constant:1000", "--torque", "rr_spin:constant:1000", "--torque", "rl_spin:step:100:0.5", "--torque",
             "rr_spin:step:100:0.5", "--out", csv},
            "vehicle_slip");
  ASSERT_EQ(sim.wait(), 0) << slurp(sim.err);
  const std::string err = slurp(sim.err);
  EXPECT_NE(err.find("t=0.5: wheel 'rl' needs more friction than its mu"), std::string::npos) << err;
  EXPECT_NE(err.find("t=0.5: wheel 'rr' needs more friction than its mu"), std::string::npos) << err;
  EXPECT_EQ(err.find("'fl'"), std::string::npos) << err;
  std::ifstream f(csv);
  std::string line;
  while (std::getline(f, line) && !line.empty() && line[0] == '#') {}  // the comment and units lines
  ASSERT_FALSE(line.empty());
  auto split = [](const std::string& l) {
    std::vector<std::string> out;
    std::stringstream ss(l);
    std::string c;
    while (std::getline(ss, c, ',')) out.push_back(c);
    return out;
  };
  const std::vector<std::string> head = split(line);
  int ct = -1, cu = -1, cs = -1;
  for (size_t i = 0; i < head.size(); ++i) {
    if (head[i] == "t") ct = static_cast<int>(i);
    if (head[i] == "rl.utilisation") cu = static_cast<int>(i);
    if (head[i] == "rl.contact") cs = static_cast<int>(i);
  }
  ASSERT_GE(ct, 0);
  ASSERT_GE(cu, 0);
  ASSERT_GE(cs, 0);
  int rows = 0;
  while (std::getline(f, line)) {
    const std::vector<std::string> c = split(line);
    const double t = std::stod(c[static_cast<size_t>(ct)]), u = std::stod(c[static_cast<size_t>(cu)]);
    const bool late = t >= 0.5 - 1e-9;
    EXPECT_EQ(c[static_cast<size_t>(cs)], late ? "slip" : "ok") << "t=" << t;
    EXPECT_EQ(u > 1.0, late) << "t=" << t << " utilisation " << u;
    ++rows;
  }
  EXPECT_EQ(rows, 101);
}

TEST(Vehicle, RollingResistanceSlowsACoastingCarAsTheEnergyBalanceSays) {
  // ground rolling_resistance c_rr: each wheel's normal force acts c_rr r ahead of its contact
  // point, a moment -c_rr r N about the axle. The moments' power is -c_rr (sum N) V = -c_rr M g V,
  // so a car coasting straight decelerates by c_rr g M / (M + 4 I / r^2) (the wheels' spin inertia
  // slows with it), whatever the pitch transfer does to each wheel.
  const double crr = 0.012, V = 20.0;
  const System sys = load_scene_string(replace_once(scene_text("four_wheel_car"), "mu: 0.85}", "mu: 0.85, rolling_resistance: 0.012}"),
                                       scene_path("four_wheel_car"));
  const Model& m = sys.model;
  Eigen::VectorXd q = sys.q0, v = Eigen::VectorXd::Zero(m.nv()), tau = Eigen::VectorXd::Zero(m.nv());
  v[3] = V;
  for (const char* w : {"fl_spin", "fr_spin", "rl_spin", "rr_spin"}) v[velocity_index_of(sys, w)] = V / kR;
  Workspace ws(sys);
  ASSERT_NE(evaluate(sys, ws, q, v, tau).status, Status::kError);
  EXPECT_GT(ws.rr_iterations, 1);
  EXPECT_LT(ws.rr_iterations, 50);
  const double M = kMc + 4 * kMw, s = V / std::sqrt(V * V + kRollingResistanceSpeed * kRollingResistanceSpeed);
  const double a = -crr * kG * M * s / (M + 4 * kIspin / (kR * kR));
  EXPECT_NEAR(ws.vdot[3], a, 1e-9 * std::abs(a));
  // each contact's wrench carries its moment, -c_rr r N about y_C
  for (const char* w : {"fl", "fr", "rl", "rr"}) {
    const Vec6 W = tip_wrench(sys, ws, spec_of(sys, w));
    EXPECT_NEAR(W[1], -crr * kR * s * W[5], 1e-12 * W[5]) << w;
  }
  // the external wrenches (contacts with their moments, gravity) equal the momentum rate
  const double eps = 1e-6;
  Eigen::VectorXd qp(m.nq()), qm(m.nq());
  integrate(m, q, v, eps, qp);
  integrate(m, q, v, -eps, qm);
  const Vec6 hdot = (total_momentum(m, qp, v + eps * ws.vdot) - total_momentum(m, qm, v - eps * ws.vdot)) / (2 * eps);
  Vec6 F = Vec6::Zero();
  for (const char* w : {"fl", "fr", "rl", "rr"}) {
    const int sp = spec_of(sys, w);
    F += rolling_contact_frame(m, ws.data, sys.constraints.specs[static_cast<size_t>(sp)]).act_force(tip_wrench(sys, ws, sp));
  }
  for (int i = 0; i < m.nbodies(); ++i) {
    const Inertia& I = m.bodies[i].inertia;
    Vec6 Fg;
    Fg << Vec3::Zero(), I.m * m.gravity_W;
    F += Transform(Mat3::Identity(), ws.data.X_WB[i].R * I.c + ws.data.X_WB[i].p).act_force(Fg);
  }
  EXPECT_LT((hdot - F).norm(), 1e-6 * F.norm());
  // coasting 2 s: the speed falls linearly at that rate (RK4, 1 ms)
  Stepper st(sys);
  for (int k = 0; k < 2000; ++k) ASSERT_NE(step(sys, st, Integrator::kRk4, 1e-3, tau, q, v).status, Status::kError);
  EXPECT_NEAR(v[3], V + 2.0 * a, 1e-6);
  std::printf("[ four_wheel_car ] c_rr %.3f: coasting from %.0f m/s decelerates %.6f m/s^2 (c_rr g M / (M + 4 I / r^2)), "
              "%.6f m/s after 2 s; %d fixed-point iterations\n",
              crr, V, -a, v[3], ws.rr_iterations);
  // only where it is solved
  try {
    SceneOverrides ov;
    ov.formulation = Formulation::kSvdBaseline;
    load_scene_string(replace_once(scene_text("four_wheel_car"), "mu: 0.85}", "mu: 0.85, rolling_resistance: 0.012}"), "car.yaml", ov);
    ADD_FAILURE() << "loaded";
  } catch (const SceneError& e) {
    EXPECT_NE(std::string(e.what()).find("mobile_platform and classic"), std::string::npos) << e.what();
  }
}

TEST(Vehicle, BrakingRampMovesLoadForwardAndTheStatusesTurnWhenTheFormulasSay) {
  // Straight at 30 m/s, a braking torque rising as -k t on all four wheels (RK4, 1 ms steps, the
  // torque held over each step as coopdyn sim does). The rigid no-slip car decelerates by
  // a = (4 tau / r) / (M + 4 I / r^2) whatever its speed; the pitch moment of the inertial forces
  // (sum m_i a h_i + 4 I a / r) moves Mp / L from the rear axle to the front (textbook m a h / L).
  // Each rear wheel's normal force N0r + Mp / 2L and braking force (tau - I a / r) / r are affine
  // in t: the rear wheels need mu = 0.85 at t_slip = mu N0r / (b + mu c) and lift off at
  // t_lift = N0r / c. The contact report says slip from the first step at or after t_slip and
  // lift_off from the first step at or after t_lift, not a step earlier.
  const System sys = load("four_wheel_car");
  const Model& m = sys.model;
  const double k = 1500.0, V = 30.0, dt = 1e-3, M = kMc + 4 * kMw;
  const double N0r = (kMc * kG * kLf / kL + 2 * kMw * kG) / 2, N0f = (kMc * kG * kLr / kL + 2 * kMw * kG) / 2;
  Eigen::VectorXd q = sys.q0, v = Eigen::VectorXd::Zero(m.nv()), tau = Eigen::VectorXd::Zero(m.nv());
  v[3] = V;
  const char* spins[4] = {"fl_spin", "fr_spin", "rl_spin", "rr_spin"};
  int dof[4];
  for (int i = 0; i < 4; ++i) {
    dof[i] = velocity_index_of(sys, spins[i]);
    v[dof[i]] = V / kR;
  }
  // per unit time: deceleration, pitch moment, rear normal force lost (c), rear braking force (b)
  const double a1 = -(4 * k / kR) / (M + 4 * kIspin / (kR * kR));
  const double Mp1 = (kMc * kH + 4 * kMw * kR + 4 * kIspin / kR) * a1;
  const double c = -Mp1 / kL / 2, b = (k + kIspin * a1 / kR) / kR;  // |fx| = (k t + I a / r) / r
  // the front wheels, gaining load, need mu at t_front = mu N0f / (b - mu c)
  const double t_slip = 0.85 * N0r / (b + 0.85 * c), t_lift = N0r / c, t_front = 0.85 * N0f / (b - 0.85 * c);
  Stepper st(sys);
  ContactData cts(sys);
  long first_slip = -1, first_lift = -1;
  double worst_transfer = 0;
  for (long i = 0; i <= 1600; ++i) {
    const double t = i * dt;
    for (int w = 0; w < 4; ++w) tau[dof[w]] = -k * t;
    ASSERT_NE(step(sys, st, Integrator::kRk4, dt, tau, q, v).status, Status::kError) << "t=" << t;
    const Workspace& ws = st.ws;  // the evaluation at the step's start (t, the torque of t)
    compute_contacts(sys, ws, cts);
    const double a = a1 * t;
    ASSERT_NEAR(ws.vdot[3], a, 1e-9 * (1 + std::abs(a))) << "t=" << t;
    const Vec3 frl = contact(sys, ws, "rl"), ffl = contact(sys, ws, "fl");
    worst_transfer = std::max({worst_transfer, std::abs(frl.z() - (N0r - c * t)), std::abs(ffl.z() - (N0f + c * t))});
    EXPECT_NEAR(frl.x(), -b * t, 1e-9 * N0r) << "t=" << t;
    const bool slip = cts.state[2] != ContactState::kOk, lift = cts.state[2] == ContactState::kLiftOff;
    EXPECT_EQ(cts.state[2], cts.state[3]) << "t=" << t;  // left and right alike
    EXPECT_EQ(cts.state[0], t >= t_front ? ContactState::kSlip : ContactState::kOk) << "t=" << t;
    if (slip && first_slip < 0) first_slip = i;
    if (lift && first_lift < 0) first_lift = i;
    EXPECT_EQ(slip, t >= t_slip) << "t=" << t;
    EXPECT_EQ(lift, t >= t_lift) << "t=" << t;
  }
  EXPECT_LT(worst_transfer, 1e-8 * N0f);
  EXPECT_EQ(first_slip, static_cast<long>(std::ceil(t_slip / dt)));
  EXPECT_EQ(first_lift, static_cast<long>(std::ceil(t_lift / dt)));
  const double textbook = M * a1 * ((kMc * kH + 4 * kMw * kR) / M) / kL;  // per second of the ramp
  std::printf("[ four_wheel_car ] braking -%.0f N*m/s per wheel from %.0f m/s: front gains %.3f N per m/s^2 of deceleration "
              "(textbook m h / L %.3f, +%.2f %% the wheels' spin); rear wheels slip at t = %.4f s (a = %.3f m/s^2) and lift off "
              "at t = %.4f s (a = %.3f m/s^2 = %.2f g), the front wheels slip at t = %.4f s, each the step the formula says; "
              "%.2f m/s left\n",
              k, V, Mp1 / a1 / kL, textbook / a1, 100 * (Mp1 / kL / textbook - 1), t_slip, a1 * t_slip, t_lift, a1 * t_lift,
              -a1 * t_lift / kG, t_front, v[3]);
}
