// coopdyn view --log: the frames of a daemon log, from its output_t messages (read with the
// clients' one log reader, clients/cli/lcm_log.h).
#include <algorithm>
#include <map>
#include <stdexcept>
#include <string>

#include "clients/cli/lcm_log.h"
#include "clients/view/view.h"
#include "service/dynamics/joint_limits.h"
#include "service/dynamics/wrenches.h"
#include "service/io/codec/codec.h"
#include "service/io/codec/messages.h"

namespace coopdyn::cli {

namespace {
std::string joined(const std::vector<std::string>& v, size_t max = 6) {
  std::string s;
  for (size_t i = 0; i < v.size() && i < max; ++i) s += (i ? ", " : "") + v[i];
  if (v.size() > max) s += ", ...";
  return s;
}
// The joint limits an output's state and torque pass (output_t limit_mask, version 5), for the status
// line's "past limits": "arm1.q1 velocity, ..."; "" none, or a log of an older version (-1: unknown).
std::string limits_text(const io::DecodedOutput& o) {
  std::string s;
  if (!o.has(io::OutputField::limit_mask) || o.limit_mask.size() != o.v_names.size()) return s;
  for (size_t i = 0; i < o.limit_mask.size(); ++i)
    for (int k = 0; k < 3; ++k)
      if (o.limit_mask[i] > 0 && (o.limit_mask[i] & (1 << k)))
        s += (s.empty() ? "" : ", ") + o.v_names[i] + " " + limit_word(static_cast<LimitBit>(1 << k));
  return s;
}
}  // namespace

bool sample_of_output(const System& sys, const ViewFrames& geo, const io::DecodedOutput& o, ViewSample* r,
                      std::string* why, const ViewSample* held) {
  const Model& m = sys.model;
  const auto& outs = sys.wrenches.outputs;
  bool same_wrenches = o.wrench_names.size() == outs.size();
  for (size_t k = 0; same_wrenches && k < outs.size(); ++k) same_wrenches = o.wrench_names[k] == outs[k].name;
  if (o.q_names != m.q_names) {
    *why = "has " + std::to_string(o.q_names.size()) + " coordinates (" + joined(o.q_names) + "), scene '" + sys.name +
           "' has " + std::to_string(m.nq()) + " (" + joined(m.q_names) + "): it was recorded with another scene";
    return false;
  }
  if (!same_wrenches) {
    std::vector<std::string> names;
    for (const WrenchOutput& w : outs) names.push_back(w.name);
    *why = "has " + std::to_string(o.wrench_names.size()) + " wrenches (" + joined(o.wrench_names) + "), scene '" +
           sys.name + "' reports " + std::to_string(outs.size()) + " (" + joined(names) +
           "): it was recorded with another scene or formulation";
    return false;
  }
  if (o.q.size() != o.q_names.size() || o.wrench.size() != outs.size() || o.indeterminate_mask.size() != outs.size() ||
      o.stress.size() != o.stress_names.size()) {
    *why = "sizes do not match its names";
    return false;
  }
  r->t = o.sim_time;
  // the codes are the library's (static_asserts in codec.cc); anything else reads as an error
  r->status = o.status == static_cast<int>(Status::kOk) || o.status == static_cast<int>(Status::kIndeterminate)
                  ? status_name(static_cast<Status>(o.status))
                  : status_name(Status::kError);
  r->q = Eigen::Map<const Eigen::VectorXd>(o.q.data(), static_cast<Eigen::Index>(o.q.size()));
  const bool error = r->status == status_name(Status::kError);
  r->note = error ? std::string(io::reason_key(o.reason)) : std::string();
  // without a fresh state (estimate mode) the output's q is no state (with a free body, zeros: not
  // even a configuration): the last valid pose is shown, as for any error whose q is not one
  const bool no_state = r->note == "no_state" || r->note == "state_stale";
  r->pose_held = false;
  if (no_state || !configuration_valid(m, r->q)) {
    if (!error) {
      *why = "not a valid configuration of scene '" + sys.name + "'";
      return false;
    }
    const bool have = held && held->q.size() == m.nq();
    r->q = have ? held->q : sys.q0;
    r->pose_held = true;
    char when[64];
    std::snprintf(when, sizeof when, "; the pose of t = %.3f s held", have ? held->t : 0.0);
    r->note += have ? when : "; no pose yet: the scene's initial pose shown";
  }
  r->w.clear();
  r->indet.clear();
  for (int k : geo.wrenches) {  // an error output's wrenches are no values: none drawn
    r->w.push_back(error ? Vec6::Zero().eval() : Vec6(Eigen::Map<const Vec6>(o.wrench[static_cast<size_t>(k)].data())));
    r->indet.push_back(error ? 0 : o.indeterminate_mask[static_cast<size_t>(k)] & 0x3f);
  }
  // each wrench's sigma (declared noise) and friction bound (joints at rest), when the message has them
  r->sigma.clear();
  r->bound.clear();
  const bool sigma_on = !error && o.sigma_source != 0 && o.wrench_sigma.size() == outs.size();
  const bool bound_on = !error && o.friction_resting > 0 && o.wrench_bound.size() == outs.size();
  for (int k : geo.wrenches) {
    if (sigma_on) r->sigma.push_back(Eigen::Map<const Vec6>(o.wrench_sigma[static_cast<size_t>(k)].data()));
    if (bound_on) r->bound.push_back(Eigen::Map<const Vec6>(o.wrench_bound[static_cast<size_t>(k)].data()));
  }
  r->stress.clear();
  for (const auto& p : error ? std::vector<ViewFrames::Pseudo>{} : geo.pseudos) {
    const auto it = std::find(o.stress_names.begin(), o.stress_names.end(), p.name);
    if (it == o.stress_names.end()) {
      r->stress.clear();  // a formulation that does not report it: no colours rather than wrong ones
      break;
    }
    r->stress.push_back(o.stress[static_cast<size_t>(it - o.stress_names.begin())]);
  }
  // the contact report (output_t contact_*), by name: a message without it leaves it unknown
  r->contact_u.clear();
  r->contact_state.clear();
  const size_t nc = o.contact_names.size();
  const bool contacts_sized = !error && o.contact_utilisation.size() == nc && o.contact_friction_needed.size() == nc &&
                              o.contact_state.size() == nc;
  for (const auto& c : geo.contacts) {
    const auto it = std::find(o.contact_names.begin(), o.contact_names.end(), c.name);
    if (!contacts_sized || it == o.contact_names.end()) {
      r->contact_u.clear();
      r->contact_state.clear();
      break;
    }
    const size_t k = static_cast<size_t>(it - o.contact_names.begin());
    r->contact_u.push_back(o.contact_utilisation[k]);
    r->contact_u.push_back(o.contact_friction_needed[k]);
    r->contact_state.push_back(o.contact_state[k] >= 0 && o.contact_state[k] <= 2 ? o.contact_state[k] : 0);
  }
  r->limits = limits_text(o);
  int count[kFreeClasses] = {};
  for (int c : o.free_class)
    if (c >= 0 && c < kFreeClasses) ++count[c];
  r->free.clear();
  for (int c = 0; c < kFreeClasses; ++c)
    if (count[c])
      r->free += (r->free.empty() ? "" : ", ") + std::to_string(count[c]) + " " + free_class_name(static_cast<FreeClass>(c));
  return true;
}

std::vector<ViewSample> read_log_samples(const System& sys, const std::string& path, const std::string& channel) {
  const ViewFrames geo = view_geometry(sys);
  std::vector<ViewSample> out;
  std::map<std::string, std::pair<io::MessageType, long>> seen;  // channel -> type of its first message, count
  long undecodable = 0, n = 0, last_pose = -1;  // last_pose: the last sample with its own pose
  io::DecodedOutput o;
  std::string why;
  read_lcm_log(path, [&](const LogMessage& ev) {
    auto& s = seen[ev.channel];
    if (s.second++ == 0) s.first = ev.type;
    if (ev.channel != channel || ev.type != io::MessageType::kOutput) return true;
    ++n;
    if (!io::decode_output(ev.data, ev.len, &o)) {
      ++undecodable;
      return true;
    }
    ViewSample r;
    if (!sample_of_output(sys, geo, o, &r, &why, last_pose >= 0 ? &out[static_cast<size_t>(last_pose)] : nullptr))
      throw std::runtime_error(path + ": output_t " + std::to_string(n) + " on channel '" + channel + "' (tick " +
                               std::to_string(o.tick) + ") " + why);
    if (!r.pose_held) last_pose = static_cast<long>(out.size());
    out.push_back(std::move(r));
    return true;
  });
  if (out.empty()) {
    std::string has;
    for (const auto& [name, s] : seen)
      has += (has.empty() ? "" : ", ") + name + " (" + io::type_name(s.first) + ", " + std::to_string(s.second) + ")";
    throw std::runtime_error(path + ": no coopdyn.output_t messages on channel '" + channel + "'" +
                             (undecodable ? " that decode (" + std::to_string(undecodable) + " did not)" : "") +
                             "; the log has " + (has.empty() ? "no messages" : has));
  }
  return out;
}

}  // namespace coopdyn::cli
