// Composite-rigid-body algorithm (RBDA table 6.2): the joint-space inertia matrix M(q).
#pragma once

#include "service/model/model.h"

namespace coopdyn {

// Fills data.M (nv x nv, both triangles), its path-compact copy data.Mc and data.Ic_W. Requires forward_kinematics.
// Joint armature (rotor inertia reflected through the gear, kg*m^2) is added on the diagonal.
void crba(const Model& model, Data& data);

// The same without the dense data.M: only data.Mc and data.Ic_W, all the tree factorization reads.
// evaluate() calls this; read data.M after it only by calling crba() yourself.
void crba_compact(const Model& model, Data& data);

}  // namespace coopdyn
