// coopdyn view --log: the frames of a daemon log, from its output_t messages (read with the
// clients' one log reader, clients/lcm_log.h).
#include <map>
#include <stdexcept>
#include <string>

#include "clients/lcm_log.h"
#include "clients/view.h"
#include "service/io/codec.h"

namespace coopdyn::cli {

namespace {
std::string joined(const std::vector<std::string>& v, size_t max = 6) {
  std::string s;
  for (size_t i = 0; i < v.size() && i < max; ++i) s += (i ? ", " : "") + v[i];
  if (v.size() > max) s += ", ...";
  return s;
}
}  // namespace

std::vector<ViewSample> read_log_samples(const System& sys, const std::string& path, const std::string& channel) {
  const Model& m = sys.model;
  const ViewFrames geo = view_geometry(sys);
  std::vector<std::string> wrench_names;
  for (const WrenchOutput& o : sys.wrenches.outputs) wrench_names.push_back(o.name);
  std::vector<ViewSample> out;
  std::map<std::string, std::pair<io::MessageType, long>> seen;  // channel -> type of its first message, count
  long undecodable = 0, n = 0;
  io::DecodedOutput o;
  read_lcm_log(path, [&](const LogMessage& ev) {
    auto& s = seen[ev.channel];
    if (s.second++ == 0) s.first = ev.type;
    if (ev.channel != channel || ev.type != io::MessageType::kOutput) return true;
    ++n;
    if (!io::decode_output(ev.data, ev.len, &o)) {
      ++undecodable;
      return true;
    }
    const std::string where = path + ": output_t " + std::to_string(n) + " on channel '" + channel + "' (tick " +
                              std::to_string(o.tick) + ")";
    if (o.q_names != m.q_names)
      throw std::runtime_error(where + " has " + std::to_string(o.q_names.size()) + " coordinates (" +
                               joined(o.q_names) + "), scene '" + sys.name + "' has " + std::to_string(m.nq()) + " (" +
                               joined(m.q_names) + "): the log was recorded with another scene");
    if (o.wrench_names != wrench_names)
      throw std::runtime_error(where + " has " + std::to_string(o.wrench_names.size()) + " wrenches (" +
                               joined(o.wrench_names) + "), scene '" + sys.name + "' reports " +
                               std::to_string(wrench_names.size()) + " (" + joined(wrench_names) +
                               "): the log was recorded with another scene or formulation");
    if (o.q.size() != o.q_names.size() || o.wrench.size() != wrench_names.size())
      throw std::runtime_error(where + ": sizes do not match its names");
    ViewSample r;
    r.t = o.sim_time;
    r.status = o.status == 0 ? "ok" : o.status == 1 ? "indeterminate" : "error";
    r.q = Eigen::Map<const Eigen::VectorXd>(o.q.data(), static_cast<Eigen::Index>(o.q.size()));
    if (!configuration_valid(m, r.q)) throw std::runtime_error(where + ": not a valid configuration of scene '" + sys.name + "'");
    for (int k : geo.wrenches) r.w.push_back(Eigen::Map<const Vec6>(o.wrench[static_cast<size_t>(k)].data()));
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
