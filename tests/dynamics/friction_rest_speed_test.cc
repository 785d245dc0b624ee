// The rest threshold of Coulomb friction joints (scene key `friction: {rest_speed}`, System::
// rest_speed): a joint slower than it is at rest and held by stiction (vdot exactly 0) while the
// bound holds; faster, it slides with the bound against its motion. The default is unchanged, and a
// bad value is a scene error at its line.
#include <gtest/gtest.h>

#include <cmath>

#include "service/dynamics/constrained_dynamics.h"
#include "service/scene/scene.h"
#include "tests/support/test_util.h"

using namespace coopdyn;
using namespace coopdyn::testing;

namespace {
// One link on a revolute joint about z (no gravity torque about it), I_zz = 0.05 kg m^2, Coulomb
// friction 1 N*m; `extra` is appended to the scene (line 11 on).
std::string pendulum(const std::string& extra) {
  return "name: pendulum\ngravity: [0, 0, -9.81]\nformulation: classic\nbodies:\n"
         "  - name: link\n    parent: world\n"
         "    joint: {type: revolute, axis: [0, 0, 1], name: q, friction: 1}\n"
         "    mass: 1\n    com: [0, 0, 0]\n    inertia: [0.05, 0.05, 0.05, 0, 0, 0]\n" +
         extra;
}
Eigen::VectorXd vec1(double x) { return Eigen::VectorXd::Constant(1, x); }
}  // namespace

TEST(FrictionRestSpeed, SlowerIsHeldByStictionFasterSlides) {
  const System sys = load_scene_string(pendulum("friction: {rest_speed: 1e-3}\n"), "pendulum.yaml");
  EXPECT_EQ(sys.rest_speed, 1e-3);
  Workspace ws(sys);
  EXPECT_EQ(ws.rest_speed, 1e-3);
  // 0.5 N*m against a 1 N*m bound
  for (double v : {5e-4, -5e-4, 1e-3, 0.0}) {  // at or below the threshold: at rest, stuck
    evaluate(sys, ws, sys.q0, vec1(v), vec1(0.5));
    EXPECT_EQ(ws.rest_count, 1) << v;
    EXPECT_EQ(ws.friction_stuck, 1) << v;
    EXPECT_EQ(ws.vdot[0], 0.0) << v;
    EXPECT_NEAR(ws.tau_loss[0], -0.5, 1e-15) << v;
  }
  for (double v : {2e-3, -2e-3}) {  // faster: slides, the bound against the motion
    evaluate(sys, ws, sys.q0, vec1(v), vec1(0.5));
    EXPECT_EQ(ws.rest_count, 0) << v;
    EXPECT_EQ(ws.tau_loss[0], v > 0 ? -1.0 : 1.0) << v;
    EXPECT_NEAR(ws.vdot[0], (0.5 + ws.tau_loss[0]) / 0.05, 1e-12) << v;  // -10 or 30 rad/s^2
  }
  // the default (1e-9): the same 5e-4 rad/s slides
  const System def = load_scene_string(pendulum(""), "pendulum.yaml");
  EXPECT_EQ(def.rest_speed, Workspace::kRestSpeed);
  EXPECT_EQ(def.rest_speed, 1e-9);
  Workspace wd(def);
  evaluate(def, wd, def.q0, vec1(5e-4), vec1(0.5));
  EXPECT_EQ(wd.rest_count, 0);
  EXPECT_NEAR(wd.vdot[0], -10.0, 1e-12);
  evaluate(def, wd, def.q0, vec1(1e-9), vec1(0.5));
  EXPECT_EQ(wd.vdot[0], 0.0);
  // 0: only an exact zero rests
  const System zero = load_scene_string(pendulum("friction: {rest_speed: 0}\n"), "pendulum.yaml");
  Workspace wz(zero);
  evaluate(zero, wz, zero.q0, vec1(1e-300), vec1(0.5));
  EXPECT_EQ(wz.rest_count, 0);
  evaluate(zero, wz, zero.q0, vec1(0.0), vec1(0.5));
  EXPECT_EQ(wz.vdot[0], 0.0);
}

TEST(FrictionRestSpeed, BadValuesAreRefusedAtTheirLine) {
  struct Bad {
    const char* text;
    const char* why;
  };
  for (const Bad& b : {Bad{"friction: {rest_speed: -1e-6}\n", "must be a finite speed >= 0"},
                       Bad{"friction: {rest_speed: .nan}\n", "friction.rest_speed must be finite"},
                       Bad{"friction: {rest_speed: .inf}\n", "friction.rest_speed must be finite"},
                       Bad{"friction: {rest_speed: slow}\n", "friction.rest_speed"},
                       Bad{"friction: {rest_speed: [1]}\n", "must be a number"},
                       Bad{"friction: {rest_sped: 1}\n", "rest_sped"},
                       Bad{"friction: 1e-6\n", "'friction' must be a mapping"}}) {
    const std::string e = scene_error(pendulum(b.text));  // line 11: the key
    EXPECT_NE(e.find("car.yaml:11:"), std::string::npos) << b.text << ": " << e;
    EXPECT_NE(e.find(b.why), std::string::npos) << b.text << ": " << e;
  }
}
