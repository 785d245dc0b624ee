#include "service/algorithms/crba.h"

namespace coopdyn {

void crba(const Model& model, Data& data) {
  const int nb = model.nbodies();
  for (int i = 0; i < nb; ++i) data.Ic[i] = data.I[i];
  for (int i = nb - 1; i >= 0; --i) {
    const int p = model.bodies[i].parent;
    if (p >= 0) data.Ic[p] += data.Ic[i].transformed(data.X_PB[i]);
  }
  for (int i = 0; i < nb; ++i) {
    const Joint& ji = model.bodies[i].joint;
    for (int k = 0; k < ji.nv; ++k) {
      Vec6 F = data.Ic[i] * data.S[i].col(k);  // in B_i
      const int col = ji.idx_v + k;
      for (int l = 0; l < ji.nv; ++l) data.M(ji.idx_v + l, col) = data.S[i].col(l).dot(F);
      data.M(col, col) += ji.armature;
      int j = i;
      while (model.bodies[j].parent >= 0) {
        F = data.X_PB[j].act_force(F);
        j = model.bodies[j].parent;
        const Joint& jj = model.bodies[j].joint;
        for (int l = 0; l < jj.nv; ++l) {
          const double m = data.S[j].col(l).dot(F);
          data.M(jj.idx_v + l, col) = m;
          data.M(col, jj.idx_v + l) = m;
        }
      }
    }
  }
}

}  // namespace coopdyn
