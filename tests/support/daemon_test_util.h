// Helpers for the coopdynd tests: scenes, an allocation-free in-memory bus, offline comparison.
#pragma once

#include <gtest/gtest.h>

#include <array>
#include <cstring>
#include <dirent.h>
#include <mutex>
#include <random>
#include <string>
#include <vector>

#include <Eigen/QR>

#include "service/algorithms/kinematics.h"
#include "service/dynamics/constrained_dynamics.h"
#include "service/dynamics/wrenches.h"
#include "service/io/transport/bus.h"
#include "service/io/codec/codec.h"
#include "service/scene/scene.h"
#include "tests/support/files.h"

namespace coopdyn::daemon_test {

using testing::scene_path;

// Every scene in config/scenes that loads (one that does not load is
// reported by the scene tests, not here).
inline std::vector<std::string> loadable_scenes() {
  std::vector<std::string> out;
  const std::string dir = std::string(COOPDYN_SOURCE_DIR) + "/config/scenes";
  if (DIR* d = opendir(dir.c_str())) {
    while (dirent* e = readdir(d)) {
      std::string n = e->d_name;
      if (n.size() > 5 && n.substr(n.size() - 5) == ".yaml") {
        n = n.substr(0, n.size() - 5);
        try {
          load_scene(scene_path(n));
          out.push_back(n);
        } catch (const std::exception&) {
        }
      }
    }
    closedir(d);
  }
  std::sort(out.begin(), out.end());
  return out;
}

// The last message per channel, in fixed storage: publish() never allocates.
class FakeBus : public io::Bus {
 public:
  static constexpr int kCap = 1 << 16;
  struct Slot {
    char channel[64] = {0};
    std::array<uint8_t, kCap> data{};
    int len = 0;
    long count = 0;
  };
  int publish(const char* channel, const void* data, int len) override {
    for (Slot& s : slots_) {
      if (s.channel[0] == 0) std::strncpy(s.channel, channel, sizeof s.channel - 1);
      if (std::strcmp(s.channel, channel) == 0) {
        if (len > kCap) return -1;
        std::memcpy(s.data.data(), data, static_cast<size_t>(len));
        s.len = len;
        ++s.count;
        return 0;
      }
    }
    return -1;
  }
  const Slot* find(const char* channel) const {
    for (const Slot& s : slots_)
      if (std::strcmp(s.channel, channel) == 0) return &s;
    return nullptr;
  }
  long count(const char* channel) const {
    const Slot* s = find(channel);
    return s ? s->count : 0;
  }
  io::DecodedOutput last_output(const char* channel = "COOPDYN_OUTPUT") const {
    io::DecodedOutput o;
    const Slot* s = find(channel);
    EXPECT_TRUE(s && io::decode_output(s->data.data(), s->len, &o)) << "no decodable output on " << channel;
    return o;
  }

 private:
  Slot slots_[4];
};

// A FakeBus the test's thread may read while the loop's thread publishes: each publish and each read
// under a mutex (test scaffolding, allocation-free; the loop's own code locks nothing).
class SharedFakeBus : public io::Bus {
 public:
  int publish(const char* channel, const void* data, int len) override {
    std::lock_guard<std::mutex> lk(mu_);
    return bus_.publish(channel, data, len);
  }
  long count(const char* channel) const {
    std::lock_guard<std::mutex> lk(mu_);
    return bus_.count(channel);
  }
  // the last output's input seq, -1 before the first output
  int64_t last_input_seq(const char* channel = "COOPDYN_OUTPUT") const {
    std::lock_guard<std::mutex> lk(mu_);
    return bus_.find(channel) ? bus_.last_output(channel).input_seq : -1;
  }
  io::DecodedOutput last_output(const char* channel = "COOPDYN_OUTPUT") const {
    std::lock_guard<std::mutex> lk(mu_);
    return bus_.last_output(channel);
  }

 private:
  mutable std::mutex mu_;
  FakeBus bus_;
};

inline Eigen::VectorXd vec(const std::vector<double>& x) {
  return Eigen::Map<const Eigen::VectorXd>(x.data(), static_cast<Eigen::Index>(x.size()));
}
inline std::vector<double> stdvec(const Eigen::VectorXd& x) { return std::vector<double>(x.data(), x.data() + x.size()); }

// v projected onto the velocities that keep the constraints at q (G(q) v = 0): a measured state
// that closes (the daemon refuses one that does not, REASON_CLOSURE).
inline Eigen::VectorXd closing_velocity(const System& sys, const Eigen::VectorXd& q, const Eigen::VectorXd& v) {
  if (sys.constraints.rows == 0) return v;
  Workspace ws(sys);
  forward_kinematics(sys.model, ws.data, q, v);
  constraint_rows(sys.model, ws.data, sys.constraints, q, v, ws.cd);
  Eigen::CompleteOrthogonalDecomposition<Eigen::MatrixXd> cod(ws.cd.G);
  return v - cod.solve(ws.cd.G * v);
}

// Asserts that a published output equals the offline evaluate() at the (q, v, tau) it carries:
// same wrenches (every output of the scene), stresses, accelerations and diagnostics.
inline void expect_matches_offline(const System& sys, const io::DecodedOutput& o, double tol = 1e-9) {
  ASSERT_EQ(static_cast<int>(o.q.size()), sys.model.nq());
  ASSERT_EQ(static_cast<int>(o.v.size()), sys.model.nv());
  Workspace ws(sys);
  const Diagnostics& d = evaluate(sys, ws, vec(o.q), vec(o.v), vec(o.tau));
  EXPECT_EQ(o.status, static_cast<int>(d.status));
  EXPECT_EQ(o.reason, static_cast<int>(d.reason));
  EXPECT_EQ(o.rank, d.rank);
  EXPECT_EQ(o.rows, d.rows);
  WrenchData wd(sys);
  compute_wrenches(sys, ws, wd);
  const auto& outs = sys.wrenches.outputs;
  ASSERT_EQ(o.wrench.size(), outs.size());
  for (size_t t = 0; t < outs.size(); ++t) {
    EXPECT_EQ(o.wrench_names[t], outs[t].name);
    EXPECT_EQ(o.wrench_frames[t], outs[t].frame);
    EXPECT_EQ(o.wrench_by[t], outs[t].by);
    EXPECT_EQ(o.wrench_kind[t], static_cast<int>(outs[t].kind));
    const Vec6& w = wd.W[t];
    const double scale = 1.0 + w.cwiseAbs().maxCoeff();
    for (int k = 0; k < 6; ++k) EXPECT_NEAR(o.wrench[t][k], w[k], tol * scale) << o.wrench_names[t] << " component " << k;
    EXPECT_EQ(static_cast<unsigned>(o.indeterminate_mask[t]) & 0x3f, wd.indeterminate[t]);
  }
  // the free directions, as vectors, with their classes
  ASSERT_EQ(static_cast<int>(o.free_direction.size()), wd.num_free);
  for (int d = 0; d < wd.num_free; ++d) {
    EXPECT_EQ(o.free_class[static_cast<size_t>(d)], static_cast<int>(wd.free_class[static_cast<size_t>(d)]));
    for (size_t t = 0; t < outs.size(); ++t)
      for (int k = 0; k < 6; ++k)
        EXPECT_NEAR(o.free_direction[static_cast<size_t>(d)][t][static_cast<size_t>(k)], wd.free_W(6 * static_cast<Eigen::Index>(t) + k, d), tol)
            << "free direction " << d << " " << o.wrench_names[t];
  }
  ASSERT_EQ(static_cast<Eigen::Index>(o.stress.size()), ws.stress.size());
  for (Eigen::Index k = 0; k < ws.stress.size(); ++k)
    EXPECT_NEAR(o.stress[k], ws.stress[k], tol * (1.0 + std::abs(ws.stress[k])));
  for (Eigen::Index k = 0; k < ws.vdot.size(); ++k) EXPECT_NEAR(o.vdot[k], ws.vdot[k], tol * (1.0 + std::abs(ws.vdot[k])));
}

// A torque within the scene's limits on every DOF that is not a pseudo-joint.
inline Eigen::VectorXd some_torque(const System& sys, unsigned seed, double scale = 2.0) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-scale, scale);
  Eigen::VectorXd tau = Eigen::VectorXd::Zero(sys.model.nv());
  for (int i = 0; i < sys.model.nv(); ++i) tau[i] = std::max(-sys.tau_limit[i], std::min(sys.tau_limit[i], u(rng)));
  for (int d : sys.model.pseudo_dofs) tau[d] = 0;
  return tau;
}

}  // namespace coopdyn::daemon_test
