// coopdyn.Client: the live service from Python over liblcm and the service's own codec (service/io):
// torque commands and measured states published (signed with the daemon's key when given one),
// outputs and loop statistics received on LCM's thread, queued as bytes and decoded when read
// (output_adapter.h). Waiting releases the GIL.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <chrono>
#include <cmath>
#include <condition_variable>
#include <deque>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "clients/python/module/output_adapter.h"
#include "service/io/transport/auth.h"
#include "service/io/codec/codec.h"
#include "service/io/transport/lcm_bus.h"

namespace coopdyn::py {

namespace pyb = pybind11;
using namespace pybind11::literals;

namespace {

// Raw messages of one channel, oldest first, at most cap (the oldest dropped beyond it).
class Inbox {
 public:
  explicit Inbox(size_t cap) : cap_(cap) {}
  void push(const void* d, int n) {
    {
      std::lock_guard<std::mutex> l(m_);
      q_.emplace_back(static_cast<const uint8_t*>(d), static_cast<const uint8_t*>(d) + n);
      ++received_;
      if (q_.size() > cap_) q_.pop_front(), ++dropped_;
    }
    cv_.notify_all();
  }
  // the oldest (latest: the newest, the older ones dropped) within timeout seconds
  std::optional<std::vector<uint8_t>> pop(double timeout, bool latest) {
    std::unique_lock<std::mutex> l(m_);
    const auto until = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout);
    if (!cv_.wait_until(l, until, [&] { return !q_.empty(); })) return std::nullopt;
    std::vector<uint8_t> m = latest ? std::move(q_.back()) : std::move(q_.front());
    if (latest)
      q_.clear();
    else
      q_.pop_front();
    return m;
  }
  long long received() const {
    std::lock_guard<std::mutex> l(m_);
    return received_;
  }
  long long dropped() const {
    std::lock_guard<std::mutex> l(m_);
    return dropped_;
  }

 private:
  size_t cap_;
  mutable std::mutex m_;
  std::condition_variable cv_;
  std::deque<std::vector<uint8_t>> q_;
  long long received_ = 0, dropped_ = 0;
};

std::vector<std::string> names_of(pyb::handle names, const char* arg) {
  if (names.is_none()) return {};
  std::vector<std::string> v;
  for (pyb::handle h : names) {
    if (!pyb::isinstance<pyb::str>(h)) throw pyb::value_error(std::string(arg) + ": names must be str");
    v.push_back(h.cast<std::string>());
  }
  return v;
}

// values (and their names) from a dict by name or an array (names: given, or the scene's order)
void values_of(pyb::handle x, pyb::handle names, const char* arg, std::vector<std::string>* n, std::vector<double>* v) {
  n->clear(), v->clear();
  if (x.is_none()) return;
  if (pyb::isinstance<pyb::dict>(x)) {
    for (auto item : pyb::reinterpret_borrow<pyb::dict>(x)) {
      n->push_back(pyb::str(item.first));
      v->push_back(pyb::float_(pyb::reinterpret_borrow<pyb::object>(item.second)).cast<double>());
    }
  } else {
    *n = names_of(names, arg);
    const auto a = pyb::array_t<double, pyb::array::c_style | pyb::array::forcecast>::ensure(x);
    if (!a || a.ndim() != 1) throw pyb::value_error(std::string(arg) + ": expected a 1-D array or a dict by name");
    v->assign(a.data(), a.data() + a.size());
    if (!n->empty() && n->size() != v->size())
      throw pyb::value_error(std::string(arg) + ": " + std::to_string(v->size()) + " values for " +
                             std::to_string(n->size()) + " names");
  }
  for (size_t i = 0; i < v->size(); ++i)
    if (!std::isfinite((*v)[i]))
      throw pyb::value_error(std::string(arg) + "[" + (n->empty() ? std::to_string(i) : "'" + (*n)[i] + "'") +
                             "] is not finite");
}

class Client {
 public:
  Client(const std::string& url, const std::string& output_channel, const std::string& stats_channel,
         const std::string& command_channel, const std::string& state_channel,
         const std::optional<std::string>& key_file, size_t queue)
      : outputs_(queue), stats_(queue), command_channel_(command_channel), state_channel_(state_channel) {
    if (key_file) {
      try {
        key_ = io::read_key_file(*key_file);
      } catch (const io::KeyError& e) {
        throw pyb::value_error(std::string("key_file: ") + e.what());
      }
    }
    bus_ = std::make_unique<io::LcmBus>(url);  // std::runtime_error with the reason: RuntimeError
    bus_->subscribe(output_channel, [this](const void* d, int n, long long) { outputs_.push(d, n); });
    bus_->subscribe(stats_channel, [this](const void* d, int n, long long) { stats_.push(d, n); });
    bus_->start();
  }

  long long publish_torque(pyb::handle tau, pyb::handle names, pyb::handle targets, std::optional<long long> seq,
                           std::optional<long long> utime) {
    std::vector<std::string> n, tn;
    std::vector<double> v, tv;
    values_of(tau, names, "tau", &n, &v);
    values_of(targets, pyb::none(), "targets", &tn, &tv);
    const long long s = seq ? *seq : ++seq_;
    seq_ = std::max(seq_, s);
    std::vector<uint8_t> m = io::encode_torque_command(utime ? *utime : io::wall_us(), s, n, v, tn, tv);
    send(command_channel_, m, io::MessageType::kTorqueCommand);
    return s;
  }

  long long publish_state(pyb::handle q, pyb::handle v, pyb::handle tau, pyb::handle q_names, pyb::handle v_names,
                          std::optional<long long> seq, std::optional<long long> utime) {
    std::vector<std::string> qn, vn, tn;
    std::vector<double> qv, vv, tv;
    values_of(q, q_names, "q", &qn, &qv);
    values_of(v, v_names, "v", &vn, &vv);
    values_of(tau, v_names, "tau", &tn, &tv);
    if (!tn.empty() && tn != vn) throw pyb::value_error("tau: must name the same joints as v, in the same order");
    const long long s = seq ? *seq : ++seq_;
    seq_ = std::max(seq_, s);
    std::vector<uint8_t> m = io::encode_measured_state(utime ? *utime : io::wall_us(), s, qn, qv, vn, vv, tv);
    send(state_channel_, m, io::MessageType::kMeasuredState);
    return s;
  }

  pyb::object next_output(double timeout, bool latest) {
    std::optional<std::vector<uint8_t>> m;
    {
      pyb::gil_scoped_release nogil;
      m = outputs_.pop(timeout, latest);
    }
    if (!m) return pyb::none();
    io::DecodedOutput o;
    if (!io::decode_output(m->data(), static_cast<int>(m->size()), &o))
      throw pyb::value_error("output: a message on the output channel is not an output_t (" +
                             std::to_string(m->size()) + " bytes)");
    return output_dict(o);
  }

  pyb::object next_stats(double timeout) {
    std::optional<std::vector<uint8_t>> m;
    {
      pyb::gil_scoped_release nogil;
      m = stats_.pop(timeout, false);
    }
    if (!m) return pyb::none();
    io::StatsFrame s;
    if (!io::decode_stats(m->data(), static_cast<int>(m->size()), &s))
      throw pyb::value_error("stats: a message on the stats channel is not a loop_stats_t");
    return stats_dict(s);
  }

  pyb::dict counts() const {
    return pyb::dict("outputs_received"_a = outputs_.received(), "outputs_dropped"_a = outputs_.dropped(),
                     "stats_received"_a = stats_.received(), "stats_dropped"_a = stats_.dropped(), "seq"_a = seq_);
  }

  void close() {
    pyb::gil_scoped_release nogil;
    if (bus_) bus_->stop();
  }

 private:
  void send(const std::string& channel, std::vector<uint8_t>& m, io::MessageType t) {
    if (key_) io::sign(m, channel, *key_, t);
    if (bus_->publish(channel.c_str(), m.data(), static_cast<int>(m.size())) != 0)
      throw std::runtime_error("publish on " + channel + " failed (LCM)");
  }

  Inbox outputs_, stats_;
  std::unique_ptr<io::LcmBus> bus_;
  std::string command_channel_, state_channel_;
  std::optional<io::AuthKey> key_;
  long long seq_ = 0;
};

}  // namespace

void bind_client(pyb::module_& m) {
  pyb::class_<Client>(m, "Client",
                      "The live service over LCM: publish torque commands and measured states (signed with "
                      "key_file, the daemon's auth.key_file), read its outputs and loop statistics as dicts of "
                      "numpy arrays. Messages are queued as they arrive (at most `queue` per channel).")
      .def(pyb::init<const std::string&, const std::string&, const std::string&, const std::string&, const std::string&,
                     const std::optional<std::string>&, size_t>(),
           "url"_a = "udpm://239.255.76.67:7667?ttl=0", "output_channel"_a = "COOPDYN_OUTPUT",
           "stats_channel"_a = "COOPDYN_STATS", "command_channel"_a = "COOPDYN_COMMAND",
           "state_channel"_a = "COOPDYN_STATE", "key_file"_a = pyb::none(), "queue"_a = 10000)
      .def("publish_torque", &Client::publish_torque, "tau"_a, "names"_a = pyb::none(), "targets"_a = pyb::none(),
           "seq"_a = pyb::none(), "utime"_a = pyb::none(),
           "A torque_command_t: tau a dict by joint name, or an array (names, or the scene's order); targets: lock "
           "targets by joint (rad or m). seq: the last + 1, utime: now (us). Returns the seq.")
      .def("publish_state", &Client::publish_state, "q"_a, "v"_a, "tau"_a = pyb::none(), "q_names"_a = pyb::none(),
           "v_names"_a = pyb::none(), "seq"_a = pyb::none(), "utime"_a = pyb::none(),
           "A measured_state_t (estimate mode): q, v, tau dicts by name or arrays. Returns the seq.")
      .def("next_output", &Client::next_output, "timeout"_a = 1.0, "latest"_a = false,
           "The oldest queued output_t as a dict (latest: the newest, dropping the older), or None after timeout s.")
      .def("next_stats", &Client::next_stats, "timeout"_a = 1.0, "The oldest queued loop_stats_t as a dict, or None.")
      .def("counts", &Client::counts, "messages received and dropped (queue full) per channel, the last seq")
      .def("close", &Client::close)
      .def("__enter__", [](Client& c) -> Client& { return c; })
      .def("__exit__", [](Client& c, pyb::args) { c.close(); });
}

}  // namespace coopdyn::py
