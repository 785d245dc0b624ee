// Error against run time: for every shipped scene, a scenario with a known or converged
// answer, swept over formulation x integrator x step size. Each run records the CPU time per
// simulated second (CLOCK_PROCESS_CPUTIME_ID around the step calls only, short runs repeated until
// they take > 50 ms), the errors of the state (q, v) and of every constraint wrench and pseudo-joint
// stress against the answer at common sample times (every 4 ms, the largest swept step), the
// constraint drift (max |position error| of the rows), the energy drift (zero torque, no damping:
// kinetic + potential energy is conserved) and whether the run ended in an error status.
//
// Answers:
//   two_puma_load, two_5dof_arms_load  passive fall from rest (zero torque), 0.5 s
//   planar_arms_load                   passive in-plane motion (arm 1 joints start at 0.5 rad/s,
//                                      the rest from the constraints), gravity out of plane, 0.5 s
//   four_bar                           passive swing from rest under gravity, 1 s
//     reference: RK4 at h_ref = 0.125 ms / 64, once per coordinate layout (the svd and pseudo-joint
//     forms share the tree of the mobile-platform / classic form and are compared with its
//     reference); its convergence is shown by the run at 2 h_ref against it.
//   unicycle            the rolling disk's steady precession, analytic (phi 0.3 rad, R 2 m):
//                       Omega^2 = 4 g tan(phi) / (6 R - 5 r sin(phi)), contact force
//                       (0, m Omega^2 rho, m g), 1 s
//   two_wheel_vehicle   the paper's experiment (Fig. 12-14): 1 N*m on the left wheel from 0 to
//                       0.5 s, then none, from rest; 1 s; reference run as above. (The steady turn
//                       without torque, analytic, is integrated exactly by every integrator here:
//                       its body-frame twist is constant and q integrates exactly on SO(3) x R^3;
//                       swept as the extra scenario two_wheel_vehicle_turn to show it.)
//
// Usage: accuracy_sweep OUT_DIR [SCENARIO...]   (writes OUT_DIR/accuracy_<scenario>.csv; a scenario
// is named after its scene: two_puma_load ... two_wheel_vehicle, plus two_wheel_vehicle_turn)
// Only the public library API (service/...) is used.
#include <time.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <functional>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Dense>

#include "service/algorithms/crba.h"
#include "service/algorithms/kinematics.h"
#include "service/dynamics/constrained_dynamics.h"
#include "service/dynamics/integrators.h"
#include "service/scene/scene.h"

using namespace coopdyn;

namespace {

constexpr double kG = 9.81;
constexpr double kSampleDt = 4e-3;  // s, common sample times (a multiple of every swept step)
const double kSteps[] = {0.125e-3, 0.25e-3, 0.5e-3, 1e-3, 2e-3, 4e-3};  // s
constexpr double kRefDivisor = 64.0;
constexpr double kMinCpu = 0.05;  // s, repeat a run until its step loop took this long

double cpu_now() {
  timespec ts;
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
  return ts.tv_sec + 1e-9 * ts.tv_nsec;
}

std::string scene_file(const std::string& name) {
  return std::string(COOPDYN_SOURCE_DIR) + "/config/scenes/" + name + ".yaml";
}

// Potential energy of gravity -sum m_i g . c_i plus kinetic energy 1/2 v^T M v (armatures
// included), J. Same as tests/support/test_util.h energy(), with the caller's Data.
double energy(const Model& m, Data& d, const Eigen::VectorXd& q, const Eigen::VectorXd& v) {
  forward_kinematics(m, d, q, v);
  crba(m, d);
  double V = 0;
  for (int i = 0; i < m.nbodies(); ++i) {
    const Inertia& I = m.bodies[i].inertia;
    V -= I.m * m.gravity_W.dot(d.X_WB[i].R * I.c + d.X_WB[i].p);
  }
  return 0.5 * v.dot(d.M * v) + V;
}

// The constraint forces a run is compared on: the wrench [moment; force] of every weld and rolling
// spec (by name, so forms with and without lock rows line up), then the pseudo-joint stresses.
struct ForceLayout {
  std::vector<std::string> names;  // spec names (6 entries each), then "stress:<v_name>"
  std::vector<int> spec_of;        // per name: spec index in the system, -1 for a stress
};
ForceLayout force_layout(const System& sys) {
  ForceLayout L;
  for (size_t s = 0; s < sys.constraints.specs.size(); ++s) {
    if (sys.constraints.specs[s].kind == ConstraintKind::kLock) continue;
    L.names.push_back(sys.constraints.specs[s].name);
    L.spec_of.push_back(static_cast<int>(s));
  }
  for (int d : sys.model.pseudo_dofs) {
    L.names.push_back("stress:" + sys.model.v_names[d]);
    L.spec_of.push_back(-1);
  }
  return L;
}
// Flattened forces in the order of `ref` (names looked up in sys).
Eigen::VectorXd forces(const System& sys, const Workspace& ws, const ForceLayout& ref) {
  std::vector<double> out;
  int stress_i = 0;
  for (const std::string& n : ref.names) {
    if (n.rfind("stress:", 0) == 0) {
      out.push_back(stress_i < ws.stress.size() ? ws.stress[stress_i] : 0.0);
      ++stress_i;
      continue;
    }
    int s = -1;
    for (size_t k = 0; k < sys.constraints.specs.size(); ++k)
      if (sys.constraints.specs[k].name == n) s = static_cast<int>(k);
    const Vec6 w = s >= 0 ? tip_wrench(sys, ws, s) : Vec6::Zero();
    for (int k = 0; k < 6; ++k) out.push_back(w[k]);
  }
  return Eigen::Map<Eigen::VectorXd>(out.data(), static_cast<Eigen::Index>(out.size()));
}

struct Sample {
  Eigen::VectorXd q, v, f;  // state, flattened forces (ForceLayout order)
};
bool is_stress(const std::string& n) { return n.rfind("stress:", 0) == 0; }

// Initial state and answer of a scene's scenario.
struct Scenario {
  std::string scene, kind, description;
  std::string scene_name;  // the scene file (scene, unless a variant scenario of it)
  double T = 1.0;  // s simulated
  bool analytic = false;
  // torque profile, piecewise constant on the 4 ms sample intervals (empty: zero torque)
  std::function<void(const System&, double, Eigen::VectorXd&)> torque;
  double passive_from = 0;  // s, energy is conserved from here on (torque off)
  // analytic answer at time t (state and forces in the layout of the system it is given)
  std::function<Sample(const System&, double)> exact;
  // initial state for a system (a formulation of the scene)
  std::function<void(const System&, Eigen::VectorXd&, Eigen::VectorXd&)> init;
};

// ---------- scenarios ----------

void init_at_rest(const System& sys, Eigen::VectorXd& q, Eigen::VectorXd& v) {
  q = sys.q0;
  v = Eigen::VectorXd::Zero(sys.model.nv());
}

// planar arms: arm 1's joints at 0.5 rad/s, every other velocity from G v = 0 (the closed chain has
// 3 DOF, so arm 1's three rates fix the motion; the same motion in every formulation)
void init_planar(const System& sys, Eigen::VectorXd& q, Eigen::VectorXd& v) {
  q = sys.q0;
  Workspace ws(sys);
  evaluate(sys, ws, q, Eigen::VectorXd::Zero(sys.model.nv()), Eigen::VectorXd::Zero(sys.model.nv()));
  const Eigen::MatrixXd& G = ws.cd.G;
  std::vector<int> sel;
  for (int i = 0; i < sys.model.nv(); ++i)
    if (sys.model.v_names[i].rfind("arm1.", 0) == 0 && sys.model.v_names[i].find("base") == std::string::npos)
      sel.push_back(i);
  Eigen::MatrixXd A = Eigen::MatrixXd::Zero(G.rows() + static_cast<Eigen::Index>(sel.size()), sys.model.nv());
  Eigen::VectorXd b = Eigen::VectorXd::Zero(A.rows());
  A.topRows(G.rows()) = G;
  for (size_t k = 0; k < sel.size(); ++k) {
    A(G.rows() + static_cast<Eigen::Index>(k), sel[k]) = 1.0;
    b[G.rows() + static_cast<Eigen::Index>(k)] = 0.5;
  }
  v = A.completeOrthogonalDecomposition().solve(b);
}

// the unicycle leaning by phi on a circle of contact radius R (tests/dynamics/wheel_test.cc,
// RollingDiskSteadyCircleMatchesTheClassicalRelation)
struct Disk {
  double r = 0.25, mass = 3.0, phi = 0.3, R = 2.0, Om = 0, sigma = 0, rho = 0;
  Mat3 Rot;
  Vec3 c0, w0, vc0, P;
  Disk() {
    Om = std::sqrt(4 * kG * std::tan(phi) / (6 * R - 5 * r * std::sin(phi)));
    sigma = Om * R / r;
    rho = R - r * std::sin(phi);
    Rot = Eigen::AngleAxisd(-phi, Vec3::UnitX()).toRotationMatrix();  // lean left
    c0 = Rot * Vec3(0, 0, r);
    w0 = Om * Vec3::UnitZ() + sigma * (Rot * Vec3::UnitY());
    vc0 = w0.cross(c0);  // the contact point (origin) is at rest
    P = Vec3(0, R, 0);   // centre of the turn
  }
  // the whole state turns about the vertical through P at Omega; the wheel spins by sigma t
  Sample at(const System& sys, double t) const {
    const Mat3 Rz = Eigen::AngleAxisd(Om * t, Vec3::UnitZ()).toRotationMatrix();
    const Mat3 R_WB = Rz * Rot * Eigen::AngleAxisd(sigma * t, Vec3::UnitY()).toRotationMatrix();
    Sample s;
    s.q = sys.q0;
    s.q.segment<3>(0) = P + Rz * (c0 - P);
    const Quat qu(R_WB);
    s.q.segment<4>(3) << qu.w(), qu.x(), qu.y(), qu.z();
    s.v.resize(6);
    s.v.head<3>() = R_WB.transpose() * (Rz * w0);
    s.v.tail<3>() = R_WB.transpose() * (Rz * vc0);
    s.f.setZero(6);
    s.f[4] = mass * Om * Om * rho;
    s.f[5] = mass * kG;
    return s;
  }
};

// the vehicle in a steady left turn (tests/dynamics/wheel_test.cc, SteadyTurnLateralForcesAreCentripetal):
// axle midpoint on a circle of radius R about (0, R, 0) at speed V, wheels rolling
struct Turn {
  double V = 1.5, R = 2.0, w = 0.25, r = 0.25, I3 = 0.09375;
  Sample at(const System& sys, double t) const {
    const Model& m = sys.model;
    const double Om = V / R;
    double M = 0;
    for (const Body& b : m.bodies) M += b.inertia.m;
    const Mat3 Rz = Eigen::AngleAxisd(Om * t, Vec3::UnitZ()).toRotationMatrix();
    const Vec3 P(0, R, 0);
    Sample s;
    s.q = sys.q0;
    s.q.segment<3>(0) = P + Rz * (sys.q0.segment<3>(0) - P);
    const Quat qu(Rz);
    s.q.segment<4>(3) << qu.w(), qu.x(), qu.y(), qu.z();
    s.v = Eigen::VectorXd::Zero(m.nv());
    s.v.segment<6>(0) << 0, 0, Om, V, 0, 0;  // rod twist in the rod frame
    double spin_sum = 0;
    for (const char* j : {"left_spin", "right_spin"}) {
      const int b = m.joint_index(j);
      const double rate = Om * (R + (std::string(j) == "left_spin" ? -w : w)) / r;
      s.v[m.bodies[b].joint.idx_v] = rate;
      s.q[m.bodies[b].joint.idx_q] = sys.q0[m.bodies[b].joint.idx_q] + rate * t;
      spin_sum += rate;
    }
    // sum f_y = M V^2 / R split equally (min norm); w (N_L - N_R) + r sum f_y = -I3 spin_sum Om
    const double fy = M * V * V / R / 2, dN = (-I3 * spin_sum * Om - r * 2 * fy) / w;
    s.f.setZero(12);  // left then right: [moment; force]
    s.f[4] = fy;
    s.f[5] = (M * kG + dN) / 2;
    s.f[10] = fy;
    s.f[11] = (M * kG - dN) / 2;
    return s;
  }
};

std::vector<Scenario> scenarios() {
  std::vector<Scenario> out;
  for (const char* s : {"two_puma_load", "two_5dof_arms_load"}) {
    Scenario c;
    c.scene = s;
    c.kind = "passive_fall";
    c.description = "passive fall from rest, zero torque";
    c.T = 0.5;
    c.init = init_at_rest;
    out.push_back(c);
  }
  {
    Scenario c;
    c.scene = "planar_arms_load";
    c.kind = "passive_motion";
    c.description = "passive in-plane motion, arm 1 joints start at 0.5 rad/s, zero torque";
    c.T = 0.5;
    c.init = init_planar;
    out.push_back(c);
  }
  {
    Scenario c;
    c.scene = "four_bar";
    c.kind = "passive_swing";
    c.description = "passive swing from rest under gravity, zero torque";
    c.T = 1.0;
    c.init = init_at_rest;
    out.push_back(c);
  }
  {
    Scenario c;
    c.scene = "unicycle";
    c.kind = "steady_precession";
    c.description = "steady precession, phi 0.3 rad, contact circle R 2 m (analytic)";
    c.T = 1.0;
    c.analytic = true;
    c.exact = [](const System& sys, double t) { return Disk().at(sys, t); };
    c.init = [](const System& sys, Eigen::VectorXd& q, Eigen::VectorXd& v) {
      const Sample s = Disk().at(sys, 0.0);
      q = s.q;
      v = s.v;
    };
    out.push_back(c);
  }
  {
    Scenario c;
    c.scene = "two_wheel_vehicle";
    c.kind = "paper_pulse";
    c.description = "the paper's experiment: 1 N*m on the left wheel 0-0.5 s, then none, from rest";
    c.T = 1.0;
    c.init = init_at_rest;
    c.torque = [](const System& sys, double t, Eigen::VectorXd& tau) {
      tau.setZero();
      if (t < 0.5 - 1e-9) tau[sys.model.bodies[sys.model.joint_index("left_spin")].joint.idx_v] = 1.0;
    };
    c.passive_from = 0.5;
    out.push_back(c);
  }
  {
    Scenario c;
    c.scene = "two_wheel_vehicle_turn";
    c.scene_name = "two_wheel_vehicle";
    c.kind = "steady_turn";
    c.description = "steady turn, R 2 m, V 1.5 m/s, zero torque (analytic)";
    c.T = 1.0;
    c.analytic = true;
    c.exact = [](const System& sys, double t) { return Turn().at(sys, t); };
    c.init = [](const System& sys, Eigen::VectorXd& q, Eigen::VectorXd& v) {
      const Sample s = Turn().at(sys, 0.0);
      q = s.q;
      v = s.v;
    };
    out.push_back(c);
  }
  return out;
}

// ---------- one run ----------

struct RunResult {
  std::vector<Sample> samples;  // at t = k * kSampleDt, k = 0..n (first repetition)
  double cpu_per_sim_s = 0;     // CPU s per simulated s
  int reps = 0;
  long steps = 0;               // per repetition
  bool error = false;
  std::string error_reason;
  double error_time = 0;
  double drift = 0;         // max |constraint position error| over the samples, m or rad
  double energy_drift = 0;  // max |E(t) - E(0)| over the samples, J
  double energy0 = 0;
};

RunResult run(const System& sys, const Scenario& sc, const ForceLayout& layout, Integrator integ, double dt,
              bool time_it) {
  RunResult r;
  const long per_sample = std::lround(kSampleDt / dt);
  const long nsamples = std::lround(sc.T / kSampleDt);
  Eigen::VectorXd tau = Eigen::VectorXd::Zero(sys.model.nv());
  Stepper st(sys);
  Workspace ws(sys);
  ws.position_errors = true;  // the drift is read
  Data d(sys.model);
  double cpu = 0, sim = 0;
  Eigen::VectorXd q, v;
  for (int rep = 0;; ++rep) {
    sc.init(sys, q, v);
    const bool record = rep == 0;
    auto record_sample = [&](double t) {
      if (sc.torque) sc.torque(sys, t, tau);  // the forces at t under the torque applied from t
      evaluate(sys, ws, q, v, tau);
      Sample s{q, v, forces(sys, ws, layout)};
      r.samples.push_back(s);
      r.drift = std::max(r.drift, ws.cd.err.size() ? ws.cd.err.cwiseAbs().maxCoeff() : 0.0);
      const double E = energy(sys.model, d, q, v);
      if (std::abs(t - sc.passive_from) < 1e-9) r.energy0 = E;
      if (t >= sc.passive_from - 1e-9) r.energy_drift = std::max(r.energy_drift, std::abs(E - r.energy0));
    };
    if (record) record_sample(0.0);
    long k = 0;
    for (; k < nsamples && !r.error; ++k) {
      if (sc.torque) sc.torque(sys, k * kSampleDt, tau);
      const double t0 = cpu_now();
      long i = 0;
      for (; i < per_sample; ++i) {
        const Diagnostics& dg = step(sys, st, integ, dt, tau, q, v);
        if (dg.status == Status::kError) {
          r.error = true;
          r.error_reason = reason_text(dg.reason);
          r.error_time = (k * per_sample + i) * dt;
          break;
        }
      }
      cpu += cpu_now() - t0;
      sim += i * dt;
      if (record && !r.error) record_sample((k + 1) * kSampleDt);
    }
    if (record) r.steps = nsamples * per_sample;
    r.reps = rep + 1;
    if (r.error || !time_it || cpu >= kMinCpu) break;
  }
  r.cpu_per_sim_s = sim > 0 ? cpu / sim : 0;
  return r;
}

struct Errors {
  double q = 0, v = 0, state = 0, f = 0, f_rel = 0, stress = 0;
};
// max over common samples of the inf-norms; quaternion signs aligned to the run
Errors compare(const System& sys, const ForceLayout& L, const std::vector<Sample>& run, const std::vector<Sample>& ref) {
  Errors e;
  double fmax = 0;
  const size_t n = std::min(run.size(), ref.size());
  for (size_t k = 0; k < n; ++k) {
    Eigen::VectorXd qr = ref[k].q;
    for (const Body& b : sys.model.bodies)
      if (b.joint.type == JointType::kFloating) {
        auto a = run[k].q.segment<4>(b.joint.idx_q + 3);
        auto c = qr.segment<4>(b.joint.idx_q + 3);
        if (a.dot(c) < 0) c = -c;
      }
    e.q = std::max(e.q, (run[k].q - qr).cwiseAbs().maxCoeff());
    e.v = std::max(e.v, (run[k].v - ref[k].v).cwiseAbs().maxCoeff());
    // tip wrenches (6 entries per spec), then stresses (1 entry each)
    Eigen::Index i = 0;
    for (const std::string& n : L.names) {
      const Eigen::Index len = is_stress(n) ? 1 : 6;
      const double d = (run[k].f.segment(i, len) - ref[k].f.segment(i, len)).cwiseAbs().maxCoeff();
      if (is_stress(n)) {
        e.stress = std::max(e.stress, d);
      } else {
        e.f = std::max(e.f, d);
        fmax = std::max(fmax, ref[k].f.segment(i, len).cwiseAbs().maxCoeff());
      }
      i += len;
    }
  }
  e.state = std::max(e.q, e.v);
  e.f_rel = fmax > 0 ? e.f / fmax : 0;
  return e;
}

std::string fmt(double x) {
  char b[32];
  std::snprintf(b, sizeof b, "%.6g", x);
  return b;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) {
    std::fprintf(stderr, "usage: %s OUT_DIR [SCENE...]\n", argv[0]);
    return 2;
  }
  const std::string out_dir = argv[1];
  std::vector<std::string> only(argv + 2, argv + argc);
  const Integrator integrators[] = {Integrator::kSemiImplicitEuler, Integrator::kRk4, Integrator::kImplicitEuler};

  for (const Scenario& sc : scenarios()) {
    const bool variant = !sc.scene_name.empty();
    if (!only.empty() && std::find(only.begin(), only.end(), sc.scene) == only.end()) continue;
    const std::string scene_name = variant ? sc.scene_name : sc.scene;
    const double wall0 = cpu_now();
    std::ofstream csv(out_dir + "/accuracy_" + sc.scene + ".csv");
    csv << "scene,scenario,duration_s,formulation,integrator,dt_ms,role,reference,status,error_reason,error_time_s,"
           "steps,reps,cpu_s_per_sim_s,us_per_step,q_err,v_err,state_err,wrench_err,wrench_rel_err,stress_err,constraint_drift,"
           "energy_drift_J,energy0_J\n";
    auto row = [&](const std::string& form, const std::string& integ, double dt, const std::string& role,
                   const std::string& refname, const RunResult& r, const Errors& e, bool timed) {
      csv << sc.scene << "," << sc.kind << "," << sc.T << "," << form << "," << integ << "," << fmt(dt * 1e3) << ","
          << role << "," << refname << "," << (r.error ? "error" : "ok") << "," << r.error_reason << ","
          << (r.error ? fmt(r.error_time) : "") << "," << r.steps << "," << r.reps << ",";
      if (timed)
        csv << fmt(r.cpu_per_sim_s) << "," << fmt(r.cpu_per_sim_s * dt * 1e6);
      else
        csv << ",";
      if (r.error)
        csv << ",,,,,,,,";
      else
        csv << "," << fmt(e.q) << "," << fmt(e.v) << "," << fmt(e.state) << "," << fmt(e.f) << "," << fmt(e.f_rel) << "," << fmt(e.stress) << ","
            << fmt(r.drift) << "," << fmt(r.energy_drift);
      csv << "," << fmt(r.energy0) << "\n";
      csv.flush();
    };

    // formulations: mobile_platform, pseudo_joint (four_bar only), classic, svd; skip what the
    // scene cannot take and say why
    struct Form {
      std::string name;
      std::optional<System> sys;
      std::string skip;
    };
    std::vector<Form> forms;
    for (Formulation f : {Formulation::kMobilePlatform, Formulation::kClassic, Formulation::kPseudoJointSchur,
                          Formulation::kSvdBaseline}) {
      Form fm;
      fm.name = formulation_name(f);
      try {
        SceneOverrides ov;
        ov.formulation = f;
        System s = load_scene(scene_file(scene_name), ov);
        if (f == Formulation::kPseudoJointSchur && s.model.pseudo_dofs.empty())
          fm.skip = "no pseudo-joints in the scene";
        else
          fm.sys = std::move(s);
      } catch (const std::exception& ex) {
        fm.skip = ex.what();
        const std::string root = std::string(COOPDYN_SOURCE_DIR) + "/";
        if (fm.skip.rfind(root, 0) == 0) fm.skip = fm.skip.substr(root.size());  // repository-relative
      }
      forms.push_back(std::move(fm));
    }
    // a scene built from explicit bodies has no load to re-root: mobile_platform and classic are
    // one computation; keep the scene's own label
    if (forms[0].sys && forms[1].sys && forms[0].sys->model.nv() == forms[1].sys->model.nv() &&
        forms[0].sys->model.v_names == forms[1].sys->model.v_names) {
      SceneOverrides none;
      const System dflt = load_scene(scene_file(scene_name), none);
      const int drop = dflt.options.formulation == Formulation::kClassic ? 0 : 1;
      forms[drop].sys.reset();
      forms[drop].skip = std::string("same computation as ") + forms[1 - drop].name + " (no load to re-root)";
    }
    for (const Form& fm : forms)
      if (!fm.sys) {
        std::printf("[%s] %s skipped: %s\n", sc.scene.c_str(), fm.name.c_str(), fm.skip.c_str());
        std::string reason = fm.skip;
        for (char& ch : reason)
          if (ch == ',' || ch == '\n') ch = ';';
        csv << sc.scene << "," << sc.kind << "," << sc.T << "," << fm.name << ",,,skipped,," << "skipped," << reason
            << ",,,,,,,,,,,,,,\n";
      }

    // references: one per coordinate layout (analytic scenarios need none)
    std::map<std::string, std::vector<Sample>> refs;  // by layout key
    std::map<std::string, std::string> ref_name;
    auto layout_key = [](const System& s) {
      std::string k;
      for (const std::string& n : s.model.v_names) k += n + ";";
      return k;
    };
    for (const Form& fm : forms) {
      if (!fm.sys || sc.analytic) continue;
      const std::string key = layout_key(*fm.sys);
      if (refs.count(key)) continue;
      const ForceLayout L = force_layout(*fm.sys);
      const double h = kSteps[0] / kRefDivisor;
      const double c0 = cpu_now();
      RunResult ref = run(*fm.sys, sc, L, Integrator::kRk4, h, false);
      RunResult ref2 = run(*fm.sys, sc, L, Integrator::kRk4, 2 * h, false);
      const std::string rn = std::string("rk4@") + fmt(h * 1e3) + "ms/" + fm.name;
      const Errors e2 = compare(*fm.sys, L, ref2.samples, ref.samples);
      row(fm.name, "rk4", h, "reference", rn, ref, Errors{}, false);
      row(fm.name, "rk4", 2 * h, "reference_2x", rn, ref2, e2, false);
      std::printf("[%s] reference %s: %.1f s CPU; 2x step vs reference: state %.3g, wrench %.3g (%.2g rel)%s\n",
                  sc.scene.c_str(), rn.c_str(), cpu_now() - c0, e2.state, e2.f, e2.f_rel, ref.error ? " ERROR" : "");
      refs[key] = ref.samples;
      ref_name[key] = rn;
    }

    for (const Form& fm : forms) {
      if (!fm.sys) continue;
      const System& sys = *fm.sys;
      // the reference (or the exact answer) in this system's force layout
      const ForceLayout L = force_layout(sys);  // by name: the same for every form of a tree
      std::vector<Sample> ref;
      std::string rn;
      if (sc.analytic) {
        for (long k = 0; k <= std::lround(sc.T / kSampleDt); ++k) ref.push_back(sc.exact(sys, k * kSampleDt));
        rn = "analytic";
      } else {
        const std::string key = layout_key(sys);
        ref = refs[key];
        rn = ref_name[key];
      }
      for (Integrator integ : integrators) {
        for (double dt : kSteps) {
          const RunResult r = run(sys, sc, L, integ, dt, true);
          const Errors e = compare(sys, L, r.samples, ref);
          row(fm.name, integrator_name(integ), dt, "sweep", rn, r, e, true);
          std::printf("[%s] %-15s %-19s %6.3f ms: %9.4f s/s  state %9.3g  wrench %9.3g  stress %9.3g  drift %9.3g  energy %9.3g%s\n",
                      sc.scene.c_str(), fm.name.c_str(), integrator_name(integ), dt * 1e3, r.cpu_per_sim_s, e.state, e.f, e.stress,
                      r.drift, r.energy_drift, r.error ? (" ERROR " + r.error_reason).c_str() : "");
          std::fflush(stdout);
        }
      }
    }
    std::printf("[%s] done in %.1f s CPU\n", sc.scene.c_str(), cpu_now() - wall0);
  }
  return 0;
}
