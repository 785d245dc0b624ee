// A user's program built against the installed coopdyn (find_package or pkg-config): it loads the
// installed two_puma_load scene (COOPDYN_INSTALLED_DATA_DIR: the package's coopdyn_DATA_DIR or the
// .pc file's datadir, share/coopdyn; its robots are in share/coopdyn/robots),
// computes the holding torques, evaluates, and checks the physics: no acceleration, and the two arm
// bases carry the weight of the arms and the box, summed from the model's own masses. It also round-
// trips an installed LCM message type. Exit 0 when all holds, 1 otherwise.
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "coopdyn/torque_command_t.hpp"
#include "service/dynamics/holding_torque.h"
#include "service/dynamics/wrenches.h"
#include "service/scene/scene.h"
#include "service/version.h"

int main() {
  using namespace coopdyn;
  int failures = 0;
  auto check = [&](bool ok, const char* what) {
    std::printf("%s: %s\n", ok ? "ok" : "FAILED", what);
    failures += ok ? 0 : 1;
  };
  const std::string scene = COOPDYN_INSTALLED_DATA_DIR "/scenes/two_puma_load.yaml";
  std::printf("scene %s\n", scene.c_str());
  const System sys = load_scene(scene);
  HoldWorkspace hw(sys, default_actuated(sys));
  Eigen::VectorXd tau(sys.model.nv());
  check(holding_torque(sys, hw, sys.q0, sys.v0, tau), "holding torques found");
  Workspace ws(sys);
  check(evaluate(sys, ws, sys.q0, sys.v0, tau).status != Status::kError, "evaluation without error");
  const double vdot = ws.vdot.cwiseAbs().maxCoeff();
  check(vdot < 1e-9, "held: no acceleration");

  double weight = 0;
  for (const Body& b : sys.model.bodies) weight += b.inertia.m * sys.model.gravity_W.norm();
  WrenchData wd(sys);
  compute_wrenches(sys, ws, wd);
  double fz = 0;
  int bases = 0;
  for (size_t k = 0; k < sys.wrenches.outputs.size(); ++k)
    if (sys.wrenches.outputs[k].kind == WrenchKind::kBase) {
      fz += wrench_frame_pose(sys, ws.data, static_cast<int>(k)).R.row(2).dot(wd.W[k].tail<3>());
      ++bases;
    }
  std::printf("coopdyn %s: %d bases carry %.9g N; arms and box weigh %.9g N; max |vdot| %.3g\n", COOPDYN_VERSION, bases,
              fz, weight, vdot);
  check(bases == 2 && weight > 0, "two bases, a positive weight");
  check(std::abs(fz - weight) <= 1e-8 * weight, "the bases carry the total weight");

  coopdyn::torque_command_t m;
  m.utime = 1;
  m.seq = 42;
  m.names = {"arm1.q1"};
  m.num_names = 1;
  m.tau = {1.5};
  m.num_torques = 1;
  std::vector<unsigned char> buf(m.getEncodedSize());
  coopdyn::torque_command_t back;
  const bool rt = m.encode(buf.data(), 0, static_cast<int>(buf.size())) == static_cast<int>(buf.size()) &&
                  back.decode(buf.data(), 0, static_cast<int>(buf.size())) == static_cast<int>(buf.size());
  check(rt && back.seq == 42 && back.names == m.names && back.tau == m.tau, "torque_command_t round trip");
  return failures == 0 ? 0 : 1;
}
