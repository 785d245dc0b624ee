// The scene compiler's shared state and its passes: arms on a load (build_arms.cc), a tree of
// bodies with frames and constraints (build_bodies.cc), the reported wrenches (scene_outputs.cc),
// the initial state closed onto the constraints (close_loops.cc). scene.cc runs them in order.
// Internal to the scene compiler.
#pragma once

#include <map>
#include <string>
#include <vector>

#include "service/dynamics/system.h"
#include "service/scene/robot_chain.h"
#include "service/scene/scene_yaml.h"

namespace coopdyn::scene_detail {

struct Builder {
  Ctx c;
  System sys;
  std::vector<double> q0, v0;  // indexed like the model as it grows
  std::vector<unsigned char> q_given;  // (nq) the scene gave this coordinate's initial value
  std::vector<double> tau_lim;
  std::vector<int> q_floating_idx;

  // adds a body (Model::add_body) with its joint's initial q, v (missing entries 0, marked not given)
  // and torque limit; returns its index
  int add(const std::string& name, int parent, const Transform& X_PJ, const Joint& j, const Inertia& I,
          const std::vector<double>& jq, const std::vector<double>& jv, double tau_limit, const YAML::Node& where) {
    int id;
    try {
      id = sys.model.add_body(name, parent, X_PJ, j, I);
    } catch (const std::invalid_argument& e) {
      fail(c, where, e.what());
    }
    const Joint& jj = sys.model.bodies[id].joint;
    for (int k = 0; k < jj.nq; ++k) {
      q0.push_back(k < static_cast<int>(jq.size()) ? jq[k] : 0.0);
      q_given.push_back(k < static_cast<int>(jq.size()) ? 1 : 0);
    }
    for (int k = 0; k < jj.nv; ++k) {
      v0.push_back(k < static_cast<int>(jv.size()) ? jv[k] : 0.0);
      tau_lim.push_back(tau_limit);
    }
    return id;
  }
};

// The components of a joint's reaction its bearings carry (WrenchOutput::constrained): all but the
// axes its DOFs move along, when those are axes of the report frame (the child's frame).
uint8_t bearing_mask(JointType t, const Vec3& axis, const Vec3& axis2);
// a joint reaction output (WrenchKind::kJoint)
WrenchOutput joint_output(const std::string& name, const std::string& frame, const std::string& by, int body,
                          bool reversed, int frame_body, const Transform& X_BF, uint8_t mask);
// writes X as a floating joint's 7 coordinates at q[idx] (xyz, then the quaternion w x y z)
void set_floating_q(Eigen::VectorXd& q, int idx, const Transform& X);

// `load` + `arms`: the paper's cooperating arms, in the mobile-platform form or rooted at the world
void build_arms(Builder& B, const YAML::Node& root, const std::map<std::string, Robot>& robots, bool mobile_platform);
// `bodies` + `frames` + `constraints`: any tree closed by welds, points and rolling wheels
void build_bodies(Builder& B, const YAML::Node& root);
// Completes the wrench outputs (wrench_outputs.h): every constraint not yet reported becomes a tip,
// every wheel on a jointed parent an axle; `reactions: all | none | [joint, ...]` selects joint reactions.
void build_wrench_outputs(const Ctx& c, const YAML::Node& root, System& sys);

// The YAML entry of a constraint, by name (for errors); the scene's root if it has none of its own.
YAML::Node constraint_node(const YAML::Node& root, const std::string& name);
// Closes the loops of the initial state (Gauss-Newton on the position error, then the velocity
// projected onto the constraints); what moved is appended to `warnings`. Leaves q0 as it was when
// the constraints cannot be closed (the caller reports the constraint that stays open).
void close_initial_state(System& sys, const std::vector<unsigned char>& q_given, const std::vector<unsigned char>& keep,
                         std::vector<std::string>* warnings);

}  // namespace coopdyn::scene_detail
