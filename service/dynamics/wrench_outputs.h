// What a system reports as wrenches (the product's promise: "forces everywhere"). Each output is
// a wrench [moment; force] exerted by `by` on the part named by `name`, taken at the origin of
// frame `frame` and expressed in its coordinates. It is either a constraint's multiplier (a
// constrained tip, read from lambda) or a joint reaction (from the backward pass of
// joint_reactions.h over the accelerations, torques and multipliers of the same evaluation).
//
// Kinds, in the order the outputs are listed:
//   kEndEffector  an arm's end-effector (frame ARM.ee): the load's wrench on it, by LOAD.ARM (the
//                 grasp frame on the load). classic: the multiplier of the grasp weld; the
//                 mobile-platform forms: the reaction across the grasp, where the arm hangs from
//                 the load. Named and framed alike in every form.
//   kBase         an arm's base (frame ARM.base): the world's wrench on it, what a base force/torque
//                 sensor reads. mobile platform: the multiplier of the base weld; classic: the
//                 reaction at joint 1.
//   kTip          any other constraint: a weld's wrench by the world or the other frame on its tip
//                 frame; a wheel's ground force at the contact, frame NAME.contact, by "ground".
//   kAxle         a wheel that hangs from a parent body by its spin joint: what the parent exerts on
//                 the wheel through the axle (NAME.axle), at the wheel centre, in the wheel-centre
//                 frame NAME.centre (the contact frame's axes: x heading, y lateral, z normal).
//   kJoint        a joint (named as its coordinate, e.g. arm1.q3): what the link before it exerts on
//                 the link after it (in the robot's own chain, whatever the tree's root), at the
//                 joint, in the frame of the link after it. Along a joint's axis it is the joint's
//                 torque minus its armature term (plus a pseudo-joint's lock: its stress); the other
//                 components are what the bearings carry.
#pragma once

#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "service/constraints/constraints.h"
#include "service/model/model.h"

namespace coopdyn {

enum class WrenchKind : int8_t { kEndEffector = 0, kBase = 1, kTip = 2, kAxle = 3, kJoint = 4 };
const char* wrench_kind_name(WrenchKind k);  // "end_effector", "base", "tip", "axle", "joint"

struct WrenchOutput {
  std::string name, frame, by;
  WrenchKind kind = WrenchKind::kTip;
  int spec = -1;          // source: the multiplier of this constraint spec, or
  int body = -1;          //         the reaction at this body's joint (tree parent -> body)
  bool reversed = false;  // the robot's chain runs against the tree (an arm hanging from the load):
                          // the wrench is the body's on its tree parent, the reaction negated
  int frame_body = -1;    // the report frame is fixed in this body (-1: the world) at X_BF
  Transform X_BF;
  int centre_of = -1;     // kAxle: the report frame is the wheel centre of this rolling spec, with
                          // its contact frame's axes (frame_body, X_BF unused)
  uint8_t constrained = 0x3f;  // bit k: component k is carried by a constraint or a bearing (a
                               // tip: its constrained axes; a joint: all but the axes its DOFs move
                               // along, when they are axes of the frame)
  // filled by WrenchSet::compile(): X_BF.R is not exactly the identity, X_BF.p not exactly zero (the
  // reaction's transform into the report frame skips what is not there)
  bool frame_rotated = true, frame_offset = true;
};

struct WrenchSet {
  std::vector<WrenchOutput> outputs;
  // filled by compile(): the bodies of the reaction pass (those whose reaction is read and all their
  // descendants), in decreasing index, and the constraint specs that push on them
  std::vector<int> pass;
  std::vector<char> in_pass;  // (bodies)
  std::vector<int> pass_specs;
  // per output k that is a reaction: the pass specs whose constraint forces act in the subtree of
  // its body, as (index into pass_specs, coefficient) with the coefficient (+-1) they enter its
  // reaction with (minus the subtree sum of the forces), in out_spec[out_spec_begin[k] ..
  // out_spec_begin[k + 1]); the change of the reaction along a free direction of lambda is read off
  // them without a pass over the bodies
  std::vector<int> out_spec_begin;
  std::vector<std::pair<int, int>> out_spec;
  void compile(const Model& model, const ConstraintSet& cs);
};

}  // namespace coopdyn
