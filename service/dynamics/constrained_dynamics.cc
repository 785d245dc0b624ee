#include "service/dynamics/constrained_dynamics.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "service/algorithms/crba.h"
#include "service/algorithms/kinematics.h"
#include "service/algorithms/rnea.h"
#include "service/algorithms/tree_cholesky.h"
#include "service/dynamics/jacobi.h"
#include "service/dynamics/q_solve.h"

namespace coopdyn {

const char* formulation_name(Formulation f) {
  switch (f) {
    case Formulation::kMobilePlatform: return "mobile_platform";
    case Formulation::kClassic: return "classic";
    case Formulation::kPseudoJointSchur: return "pseudo_joint";
    case Formulation::kSvdBaseline: return "svd";
  }
  return "?";
}

bool parse_formulation(const std::string& s, Formulation* f) {
  for (Formulation x : {Formulation::kMobilePlatform, Formulation::kClassic, Formulation::kPseudoJointSchur,
                        Formulation::kSvdBaseline})
    if (s == formulation_name(x)) {
      *f = x;
      return true;
    }
  return false;
}

const char* status_name(Status s) {
  switch (s) {
    case Status::kOk: return "ok";
    case Status::kIndeterminate: return "indeterminate";
    case Status::kError: return "error";
  }
  return "?";
}

const char* reason_text(Reason r) {
  switch (r) {
// clang-format off
#define COOPDYN_REASON(e, code, key, text) \
  case Reason::e: return text;
#include "service/dynamics/reasons.def"
// clang-format on
  }
  return "?";
}
const char* reason_key(Reason r) {
  switch (r) {
// clang-format off
#define COOPDYN_REASON(e, code, key, text) \
  case Reason::e: return #key;
#include "service/dynamics/reasons.def"
// clang-format on
  }
  return "unknown";
}

int num_stresses(const System& sys) {
  return static_cast<int>(sys.model.pseudo_dofs.size() + sys.constraints.couple_specs.size());
}

namespace {
int stress_dof(const System& sys, int k) {
  const size_t p = sys.model.pseudo_dofs.size();
  return static_cast<size_t>(k) < p ? sys.model.pseudo_dofs[static_cast<size_t>(k)]
                                    : sys.constraints.specs[static_cast<size_t>(sys.constraints.couple_specs[k - p])].dof;
}
}  // namespace

std::string stress_name(const System& sys, int k) { return sys.model.v_names[static_cast<size_t>(stress_dof(sys, k))]; }

const char* stress_unit(const System& sys, int k) {
  const Model& m = sys.model;
  return m.bodies[m.dof_body[stress_dof(sys, k)]].joint.type == JointType::kPrismatic ? "N" : "N*m";
}

namespace {
// the joints' damping and friction per DOF, and the stiction solve's buffers
void size_joint_losses(const System& sys, Workspace& ws) {
  const int n = sys.model.nv();
  ws.tau_loss.setZero(n);
  ws.damping.setZero(n);
  ws.friction.setZero(n);
  for (const Body& b : sys.model.bodies)
    for (int k = 0; k < b.joint.nv; ++k) {
      const int d = b.joint.idx_v + k;
      ws.damping[d] = b.joint.damping;
      ws.friction[d] = b.joint.friction;
      if (b.joint.damping > 0.0) ws.damped_dofs.push_back(d);
      if (b.joint.friction > 0.0) ws.friction_dofs.push_back(d);
    }
  ws.rest_speed = sys.rest_speed;
  ws.rest_dofs.assign(ws.friction_dofs.size(), 0);
  ws.lcp = FrictionLcp(static_cast<int>(ws.friction_dofs.size()));
  if (!ws.friction_dofs.empty()) {
    const int k = static_cast<int>(ws.friction_dofs.size());
    ws.tau_c_fr.setZero(n);
    ws.vdot_fr.setZero(n);
    ws.lambda_fr.setZero(sys.constraints.rows);
    ws.rest_dvdot.setZero(n, k);
    ws.rest_dlambda.setZero(sys.constraints.rows, k);
  }
}

// the SVD baseline's buffers: each tip's own columns (the DOFs only it moves) and its factors
void size_svd_baseline(const System& sys, Workspace& ws) {
  const int n = sys.model.nv(), m = sys.constraints.rows;
  const ConstraintSet& cs = sys.constraints;
  for (size_t s = 0; s < sys.constraints.specs.size(); ++s) {
    const int k = sys.constraints.row_count[s];
    const ConstraintSpec& c = sys.constraints.specs[s];
    ws.own_cols.emplace_back();
    if (c.kind == ConstraintKind::kWeld && c.frame_b >= 0 && sys.model.frames[c.frame_b].body >= 0) {
      const std::vector<int>& other = sys.model.body_support[sys.model.frames[c.frame_b].body];
      for (int d : cs.support[s])
        if (!std::binary_search(other.begin(), other.end(), d)) ws.own_cols.back().push_back(d);
    } else {
      ws.own_cols.back() = cs.support[s];  // a weld to the world, a wheel, a lock: every DOF it touches
    }
    ws.tip_rank.push_back(0);
    ws.tip_B.push_back(Eigen::MatrixXd::Zero(k, n));
    ws.tip_U.push_back(Eigen::MatrixXd::Zero(k, k));
    ws.tip_s.push_back(Eigen::VectorXd::Zero(k));
  }
  ws.R.setZero(m, m);
  ws.Gr.setZero(m, n);
}
}  // namespace

void Workspace::ignore_joint_losses() {
  damped_dofs.clear();
  friction_dofs.clear();
  rest_count = 0;
  tau_loss.setZero();
}

namespace {
// The nominal directions' reference (QBlocks::set_nominal_reference): the constraint rows at the
// scene's initial configuration, in scratch kinematics (the workspace's own stay as they are). Where
// that configuration is not valid or gives no finite rows, no reference is set: every evaluation
// then takes its own reflections.
void set_nominal_reference(const System& sys, Workspace& ws) {
  if (!configuration_valid(sys.model, sys.q0)) return;
  Data d(sys.model);
  ConstraintData cd(sys.model, sys.constraints);
  const Eigen::VectorXd v = Eigen::VectorXd::Zero(sys.model.nv());
  forward_kinematics(sys.model, d, sys.q0, v);
  constraint_rows(sys.model, d, sys.constraints, sys.q0, v, cd, PositionErrors::kSkip);
  if (!cd.G.allFinite()) return;
  if (ws.qb.has_nominal) ws.qb.set_nominal_reference(cd.G);
  ws.qs.set_nominal_reference(cd.G);
}
}  // namespace

Workspace::Workspace(const System& sys)
    : data(sys.model), cd(sys.model, sys.constraints), qs(sys.constraints.rows) {
  const int n = sys.model.nv(), m = sys.constraints.rows;
  tau_c.setZero(n);
  tau_c0.setZero(n);
  vdot.setZero(n);
  lambda.setZero(m);
  stress.setZero(num_stresses(sys));
  diag.rows = m;
  size_joint_losses(sys, *this);
  Yt.setZero(n, m);
  const ConstraintSet& cs = sys.constraints;
  const int ns = static_cast<int>(cs.specs.size());
  std::vector<std::vector<char>> touch(ns, std::vector<char>(n, 0));
  for (int s = 0; s < ns; ++s) {
    for (int d : cs.support[s])
      for (int a : sys.model.body_support[sys.model.dof_body[d]]) touch[s][a] = 1;
    y_support.emplace_back();
    for (int d = 0; d < n; ++d)
      if (touch[s][d]) y_support[s].push_back(d);
  }
  for (int s = 0; s < ns; ++s) Yb.push_back(YBlock::Zero(n, kYStride));
  for (const auto& [k, j] : sys.model.dof_elim_steps)
    for (int s = 0; s < ns; ++s) {
      if (touch[s][k]) y_sweep.push_back({s, k, j});
      else if (j >= 0 && touch[s][j]) y_sweep.push_back({s, j, -1});
    }
  pair_ranges.resize(static_cast<size_t>(ns) * ns);
  for (int s = 0; s < ns; ++s)
    for (int t = s; t < ns; ++t)
      for (int d = 0; d < n;) {
        if (!(touch[s][d] && touch[t][d])) {
          ++d;
          continue;
        }
        int e = d;
        while (e < n && touch[s][e] && touch[t][e]) ++e;
        pair_ranges[s * ns + t].push_back({d, e - d});
        d = e;
      }
  Q.setZero(m, m);
  u.setZero(n);
  rhs.setZero(m);
  eig_A.setZero(m, m);
  eig_V.setZero(m, m);
  eig_w.setZero(m);
  tmp_m.setZero(m);
  tmp_m2.setZero(m);
  spec_nominal.assign(cs.specs.size(), -1);
  for (const System::NominalBase& nb : sys.nominal_bases)  // joint 1 reversed: one DOF, a 6-row weld
    if (cs.row_count[nb.spec] == 6) {
      spec_nominal[nb.spec] = static_cast<int>(nominal_rows.size());
      nominal_rows.emplace_back(sys.model.bodies[nb.body].joint.idx_v, cs.row_offset[nb.spec]);
    }
  for (size_t s = 0; s < cs.specs.size(); ++s) Yr.push_back(spec_nominal[s] >= 0 ? YBlock::Zero(n, kYStride) : YBlock());
  if (sys.options.formulation == Formulation::kMobilePlatform || sys.options.formulation == Formulation::kClassic) {
    qb.plan(sys, y_support, nominal_rows);
    use_q_blocks = qb.usable && static_cast<int>(qb.groups.size()) >=
                                    (qb.has_nominal ? kQBlocksMinGroupsNominal : kQBlocksMinGroups);
  }
  qs.plan_nominal(nominal_rows);
  if (!nominal_rows.empty()) {
    Qn.setZero(m, m);
    set_nominal_reference(sys, *this);
  }
  // Eigen's default LLT leaves its info unset, which a copy of the workspace reads (UBSan: "invalid
  // value for type ComputationInfo"): every workspace computes it once, sized where it is used
  d4_llt.compute(Eigen::MatrixXd::Identity(0, 0));
  if (sys.options.formulation == Formulation::kPseudoJointSchur) {
    const int p = static_cast<int>(sys.model.pseudo_dofs.size());
    Minv.setZero(n, n);
    P.setZero(n, m);
    QinvPt.setZero(m, n);
    D.setZero(n, n);
    E.setZero(n);
    d4.setZero(p, p);
    d4_llt.compute(Eigen::MatrixXd::Identity(p, p));  // sizes it; LLT(p) leaves its info unset
    tp.setZero(p);
  }
  if (sys.options.formulation == Formulation::kSvdBaseline) size_svd_baseline(sys, *this);
}

namespace {

// The fast-path condition of the symmetric k x k corner of a (column-major, leading dimension m):
// the unpivoted Cholesky L, left-looking, read from the lower triangle and written transposed into
// the strict upper one (L(i, j) at (j, i)); true with *condition = (largest / smallest diagonal)^2
// when every pivot is positive and the ratio passes fast_tol, else false with the corner restored.
bool unpivoted_condition(double* a, int m, int k, double fast_tol, double* condition) {
  auto at = [&](int i, int j) -> double& { return a[static_cast<size_t>(j) * m + i]; };
  double dmax = 0.0, dmin = HUGE_VAL;
  bool ok = true;
  for (int j = 0; j < k && ok; ++j) {
    double d = at(j, j);
    const double* lj = &at(0, j);  // L(j, p) = at(p, j), p < j
    for (int p = 0; p < j; ++p) d -= lj[p] * lj[p];
    if (!(d > 0.0)) {
      ok = false;
      break;
    }
    const double l = std::sqrt(d), inv = 1.0 / l;
    dmax = std::max(dmax, l);
    dmin = std::min(dmin, l);
    for (int i = j + 1; i < k; ++i) {
      const double* li = &at(0, i);
      double sum = at(i, j);
      for (int p = 0; p < j; ++p) sum -= li[p] * lj[p];
      at(j, i) = sum * inv;
    }
  }
  const double ratio = ok ? dmin * dmin / (dmax * dmax) : 0.0;
  if (ok && ratio >= fast_tol) {
    *condition = 1.0 / ratio;
    return true;
  }
  for (int j = 0; j < k; ++j)
    for (int i = j + 1; i < k; ++i) at(j, i) = at(i, j);
  return false;
}

// The condition of Q with each nominal base-link direction eliminated (System::nominal_bases). In
// the weld's six rows that direction is u = G's column of joint 1 (the base link's motion about
// joint 1 in the weld frame, constant): a Householder reflection H (H u = |u| e_0, up to sign) of
// those rows, Q <- H Q H, makes row r0 the only one carrying the nominal inertia's ~1/I eigenvalue,
// and it is dropped. What remains is the Q of the rows that do no work on joint 1 (the five of a
// revolute bearing at the base), whose dependence on the nominal inertia is O(I) (the base link's
// inertia in the other DOFs' motion) instead of 1/I. Its condition is measured as QSolver measures
// Q's: the pivot ratio of the unpivoted Cholesky where it passes the fast-path test (the block
// path's reduced factor, q_blocks.h, and the leading pivots of QSolver::factor_nominal_last are
// the same), else that of a diagonally pivoted Cholesky stopped at rank_tol (the rank path's).
// Used where factor_nominal_last's fast path fails (solve_q).
double condition_without_nominal(const System& sys, Workspace& ws) {
  const int m = sys.constraints.rows;
  Eigen::MatrixXd& A = ws.Qn;
  A = ws.Q;
  double* a = A.data();  // column-major, leading dimension m; raw loops: the sizes are small
  ws.qs.prepare_nominal(ws.cd.G);  // the reflections H and the rows dropped (q_solve.h)
  ws.qs.reflect_symmetric(a);
  const std::vector<unsigned char>& kept = ws.qs.nominal_kept;
  // compact the kept rows and columns into the top-left k x k corner (leading dimension m)
  int k = 0;
  for (int j = 0; j < m; ++j) {
    if (!kept[j]) continue;
    const double* src = a + static_cast<size_t>(j) * m;
    double* dst = a + static_cast<size_t>(k) * m;
    int l = 0;
    for (int i = 0; i < m; ++i)
      if (kept[i]) dst[l++] = src[i];
    ++k;
  }
  double fast = 0.0;
  if (unpivoted_condition(a, m, k, sys.options.fast_tol, &fast)) return fast;
  // pivoted Cholesky of the corner, right-looking on the full symmetric trailing block
  auto at = [&](int i, int j) -> double& { return a[static_cast<size_t>(j) * m + i]; };
  double qmax = 0.0;
  for (int i = 0; i < k; ++i) qmax = std::max(qmax, at(i, i));
  if (!(qmax > 0.0)) return std::numeric_limits<double>::infinity();
  const double tol = sys.options.rank_tol * qmax;
  double first = 0.0, last = 0.0;
  for (int j = 0; j < k; ++j) {
    int p = j;
    for (int i = j + 1; i < k; ++i)
      if (at(i, i) > at(p, p)) p = i;
    const double d = at(p, p);
    if (!(d > tol) || !std::isfinite(d)) break;
    if (p != j) {  // symmetric swap of j and p in the trailing block
      for (int i = j; i < k; ++i) std::swap(at(i, j), at(i, p));
      for (int i = j; i < k; ++i) std::swap(at(j, i), at(p, i));
    }
    if (j == 0) first = d;
    last = d;
    const double inv = 1.0 / d;
    for (int c = j + 1; c < k; ++c) {
      const double f = at(j, c) * inv;
      double* col = a + static_cast<size_t>(c) * m;
      const double* cj = a + static_cast<size_t>(j) * m;
      for (int i = j + 1; i < k; ++i) col[i] -= f * cj[i];
    }
  }
  return last > 0.0 ? first / last : std::numeric_limits<double>::infinity();
}

void dense_q_from_yb(const System& sys, Workspace& ws);
void reflected_q_from_yb(const System& sys, Workspace& ws);

// Solves Q x = b through ws.qs; with factor, factors ws.Q first and records rank and condition.
// With the block structure (ws.use_q_blocks, build_q formed the blocks only) the block Cholesky is
// tried first; where it fails the dense Q is formed and ws.qs decides. With nominal base links the
// dense path first tries the fast path on Q with the nominal directions last (one factor for the
// solve and the condition); where that fails (a pivot or the ratio of all pivots), ws.qs factors
// Q as it is, as without nominal bases, and the condition comes from condition_without_nominal.
// Where build_q formed R Q R^T only (ws.q_reflected), that factor is tried on it as it stands and
// the dense Q is formed only where it fails.
void solve_q(const System& sys, Workspace& ws, const Eigen::VectorXd& b, Eigen::VectorXd& x, bool factor) {
  if (factor && ws.q_reflected) {  // build_q formed R Q R^T only
    double condition = 1.0;
    ws.q_blocks_active = false;
    if (ws.qs.factor_nominal_formed(sys.options, &condition)) {
      ws.diag.rank = ws.qs.m;
      ws.diag.condition = condition;
      ws.qs.solve(b, x);
      return;
    }
    dense_q_from_yb(sys, ws);  // as factor_nominal_last failing below: Q as it is
    ws.q_reflected = false;
    const QFactorInfo fi = ws.qs.factor(ws.Q, sys.options, sys.constraints.row_compliance);
    ws.diag.rank = fi.rank;
    ws.diag.condition = condition_without_nominal(sys, ws);
    ws.qs.solve(b, x);
    return;
  }
  if (factor) {
    ws.q_blocks_active = false;
    if (ws.use_q_blocks) {
      double condition = 1.0;
      if (ws.qb.factor(sys.options, ws.cd.G, &condition)) {
        ws.q_blocks_active = true;
        ws.qs.fast_path = true;  // what the wrenches read: every row determined
        ws.qs.rank = ws.qs.m;
        for (int i = 0; i < ws.qs.m; ++i) ws.qs.row_indeterminate[i] = 0;
        ws.diag.rank = ws.qs.m;
        ws.diag.condition = condition;
      } else {
        dense_q_from_yb(sys, ws);
      }
    }
    double condition = 1.0;
    if (!ws.q_blocks_active && !ws.nominal_rows.empty() &&
        ws.qs.factor_nominal_last(ws.Q, ws.cd.G, sys.options, &condition)) {
      ws.diag.rank = ws.qs.m;  // one factor gives the solve and the condition (q_solve.h)
      ws.diag.condition = condition;
    } else if (!ws.q_blocks_active) {
      const QFactorInfo fi = ws.qs.factor(ws.Q, sys.options, sys.constraints.row_compliance);
      ws.diag.rank = fi.rank;
      ws.diag.condition = ws.nominal_rows.empty() ? fi.condition : condition_without_nominal(sys, ws);
    }
  }
  if (ws.q_blocks_active) ws.qb.solve(b, x);
  else ws.qs.solve(b, x);
}

// One step of the L^-T solve of a spec's rows (y: its Yb, row-major, DOF i's entries at y + kYStride i):
// DOF k, then its parent j (Model::dof_elim_steps) in the same pass over their ancestors, each
// ancestor's two updates in that order (the arithmetic of k's step, then j's).
void y_sweep_step(const Model& model, const Data& data, const Workspace::YStep& st, double* y) {
  using YRow = Eigen::Matrix<double, Workspace::kYStride, 1>;  // a DOF's row of Yb
  using Row = Eigen::Map<YRow>;
  constexpr int S = Workspace::kYStride;
  const int k = st.k, d = model.dof_depth[k];
  const double* rk = tree_factor_row(model, data, k);
  const int* pk = model.dof_path.data() + model.dof_path_offset[k];
  const YRow yk = Row(y + S * k) * data.Ld_inv[k];
  Row(y + S * k) = yk;
  if (st.j < 0) {
    for (int p = 0; p < d; ++p) Row(y + S * pk[p]) -= rk[p] * yk;
    return;
  }
  const double* rj = tree_factor_row(model, data, st.j);  // j's path: k's first d - 1 entries
  const YRow yj = (Row(y + S * st.j) - rk[d - 1] * yk) * data.Ld_inv[st.j];
  Row(y + S * st.j) = yj;
  for (int p = 0; p < d - 1; ++p) {
    Row ya(y + S * pk[p]);
    ya = ya - rk[p] * yk - rj[p] * yj;
  }
}

// Y^T = (G L^-1)^T and Q = Y Y^T from the rows of G, touching only the DOFs each row reaches: the
// arms of a mobile platform share only the platform's DOFs, so their off-diagonal blocks of Q are
// sums over 6 entries. With dense_yt, also the dense Y^T (the pseudo-joint Schur form reads it).
void build_q(const System& sys, Workspace& ws, const Eigen::MatrixXd& G, bool dense_yt) {
  const Model& model = sys.model;
  const ConstraintSet& cs = sys.constraints;
  const int ns = static_cast<int>(cs.specs.size());
  // the nominal directions' reflections need only G: taken first, their chain of square roots and
  // divisions overlaps the sweep below
  const bool blocks = ws.use_q_blocks && !dense_yt, reflected = !dense_yt && !blocks && !ws.nominal_rows.empty();
  if (blocks && ws.qb.has_nominal) ws.qb.prepare_nominal(G);
  else if (reflected) ws.qs.prepare_nominal(G);
  // L^-T solve of each spec's rows at once: one 6-wide row operation per (DOF, ancestor) pair, the
  // specs' sweeps interleaved (their chains are independent)
  for (int s = 0; s < ns; ++s) {
    Workspace::YBlock& Y = ws.Yb[s];
    const int r0 = cs.row_offset[s], nk = cs.row_count[s];
    if (nk == 6) {  // a weld: its column of G is Y's row, six contiguous doubles each
      for (int d : ws.y_support[s]) Y.row(d).head<6>() = G.block<6, 1>(r0, d).transpose();
      continue;
    }
    for (int d : ws.y_support[s])
      for (int k = 0; k < nk; ++k) Y(d, k) = G(r0 + k, d);
  }
  for (const Workspace::YStep& st : ws.y_sweep) y_sweep_step(model, ws.data, st, ws.Yb[st.spec].data());
  if (dense_yt)
    for (int s = 0; s < ns; ++s)
      for (int d : ws.y_support[s])
        for (int k = 0; k < cs.row_count[s]; ++k) ws.Yt(d, cs.row_offset[s] + k) = ws.Yb[s](d, k);
  ws.q_reflected = false;
  if (blocks) ws.qb.assemble(sys, ws.Yb);  // solve_q forms the dense Q if it needs it
  else if (reflected) reflected_q_from_yb(sys, ws);
  else dense_q_from_yb(sys, ws);
}

// R Q R^T's upper triangle into ws.qs.Nq (q_solve.h, after build_q's prepare_nominal): each nominal weld's
// rows of Y reflected (Yr: H Y, per DOF one 6-vector), then the sums of dense_q_from_yb over the
// reflected rows, H Q H = (H Y)(H Y)^T, each entry written to its place in the order R. Against
// factor_nominal_last on the dense Q (Q, then a copy reflected from both sides, then permuted) this
// reflects 6-vectors of Y instead of Q's rows and columns and writes the factored matrix once.
void reflected_q_from_yb(const System& sys, Workspace& ws) {
  const ConstraintSet& cs = sys.constraints;
  const int ns = static_cast<int>(cs.specs.size());
  QSolver& qs = ws.qs;
  for (int s = 0; s < ns; ++s) {
    const int a = ws.spec_nominal[s];
    if (a < 0) continue;
    const Vec6 w = qs.nominal_w[a];
    const double* y = ws.Yb[s].data();
    double* yr = ws.Yr[s].data();
    for (int d : ws.y_support[s]) {
      const Vec6 yd = Eigen::Map<const Vec6>(y + Workspace::kYStride * d);
      double t = 0.0;
      for (int k = 0; k < 6; ++k) t += w[k] * yd[k];
      for (int k = 0; k < 6; ++k) yr[Workspace::kYStride * d + k] = yd[k] - t * w[k];
    }
  }
  const int* ip = qs.nominal_iperm.data();
  for (int s = 0; s < ns; ++s)
    for (int t = s; t < ns; ++t) {
      const Workspace::YBlock& ys = ws.spec_nominal[s] >= 0 ? ws.Yr[s] : ws.Yb[s];
      const Workspace::YBlock& yt = ws.spec_nominal[t] >= 0 ? ws.Yr[t] : ws.Yb[t];
      const Mat6 acc = pair_block(ys, yt, ws.pair_ranges[s * ns + t], s == t);
      const int rs = cs.row_offset[s], rt = cs.row_offset[t], ks = cs.row_count[s], kt = cs.row_count[t];
      for (int l = 0; l < kt; ++l)
        for (int k = 0; k < ks; ++k) {
          const int i = ip[rs + k], j = ip[rt + l];
          if (i <= j) qs.Nq(i, j) = acc(k, l);
          else qs.Nq(j, i) = acc(k, l);
        }
    }
  ws.q_reflected = true;
}

// Q_st = sum over the DOFs both specs reach of outer products of 6-vectors
void dense_q_from_yb(const System& sys, Workspace& ws) {
  const ConstraintSet& cs = sys.constraints;
  const int ns = static_cast<int>(cs.specs.size());
  for (int s = 0; s < ns; ++s)
    for (int t = s; t < ns; ++t) {
      const Mat6 acc = pair_block(ws.Yb[s], ws.Yb[t], ws.pair_ranges[s * ns + t], s == t);
      const int rs = cs.row_offset[s], rt = cs.row_offset[t], ks = cs.row_count[s], kt = cs.row_count[t];
      ws.Q.block(rs, rt, ks, kt) = acc.topLeftCorner(ks, kt);
      if (s != t) ws.Q.block(rt, rs, kt, ks) = acc.topLeftCorner(ks, kt).transpose();
    }
}

// lambda from Q lambda = gamma - Y u with u = L^-T tau_c, then vdot = L^-1 (u + Y^T lambda); the
// products with Y run per spec over the DOFs its rows reach.
void schur_solve(const System& sys, Workspace& ws, bool factor) {
  const Model& model = sys.model;
  const ConstraintSet& cs = sys.constraints;
  const int ns = static_cast<int>(cs.specs.size());
  ws.u = ws.tau_c;
  tree_solve_Lt(model, ws.data, ws.u);
  ws.rhs = ws.cd.gamma;
  for (int s = 0; s < ns; ++s) {
    const double* y = ws.Yb[s].data();
    Vec6 acc = Vec6::Zero();
    for (int d : ws.y_support[s]) acc += ws.u[d] * Eigen::Map<const Vec6>(y + Workspace::kYStride * d);
    const int r0 = cs.row_offset[s];
    for (int k = 0; k < cs.row_count[s]; ++k) ws.rhs[r0 + k] -= acc[k];
  }
  solve_q(sys, ws, ws.rhs, ws.lambda, factor);
  ws.vdot = ws.u;
  for (int s = 0; s < ns; ++s) {
    const double* y = ws.Yb[s].data();
    Vec6 lam = Vec6::Zero();  // Y's unused columns (specs of fewer than 6 rows) are zero
    const int r0 = cs.row_offset[s];
    for (int k = 0; k < cs.row_count[s]; ++k) lam[k] = ws.lambda[r0 + k];
    for (int d : ws.y_support[s]) ws.vdot[d] += Eigen::Map<const Vec6>(y + Workspace::kYStride * d).dot(lam);
  }
  tree_solve_L(model, ws.data, ws.vdot);
}

bool pseudo_schur(const System& sys, Workspace& ws) {
  // (18): vdot = D tau_c + E of the system with the pseudo-joints free, then (23)-(26).
  const Model& model = sys.model;
  const int n = model.nv(), m = sys.constraints.rows;
  const std::vector<int>& pd = model.pseudo_dofs;
  const int p = static_cast<int>(pd.size());
  ws.Minv.setIdentity();
  for (int j = 0; j < n; ++j) tree_solve_M(model, ws.data, ws.Minv.col(j));
  ws.P = ws.Yt;  // M^-1 G^T = L^-1 Y^T
  for (int r = 0; r < m; ++r) tree_solve_L(model, ws.data, ws.P.col(r));
  // Q^-1 P^T, column by column through the same rank-revealing solve
  for (int j = 0; j < n; ++j) {
    ws.tmp_m2 = ws.P.row(j).transpose();
    solve_q(sys, ws, ws.tmp_m2, ws.rhs, j == 0);
    ws.QinvPt.col(j) = ws.rhs;
  }
  ws.D = ws.Minv;
  ws.D.noalias() -= ws.P * ws.QinvPt;
  solve_q(sys, ws, ws.cd.gamma, ws.rhs, false);
  ws.E.noalias() = ws.P * ws.rhs;
  // tau_c,p = -d4^-1 (d3 tau_c,r + e2); the pseudo-joints carry no applied torque of their own
  for (int a = 0; a < p; ++a) ws.tau_c[pd[a]] = -ws.data.h[pd[a]];
  for (int a = 0; a < p; ++a) {
    double s = ws.E[pd[a]];
    for (int j = 0; j < n; ++j) s += ws.D(pd[a], j) * ws.tau_c[j];
    for (int bb = 0; bb < p; ++bb) s -= ws.D(pd[a], pd[bb]) * ws.tau_c[pd[bb]];
    ws.tp[a] = -s;
    for (int bb = 0; bb < p; ++bb) ws.d4(a, bb) = ws.D(pd[a], pd[bb]);
  }
  if (p > 0) {
    ws.d4_llt.compute(ws.d4);
    const double scale = ws.d4.diagonal().maxCoeff();
    if (ws.d4_llt.info() != Eigen::Success || !(scale > 0.0)) return false;
    const auto dl = ws.d4_llt.matrixLLT().diagonal();
    if (dl.minCoeff() * dl.minCoeff() < 1e-10 * scale) return false;
    ws.d4_llt.solveInPlace(ws.tp);
  }
  for (int a = 0; a < p; ++a) {
    ws.tau_c[pd[a]] = ws.tp[a];
    ws.stress[a] = ws.tp[a] + ws.data.h[pd[a]];
  }
  ws.vdot = ws.E;
  ws.vdot.noalias() += ws.D * ws.tau_c;
  // lambda for the real constraints with the locking torques applied
  ws.u = ws.tau_c;
  tree_solve_Lt(model, ws.data, ws.u);
  ws.rhs = ws.cd.gamma;
  ws.rhs.noalias() -= ws.Yt.transpose() * ws.u;
  solve_q(sys, ws, ws.rhs, ws.lambda, false);
  return true;
}

void svd_baseline(const System& sys, Workspace& ws) {
  // (19)-(21), the paper's numerical method in its classic setting: per tip k, the SVD of the
  // manipulator's own tip Jacobian J_k (the rows of G_k over the DOFs that move the tip but not the
  // other side: an arm's joints, not the load's) gives U = [U_r U_0], U_r spanning the directions the
  // tip can move in, U_0 = N(J_k^T). R_k = U_r^T keeps those rows of the constraint, G_r = R G;
  // the force components along N(J_k^T) are dropped (not determined). Then Q_r = G_r M^-1 G_r^T
  // by an SVD (eigen-decomposition) pseudo-inverse.
  const Model& model = sys.model;
  const ConstraintSet& cs = sys.constraints;
  const int n = model.nv(), m = cs.rows;
  ws.R.setZero();
  int mr = 0;
  ws.dropped = 0;
  for (size_t s = 0; s < cs.specs.size(); ++s) {
    const int r0 = cs.row_offset[s], nk = cs.row_count[s];
    Eigen::MatrixXd& B = ws.tip_B[s];
    B.setZero();
    for (int c : ws.own_cols[s]) B.col(c) = ws.cd.G.block(r0, c, nk, 1);
    jacobi_svd_rows(B, ws.tip_U[s], ws.tip_s[s]);
    const Eigen::VectorXd& sv = ws.tip_s[s];
    const double tol = std::sqrt(sys.options.rank_tol) * sv[0];
    ws.tip_rank[s] = 0;
    for (int i = 0; i < nk; ++i)
      if (sv[i] > tol && sv[0] > 0.0) {
        ws.R.row(mr).segment(r0, nk) = ws.tip_U[s].col(i).transpose();
        ++mr;
        ++ws.tip_rank[s];
      }
    ws.dropped += nk - ws.tip_rank[s];
  }
  ws.mr = mr;
  ws.Gr.topRows(mr).noalias() = ws.R.topRows(mr) * ws.cd.G;
  for (int r = 0; r < mr; ++r) {
    ws.Yt.col(r) = ws.Gr.row(r).transpose();
    tree_solve_Lt(model, ws.data, ws.Yt.col(r));
  }
  for (int r = mr; r < m; ++r) ws.Yt.col(r).setZero();
  ws.Q.noalias() = ws.Yt.transpose() * ws.Yt;  // reduced rows first, zero padding after
  ws.u = ws.tau_c;
  tree_solve_Lt(model, ws.data, ws.u);
  ws.rhs.setZero();
  ws.rhs.head(mr).noalias() = ws.R.topRows(mr) * ws.cd.gamma;
  ws.rhs.noalias() -= ws.Yt.transpose() * ws.u;
  // SVD of the symmetric PSD Q_r = its eigen-decomposition (singular values descending below)
  ws.eig_A = ws.Q;
  jacobi_eigen(ws.eig_A, ws.eig_w, ws.eig_V);
  const Eigen::VectorXd& ev = ws.eig_w;  // ascending
  const double smax = m ? std::max(ev[m - 1], 0.0) : 0.0;
  const double tol = sys.options.rank_tol * smax;
  int rank = 0;
  double smin_kept = smax;
  ws.tmp_m.noalias() = ws.eig_V.transpose() * ws.rhs;
  for (int i = 0; i < m; ++i) {
    if (ev[i] > tol && smax > 0.0) {
      ws.tmp_m[i] /= ev[i];
      ++rank;
      smin_kept = std::min(smin_kept, ev[i]);
    } else {
      ws.tmp_m[i] = 0.0;
    }
  }
  ws.tmp_m2.noalias() = ws.eig_V * ws.tmp_m;  // lambda_r (first mr entries)
  ws.lambda.noalias() = ws.R.topRows(mr).transpose() * ws.tmp_m2.head(mr);
  ws.diag.rank = rank;
  ws.diag.condition = rank > 0 ? smax / smin_kept : std::numeric_limits<double>::infinity();
  // rows outside the reduced space, or along the null space of Q_r, are indeterminate
  for (int i = 0; i < m; ++i) {
    double s = 0.0;
    for (int r = 0; r < mr; ++r) s += ws.R(r, i) * ws.R(r, i);
    for (int j = 0; j < m; ++j) {  // eigenvectors of the null space: eigenvalue <= tol
      if (ev[j] > tol && smax > 0.0) continue;
      double w = 0.0;
      for (int r = 0; r < mr; ++r) w += ws.R(r, i) * ws.eig_V(r, j);
      s -= w * w;
    }
    ws.qs.row_indeterminate[i] = s < 1.0 - 1e-6 ? 1 : 0;  // a row with a share along N(J^T)
  }
  ws.vdot = ws.u;
  ws.vdot.noalias() += ws.Yt * ws.tmp_m2;
  tree_solve_L(model, ws.data, ws.vdot);
  (void)n;
}

// Pseudo-joint stresses are the multipliers of their lock rows (combined solves).
// Rolling resistance (ConstraintSpec::rolling_resistance): each wheel's normal force N acts
// c_rr r ahead of its contact point, a moment rr_arm N about y_C on the wheel, a generalized force
// that depends on the multipliers it changes. Solved exactly by fixed-point iteration on the
// factored Q (only the right-hand side changes): tau_c = tau - h + sum_s J_w,s^T y_C rr_arm N_s.
// The map is a contraction of ratio ~ c_rr r / (the wheelbase): a car converges to 1e-14 in a few
// iterations; the last iterate is kept after 50.
void rolling_resistance_solve(const System& sys, Workspace& ws) {
  const ConstraintSet& cs = sys.constraints;
  ws.tau_c0 = ws.tau_c;
  ws.rr_iterations = 0;
  for (int it = 0; it < 50; ++it) {
    ws.tau_c = ws.tau_c0;
    for (size_t s = 0; s < cs.specs.size(); ++s) {
      const double arm = ws.cd.rr_arm[s];
      if (arm == 0.0) continue;
      const Vec3 m = (arm * ws.lambda[cs.row_offset[s] + 2]) * ws.cd.X_RS[s].R.col(1);  // world axes
      for (int d : cs.support[s]) ws.tau_c[d] += ws.data.S_W.col(d).head<3>().dot(m);
    }
    ws.tmp_m2 = ws.lambda;
    schur_solve(sys, ws, false);
    ++ws.rr_iterations;
    const double step = (ws.lambda - ws.tmp_m2).cwiseAbs().maxCoeff();
    if (!(step > 1e-14 * (1.0 + ws.lambda.cwiseAbs().maxCoeff()))) break;
  }
}

void lock_stresses(const System& sys, Workspace& ws) {
  for (size_t s = 0, a = 0; s < sys.constraints.specs.size(); ++s)
    if (sys.constraints.specs[s].kind == ConstraintKind::kLock && a < sys.model.pseudo_dofs.size())
      ws.stress[a++] = ws.lambda[sys.constraints.row_offset[s]];
}

// the couplings' forces on their mimicking joints: their rows' multipliers (every formulation)
void couple_stresses(const System& sys, Workspace& ws) {
  const std::vector<int>& cs = sys.constraints.couple_specs;
  const size_t p = sys.model.pseudo_dofs.size();
  for (size_t k = 0; k < cs.size(); ++k) ws.stress[p + k] = ws.lambda[sys.constraints.row_offset[cs[k]]];
}

// The formulation's solve of vdot and lambda for ws.tau_c; `first` factors (every later call reuses
// the factorization where the formulation keeps one). false: the pseudo-joint block is singular.
bool solve_formulation(const System& sys, Workspace& ws, bool first) {
  switch (sys.options.formulation) {
    case Formulation::kMobilePlatform:
    case Formulation::kClassic:
      if (first) build_q(sys, ws, ws.cd.G, false);
      schur_solve(sys, ws, first);
      if (sys.constraints.rolling_resistance) rolling_resistance_solve(sys, ws);
      lock_stresses(sys, ws);
      break;
    case Formulation::kPseudoJointSchur:
      if (first) build_q(sys, ws, ws.cd.G, true);
      if (!pseudo_schur(sys, ws)) return false;
      break;
    case Formulation::kSvdBaseline:
      svd_baseline(sys, ws);
      lock_stresses(sys, ws);
      break;
  }
  return true;
}

// Joint losses known before the solve: damping -b v at every damped joint and -F sign(v) at every
// friction joint that moves; the resting friction joints are listed for friction_at_rest.
void apply_joint_losses(Workspace& ws, const Eigen::VectorXd& v) {
  ws.tau_loss.setZero();
  for (int d : ws.damped_dofs) ws.tau_loss[d] = -ws.damping[d] * v[d];
  ws.rest_count = 0;
  for (int d : ws.friction_dofs) {
    if (std::abs(v[d]) > ws.rest_speed) ws.tau_loss[d] -= v[d] > 0 ? ws.friction[d] : -ws.friction[d];
    else ws.rest_dofs[ws.rest_count++] = d;
  }
  ws.tau_c += ws.tau_loss;
}

// Stiction at the resting friction joints (friction_lcp.h), after a first solve without it: the
// accelerations are affine in their friction forces, vdot = vdot_0 + A f, with A's columns the
// change of the accelerations under a torque at each resting joint (one solve each, on the same
// factorization; exact for an affine solve up to rounding, the torque scaled to the problem's).
// Then the final solve with the friction found; a stuck joint's acceleration, zero to rounding
// there, is set to exactly 0.
bool friction_at_rest(const System& sys, Workspace& ws) {
  const int k = ws.rest_count;
  FrictionLcp& lcp = ws.lcp;
  ws.tau_c_fr = ws.tau_c;
  ws.vdot_fr = ws.vdot;
  ws.lambda_fr = ws.lambda;
  const double s = 1.0 + ws.tau_c.cwiseAbs().maxCoeff();
  for (int j = 0; j < k; ++j) {
    lcp.b[j] = ws.vdot_fr[ws.rest_dofs[j]];
    lcp.bound[j] = ws.friction[ws.rest_dofs[j]];
    ws.tau_c = ws.tau_c_fr;
    ws.tau_c[ws.rest_dofs[j]] += s;
    if (!solve_formulation(sys, ws, false)) return false;
    ws.rest_dvdot.col(j) = (ws.vdot - ws.vdot_fr) / s;
    ws.rest_dlambda.col(j) = (ws.lambda - ws.lambda_fr) / s;
    for (int i = 0; i < k; ++i) lcp.A(i, j) = ws.rest_dvdot(ws.rest_dofs[i], j);
  }
  for (int i = 0; i < k; ++i)  // symmetric in exact arithmetic
    for (int j = 0; j < i; ++j) lcp.A(i, j) = lcp.A(j, i) = 0.5 * (lcp.A(i, j) + lcp.A(j, i));
  lcp.solve(k);
  ws.tau_c = ws.tau_c_fr;
  ws.friction_stuck = 0;
  for (int j = 0; j < k; ++j) {
    ws.tau_c[ws.rest_dofs[j]] += lcp.f[j];
    ws.tau_loss[ws.rest_dofs[j]] += lcp.f[j];
  }
  if (!solve_formulation(sys, ws, false)) return false;
  for (int j = 0; j < k; ++j)
    if (lcp.state[j] == 0) {
      ws.vdot[ws.rest_dofs[j]] = 0.0;
      ++ws.friction_stuck;
    }
  ws.friction_indeterminate = lcp.indeterminate;
  ws.friction_converged = lcp.converged;
  return true;
}

}  // namespace

namespace {
const Diagnostics& fail_evaluation(Workspace& ws, Reason r) {
  ws.diag.status = Status::kError;
  ws.diag.reason = r;
  ws.vdot.setZero();
  ws.lambda.setZero();
  ws.stress.setZero();
  return ws.diag;
}

void reset_diagnostics(const System& sys, Diagnostics& dg) {
  const int m = sys.constraints.rows;
  dg.rows = m;
  dg.rank = m;
  dg.indeterminate = 0;
  dg.condition = 1.0;
  dg.residual = 0.0;
  dg.status = Status::kOk;
  dg.reason = Reason::kNone;
  dg.bad_index = -1;
  dg.dropped = 0;
}
}  // namespace

bool begin_evaluation(const System& sys, Workspace& ws, const Eigen::VectorXd& q, const Eigen::VectorXd& v) {
  const Model& model = sys.model;
  Diagnostics& dg = ws.diag;
  reset_diagnostics(sys, dg);
  if (!configuration_valid(model, q) || v.size() != model.nv() || !v.allFinite()) {
    fail_evaluation(ws, Reason::kNonFiniteInput);
    return false;
  }
  forward_kinematics(model, ws.data, q, v);
  rnea_bias(model, ws.data);
  crba_compact(model, ws.data);
  int bad = -1;
  if (!tree_cholesky_factor(model, ws.data, 1e-13, &bad)) {
    dg.bad_index = bad;
    fail_evaluation(ws, Reason::kMassMatrixSingular);
    return false;
  }
  constraint_rows(model, ws.data, sys.constraints, q, v, ws.cd,
                  ws.position_errors ? PositionErrors::kFill : PositionErrors::kSkip);
  return true;
}

namespace {

bool tau_valid(const System& sys, const Eigen::VectorXd& tau) { return tau.size() == sys.model.nv() && tau.allFinite(); }

// finish_evaluation() for a tau already checked (tau_valid): evaluate() checks it before the
// kinematics, finish_evaluation() on entry
const Diagnostics& finish_checked(const System& sys, Workspace& ws, const Eigen::VectorXd& v, const Eigen::VectorXd& tau) {
  Diagnostics& dg = ws.diag;
  const int m = sys.constraints.rows;
  reset_diagnostics(sys, dg);
  ws.tau_c = tau - ws.data.h;
  ws.friction_stuck = ws.friction_indeterminate = 0;
  ws.friction_converged = true;
  ws.rest_count = 0;
  if (!ws.damped_dofs.empty() || !ws.friction_dofs.empty()) apply_joint_losses(ws, v);

  if (!solve_formulation(sys, ws, true)) return fail_evaluation(ws, Reason::kPseudoBlockSingular);
  if (ws.rest_count > 0 && !friction_at_rest(sys, ws)) return fail_evaluation(ws, Reason::kPseudoBlockSingular);
  couple_stresses(sys, ws);

  dg.indeterminate = m - dg.rank;
  if (m > 0) {
    // gamma - G vdot over each spec's support (G is zero elsewhere): linear in the specs
    const ConstraintSet& cs = sys.constraints;
    ws.tmp_m = ws.cd.gamma;
    for (size_t s = 0; s < cs.specs.size(); ++s) {
      const int r0 = cs.row_offset[s], nk = cs.row_count[s];
      if (nk == 6) {  // a weld: the six rows in registers, the same multiply-adds in the same order
        Vec6 acc = ws.tmp_m.segment<6>(r0);
        for (int d : cs.support[s]) acc -= ws.cd.G.block<6, 1>(r0, d) * ws.vdot[d];
        ws.tmp_m.segment<6>(r0) = acc;
        continue;
      }
      for (int d : cs.support[s]) {
        const double vd = ws.vdot[d];
        const double* g = ws.cd.G.col(d).data() + r0;
        for (int k = 0; k < nk; ++k) ws.tmp_m[r0 + k] -= g[k] * vd;
      }
    }
    dg.residual = ws.tmp_m.cwiseAbs().maxCoeff();
  }
  if (!ws.vdot.allFinite() || !ws.lambda.allFinite() || !ws.stress.allFinite() || !std::isfinite(dg.residual))
    return fail_evaluation(ws, Reason::kNonFiniteResult);
  if (dg.indeterminate > 0) {
    dg.status = Status::kIndeterminate;
    dg.reason = Reason::kOverconstrained;
  }
  if (sys.options.formulation == Formulation::kSvdBaseline && ws.dropped > 0) {
    dg.dropped = ws.dropped;
    dg.status = Status::kIndeterminate;
    dg.reason = Reason::kSvdDropped;
  }
  return dg;
}

}  // namespace

const Diagnostics& finish_evaluation(const System& sys, Workspace& ws, const Eigen::VectorXd& v, const Eigen::VectorXd& tau) {
  if (!tau_valid(sys, tau)) {
    reset_diagnostics(sys, ws.diag);
    return fail_evaluation(ws, Reason::kNonFiniteInput);
  }
  return finish_checked(sys, ws, v, tau);
}

const Diagnostics& evaluate(const System& sys, Workspace& ws, const Eigen::VectorXd& q, const Eigen::VectorXd& v,
                            const Eigen::VectorXd& tau) {
  if (!tau_valid(sys, tau)) {  // before the kinematics: a bad torque costs nothing
    reset_diagnostics(sys, ws.diag);
    return fail_evaluation(ws, Reason::kNonFiniteInput);
  }
  if (!begin_evaluation(sys, ws, q, v)) return ws.diag;
  return finish_checked(sys, ws, v, tau);
}

Vec6 tip_wrench(const System& sys, const Workspace& ws, int spec, unsigned* indeterminate) {
  const ConstraintSet& cs = sys.constraints;
  Vec6 w = Vec6::Zero();
  unsigned mask = 0;
  const int r0 = cs.row_offset[spec];
  for (int k = 0; k < cs.row_count[spec]; ++k) {
    const int ax = cs.row_axis[spec][k];
    w[ax] = ws.lambda[r0 + k];
    if (ws.qs.row_indeterminate[r0 + k]) mask |= 1u << ax;
  }
  set_rolling_resistance_moment(cs, ws.cd, spec, w.data());
  if (ws.cd.rr_arm[spec] != 0.0 && (mask & (1u << 5))) mask |= 1u << 1;  // it moves with an indeterminate N
  if (indeterminate) *indeterminate = mask;
  return w;
}

}  // namespace coopdyn
