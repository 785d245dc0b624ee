// The service config: the shipped config/coopdynd.yaml is valid and equals the built-in defaults
// (so the README's two ways of starting the daemon agree); every bad value names file and line.
#include <gtest/gtest.h>

#include <yaml-cpp/yaml.h>

#include <cmath>
#include <fstream>
#include <sstream>
#include <typeinfo>

#include "service/runtime/config.h"
#include "service/runtime/config_fields.h"

using namespace coopdyn::runtime;

namespace {
// Each config text is refused with a ConfigError whose message holds the expected words (no other
// exception escapes).
void expect_refused(const std::vector<std::pair<std::string, std::string>>& cases) {
  for (const auto& [text, expect] : cases) {
    SCOPED_TRACE(text);
    try {
      load_config_string(text, "t.yaml");
      ADD_FAILURE() << "accepted";
    } catch (const ConfigError& e) {
      EXPECT_NE(std::string(e.what()).find(expect), std::string::npos) << e.what();
    } catch (const std::exception& e) {
      ADD_FAILURE() << "escaped as a " << typeid(e).name() << ": " << e.what();
    }
  }
}
}  // namespace

// Every key of the table is written in the shipped file, with its default.
TEST(DaemonConfig, ShippedConfigEqualsBuiltInDefaults) {
  const std::string path = std::string(COOPDYN_SOURCE_DIR) + "/config/coopdynd.yaml";
  const ServiceConfig f = load_config(path);
  const ServiceConfig d;
  const YAML::Node file = YAML::LoadFile(path);
  for (const ConfigField& field : config_fields()) {
    const YAML::Node section = *field.section ? file[field.section] : file;
    EXPECT_TRUE(section.IsDefined() && section[field.key].IsDefined()) << field_path(field) << " is not in " << path;
    EXPECT_EQ(field_text(field, field.get(f)), field_text(field, field.get(d))) << field_path(field);
  }
  EXPECT_EQ(f.input_url(), f.lcm_url);
  EXPECT_EQ(f.max_input_age_us(), 1000000);
  EXPECT_EQ(f.period_ns(), 1000000);
  EXPECT_EQ(f.watchdog_ns(), 100000000);
}

// docs/reference/config.md's table of keys is what coopdynd --print-config-reference prints.
TEST(DaemonConfig, ReferencePageListsTheTable) {
  std::ifstream in(std::string(COOPDYN_SOURCE_DIR) + "/docs/reference/config.md");
  std::stringstream page;
  page << in.rdbuf();
  const std::string text = page.str();
  const size_t from = text.find("| key | default | range | meaning |");
  ASSERT_NE(from, std::string::npos);
  const size_t to = text.find("\n\n", from);
  EXPECT_EQ(text.substr(from, to + 1 - from), config_reference_markdown())
      << "regenerate the table: build/bin/coopdynd --print-config-reference";
}

TEST(DaemonConfig, EveryBadValueNamesFileLineAndReason) {
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"rate_hz: 0\n", "t.yaml:1:10: rate_hz must be in [1, 20000] Hz, got 0"},
      {"rate_hz: fast\n", "t.yaml:1:10: 'rate_hz' must be a number (Hz)"},
      {"mode: simulate\nwatchdog_ms: -1\n", "t.yaml:2:14: watchdog_ms must be in [1, 3.6e+06] ms"},
      {"safe_torque: {policy: gravity}\n", "t.yaml:1:23: safe_torque.policy must be hold, zero or damping"},
      {"overrun: {policy: skip, max_catch_up: 5000}\n", "overrun.max_catch_up must be in [0, 1000]"},
      {"channels: {output: ''}\n", "channel 'output' is empty"},
      {"realtime: {priority: 120}\n", "realtime.priority must be 1..99, got 120"},
      {"realtime: {sched_fifo: maybe}\n", "t.yaml:1:24: realtime.sched_fifo must be auto, true or false"},
      {"realtime: {sched_fifo: yes}\n", "t.yaml:1:24: realtime.sched_fifo must be auto, true or false"},
      {"realtime: {sched_fifo: ~}\n", "t.yaml:1:24: realtime.sched_fifo must be auto, true or false"},
      {"realtime: {sched_fifo: [true]}\n", "t.yaml:1:24: 'sched_fifo' must be a string"},
      {"realtime: {receive_priority: 80}\n",
       "t.yaml:1:30: realtime.receive_priority must be 0 (SCHED_OTHER) or 1..79 (below realtime.priority 80"},
      {"realtime: {priority: 10, receive_priority: 10}\n", "realtime.receive_priority must be 0 (SCHED_OTHER) or 1..9"},
      {"rate: 1000\n", "t.yaml:1:1: unknown key 'rate' in the service config"},
      {"rate_hz: [1\n", "t.yaml:"},
      {"trigger: arrival\n",
       "t.yaml:1:10: trigger: arrival computes on arrival of a measured state and applies to mode estimate only"},
      {"mode: estimate\ntrigger: always\n", "t.yaml:2:10: trigger must be tick or arrival"},
      {"realtime: {spin_us: 1000}\n", "t.yaml:1:21: realtime.spin_us must be in [0, 1000] us and below the period (1000 us"},
      {"rate_hz: 5000\nrealtime: {spin_us: 300}\n", "realtime.spin_us must be in [0, 1000] us and below the period (200 us"},
      {"realtime: {cpu_dma_latency_zero: 0.5}\n", "'cpu_dma_latency_zero' must be true or false"},
      {"mode: estimate\nrealtime: {busy_poll: true}\n",
       "t.yaml:2:23: realtime.busy_poll polls for measured states and applies to mode estimate with trigger arrival only "
       "(mode estimate, trigger tick)"},
      {"realtime: {receive_in_loop: true}\n",
       "t.yaml:1:29: realtime.receive_in_loop reads measured states on the loop's thread and applies to mode estimate "
       "with trigger arrival only (mode simulate, trigger tick)"},
  };
  expect_refused(cases);
  EXPECT_THROW(load_config("/no/such/coopdynd.yaml"), ConfigError);
  const ServiceConfig c = load_config_string(
      "mode: estimate\ntrigger: arrival\noverrun: {policy: skip}\nrealtime: {spin_us: 50, cpu_dma_latency_zero: true, busy_poll: true, "
      "receive_in_loop: true}\n",
      "t.yaml");
  EXPECT_EQ(c.mode, ServiceMode::kEstimate);
  EXPECT_EQ(c.trigger, Trigger::kArrival);
  EXPECT_EQ(c.realtime.spin_us, 50);
  EXPECT_TRUE(c.realtime.cpu_dma_latency_zero);
  EXPECT_TRUE(c.realtime.busy_poll);
  EXPECT_TRUE(c.realtime.receive_in_loop);
  EXPECT_EQ(c.overrun, OverrunPolicy::kSkip);
}

// realtime.sched_fifo: auto (the default), true or false, each its own policy; whether the loop asks
// for SCHED_FIFO follows from it and busy_poll without a cpu (auto then stays SCHED_OTHER).
TEST(DaemonConfig, SchedFifoIsAutoTrueOrFalse) {
  EXPECT_EQ(ServiceConfig().realtime.sched_fifo, SchedFifo::kAuto);
  EXPECT_EQ(load_config_string("realtime: {sched_fifo: auto}\n", "t.yaml").realtime.sched_fifo, SchedFifo::kAuto);
  EXPECT_EQ(load_config_string("realtime: {sched_fifo: true}\n", "t.yaml").realtime.sched_fifo, SchedFifo::kOn);
  EXPECT_EQ(load_config_string("realtime: {sched_fifo: false}\n", "t.yaml").realtime.sched_fifo, SchedFifo::kOff);
  const std::string arrival = "mode: estimate\ntrigger: arrival\n";
  auto asks = [&](const std::string& rt) { return loop_asks_fifo(load_config_string(arrival + rt, "t.yaml").realtime); };
  EXPECT_TRUE(asks("realtime: {sched_fifo: auto}\n"));
  EXPECT_FALSE(asks("realtime: {sched_fifo: auto, busy_poll: true}\n")) << "a polling loop on a shared CPU";
  EXPECT_TRUE(asks("realtime: {sched_fifo: auto, busy_poll: true, cpu: 1}\n"));
  EXPECT_TRUE(asks("realtime: {sched_fifo: true, busy_poll: true}\n")) << "true keeps its meaning";
  EXPECT_FALSE(asks("realtime: {sched_fifo: false}\n"));
  EXPECT_EQ(load_config_string("realtime: {priority: 60, receive_priority: 59}\n", "t.yaml").realtime.receive_priority, 59);
}

// Every value bounded to what the code can represent (period_ns(), watchdog_ns()
// and the stats window in 64 bits, a CPU bit that exists), the limits and the value in the message,
// and no exception but ConfigError (a list as a key used to escape as YAML::TypedBadConversion).
TEST(DaemonConfig, EveryValueBoundedWithTheLimitsInTheMessage) {
  const std::string long_channel(64, 'C');
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"rate_hz: 0.001\n", "t.yaml:1:10: rate_hz must be in [1, 20000] Hz, got 0.001"},
      {"rate_hz: 1e-300\n", "t.yaml:1:10: rate_hz must be in [1, 20000] Hz, got 1e-300"},
      {"rate_hz: 20001\n", "t.yaml:1:10: rate_hz must be in [1, 20000] Hz, got 20001"},
      {"rate_hz: .nan\n", "t.yaml:1:10: rate_hz must be in [1, 20000] Hz, got nan"},
      {"watchdog_ms: 1e13\n", "t.yaml:1:14: watchdog_ms must be in [1, 3.6e+06] ms (1 ms to 1 hour), got 1e+13"},
      {"watchdog_ms: 0.5\n", "t.yaml:1:14: watchdog_ms must be in [1, 3.6e+06] ms (1 ms to 1 hour), got 0.5"},
      {"watchdog_ms: .inf\n", "watchdog_ms must be in [1, 3.6e+06] ms (1 ms to 1 hour), got inf"},
      {"stats_period_s: 1e300\n",
       "t.yaml:1:17: stats_period_s must be in [0.001, 3600] s (at least one tick at rate_hz 1000, at most an hour), got 1e+300"},
      {"stats_period_s: 0.0001\n", "stats_period_s must be in [0.001, 3600] s"},
      {"rate_hz: 10\nstats_period_s: 0.05\n", "t.yaml:2:17: stats_period_s must be in [0.1, 3600] s (at least one tick at rate_hz 10"},
      {"overrun: {max_catch_up: 5000}\n", "t.yaml:1:25: overrun.max_catch_up must be in [0, 1000] ticks, got 5000"},
      {"overrun: {max_catch_up: -1}\n", "overrun.max_catch_up must be in [0, 1000] ticks, got -1"},
      {"overrun: {max_catch_up: 99999999999999999999}\n", "t.yaml:1:25: 'max_catch_up' must be an integer (ticks)"},
      {"realtime: {cpu: 5000}\n", "t.yaml:1:17: realtime.cpu must be -1 (none) or a CPU number in [0, 1023], got 5000"},
      {"realtime: {priority: 2147483648}\n", "realtime.priority must be 1..99, got 2147483648"},
      {"channels: {command: " + long_channel + "}\n", "channel 'command' must be 1..63 characters (LCM's limit), got 64"},
      {"lcm_url: ''\n", "t.yaml:1:10: lcm_url is empty"},
      {"max_input_age_ms: 0.5\n", "t.yaml:1:19: max_input_age_ms must be off (or 0) or in [1, 3.6e+06] ms, got 0.5"},
      {"max_input_age_ms: 1e13\n", "max_input_age_ms must be off (or 0) or in [1, 3.6e+06] ms, got 1e+13"},
      {"max_input_age_ms: never\n", "t.yaml:1:19: 'max_input_age_ms' must be a number (ms) or off"},
      {"rate_hz: [1000]\n", "t.yaml:1:10: 'rate_hz' must be a number (Hz)"},
      {"lcm_url_in: \"" + std::string(2000, 'u') + "\"\n", "t.yaml:1:13: lcm_url_in must be 1..1024 characters, got 2000"},
      {"receive: {queue: 1}\n", "t.yaml:1:18: receive.queue must be an integer in [2, 4096] messages, got 1"},
      {"receive: {queue: 2.5}\n", "receive.queue must be an integer in [2, 4096] messages, got 2.5"},
      {"receive: {max_message_bytes: 1e12}\n", "t.yaml:1:30: receive.max_message_bytes must be an integer in [256, 4194304] bytes"},
      {"receive: {bogus: 1}\n", "unknown key 'bogus' in receive"},
      {"receive: {socket_buffer_bytes: 100}\n",
       "t.yaml:1:32: receive.socket_buffer_bytes must be 0 (the OS default) or an integer in [4096, 268435456] bytes, got 100"},
      {"receive: {socket_buffer_bytes: 1e12}\n", "receive.socket_buffer_bytes must be 0 (the OS default) or an integer in [4096, 268435456]"},
      {"receive: {socket_buffer_bytes: -1}\n", "got -1"},
      // a non-scalar mapping key, at the top and inside a section
      {"? [a, b]\n: 1\n", "t.yaml:1:3: a key in the service config must be a plain name, not a list or mapping"},
      {"realtime:\n  ? {x: 1}\n  : 2\n", "t.yaml:2:5: a key in realtime must be a plain name, not a list or mapping"},
      {"channels: {? [a]\n: b}\n", "t.yaml:1:"},
  };
  expect_refused(cases);
}

TEST(DaemonConfig, TheLimitsThemselvesAreRepresentable) {
  const ServiceConfig lo = load_config_string("rate_hz: 1\nwatchdog_ms: 1\nstats_period_s: 1\n", "t.yaml");
  EXPECT_EQ(lo.period_ns(), 1000000000LL);
  EXPECT_EQ(lo.watchdog_ns(), 1000000LL);
  const ServiceConfig hi = load_config_string(
      "rate_hz: 20000\nwatchdog_ms: 3600000\nstats_period_s: 3600\noverrun: {max_catch_up: 1000}\nrealtime: {cpu: 1023}\n",
      "t.yaml");
  EXPECT_EQ(hi.period_ns(), 50000LL);
  EXPECT_EQ(hi.watchdog_ns(), 3600000000000LL);
  EXPECT_EQ(std::llround(hi.stats_period_s * hi.rate_hz), 72000000LL);  // ticks per stats window
  // one tick per window exactly at the lower limit (1 / rate, despite the rounding of 1e-3 * 1000)
  EXPECT_NO_THROW(load_config_string("rate_hz: 1000\nstats_period_s: 0.001\n", "t.yaml"));
  EXPECT_NO_THROW(load_config_string("rate_hz: 3\nstats_period_s: 0.3333333333333333\n", "t.yaml"));
  EXPECT_EQ(load_config_string("max_input_age_ms: off\n", "t.yaml").max_input_age_us(), 0);
  EXPECT_EQ(load_config_string("max_input_age_ms: 0\n", "t.yaml").max_input_age_us(), 0);
  EXPECT_EQ(load_config_string("max_input_age_ms: 3600000\n", "t.yaml").max_input_age_us(), 3600000000LL);
}

// Command-line overrides go through validate(): the same limits, no place to name.
TEST(DaemonConfig, ValidateAfterOverridesAppliesTheSameLimits) {
  ServiceConfig c;
  c.rate_hz = 0.001;
  try {
    validate(c);
    ADD_FAILURE() << "accepted";
  } catch (const ConfigError& e) {
    EXPECT_EQ(std::string(e.what()), "rate_hz must be in [1, 20000] Hz, got 0.001");
  }
  c = ServiceConfig();
  c.rate_hz = 10;  // stats_period_s 1 s = 10 ticks: fine
  EXPECT_NO_THROW(validate(c));
  c.stats_period_s = 0.01;  // a tenth of a tick
  EXPECT_THROW(validate(c), ConfigError);
}

// Deep or huge input is a clear error naming the file, and no message echoes a
// long value (a 100 kB key gave a 100 kB line).
TEST(DaemonConfig, DeepHugeOrLongInputIsAShortClearError) {
  auto error_of = [](const std::string& text) -> std::string {
    try {
      load_config_string(text, "t.yaml");
    } catch (const ConfigError& e) {
      return e.what();
    }
    return "accepted";
  };
  std::string e = error_of("rate_hz: " + std::string(200000, '['));
  // 2 for the indentation level, 1 for "rate_hz:", so the 62nd bracket passes 64
  EXPECT_EQ(e, "t.yaml:1:" + std::to_string(9 + 62) + ": YAML nested deeper than 64 levels (the limit for a config file)");
  e = error_of(std::string(200000, '{'));
  EXPECT_NE(e.find("t.yaml:1:"), std::string::npos) << e;
  EXPECT_NE(e.find("nested deeper than 64 levels"), std::string::npos) << e;
  const std::string big = "# " + std::string(2u << 20, 'x') + "\n";
  e = error_of(big);
  EXPECT_EQ(e, "t.yaml: the service config is " + std::to_string(big.size()) + " bytes, more than the limit of 1048576");
  // a key as long as YAML allows (1024 characters for an implicit key), and a 100 kB value
  const std::string key = "HEAD" + std::string(1000, 'k') + "TAIL";
  e = error_of(key + ": 1\n");
  EXPECT_LT(e.size(), 400u) << e.size();
  EXPECT_EQ(e.rfind("t.yaml:1:1: unknown key 'HEAD", 0), 0u) << e.substr(0, 100);
  EXPECT_NE(e.find("kkkkTAIL' in the service config (allowed: "), std::string::npos) << e;
  const std::string huge = "HEAD" + std::string(100000, 'v') + "TAIL";
  e = error_of("channels: {command: " + huge + "}\n");
  EXPECT_LT(e.size(), 400u) << e.size();
  EXPECT_NE(e.find("channel 'command' must be 1..63 characters (LCM's limit), got 100008"), std::string::npos) << e;
  // files: a device, a directory, a missing file
  for (const char* p : {"/dev/zero", "/tmp", "/no/such/coopdynd.yaml"}) {
    try {
      load_config(p);
      ADD_FAILURE() << p;
    } catch (const ConfigError& err) {
      const std::string m = err.what();
      EXPECT_EQ(m.rfind(std::string(p) + ": ", 0), 0u) << m;
      EXPECT_TRUE(m.find("is not a regular file") != std::string::npos || m.find("cannot open the service config") != std::string::npos) << m;
    }
  }
}
