// coopdyn view: one self-contained HTML page with the scene in 3D over the run of a sim CSV.
#include "clients/view/view.h"

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <sstream>
#include <stdexcept>

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>

#include "clients/cli/cli.h"
#include "clients/cli/common.h"
#include "clients/cli/scene_load.h"
#include "clients/csv/step_csv.h"
#include "service/algorithms/kinematics.h"
#include "service/constraints/constraints.h"
#include "service/dynamics/constrained_dynamics.h"
#include "service/dynamics/contacts.h"
#include "service/dynamics/joint_limits.h"
#include "service/dynamics/holding_torque.h"
#include "service/dynamics/wrench_components.h"
#include "service/dynamics/wrenches.h"
#include "service/scene/scene.h"

namespace coopdyn::cli {

namespace {

const char kPage[] =
#include "view_page.inc"
    ;
// the plot of the selected wrench, inlined into the page at /*@PLOT_JS@*/
const char kPlotJs[] =
#include "view_plot.inc"
    ;

// A rotation taking +y to unit vector a (the three.js cylinder's axis to a wheel's axle).
Mat3 y_to(const Vec3& a) {
  return Eigen::Quaterniond::FromTwoVectors(Vec3::UnitY(), a.normalized()).toRotationMatrix();
}

}  // namespace

namespace {

// The shapes drawn whole: each rolling wheel, and each free body as the box of its inertia.
void add_view_shapes(const System& sys, ViewFrames* vf, std::vector<char>& is_shape) {
  const Model& m = sys.model;
  for (const ConstraintSpec& c : sys.constraints.specs) {
    if (c.kind != ConstraintKind::kRolling || c.body < 0 || is_shape[c.body]) continue;
    ViewFrames::Shape s;
    s.name = m.bodies[c.body].name;
    s.kind = "wheel";
    s.body = c.body;
    s.X_BS = Transform(y_to(c.axle), Vec3::Zero());
    s.size = Vec3(c.radius, std::max(0.02, 0.16 * c.radius), 0);
    vf->shapes.push_back(s);
    is_shape[c.body] = 1;
  }
  for (int b = 0; b < m.nbodies(); ++b) {
    const Body& body = m.bodies[b];
    if (is_shape[b] || body.joint.type != JointType::kFloating || !(body.inertia.m > 0)) continue;
    // a free body (a load, a vehicle's platform): the box of uniform density with its inertia
    Eigen::SelfAdjointEigenSolver<Mat3> es(body.inertia.Ic);
    Mat3 R = es.eigenvectors();
    if (R.determinant() < 0) R.col(2) = -R.col(2);
    const Vec3 I = es.eigenvalues();
    Vec3 size;
    for (int i = 0; i < 3; ++i) {
      const double s2 = 6.0 / body.inertia.m * (I[(i + 1) % 3] + I[(i + 2) % 3] - I[i]);
      size[i] = std::max(0.02, std::sqrt(std::max(0.0, s2)));
    }
    ViewFrames::Shape s;
    s.name = body.name;
    s.kind = "box";
    s.body = b;
    s.X_BS = Transform(R, body.inertia.c);
    s.size = size;
    vf->shapes.push_back(s);
    is_shape[b] = 1;
  }
}

// The rolling contacts in the contact report's order (ContactData::spec) and the distinct planes
// they roll on: the scene's `ground`, or a wheel's own.
void add_view_contacts(const System& sys, ViewFrames* vf) {
  const ContactData cd(sys);
  for (int s : cd.spec) {
    const ConstraintSpec& c = sys.constraints.specs[static_cast<size_t>(s)];
    vf->contacts.push_back({c.name, s, c.mu});
    const int k = static_cast<int>(vf->contacts.size()) - 1;
    auto same = [&](const ViewFrames::Ground& g) {
      return (g.n - c.ground_n).norm() < 1e-12 && std::abs(g.d - c.ground_d) < 1e-12;
    };
    auto it = std::find_if(vf->grounds.begin(), vf->grounds.end(), same);
    if (it == vf->grounds.end()) {
      vf->grounds.push_back({c.ground_n, c.ground_d, {}});
      it = vf->grounds.end() - 1;
    }
    it->contacts.push_back(k);
  }
}

}  // namespace

ViewFrames view_geometry(const System& sys, const ViewVisuals* vis) {
  ViewFrames out;
  ViewFrames* vf = &out;
  if (vis) out.visuals = *vis;
  const Model& m = sys.model;
  std::vector<char> is_shape(m.nbodies(), 0);
  add_view_shapes(sys, vf, is_shape);
  // links: from the parent's origin (or the joint's place in the world) to the body's origin, and
  // from a link's origin to the operational frames fixed in it (a cut, a tool point)
  for (int b = 0; b < m.nbodies(); ++b) {
    const Body& body = m.bodies[b];
    ViewFrames::Segment s;
    s.name = body.name;
    s.body_b = b;
    if (body.parent >= 0) {
      s.body_a = body.parent;
    } else {
      if (body.joint.type == JointType::kFloating) continue;
      s.p_a = body.X_PJ.p;
    }
    vf->segments.push_back(s);
  }
  for (const Frame& f : m.frames) {
    if (f.body < 0 || is_shape[f.body] || f.X_BF.p.norm() < 1e-6) continue;
    ViewFrames::Segment s;
    s.name = f.name;
    s.body_a = f.body;
    s.body_b = f.body;
    s.p_b = f.X_BF.p;
    vf->segments.push_back(s);
  }
  for (size_t k = 0; k < sys.wrenches.outputs.size(); ++k)
    if (sys.wrenches.outputs[k].kind != WrenchKind::kJoint) vf->wrenches.push_back(static_cast<int>(k));
  add_view_contacts(sys, vf);
  for (int dof : m.pseudo_dofs) {
    ViewFrames::Pseudo p;
    p.dof = dof;
    p.body = m.dof_body[dof];
    p.name = m.v_names[dof];
    p.unit = m.bodies[p.body].joint.type == JointType::kPrismatic ? "N" : "N*m";
    vf->pseudos.push_back(p);
  }
  // then each joint coupling (<mimic>): its force on the mimicking joint, in Workspace::stress's order
  for (int k = static_cast<int>(m.pseudo_dofs.size()); k < num_stresses(sys); ++k) {
    const std::string name = stress_name(sys, k);
    const auto it = std::find(m.v_names.begin(), m.v_names.end(), name);
    if (it == m.v_names.end()) break;
    ViewFrames::Pseudo p;
    p.dof = static_cast<int>(it - m.v_names.begin());
    p.body = m.dof_body[p.dof];
    p.name = name;
    p.unit = stress_unit(sys, k);
    p.coupling = true;
    vf->pseudos.push_back(p);
  }
  return out;
}

void ViewFrames::clear_frames() {
  t.clear();
  status.clear();
  shape_pose.clear();
  seg_ends.clear();
  body_pose.clear();
  wrench_W.clear();
  wrench_F.clear();
  wrench_sigma.clear();
  wrench_bound.clear();
  wrench_R.clear();
  contact_p.clear();
  contact_u.clear();
  contact_state.clear();
  pseudo_p.clear();
  stress.clear();
  indet.clear();
  free.clear();
  limits.clear();
  note.clear();
}

void add_view_frame(const System& sys, Data& data, ViewSample& row, ViewFrames* vf) {
  const Model& m = sys.model;
  const Eigen::VectorXd v0 = Eigen::VectorXd::Zero(m.nv());
  normalize_configuration(m, row.q);
  forward_kinematics(m, data, row.q, v0);
  vf->t.push_back(row.t);
  vf->status.push_back(row.status);
  std::vector<double> sp, se, ww, wr, bp;
  for (int b : vf->visuals.bodies) {
    const Transform& X = data.X_WB[b];
    const Eigen::Quaterniond qq(X.R);
    bp.insert(bp.end(), {X.p.x(), X.p.y(), X.p.z(), qq.x(), qq.y(), qq.z(), qq.w()});
  }
  const size_t nw = vf->wrenches.size();
  const bool has_sigma = row.sigma.size() == nw && nw > 0, has_bound = row.bound.size() == nw && nw > 0;
  for (const auto& s : vf->shapes) {
    const Transform X = data.X_WB[s.body] * s.X_BS;
    const Eigen::Quaterniond qq(X.R);
    sp.insert(sp.end(), {X.p.x(), X.p.y(), X.p.z(), qq.x(), qq.y(), qq.z(), qq.w()});
  }
  for (const auto& s : vf->segments) {
    const Vec3 a = s.body_a >= 0 ? Vec3(data.X_WB[s.body_a].R * s.p_a + data.X_WB[s.body_a].p) : s.p_a;
    const Vec3 b = s.body_b >= 0 ? Vec3(data.X_WB[s.body_b].R * s.p_b + data.X_WB[s.body_b].p) : s.p_b;
    se.insert(se.end(), {a.x(), a.y(), a.z(), b.x(), b.y(), b.z()});
  }
  for (size_t j = 0; j < vf->wrenches.size(); ++j) {
    // [moment; force] at the report frame's origin in its coordinates -> world coordinates there
    const Transform X = wrench_frame_pose(sys, data, vf->wrenches[j]);
    const Vec3 f = X.R * row.w[j].tail<3>(), mo = X.R * row.w[j].head<3>();
    ww.insert(ww.end(), {X.p.x(), X.p.y(), X.p.z(), f.x(), f.y(), f.z(), mo.x(), mo.y(), mo.z()});
    if (has_sigma || has_bound) {
      const Eigen::Quaterniond qr(X.R);
      wr.insert(wr.end(), {qr.x(), qr.y(), qr.z(), qr.w()});
    }
  }
  std::vector<double> pp;
  for (const auto& p : vf->pseudos) {
    const Vec3& x = data.X_WB[p.body].p;
    pp.insert(pp.end(), {x.x(), x.y(), x.z()});
  }
  std::vector<double> wf, cp;
  for (const Vec6& w : row.w) wf.insert(wf.end(), w.data(), w.data() + 6);
  for (const auto& c : vf->contacts) {
    const Vec3 x = rolling_contact_frame(m, data, sys.constraints.specs[static_cast<size_t>(c.spec)]).p;
    cp.insert(cp.end(), {x.x(), x.y(), x.z()});
  }
  const bool contacts_known = row.contact_u.size() == 2 * vf->contacts.size() && row.contact_state.size() == vf->contacts.size();
  vf->wrench_F.push_back(std::move(wf));
  std::vector<double> wsg, wbd;
  if (has_sigma)
    for (const Vec6& x : row.sigma) wsg.insert(wsg.end(), x.data(), x.data() + 6);
  if (has_bound)
    for (const Vec6& x : row.bound) wbd.insert(wbd.end(), x.data(), x.data() + 6);
  vf->wrench_sigma.push_back(std::move(wsg));
  vf->wrench_bound.push_back(std::move(wbd));
  vf->wrench_R.push_back(std::move(wr));
  vf->contact_p.push_back(std::move(cp));
  vf->contact_u.push_back(contacts_known ? row.contact_u : std::vector<double>{});
  vf->contact_state.push_back(contacts_known ? row.contact_state : std::vector<int>{});
  vf->shape_pose.push_back(std::move(sp));
  vf->seg_ends.push_back(std::move(se));
  vf->body_pose.push_back(std::move(bp));
  vf->wrench_W.push_back(std::move(ww));
  vf->pseudo_p.push_back(std::move(pp));
  // the pseudo-joints' stresses lead (joint couplings' follow; the view draws the pseudo-joints')
  vf->stress.push_back(row.stress.size() >= vf->pseudos.size()
                           ? std::vector<double>(row.stress.begin(), row.stress.begin() + static_cast<long>(vf->pseudos.size()))
                           : std::vector<double>{});
  vf->indet.push_back(row.indet.size() == vf->wrenches.size() ? row.indet : std::vector<int>{});
  vf->free.push_back(row.free);
  vf->limits.push_back(row.limits);
  vf->note.push_back(row.note);
}

ViewFrames view_frames_of(const System& sys, std::vector<ViewSample>& rows, int max_frames, const ViewVisuals* vis) {
  ViewFrames vf = view_geometry(sys, vis);
  // evenly spaced rows, the first and the last always
  const size_t n = rows.size(), keep = std::min(n, static_cast<size_t>(std::max(2, max_frames)));
  std::vector<size_t> pick;
  for (size_t i = 0; i < keep; ++i) {
    const size_t r = keep == 1 ? 0 : static_cast<size_t>(std::llround(static_cast<double>(i) * (n - 1) / (keep - 1)));
    if (pick.empty() || r != pick.back()) pick.push_back(r);
  }
  Data data(sys.model);
  for (size_t r : pick) add_view_frame(sys, data, rows[r], &vf);
  return vf;
}

namespace {
// the columns NAME.<tag>mx .. NAME.<tag>fz of every drawn wrench (need: a column's index, or throws)
template <class Need>
std::vector<std::array<int, 6>> wrench_columns(const System& sys, const ViewFrames& geo, const char* tag, const Need& need) {
  std::vector<std::array<int, 6>> cols;
  for (int k : geo.wrenches) {
    std::array<int, 6> c{};
    for (int j = 0; j < 6; ++j) c[j] = need(sys.wrenches.outputs[k].name + "." + tag + kWrenchComponents[j]);
    cols.push_back(c);
  }
  return cols;
}
// A row's contact report (utilisation, friction needed, state) and the joints' limits it flags.
template <class Num>
void read_report_cells(const std::vector<std::string>& cells, const std::vector<std::string>& head,
                       const std::string& where, const std::vector<std::array<int, 3>>& c_c,
                       const std::vector<std::pair<std::string, int>>& c_lim, const Num& num, ViewSample* r) {
  for (const auto& c : c_c) {
    r->contact_u.push_back(num(c[0]));
    r->contact_u.push_back(num(c[1]));
    const std::string& st = cells[c[2]];
    const int code = st == "ok" ? 0 : st == "slip" ? 1 : st == "lift_off" ? 2 : -1;
    if (code < 0)
      throw std::runtime_error(where + ": unknown contact state '" + st + "' in column '" + head[c[2]] +
                               "' (ok, slip or lift_off)");
    r->contact_state.push_back(code);
  }
  for (const auto& [name, c] : c_lim) {
    const int bits = static_cast<int>(num(c));
    for (int k = 0; k < 3; ++k)
      if (bits & (1 << k))
        r->limits += (r->limits.empty() ? "" : ", ") + name + " " + limit_word(static_cast<LimitBit>(1 << k));
  }
}
}  // namespace

ViewFrames read_view_frames(const System& sys, const std::string& path, int max_frames, const ViewVisuals* vis) {
  const Model& m = sys.model;
  std::ifstream in(path);
  if (!in) throw std::runtime_error("cannot open '" + path + "'");
  std::string line;
  CsvHeader hdr;  // the per-step CSV's comment and units lines, then its header (clients/csv/step_csv.h)
  std::string err;
  if (!read_step_csv_header(in, path, &hdr, &err)) throw std::runtime_error(err + " (expected a `coopdyn sim` CSV)");
  const std::vector<std::string>& head = hdr.names;
  std::map<std::string, int> col;
  for (size_t i = 0; i < head.size(); ++i) col[head[i]] = static_cast<int>(i);
  auto need = [&](const std::string& name) {
    auto it = col.find(name);
    if (it == col.end())
      throw std::runtime_error(path + ":" + std::to_string(hdr.line_no) + ": no column '" + name + "', which scene '" + sys.name +
                               "' needs: is this a `coopdyn sim` CSV of that scene?");
    return it->second;
  };
  const int c_t = need("t"), c_status = need("status");
  std::vector<int> c_q;
  for (const auto& n : m.q_names) c_q.push_back(need("q:" + n));
  for (const auto& h : head)
    if (h.rfind("q:", 0) == 0 && std::find(m.q_names.begin(), m.q_names.end(), h.substr(2)) == m.q_names.end())
      throw std::runtime_error(path + ":" + std::to_string(hdr.line_no) + ": column '" + h + "' is not a coordinate of scene '" + sys.name +
                               "': the CSV was written for another scene");
  const ViewFrames geo = view_geometry(sys);
  const std::vector<std::array<int, 6>> c_w = wrench_columns(sys, geo, "", need);
  // each wrench's sigma and friction bound, when the CSV has them (clients/csv/step_csv.h): all of
  // them or none
  auto has = [&](const char* tag) {
    return !geo.wrenches.empty() && col.count(sys.wrenches.outputs[geo.wrenches[0]].name + "." + tag + "mx") > 0;
  };
  const std::vector<std::array<int, 6>> c_sigma = has("sigma_") ? wrench_columns(sys, geo, "sigma_", need) : std::vector<std::array<int, 6>>{};
  const std::vector<std::array<int, 6>> c_bound = has("bound_") ? wrench_columns(sys, geo, "bound_", need) : std::vector<std::array<int, 6>>{};

  // the contact report of each wheel (clients/cli/sim.cc writes it for every rolling contact)
  std::vector<std::array<int, 3>> c_c;
  for (const auto& c : geo.contacts)
    c_c.push_back({need(c.name + ".utilisation"), need(c.name + ".friction_needed"), need(c.name + ".contact")});
  // the joints' limits exceeded (limit:NAME, bits 1 position, 2 velocity, 4 effort), when the CSV has them
  std::vector<std::pair<std::string, int>> c_lim;
  for (size_t i = 0; i < head.size(); ++i)
    if (head[i].rfind("limit:", 0) == 0) c_lim.emplace_back(head[i].substr(6), static_cast<int>(i));

  std::vector<ViewSample> rows;
  int ln = hdr.line_no;
  while (std::getline(in, line)) {
    ++ln;
    if (line.empty()) continue;
    const std::vector<std::string> cells = split_csv_line(line);
    const std::string where = path + ":" + std::to_string(ln);
    if (cells.size() != head.size())
      throw std::runtime_error(where + ": " + std::to_string(cells.size()) + " columns, the header has " +
                               std::to_string(head.size()));
    auto num = [&](int c) {
      try {
        size_t pos = 0;
        const double x = std::stod(cells[c], &pos);
        if (pos != cells[c].size()) throw std::invalid_argument("");
        return x;
      } catch (const std::exception&) {
        throw std::runtime_error(where + ": bad number '" + cells[c] + "' in column '" + head[c] + "'");
      }
    };
    ViewSample r;
    r.t = num(c_t);
    r.status = cells[c_status];
    if (r.status != "ok" && r.status != "indeterminate" && r.status != "error")
      throw std::runtime_error(where + ": unknown status '" + r.status + "'");
    r.q.resize(m.nq());
    for (int i = 0; i < m.nq(); ++i) r.q[i] = num(c_q[i]);
    auto wrenches6 = [&](const std::vector<std::array<int, 6>>& cols, std::vector<Vec6>* out) {
      for (const auto& c : cols) {
        Vec6 w;
        for (int j = 0; j < 6; ++j) w[j] = num(c[j]);
        out->push_back(w);
      }
    };
    wrenches6(c_w, &r.w);
    wrenches6(c_sigma, &r.sigma);
    wrenches6(c_bound, &r.bound);
    read_report_cells(cells, head, where, c_c, c_lim, num, &r);
    if (!configuration_valid(m, r.q)) throw std::runtime_error(where + ": not a valid configuration of scene '" + sys.name + "'");
    rows.push_back(std::move(r));
  }
  if (rows.empty()) throw std::runtime_error(path + ": no rows after the header");
  return view_frames_of(sys, rows, max_frames, vis);
}

namespace {


void jnum(std::string& o, double x, const char* fmt = "%.6g") {
  if (!std::isfinite(x)) {
    o += "0";
    return;
  }
  char buf[32];
  std::snprintf(buf, sizeof buf, fmt, x);
  o += buf;
}

void jvec(std::string& o, const double* x, size_t n, const char* fmt = "%.6g") {
  o += '[';
  for (size_t i = 0; i < n; ++i) {
    if (i) o += ',';
    jnum(o, x[i], fmt);
  }
  o += ']';
}

// the source's numbers as they are: shortest round-trip (the page's plot and contact report show
// what the CSV or the message said, to the last bit)
void jexact(std::string& o, const std::vector<double>& x) {
  o += '[';
  char buf[32];
  for (size_t i = 0; i < x.size(); ++i) {
    if (i) o += ',';
    if (!std::isfinite(x[i])) {
      o += '0';
      continue;
    }
    o.append(buf, std::to_chars(buf, buf + sizeof buf, x[i]).ptr);
  }
  o += ']';
}

void jints(std::string& o, const std::vector<int>& x) {
  o += '[';
  for (size_t i = 0; i < x.size(); ++i) o += (i ? "," : "") + std::to_string(x[i]);
  o += ']';
}

// the smallest of 1, 2, 5 x 10^k that is >= x
double nice_ceil(double x) {
  if (!(x > 0) || !std::isfinite(x)) return 1.0;
  const double e = std::pow(10.0, std::floor(std::log10(x)));
  for (double m : {1.0, 2.0, 5.0, 10.0})
    if (m * e >= x * (1 - 1e-12)) return m * e;
  return 10 * e;
}

std::string replace_once(std::string s, const std::string& key, const std::string& value) {
  const size_t at = s.find(key);
  if (at == std::string::npos) throw std::logic_error("view page template lacks " + key);
  return s.replace(at, key.size(), value);
}

}  // namespace

std::string view_frame_json(const ViewFrames& vf, size_t i) {
  std::string d = "{\"t\":";
  jnum(d, vf.t[i], "%.9g");
  d += ",\"status\":" + json_string(vf.status[i]) + ",\"sp\":";
  jvec(d, vf.shape_pose[i].data(), vf.shape_pose[i].size());
  d += ",\"seg\":";
  jvec(d, vf.seg_ends[i].data(), vf.seg_ends[i].size());
  d += ",\"bp\":";
  jvec(d, vf.body_pose[i].data(), vf.body_pose[i].size(), "%.9g");
  d += ",\"w\":";
  jvec(d, vf.wrench_W[i].data(), vf.wrench_W[i].size());
  d += ",\"pj\":";
  jvec(d, vf.pseudo_p[i].data(), vf.pseudo_p[i].size());
  d += ",\"stress\":";
  jvec(d, vf.stress[i].data(), vf.stress[i].size(), "%.9g");
  d += ",\"indet\":";
  jints(d, vf.indet[i]);
  d += ",\"free\":" + json_string(vf.free[i]);
  d += ",\"note\":" + json_string(vf.note[i]);
  d += ",\"wf\":";
  jexact(d, vf.wrench_F[i]);
  d += ",\"ws\":";
  jexact(d, vf.wrench_sigma[i]);
  d += ",\"wb\":";
  jexact(d, vf.wrench_bound[i]);
  d += ",\"wr\":";
  jvec(d, vf.wrench_R[i].data(), vf.wrench_R[i].size(), "%.9g");
  d += ",\"cp\":";
  jvec(d, vf.contact_p[i].data(), vf.contact_p[i].size());
  d += ",\"cu\":";
  jexact(d, vf.contact_u[i]);
  d += ",\"cs\":";
  jints(d, vf.contact_state[i]);
  return d + "}";
}

namespace {

// An axis-aligned box grown point by point; empty (lo > hi) before the first.
struct Box {
  Vec3 lo = Vec3::Constant(std::numeric_limits<double>::infinity());
  Vec3 hi = Vec3::Constant(-std::numeric_limits<double>::infinity());
  void grow(const Vec3& p, double r) {
    lo = lo.cwiseMin(p - Vec3::Constant(r));
    hi = hi.cwiseMax(p + Vec3::Constant(r));
  }
  bool empty() const { return !(lo.array() <= hi.array()).all(); }
};

// The extent of the bodies over the run (a wheel: its radius about its centre; a box: half its
// longest edge), the links' ends and the wrenches' origins; a point at the origin when none.
Box bodies_extent(const ViewFrames& vf) {
  Box b;
  for (size_t i = 0; i < vf.t.size(); ++i) {
    for (size_t s = 0; s < vf.shapes.size(); ++s) {
      const Vec3 p(vf.shape_pose[i][7 * s], vf.shape_pose[i][7 * s + 1], vf.shape_pose[i][7 * s + 2]);
      const Vec3& z = vf.shapes[s].size;
      b.grow(p, vf.shapes[s].kind == "wheel" ? z[0] : 0.5 * z.maxCoeff());
    }
    for (size_t s = 0; s < vf.segments.size(); ++s)
      for (int e = 0; e < 2; ++e) b.grow(Vec3(vf.seg_ends[i][6 * s + 3 * e], vf.seg_ends[i][6 * s + 3 * e + 1], vf.seg_ends[i][6 * s + 3 * e + 2]), 0);
    for (size_t w = 0; w < vf.wrenches.size(); ++w) b.grow(Vec3(vf.wrench_W[i][9 * w], vf.wrench_W[i][9 * w + 1], vf.wrench_W[i][9 * w + 2]), 0);
  }
  if (b.empty()) b.lo = b.hi = Vec3::Zero();
  return b;
}

struct ArrowScales {
  double force, moment;  // N (N*m) per metre of arrow
};

// The largest force (moment) over the run is at most 0.4 of the scene's size.
ArrowScales arrow_scales(const ViewFrames& vf, double size) {
  double fmax = 0, mmax = 0;
  for (const auto& ww : vf.wrench_W)
    for (size_t w = 0; w < vf.wrenches.size(); ++w) {
      fmax = std::max(fmax, Vec3(ww[9 * w + 3], ww[9 * w + 4], ww[9 * w + 5]).norm());
      mmax = std::max(mmax, Vec3(ww[9 * w + 6], ww[9 * w + 7], ww[9 * w + 8]).norm());
    }
  return {nice_ceil(fmax / (0.4 * size)), nice_ceil(mmax / (0.4 * size))};
}

// The arrows in view too: their tips grow the box.
void grow_by_arrows(const ViewFrames& vf, const ArrowScales& scale, Box* b) {
  for (size_t i = 0; i < vf.t.size(); ++i)
    for (size_t w = 0; w < vf.wrenches.size(); ++w) {
      const double* x = &vf.wrench_W[i][9 * w];
      const Vec3 o(x[0], x[1], x[2]);
      b->grow(o + Vec3(x[3], x[4], x[5]) / scale.force, 0);
      b->grow(o + Vec3(x[6], x[7], x[8]) / scale.moment, 0);
    }
}

struct GroundOut {  // a grid the page draws: origin, normal, an in-plane axis, edge length
  Vec3 o, n, e1;
  double size;
};

Vec3 in_plane_axis(const Vec3& n) {  // the world axis least along n, made normal to it
  int a = 0;
  for (int k = 1; k < 3; ++k)
    if (std::abs(n[k]) < std::abs(n[a]) - 1e-12) a = k;
  const Vec3 e = Vec3::Unit(a) - n[a] * n;
  return Vec3(e.normalized());
}

// Each plane the wheels roll on as declared (the scene's `ground`, a wheel's own), a grid in that
// plane about the scene's centre (a wheel's own plane: about its wheels' contacts, over the run).
std::vector<GroundOut> wheel_grounds(const System& sys, const ViewFrames& vf, const Vec3& centre, double radius) {
  std::vector<GroundOut> grounds;
  size_t main_plane = 0;
  for (size_t g = 0; g < vf.grounds.size(); ++g)
    if (vf.grounds[g].contacts.size() > vf.grounds[main_plane].contacts.size()) main_plane = g;
  for (size_t g = 0; g < vf.grounds.size(); ++g) {
    const ViewFrames::Ground& gr = vf.grounds[g];
    Vec3 c = centre;
    double gsize = nice_ceil(2.5 * radius);
    if (g != main_plane) {
      Box cb;
      double r = 0;
      for (int k : gr.contacts) {
        r = std::max(r, sys.constraints.specs[static_cast<size_t>(vf.contacts[k].spec)].radius);
        for (const auto& cp : vf.contact_p) cb.grow(Vec3(cp[3 * k], cp[3 * k + 1], cp[3 * k + 2]), 0);
      }
      if (!cb.empty()) {
        c = 0.5 * (cb.lo + cb.hi);
        gsize = nice_ceil((cb.hi - cb.lo).norm() + 8 * r);
      }
    }
    grounds.push_back({c - (gr.n.dot(c) - gr.d) * gr.n, gr.n, in_plane_axis(gr.n), gsize});
  }
  return grounds;
}

// Without wheels: a plane normal to gravity below everything.
GroundOut ground_below(const Box& b, const Vec3& up, const Vec3& centre, double size, double radius) {
  double lowest = std::numeric_limits<double>::infinity();
  for (int c = 0; c < 8; ++c) {
    const Vec3 p((c & 1) ? b.hi.x() : b.lo.x(), (c & 2) ? b.hi.y() : b.lo.y(), (c & 4) ? b.hi.z() : b.lo.z());
    lowest = std::min(lowest, p.dot(up));
  }
  const double ground_h = lowest - 0.05 * size;
  return {centre - (centre.dot(up) - ground_h) * up, up, in_plane_axis(up), nice_ceil(2.5 * radius)};
}

// The camera: along the world axis (normal to up) in which the scene is thinnest, a little from the
// side and above; the page moves it back to fit the window.
Vec3 view_direction(const Vec3& up, const Box& b) {
  int axes[3] = {0, 1, 2};
  std::sort(axes, axes + 3, [&](int a, int c) { return std::abs(up[a]) < std::abs(up[c]); });
  int thin = axes[0], other = axes[1];
  if ((b.hi - b.lo)[other] < (b.hi - b.lo)[thin]) std::swap(thin, other);
  const Vec3 e_thin = Vec3::Unit(thin), e_other = Vec3::Unit(other);
  const double sgn = up.cross(e_thin).dot(e_other) >= 0 ? 1.0 : -1.0;
  return (sgn * e_thin + 0.45 * e_other + 0.5 * up).normalized();
}

// Where the page puts the scene: its size (the bodies' extent), centre and radius (the arrows'
// too), the arrows' scales, the grounds and the camera.
struct PageLayout {
  Vec3 up, centre, view_dir;
  double size, radius;
  ArrowScales scale;
  std::vector<GroundOut> grounds;
};

PageLayout page_layout(const System& sys, const ViewFrames& vf) {
  PageLayout l;
  const Vec3 up = -sys.model.gravity_W;
  l.up = up.norm() > 0 ? Vec3(up.normalized()) : Vec3(Vec3::UnitZ());
  Box b = bodies_extent(vf);
  l.size = std::max(0.2, (b.hi - b.lo).norm());
  l.scale = arrow_scales(vf, l.size);
  grow_by_arrows(vf, l.scale, &b);
  l.centre = 0.5 * (b.lo + b.hi);
  l.radius = 0.5 * std::max(0.2, (b.hi - b.lo).norm());
  l.grounds = wheel_grounds(sys, vf, l.centre, l.radius);
  if (l.grounds.empty()) l.grounds.push_back(ground_below(b, l.up, l.centre, l.size, l.radius));
  l.view_dir = view_direction(l.up, b);
  return l;
}

// "size" .. "moment_scale": the layout's numbers.
void append_layout_json(std::string& d, const PageLayout& l) {
  jnum(d, l.size);
  d += ",\"up\":";
  jvec(d, l.up.data(), 3);
  d += ",\"centre\":";
  jvec(d, l.centre.data(), 3);
  d += ",\"radius\":";
  jnum(d, l.radius);
  d += ",\"view_dir\":";
  jvec(d, l.view_dir.data(), 3);
  d += ",\"fov\":40,\"grounds\":[";
  for (size_t g = 0; g < l.grounds.size(); ++g) {
    d += g ? ",{\"origin\":" : "{\"origin\":";
    jvec(d, l.grounds[g].o.data(), 3, "%.9g");
    d += ",\"normal\":";
    jvec(d, l.grounds[g].n.data(), 3, "%.17g");
    d += ",\"e1\":";
    jvec(d, l.grounds[g].e1.data(), 3, "%.17g");
    d += ",\"size\":";
    jnum(d, l.grounds[g].size);
    d += "}";
  }
  d += "],\"link_radius\":";
  jnum(d, std::clamp(0.012 * l.size, 0.004, 0.04));
  d += ",\"force_scale\":";
  jnum(d, l.scale.force);
  d += ",\"moment_scale\":";
  jnum(d, l.scale.moment);
}

// "shapes" .. "pseudos": what the page draws, by name.
void append_parts_json(std::string& d, const System& sys, const ViewFrames& vf) {
  d += ",\"shapes\":[";
  for (size_t s = 0; s < vf.shapes.size(); ++s) {
    d += (s ? ",{\"name\":" : "{\"name\":") + json_string(vf.shapes[s].name) + ",\"kind\":" + json_string(vf.shapes[s].kind) + ",\"size\":";
    jvec(d, vf.shapes[s].size.data(), 3);
    d += "}";
  }
  d += "],\"segments\":[";
  for (size_t s = 0; s < vf.segments.size(); ++s) d += (s ? "," : "") + json_string(vf.segments[s].name);
  d += "],\"wrenches\":[";
  for (size_t w = 0; w < vf.wrenches.size(); ++w) {
    const WrenchOutput& o = sys.wrenches.outputs[vf.wrenches[w]];
    d += (w ? ",{\"name\":" : "{\"name\":") + json_string(o.name) + ",\"kind\":" + json_string(wrench_kind_name(o.kind)) +
         ",\"frame\":" + json_string(o.frame) + ",\"by\":" + json_string(o.by) + "}";
  }
  d += "],\"contacts\":[";
  for (size_t k = 0; k < vf.contacts.size(); ++k) {
    const ViewFrames::Contact& c = vf.contacts[k];
    const int body = sys.constraints.specs[static_cast<size_t>(c.spec)].body;
    int shape = -1;
    for (size_t s = 0; s < vf.shapes.size(); ++s)
      if (vf.shapes[s].body == body && vf.shapes[s].kind == "wheel") shape = static_cast<int>(s);
    d += (k ? ",{\"name\":" : "{\"name\":") + json_string(c.name) + ",\"mu\":";
    jnum(d, c.mu, "%.17g");
    d += ",\"shape\":" + std::to_string(shape) + ",\"radius\":";
    jnum(d, sys.constraints.specs[static_cast<size_t>(c.spec)].radius);
    d += ",\"normal\":";
    jvec(d, sys.constraints.specs[static_cast<size_t>(c.spec)].ground_n.data(), 3, "%.17g");
    d += "}";
  }
  d += "],\"pseudos\":[";
  for (size_t k = 0; k < vf.pseudos.size(); ++k)
    d += (k ? ",{\"name\":" : "{\"name\":") + json_string(vf.pseudos[k].name) + ",\"unit\":" + json_string(vf.pseudos[k].unit) +
         ",\"coupling\":" + (vf.pseudos[k].coupling ? "true}" : "false}");
}

std::string base64(const std::string& in) {
  static const char* k = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  out.reserve((in.size() + 2) / 3 * 4);
  for (size_t i = 0; i < in.size(); i += 3) {
    const unsigned n = static_cast<unsigned char>(in[i]) << 16 |
                       (i + 1 < in.size() ? static_cast<unsigned char>(in[i + 1]) << 8 : 0u) |
                       (i + 2 < in.size() ? static_cast<unsigned char>(in[i + 2]) : 0u);
    out += k[n >> 18 & 63];
    out += k[n >> 12 & 63];
    out += i + 1 < in.size() ? k[n >> 6 & 63] : '=';
    out += i + 2 < in.size() ? k[n & 63] : '=';
  }
  return out;
}

// "visuals", "vbodies", "meshes" (each mesh file once, base64) and "seg_vb" (each segment's body
// among vbodies, -1: none, -2: a link the URDF draws nothing for; the page hides the capsule of a
// body whose visuals all drew, and of -2).
void append_visuals_json(std::string& d, const System& sys, const ViewFrames& vf) {
  const ViewVisuals& vis = vf.visuals;
  std::map<std::string, int> mesh_of;
  std::vector<std::string> files;
  d += "],\"visuals\":[";
  for (size_t k = 0; k < vis.visuals.size(); ++k) {
    const ViewVisual& v = vis.visuals[k];
    int mesh = -1;
    if (!v.file.empty()) {
      auto it = mesh_of.find(v.file);
      if (it == mesh_of.end()) it = mesh_of.emplace(v.file, static_cast<int>(files.size())).first, files.push_back(v.file);
      mesh = it->second;
    }
    const Eigen::Quaterniond q(v.X_BV.R);
    const double X[7] = {v.X_BV.p.x(), v.X_BV.p.y(), v.X_BV.p.z(), q.x(), q.y(), q.z(), q.w()};
    d += (k ? ",{\"link\":" : "{\"link\":") + json_string(v.link) + ",\"kind\":" + json_string(v.kind) + ",\"uri\":" +
         json_string(v.uri) + ",\"body\":" + std::to_string(v.body) + ",\"mesh\":" + std::to_string(mesh) + ",\"X\":";
    jvec(d, X, 7, "%.9g");
    d += ",\"size\":";
    jvec(d, v.size.data(), 3, "%.9g");
    d += ",\"scale\":";
    jvec(d, v.scale.data(), 3, "%.9g");
    d += ",\"rgba\":";
    jvec(d, v.rgba.data(), 4, "%.4g");
    d += "}";
  }
  d += "],\"vbodies\":[";
  for (size_t b = 0; b < vis.bodies.size(); ++b) d += (b ? "," : "") + json_string(sys.model.bodies[vis.bodies[b]].name);
  d += "],\"meshes\":[";
  for (size_t f = 0; f < files.size(); ++f) {
    std::ifstream in(files[f], std::ios::binary);
    std::ostringstream ss;
    ss << in.rdbuf();
    std::string ext = std::filesystem::path(files[f]).extension().string();
    std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
    d += (f ? ",{\"file\":" : "{\"file\":") + json_string(files[f]) + ",\"ext\":" + json_string(ext) + ",\"data\":\"" +
         (in ? base64(ss.str()) : std::string()) + "\"}";
  }
  d += "],\"seg_vb\":[";
  for (size_t s = 0; s < vf.segments.size(); ++s) {
    const int body = vf.segments[s].body_b;
    const auto it = std::find(vis.bodies.begin(), vis.bodies.end(), body);
    const bool bare = std::find(vis.bare.begin(), vis.bare.end(), body) != vis.bare.end();
    d += (s ? "," : "") + std::to_string(it != vis.bodies.end() ? static_cast<int>(it - vis.bodies.begin()) : bare ? -2 : -1);
  }
}

// "t" .. "contact_state": one array over the frames per key.
void append_frames_json(std::string& d, const ViewFrames& vf) {
  d += "],\"t\":";
  jvec(d, vf.t.data(), vf.t.size(), "%.9g");
  d += ",\"status\":[";
  for (size_t i = 0; i < vf.status.size(); ++i) d += (i ? "," : "") + json_string(vf.status[i]);
  // key, then write(i) appends frame i's value
  auto per_frame = [&](const char* key, const auto& write) {
    d += key;
    for (size_t i = 0; i < vf.t.size(); ++i) {
      if (i) d += ',';
      write(i);
    }
  };
  per_frame("],\"shape_pose\":[", [&](size_t i) { jvec(d, vf.shape_pose[i].data(), vf.shape_pose[i].size()); });
  per_frame("],\"seg\":[", [&](size_t i) { jvec(d, vf.seg_ends[i].data(), vf.seg_ends[i].size()); });
  per_frame("],\"bp\":[", [&](size_t i) { jvec(d, vf.body_pose[i].data(), vf.body_pose[i].size(), "%.9g"); });
  per_frame("],\"wrench\":[", [&](size_t i) { jvec(d, vf.wrench_W[i].data(), vf.wrench_W[i].size()); });
  per_frame("],\"pj\":[", [&](size_t i) { jvec(d, vf.pseudo_p[i].data(), vf.pseudo_p[i].size()); });
  per_frame("],\"stress\":[", [&](size_t i) { jvec(d, vf.stress[i].data(), vf.stress[i].size(), "%.9g"); });
  per_frame("],\"indet\":[", [&](size_t i) { jints(d, vf.indet[i]); });
  per_frame("],\"free\":[", [&](size_t i) { d += json_string(vf.free[i]); });
  per_frame("],\"limits\":[", [&](size_t i) { d += json_string(vf.limits[i]); });
  per_frame("],\"note\":[", [&](size_t i) { d += json_string(vf.note[i]); });
  per_frame("],\"wrench_F\":[", [&](size_t i) { jexact(d, vf.wrench_F[i]); });
  per_frame("],\"wrench_sigma\":[", [&](size_t i) { jexact(d, vf.wrench_sigma[i]); });
  per_frame("],\"wrench_bound\":[", [&](size_t i) { jexact(d, vf.wrench_bound[i]); });
  per_frame("],\"wrench_R\":[", [&](size_t i) { jvec(d, vf.wrench_R[i].data(), vf.wrench_R[i].size(), "%.9g"); });
  per_frame("],\"contact_p\":[", [&](size_t i) { jvec(d, vf.contact_p[i].data(), vf.contact_p[i].size()); });
  per_frame("],\"contact_u\":[", [&](size_t i) { jexact(d, vf.contact_u[i]); });
  per_frame("],\"contact_state\":[", [&](size_t i) { jints(d, vf.contact_state[i]); });
  d += "]}";
}

// The page template with the data, three.js and the plot's script in their places.
std::string fill_page(const std::string& data, const std::string& three_js, const std::string& loaders) {
  // three.js inline: a "</script" in it would end the element early
  auto inline_js = [](std::string js) {
    for (size_t at = 0; (at = js.find("</script", at)) != std::string::npos; at += 2) js.replace(at, 2, "<\\/");
    return js;
  };
  std::string page = kPage;
  page = replace_once(page, "/*@VIEW_DATA@*/", data);
  page = replace_once(page, "/*@PLOT_JS@*/", kPlotJs);
  page = replace_once(page, "/*@LOADERS_JS@*/", inline_js(loaders));
  page = replace_once(page, "/*@THREE_JS@*/", inline_js(three_js));
  return page;
}

}  // namespace

std::string view_page(const System& sys, const ViewFrames& vf, const std::string& three_js, const std::string& source,
                      bool live, const std::string& loaders) {
  const PageLayout layout = page_layout(sys, vf);
  std::string d;
  d.reserve(vf.t.size() * (vf.shapes.size() * 7 + vf.segments.size() * 6 + vf.wrenches.size() * 9) * 11 + 4096);
  d += "{\"scene\":" + json_string(sys.name) + ",\"source\":" + json_string(source) + ",\"live\":" + (live ? "true" : "false") +
       ",\"size\":";
  append_layout_json(d, layout);
  append_parts_json(d, sys, vf);
  append_visuals_json(d, sys, vf);
  append_frames_json(d, vf);
  const bool meshes = std::any_of(vf.visuals.visuals.begin(), vf.visuals.visuals.end(), [](const ViewVisual& v) { return !v.file.empty(); });
  return fill_page(d, three_js, meshes ? loaders : std::string());
}

bool read_three_js(const std::string& three_path, std::string* three) {
  std::ifstream f(three_path, std::ios::binary);
  if (!f) {
    std::fprintf(stderr,
                 "coopdyn view: cannot read three.js at '%s' (Debian: apt-get install libjs-three; or give its path "
                 "with --three-js FILE)\n",
                 three_path.c_str());
    return false;
  }
  std::ostringstream ss;
  ss << f.rdbuf();
  *three = ss.str();
  if (three->find("WebGLRenderer") == std::string::npos) {
    std::fprintf(stderr, "coopdyn view: '%s' is not three.js (no WebGLRenderer in it)\n", three_path.c_str());
    return false;
  }
  return true;
}

std::string read_three_loaders(const std::string& three_path, std::string* why) {
  // three.min.js beside examples/ (Debian's /usr/share/javascript/three/) or in build/ beside it
  const std::filesystem::path up = std::filesystem::path(three_path).parent_path();
  std::filesystem::path dir = up / "examples" / "js" / "loaders";
  std::error_code ec;
  if (!std::filesystem::is_directory(dir, ec)) dir = up.parent_path() / "examples" / "js" / "loaders";
  std::string out;
  for (const char* name : {"STLLoader.js", "ColladaLoader.js", "OBJLoader.js"}) {
    std::ifstream f(dir / name, std::ios::binary);
    if (!f) {
      *why = "three.js's " + std::string(name) + " not found in '" + dir.string() +
             "' (Debian: apt-get install libjs-three): meshes drawn as capsules";
      return "";
    }
    std::ostringstream ss;
    ss << f.rdbuf();
    out += ss.str() + "\n";
  }
  return out;
}

namespace {
// --scene alone: the scene's initial state, at rest, with zero torque or (hold) the holding torques,
// evaluated once: its wrenches, status, stresses and contact report as the daemon would publish them.
bool scene_sample(const System& sys, const ViewFrames& geo, bool hold, ViewSample* s) {
  Eigen::VectorXd q = sys.q0, v = Eigen::VectorXd::Zero(sys.model.nv()), tau = Eigen::VectorXd::Zero(sys.model.nv());
  if (hold) {
    HoldWorkspace hw(sys, default_actuated(sys));
    Eigen::VectorXd th(sys.model.nv());
    bool said = false;
    if (!holding_torques("view", sys, hw, q, v, th, &said)) return false;
    tau += th;
  }
  Workspace ws(sys);
  const Diagnostics& d = evaluate(sys, ws, q, v, tau);
  WrenchData wd(sys);
  compute_wrenches(sys, ws, wd);
  s->t = 0;
  s->status = status_name(d.status);
  s->q = q;
  for (int k : geo.wrenches) {
    s->w.push_back(wd.W[static_cast<size_t>(k)]);
    s->indet.push_back(wd.indeterminate[static_cast<size_t>(k)]);
  }
  s->stress.assign(ws.stress.data(), ws.stress.data() + ws.stress.size());
  ContactData cts(sys);
  compute_contacts(sys, ws, cts);
  for (size_t k = 0; k < geo.contacts.size(); ++k) {
    s->contact_u.push_back(cts.utilisation[k]);
    s->contact_u.push_back(cts.friction_needed[k]);
    s->contact_state.push_back(static_cast<int>(cts.state[k]));
  }
  return true;
}
}  // namespace

void register_view(Cli& cli) {
  auto [c, a] = cli.add("view", cmd_view);
  scene_options(c, a, true);
  CLI::Option* csv = value(c, "--csv", a.csv, "SIM.csv", "the run: a 'coopdyn sim --out' CSV of the same scene");
  CLI::Option* log = value(c, "--log", a.log, "RUN.lcmlog", "the run: an lcm-logger log of coopdynd running the same scene");
  CLI::Option* live = flag(c, "--live", a.live, "serve a live page fed from the daemon's LCM outputs (until SIGINT/SIGTERM)");
  csv->excludes(log)->excludes(live);
  log->excludes(live);
  value(c, "--out", a.out, "VIEW.html", "the page to write (--csv, --log)");
  value(c, "--channel", a.channel, "NAME", "the output_t channel (--log, --live)", Default::kShown);
  number(c, "--max-frames", a.max_frames, "N", "frames kept, evenly spaced (first and last always; --csv, --log)",
         Default::kShown);
  value(c, "--listen", a.listen, "HOST:PORT", "--live: the address to serve the page and its WebSocket on", Default::kShown);
  value(c, "--lcm-url", a.lcm_url, "URL", "--live: the LCM URL of the daemon's outputs", Default::kShown);
  number(c, "--rate", a.rate, "HZ", "--live: frames sent to the page per second at most (the rest are skipped)",
         Default::kShown);
  number(c, "--queue", a.queue, "N", "--live: frames queued per client at most; a client that falls behind loses the oldest",
         Default::kShown);
  value(c, "--three-js", a.three_js, "FILE", "three.js to inline (Debian libjs-three)", Default::kShown);
  flag(c, "--capsules", a.capsules, "draw links as capsules, not the URDFs' <visual>s (a smaller page)");
  flag(c, "--hold", a.hold, "without a run: the wrenches with the holding torques (default: zero torque)");
  repeated(c, "--package-path", a.package_path, "DIR",
           "where a URDF's package://NAME/... meshes are found (as DIR/NAME/...; also the URDF's folder and ROS_PACKAGE_PATH)");
}

int cmd_view(const ViewArgs& a) {
  const int sources = a.csv.has_value() + a.log.has_value() + a.live;
  if (sources > 1 || (!a.live && !a.out)) {
    std::fprintf(stderr,
                 "coopdyn view: --scene FILE and one of --out VIEW.html (the scene alone), --csv SIM.csv --out VIEW.html, "
                 "--log RUN.lcmlog --out VIEW.html or --live are required\n");
    return 2;
  }
  if (a.hold && sources) {
    std::fprintf(stderr, "coopdyn view: --hold is for the scene alone (without --csv, --log or --live)\n");
    return 2;
  }
  System sys;
  if (const int rc = load_cli_scene(a, "view", &sys)) return rc;
  const int max_frames = a.max_frames;
  if (max_frames < 2) {
    std::fprintf(stderr, "coopdyn view: --max-frames must be an integer >= 2\n");
    return 2;
  }
  std::string three;
  if (!read_three_js(a.three_js, &three)) return 1;
  // the robots' own visuals: what cannot be drawn is said once, and drawn as a capsule
  const ViewVisuals vis = a.capsules ? ViewVisuals{} : read_view_visuals(sys, *a.scene, a.package_path);
  for (const std::string& w : vis.warnings) std::fprintf(stderr, "coopdyn view: warning: %s\n", w.c_str());
  std::string loaders, why;
  if (std::any_of(vis.visuals.begin(), vis.visuals.end(), [](const ViewVisual& v) { return !v.file.empty(); })) {
    loaders = read_three_loaders(a.three_js, &why);
    if (!why.empty()) std::fprintf(stderr, "coopdyn view: warning: %s\n", why.c_str());
  }
  const std::string channel = a.channel;
  if (a.live) {
    const double rate = a.rate;
    const int queue = a.queue;
    if (!(rate > 0) || queue < 1) {
      std::fprintf(stderr, "coopdyn view: --rate must be > 0 and --queue >= 1\n");
      return 2;
    }
    return run_view_live(sys, vis, three, loaders, a.listen, a.lcm_url, channel,
                         rate, queue);
  }
  std::string page;
  try {
    ViewFrames vf;
    std::string source;
    if (a.csv) {
      source = *a.csv;
      vf = read_view_frames(sys, source, max_frames, &vis);
    } else if (!a.log) {
      source = std::string("the scene at rest, ") + (a.hold ? "holding torques" : "zero torque");
      vf = view_geometry(sys, &vis);
      ViewSample s;
      if (!scene_sample(sys, vf, a.hold, &s)) return 1;
      Data data(sys.model);
      add_view_frame(sys, data, s, &vf);
    } else {
      source = *a.log;
      std::vector<ViewSample> samples = read_log_samples(sys, source, channel);
      vf = view_frames_of(sys, samples, max_frames, &vis);
    }
    page = view_page(sys, vf, three, source, false, loaders);
    std::fprintf(stderr, "coopdyn view: %zu frames (t %g .. %g s), %zu shapes, %zu links, %zu wrenches\n", vf.t.size(),
                 vf.t.front(), vf.t.back(), vf.shapes.size(), vf.segments.size(), vf.wrenches.size());
  } catch (const std::runtime_error& e) {
    std::fprintf(stderr, "coopdyn view: %s\n", e.what());
    return 1;
  }
  std::FILE* out = std::fopen(a.out->c_str(), "wb");
  bool ok = out != nullptr;
  if (out) {
    ok = std::fwrite(page.data(), 1, page.size(), out) == page.size();
    ok = std::fclose(out) == 0 && ok;
  }
  if (!ok) {
    std::fprintf(stderr, "coopdyn view: cannot write '%s'\n", a.out->c_str());
    return 1;
  }
  std::fprintf(stderr, "coopdyn view: wrote %s (%zu bytes)\n", a.out->c_str(), page.size());
  return 0;
}

}  // namespace coopdyn::cli
