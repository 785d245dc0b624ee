// coopdyn against Pinocchio's constraintDynamics and pv on the arms-on-one-load scenes
// (bench/scenes/pumas_N.yaml: N PUMA 560 arms holding one 5 kg box), in one process.
//
// The Pinocchio models are converted from coopdyn's own Model (same bodies, joint axes, placements,
// inertias, armatures, gravity), in two trees:
//   "mp"      coopdyn's default mobile-platform tree: the box is the floating root, every arm hangs
//             from it (reversed joints), and each arm's base frame is welded to the world: one 6D
//             RigidConstraintModel per arm, joint2 = universe (the form pv accepts);
//   "classic" coopdyn's classic tree (scene loaded with formulation classic): arms rooted at the
//             world, the box a free-flyer, each arm's tip ("armK.ee") welded to the grasp frame on
//             the box ("load.armK"): one 6D constraint per arm between two moving joints (what the
//             issue describes; pv refuses loops between two moving joints: "Internal loops are not
//             yet permitted in PV").
// Coordinates: coopdyn floating q = [p; qw qx qy qz], v = [w_B; v_B] (body frame); Pinocchio
// free-flyer q = [p; qx qy qz qw], v = [v_B; w_B] (LOCAL): the same quantities reordered. Revolute
// joints about -z (the reversed DH joints) become JointModelRZ with the joint frame turned by pi
// about x (the fastest joint Pinocchio has), the body frame mapped back for children and inertias.
//
//   pin_arms [REPETITIONS=21] [SUFFIX]   (COOPDYN_SOURCE_DIR: where bench/scenes is)
// SUFFIX picks bench/scenes/pumas_N<SUFFIX>.yaml: none (with armature) or _no_armature (arms without
// joint armature: coopdyn's nominal base links, Pinocchio's same inertias).
#include <time.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <random>
#include <string>
#include <vector>

#include "pinocchio/algorithm/constrained-dynamics.hpp"
#include "pinocchio/algorithm/contact-info.hpp"
#include "pinocchio/algorithm/proximal.hpp"
#include "pinocchio/algorithm/pv.hpp"
#include "pinocchio/multibody/data.hpp"
#include "pinocchio/multibody/model.hpp"

#include <Eigen/SVD>

#include "service/dynamics/constrained_dynamics.h"
#include "service/dynamics/wrenches.h"
#include "service/scene/scene.h"

namespace pin = pinocchio;
using coopdyn::System;

namespace {

double cpu_ns() {
  timespec ts;
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return static_cast<double>(ts.tv_sec) * 1e9 + static_cast<double>(ts.tv_nsec);
}
double median(std::vector<double> x) {
  std::sort(x.begin(), x.end());
  return x[x.size() / 2];
}
pin::SE3 se3(const coopdyn::Transform& X) { return pin::SE3(X.R, X.p); }

// A coopdyn Model as a Pinocchio Model, with the index maps between their coordinates.
struct Converted {
  pin::Model model;
  std::vector<int> body_joint;      // coopdyn body -> Pinocchio joint carrying it
  std::vector<pin::SE3> X_jb;       // coopdyn body frame in that joint's frame
  std::vector<int> q_map, v_map;    // coopdyn coordinate i -> Pinocchio coordinate
  pin::context::RigidConstraintModelVector cons;  // one per coopdyn weld spec, same order
};

Converted convert(const System& sys) {
  const coopdyn::Model& m = sys.model;
  Converted c;
  pin::Model& pm = c.model;
  pm.gravity = pin::Motion(m.gravity_W, Eigen::Vector3d::Zero());
  const int nb = m.nbodies();
  c.body_joint.assign(nb, 0);
  c.X_jb.assign(nb, pin::SE3::Identity());
  c.q_map.assign(m.nq(), -1);
  c.v_map.assign(m.nv(), -1);
  std::vector<std::pair<int, double>> armature;  // (pin idx_v, value)
  for (int b = 0; b < nb; ++b) {
    const coopdyn::Body& B = m.bodies[b];
    const int pj = B.parent >= 0 ? c.body_joint[B.parent] : 0;
    const pin::SE3 X_pj_P = B.parent >= 0 ? c.X_jb[B.parent] : pin::SE3::Identity();
    const pin::SE3 X_pj_J = X_pj_P * se3(B.X_PJ);  // coopdyn joint frame J in the parent Pinocchio joint
    const coopdyn::Joint& J = B.joint;
    if (J.type == coopdyn::JointType::kFixed) {
      c.body_joint[b] = pj;
      c.X_jb[b] = X_pj_J;
    } else {
      pin::JointIndex jid = 0;
      pin::SE3 flip = pin::SE3::Identity();  // X_J,J' (J' the Pinocchio joint frame)
      const std::string name = J.name + "#" + std::to_string(b);
      if (J.type == coopdyn::JointType::kFloating) {
        jid = pm.addJoint(pj, pin::JointModelFreeFlyer(), X_pj_J, name);
        const int iq = pm.idx_qs[jid], iv = pm.idx_vs[jid];
        for (int k = 0; k < 3; ++k) c.q_map[J.idx_q + k] = iq + k;
        c.q_map[J.idx_q + 3] = iq + 6;  // qw
        for (int k = 0; k < 3; ++k) c.q_map[J.idx_q + 4 + k] = iq + 3 + k;
        for (int k = 0; k < 3; ++k) c.v_map[J.idx_v + k] = iv + 3 + k;  // w
        for (int k = 0; k < 3; ++k) c.v_map[J.idx_v + 3 + k] = iv + k;  // v
      } else if (J.type == coopdyn::JointType::kRevolute || J.type == coopdyn::JointType::kPrismatic) {
        int ax = -1;
        double sgn = 1.0;
        for (int k = 0; k < 3; ++k)  // exactly +-e_k
          if (std::abs(J.axis[k]) == 1.0 && J.axis[(k + 1) % 3] == 0.0 && J.axis[(k + 2) % 3] == 0.0) ax = k, sgn = J.axis[k] > 0 ? 1 : -1;
        const bool rev = J.type == coopdyn::JointType::kRevolute;
        if (ax >= 0 && sgn < 0)  // turn the joint frame by pi about the next axis: ax -> -ax
          flip.rotation() = Eigen::AngleAxisd(M_PI, Eigen::Vector3d::Unit((ax + 1) % 3)).toRotationMatrix();
        const pin::SE3 plc = X_pj_J * flip;
        if (ax == 0) jid = rev ? pm.addJoint(pj, pin::JointModelRX(), plc, name) : pm.addJoint(pj, pin::JointModelPX(), plc, name);
        else if (ax == 1) jid = rev ? pm.addJoint(pj, pin::JointModelRY(), plc, name) : pm.addJoint(pj, pin::JointModelPY(), plc, name);
        else if (ax == 2) jid = rev ? pm.addJoint(pj, pin::JointModelRZ(), plc, name) : pm.addJoint(pj, pin::JointModelPZ(), plc, name);
        else
          jid = rev ? pm.addJoint(pj, pin::JointModelRevoluteUnaligned(J.axis), plc, name)
                    : pm.addJoint(pj, pin::JointModelPrismaticUnaligned(J.axis), plc, name);
        c.q_map[J.idx_q] = pm.idx_qs[jid];
        c.v_map[J.idx_v] = pm.idx_vs[jid];
        armature.push_back({pm.idx_vs[jid], J.armature});
      } else {
        std::fprintf(stderr, "joint type of %s not converted\n", J.name.c_str());
        std::exit(2);
      }
      c.body_joint[b] = static_cast<int>(jid);
      c.X_jb[b] = flip.inverse();  // coopdyn body B = J' Rot(q) flip^-1
    }
    const coopdyn::Inertia& I = B.inertia;
    if (I.m != 0.0 || !I.Ic.isZero(0.0))
      pm.appendBodyToJoint(c.body_joint[b], pin::Inertia(I.m, I.c, pin::Symmetric3(I.Ic)), c.X_jb[b]);
  }
  for (auto& a : armature) pm.armature[a.first] = a.second;
  // constraints: coopdyn welds (all six axes) as CONTACT_6D in the LOCAL frame of the tip A
  auto frame_in_joint = [&](int f, int* jid) {
    const coopdyn::Frame& F = m.frames[f];
    if (F.body < 0) {
      *jid = 0;
      return se3(F.X_BF);
    }
    *jid = c.body_joint[F.body];
    return pin::SE3(c.X_jb[F.body] * se3(F.X_BF));
  };
  for (const coopdyn::ConstraintSpec& s : sys.constraints.specs) {
    if (s.kind != coopdyn::ConstraintKind::kWeld) {
      std::fprintf(stderr, "constraint %s is not a weld\n", s.name.c_str());
      std::exit(2);
    }
    int j1 = 0, j2 = 0;
    const pin::SE3 P1 = frame_in_joint(s.frame_a, &j1);
    const pin::SE3 P2 = s.frame_b >= 0 ? frame_in_joint(s.frame_b, &j2) : se3(s.X_WA_target);
    pin::RigidConstraintModel cm(pin::CONTACT_6D, pm, j1, P1, j2, P2, pin::LOCAL);
    cm.name = s.name;
    c.cons.push_back(cm);
  }
  return c;
}

Eigen::VectorXd to_pin_q(const Converted& c, const Eigen::VectorXd& q) {
  Eigen::VectorXd r(c.model.nq);
  for (int i = 0; i < q.size(); ++i) r[c.q_map[i]] = q[i];
  return r;
}
Eigen::VectorXd to_pin_v(const Converted& c, const Eigen::VectorXd& v) {
  Eigen::VectorXd r(c.model.nv);
  for (int i = 0; i < v.size(); ++i) r[c.v_map[i]] = v[i];
  return r;
}
Eigen::VectorXd from_pin_v(const Converted& c, const Eigen::VectorXd& v) {
  Eigen::VectorXd r(c.model.nv);
  for (int i = 0; i < v.size(); ++i) r[i] = v[c.v_map[i]];
  return r;
}
// Pinocchio's per-constraint [force; moment] -> coopdyn's [moment; force]
Eigen::VectorXd lambda_to_coopdyn(const Eigen::VectorXd& l) {
  Eigen::VectorXd r(l.size());
  for (int k = 0; k + 6 <= l.size(); k += 6) {
    r.segment<3>(k) = l.segment<3>(k + 3);
    r.segment<3>(k + 3) = l.segment<3>(k);
  }
  return r;
}

// One formulation of one scene: coopdyn's System and its Pinocchio twin.
struct Twin {
  System sys;
  Converted cv;
  pin::Data data_cd, data_pv;
  pin::context::RigidConstraintDataVector cdat_cd, cdat_pv;
  bool pv_ok = false;
  explicit Twin(System s) : sys(std::move(s)), cv(convert(sys)), data_cd(cv.model), data_pv(cv.model) {
    for (auto& cm : cv.cons) {
      cdat_cd.push_back(pin::RigidConstraintData(cm));
      cdat_pv.push_back(pin::RigidConstraintData(cm));
    }
    pin::initConstraintDynamics(cv.model, data_cd, cv.cons);
    pv_ok = std::all_of(cv.cons.begin(), cv.cons.end(), [](const pin::RigidConstraintModel& cm) { return cm.joint2_id == 0; });
    if (pv_ok) pin::initPvSolver(cv.model, data_pv, cv.cons);
  }
};

// exact for a full-rank rigid problem: no proximal regularization, one solve
pin::ProximalSettings exact_settings() { return pin::ProximalSettings(1e-12, 0.0, 1); }

struct Errs {
  double a_abs = 0, a_ref = 0, l_abs = 0, l_ref = 0, l_abs_neg = 0;
  void add(const Eigen::VectorXd& a, const Eigen::VectorXd& a_ref_, const Eigen::VectorXd& l, const Eigen::VectorXd& l_ref_) {
    a_abs = std::max(a_abs, (a - a_ref_).cwiseAbs().maxCoeff());
    a_ref = std::max(a_ref, a_ref_.cwiseAbs().maxCoeff());
    l_abs = std::max(l_abs, (l - l_ref_).cwiseAbs().maxCoeff());
    l_abs_neg = std::max(l_abs_neg, (l + l_ref_).cwiseAbs().maxCoeff());
    l_ref = std::max(l_ref, l_ref_.cwiseAbs().maxCoeff());
  }
};

struct Case {
  int arms;
  Twin* mp;
  Twin* cl;
  std::vector<Eigen::VectorXd> q, v;  // coopdyn mobile-platform coordinates (as arms_scaling)
  std::vector<Eigen::VectorXd> q_mp, v_mp, q_cl, v_cl;  // Pinocchio coordinates
  std::vector<Eigen::VectorXd> qc_cl, vc_cl;  // coopdyn classic coordinates
  Eigen::VectorXd tau, tau_mp, tau_cl;
};

// permutation from coordinates of model a to model b by name
std::vector<int> name_map(const std::vector<std::string>& a, const std::vector<std::string>& b) {
  std::vector<int> r(a.size(), -1);
  for (size_t i = 0; i < a.size(); ++i) {
    auto it = std::find(b.begin(), b.end(), a[i]);
    if (it == b.end()) {
      std::fprintf(stderr, "coordinate %s has no twin\n", a[i].c_str());
      std::exit(2);
    }
    r[i] = static_cast<int>(it - b.begin());
  }
  return r;
}
Eigen::VectorXd permute(const Eigen::VectorXd& x, const std::vector<int>& to) {
  Eigen::VectorXd r(x.size());
  for (int i = 0; i < x.size(); ++i) r[to[i]] = x[i];
  return r;
}

}  // namespace

int main(int argc, char** argv) {
  const int reps = argc > 1 ? std::max(3, std::atoi(argv[1])) : 21;
  const std::string suffix = argc > 2 ? argv[2] : "";
  const int arms[] = {1, 2, 3, 4, 6, 8};
  std::vector<Case> cases;
  std::printf("Pinocchio %s (header-only), Eigen %d.%d.%d, coopdyn from %s\n", PINOCCHIO_VERSION, EIGEN_WORLD_VERSION,
              EIGEN_MAJOR_VERSION, EIGEN_MINOR_VERSION, COOPDYN_SOURCE_DIR);
  std::printf("\n## Accuracy (max over 16 states; relative = max abs diff / max abs of coopdyn's value)\n\n");
  std::printf("| arms | tree | states | tau | nv | rows | vdot: pinocchio cD vs coopdyn | pv vs coopdyn | lambda: cD vs coopdyn (sign) | pv vs coopdyn | ee wrench vs coopdyn's `armK.ee` |\n");
  std::printf("|---|---|---|---|---|---|---|---|---|---|---|\n");
  for (int n : arms) {
    const std::string path = std::string(COOPDYN_SOURCE_DIR) + "/bench/scenes/pumas_" + std::to_string(n) + suffix + ".yaml";
    Case c;
    c.arms = n;
    c.mp = new Twin(coopdyn::load_scene(path));
    coopdyn::SceneOverrides ov;
    ov.formulation = coopdyn::Formulation::kClassic;
    c.cl = new Twin(coopdyn::load_scene(path, ov));
    const coopdyn::Model& m = c.mp->sys.model;
    // the states of arms_scaling.cc
    std::mt19937 rng(5);
    std::uniform_real_distribution<double> U(-1.0, 1.0);
    for (int k = 0; k < 16; ++k) {
      Eigen::VectorXd dq(m.nv()), q(m.nq()), v(m.nv());
      for (int i = 0; i < m.nv(); ++i) dq[i] = 0.05 * U(rng);
      coopdyn::integrate(m, c.mp->sys.q0, dq, 1.0, q);
      for (int i = 0; i < m.nv(); ++i) v[i] = 0.3 * U(rng);
      c.q.push_back(q);
      c.v.push_back(v);
    }
    c.tau = Eigen::VectorXd::Zero(m.nv());
    const std::vector<int> qm = name_map(m.q_names, c.cl->sys.model.q_names), vm = name_map(m.v_names, c.cl->sys.model.v_names);
    for (int k = 0; k < 16; ++k) {
      c.q_mp.push_back(to_pin_q(c.mp->cv, c.q[k]));
      c.v_mp.push_back(to_pin_v(c.mp->cv, c.v[k]));
      c.qc_cl.push_back(permute(c.q[k], qm));
      c.vc_cl.push_back(permute(c.v[k], vm));
      c.q_cl.push_back(to_pin_q(c.cl->cv, c.qc_cl[k]));
      c.v_cl.push_back(to_pin_v(c.cl->cv, c.vc_cl[k]));
    }
    c.tau_mp = to_pin_v(c.mp->cv, c.tau);
    c.tau_cl = to_pin_v(c.cl->cv, permute(c.tau, vm));

    // ---- accuracy: each Pinocchio tree against coopdyn evaluated on the same tree ----
    // state sets: "bench" = the 16 timing states (q off the closure by the 0.05 perturbation, v not
    // tangent to the constraints); "closed" = q0 with 16 velocities projected onto G v = 0 (then the
    // two trees are the same physical system and their results must agree by name)
    std::vector<Eigen::VectorXd> vq_closed;
    {
      coopdyn::Workspace ws(c.mp->sys);
      coopdyn::evaluate(c.mp->sys, ws, c.mp->sys.q0, c.v[0], c.tau);
      const Eigen::MatrixXd G = ws.cd.G;
      Eigen::JacobiSVD<Eigen::MatrixXd> svd(G, Eigen::ComputeFullV);
      const int r = static_cast<int>((svd.singularValues().array() > 1e-10 * svd.singularValues()[0]).count());
      const Eigen::MatrixXd N = svd.matrixV().rightCols(m.nv() - r);
      for (int k = 0; k < 16; ++k) vq_closed.push_back(N * (N.transpose() * c.v[k]));
    }
    std::mt19937 rng2(11);
    for (int tree = 0; tree < 2; ++tree)
      for (int set = 0; set < 2; ++set)
        for (int torque = 0; torque < 2; ++torque) {
          Twin& T = tree == 0 ? *c.mp : *c.cl;
          coopdyn::Workspace ws(T.sys);
          coopdyn::WrenchData wd(T.sys);
          Errs ecd, epv, eee;
          std::vector<int> pv_order(T.cv.cons.size(), -1);
          for (int k = 0; k < 16; ++k) {
            // the state in the mobile-platform coordinates, then in this tree's
            Eigen::VectorXd q = set == 0 ? c.q[k] : c.mp->sys.q0;
            Eigen::VectorXd v = set == 0 ? c.v[k] : vq_closed[k];
            Eigen::VectorXd tau = Eigen::VectorXd::Zero(m.nv());
            if (torque)
              for (int i = 0; i < m.nv(); ++i)
                tau[i] = c.mp->sys.tau_limit[i] > 0 && std::isfinite(c.mp->sys.tau_limit[i]) ? 0.2 * c.mp->sys.tau_limit[i] * U(rng2) : 0.0;
            if (tree == 1) q = permute(q, qm), v = permute(v, vm), tau = permute(tau, vm);
            const coopdyn::Diagnostics& d = coopdyn::evaluate(T.sys, ws, q, v, tau);
            if (d.status != coopdyn::Status::kOk) std::fprintf(stderr, "coopdyn status %d\n", static_cast<int>(d.status));
            coopdyn::compute_wrenches(T.sys, ws, wd);
            const Eigen::VectorXd pq = to_pin_q(T.cv, q), pv_ = to_pin_v(T.cv, v), pt = to_pin_v(T.cv, tau);
            pin::ProximalSettings st = exact_settings();
            pin::constraintDynamics(T.cv.model, T.data_cd, pq, pv_, pt, T.cv.cons, T.cdat_cd, st);
            const Eigen::VectorXd a_cd = from_pin_v(T.cv, T.data_cd.ddq);
            const Eigen::VectorXd l_cd = lambda_to_coopdyn(T.data_cd.lambda_c);
            ecd.add(a_cd, ws.vdot, l_cd, ws.lambda);
            if (T.pv_ok) {
              pin::ProximalSettings st2 = exact_settings();
              pin::pv(T.cv.model, T.data_pv, pq, pv_, pt, T.cv.cons, T.cdat_pv, st2);
              // pv orders its multipliers by its own traversal (data.lambdaA[0]): each 6-block is
              // matched to the coopdyn block it is closest to (blocks_matched counts identity matches)
              const Eigen::VectorXd lp = lambda_to_coopdyn(T.data_pv.lambdaA[0]);
              Eigen::VectorXd lm(lp.size());
              const int nbk = static_cast<int>(lp.size() / 6);
              for (int i = 0; i < nbk; ++i) {
                int best = 0;
                double bd = 1e300;
                for (int j = 0; j < nbk; ++j) {
                  const double d = std::min((lp.segment<6>(6 * i) - ws.lambda.segment<6>(6 * j)).cwiseAbs().maxCoeff(),
                                            (lp.segment<6>(6 * i) + ws.lambda.segment<6>(6 * j)).cwiseAbs().maxCoeff());
                  if (d < bd) bd = d, best = j;
                }
                lm.segment<6>(6 * best) = lp.segment<6>(6 * i);
                pv_order[i] = best;
              }
              epv.add(from_pin_v(T.cv, T.data_pv.ddq), ws.vdot, lm, ws.lambda);
            }
            // the grasp wrench: classic = the constraint force itself; mp = coopdyn's reported
            // armK.ee (the reaction across the grasp) against the same output of the classic
            // coopdyn at the same state (closed states only), via the classic Pinocchio below
            if (tree == 1) {
              Eigen::VectorXd ee(6 * n), ref(6 * n);
              for (int a = 0; a < n; ++a) {
                const std::string nm = "arm" + std::to_string(a + 1) + ".ee";
                int o = -1;
                for (size_t j = 0; j < T.sys.wrenches.outputs.size(); ++j)
                  if (T.sys.wrenches.outputs[j].name == nm) o = static_cast<int>(j);
                ref.segment<6>(6 * a) = wd.W[o];
                int s = -1;
                for (size_t j = 0; j < T.sys.constraints.specs.size(); ++j)
                  if (T.sys.constraints.specs[j].name == nm) s = static_cast<int>(j);
                ee.segment<6>(6 * a) = l_cd.segment<6>(T.sys.constraints.row_offset[s]);
              }
              eee.add(a_cd, ws.vdot, ee, ref);
            }
          }
          auto rel = [](double x, double r) { return r > 0 ? x / r : x; };
          char pvs[64] = "n/a (loops)", pvl[128] = "n/a", ees[96] = "(base welds)";
          if (T.pv_ok) {
            std::snprintf(pvs, sizeof pvs, "%.1e", rel(epv.a_abs, epv.a_ref));
            std::string ord;
            for (int o : pv_order) ord += (ord.empty() ? "" : ",") + std::to_string(o + 1);
            std::snprintf(pvl, sizeof pvl, "%.1e (%s; arms %s)", rel(std::min(epv.l_abs, epv.l_abs_neg), epv.l_ref),
                          epv.l_abs <= epv.l_abs_neg ? "+" : "-", ord.c_str());
          }
          if (tree == 1) std::snprintf(ees, sizeof ees, "%.1e (%s)", rel(std::min(eee.l_abs, eee.l_abs_neg), eee.l_ref), eee.l_abs <= eee.l_abs_neg ? "+" : "-");
          std::printf("| %d | %s | %s | %s | %d | %d | %.1e (abs %.1e) | %s | %.1e (%s; abs %.1e of %.0f) | %s | %s |\n", n,
                      tree == 0 ? "mobile platform" : "classic", set == 0 ? "bench" : "closed", torque ? "random" : "0",
                      T.sys.model.nv(), T.sys.constraints.rows, rel(ecd.a_abs, ecd.a_ref), ecd.a_abs, pvs,
                      rel(std::min(ecd.l_abs, ecd.l_abs_neg), ecd.l_ref), ecd.l_abs <= ecd.l_abs_neg ? "+" : "-",
                      std::min(ecd.l_abs, ecd.l_abs_neg), ecd.l_ref, pvl, ees);
        }
    // cross-tree: on closed states the mobile platform and the classic tree are one system: compare
    // Pinocchio classic's accelerations (by name) with coopdyn's mobile platform
    {
      coopdyn::Workspace ws(c.mp->sys);
      coopdyn::WrenchData wd(c.mp->sys);
      double dmax = 0, amax = 0, wmax = 0, wref = 0;
      for (int k = 0; k < 16; ++k) {
        coopdyn::evaluate(c.mp->sys, ws, c.mp->sys.q0, vq_closed[k], c.tau);
        coopdyn::compute_wrenches(c.mp->sys, ws, wd);
        Twin& T = *c.cl;
        pin::ProximalSettings st = exact_settings();
        pin::constraintDynamics(T.cv.model, T.data_cd, to_pin_q(T.cv, permute(c.mp->sys.q0, qm)),
                                to_pin_v(T.cv, permute(vq_closed[k], vm)), c.tau_cl, T.cv.cons, T.cdat_cd, st);
        const Eigen::VectorXd a = from_pin_v(T.cv, T.data_cd.ddq);  // classic coopdyn order
        for (int i = 0; i < m.nv(); ++i) {
          dmax = std::max(dmax, std::abs(a[vm[i]] - ws.vdot[i]));
          amax = std::max(amax, std::abs(ws.vdot[i]));
        }
        // the grasp wrenches: Pinocchio classic's multiplier of armK.ee against the mobile
        // platform's reported armK.ee (the reaction across the grasp, coopdyn's default path)
        const Eigen::VectorXd l = lambda_to_coopdyn(T.data_cd.lambda_c);
        for (int a = 0; a < n; ++a) {
          const std::string nm = "arm" + std::to_string(a + 1) + ".ee";
          int o = -1, sp = -1;
          for (size_t j = 0; j < c.mp->sys.wrenches.outputs.size(); ++j)
            if (c.mp->sys.wrenches.outputs[j].name == nm) o = static_cast<int>(j);
          for (size_t j = 0; j < T.sys.constraints.specs.size(); ++j)
            if (T.sys.constraints.specs[j].name == nm) sp = static_cast<int>(j);
          wmax = std::max(wmax, (l.segment<6>(T.sys.constraints.row_offset[sp]) - wd.W[o]).cwiseAbs().maxCoeff());
          wref = std::max(wref, wd.W[o].cwiseAbs().maxCoeff());
        }
      }
      std::printf("| %d | cross: Pinocchio classic vs coopdyn mobile platform | closed | 0 | | | %.1e (abs %.1e) | | | | %.1e (+; abs %.1e of %.0f) |\n", n,
                  dmax / amax, dmax, wmax / wref, wmax, wref);
    }
    cases.push_back(std::move(c));
  }

  // ---- timing, as arms_scaling.cc: per repetition every (case, path) in turn for ~2 ms of thread
  // CPU time, cycling the 16 states; medians over repetitions of the time per call ----
  // paths: 0 coopdyn evaluate (default: mobile platform, blocks of Q from 3 arms), 1 Pinocchio
  // constraintDynamics on the mobile-platform tree, 2 Pinocchio pv on it, 3 Pinocchio
  // constraintDynamics on the classic tree, 4 coopdyn evaluate on the classic tree
  const int P = 5;
  std::vector<std::vector<std::vector<double>>> t(cases.size(), std::vector<std::vector<double>>(P));
  double sink = 0;
  for (int r = 0; r < reps + 1; ++r)
    for (size_t ci = 0; ci < cases.size(); ++ci)
      for (int path = 0; path < P; ++path) {
        Case& c = cases[ci];
        coopdyn::Workspace ws(path == 4 ? c.cl->sys : c.mp->sys);
        pin::ProximalSettings st = exact_settings();
        long calls = 0;
        const double t0 = cpu_ns();
        double t1 = t0;
        while (t1 - t0 < 2e6) {
          for (int k = 0; k < 16; ++k) {
            switch (path) {
              case 0: coopdyn::evaluate(c.mp->sys, ws, c.q[k], c.v[k], c.tau); break;
              case 1:
                pin::constraintDynamics(c.mp->cv.model, c.mp->data_cd, c.q_mp[k], c.v_mp[k], c.tau_mp, c.mp->cv.cons, c.mp->cdat_cd, st);
                break;
              case 2: pin::pv(c.mp->cv.model, c.mp->data_pv, c.q_mp[k], c.v_mp[k], c.tau_mp, c.mp->cv.cons, c.mp->cdat_pv, st); break;
              case 3:
                pin::constraintDynamics(c.cl->cv.model, c.cl->data_cd, c.q_cl[k], c.v_cl[k], c.tau_cl, c.cl->cv.cons, c.cl->cdat_cd, st);
                break;
              case 4: coopdyn::evaluate(c.cl->sys, ws, c.qc_cl[k], c.vc_cl[k], c.tau); break;
            }
          }
          calls += 16;
          t1 = cpu_ns();
        }
        sink += ws.vdot[0] + c.mp->data_cd.ddq[0] + c.mp->data_pv.ddq[0] + c.cl->data_cd.ddq[0];
        if (r > 0) t[ci][path].push_back((t1 - t0) / static_cast<double>(calls));
      }
  size_t i2 = 0;
  while (cases[i2].arms != 2) ++i2;
  std::printf("\n## Timing (%d repetitions; medians of the time per call, thread CPU time)\n\n", reps);
  std::printf("| arms | nv | rows | coopdyn evaluate (mp) | Pinocchio cD (mp tree) | pv (mp tree) | Pinocchio cD (classic tree) | coopdyn / min(Pinocchio) | coopdyn / 2 arms | cD mp / 2 arms | pv / 2 arms | cD classic / 2 arms | coopdyn classic evaluate |\n");
  std::printf("|---|---|---|---|---|---|---|---|---|---|---|---|---|\n");
  std::vector<double> m2(P);
  for (int p = 0; p < P; ++p) m2[p] = median(t[i2][p]);
  for (size_t ci = 0; ci < cases.size(); ++ci) {
    std::vector<double> md(P);
    for (int p = 0; p < P; ++p) md[p] = median(t[ci][p]);
    const double best = std::min({md[1], md[2], md[3]});
    std::printf("| %d | %d | %d | %.2f us | %.2f us | %.2f us | %.2f us | **%.2f** | %.2f | %.2f | %.2f | %.2f | %.2f us |\n", cases[ci].arms,
                cases[ci].mp->sys.model.nv(), cases[ci].mp->sys.constraints.rows, md[0] * 1e-3, md[1] * 1e-3, md[2] * 1e-3,
                md[3] * 1e-3, md[0] / best, md[0] / m2[0], md[1] / m2[1], md[2] / m2[2], md[3] / m2[3], md[4] * 1e-3);
  }
  std::printf("\n(checksum %g)\n", sink);
  return 0;
}
