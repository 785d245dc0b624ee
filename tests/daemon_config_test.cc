// The service config: the shipped config/coopdynd.yaml is valid and equals the built-in defaults
// (so the README's two ways of starting the daemon agree); every bad value names file and line.
#include <gtest/gtest.h>

#include "service/runtime/config.h"

using namespace coopdyn::runtime;

TEST(DaemonConfig, ShippedConfigEqualsBuiltInDefaults) {
  const ServiceConfig f = load_config(std::string(COOPDYN_SOURCE_DIR) + "/config/coopdynd.yaml");
  const ServiceConfig d;
  EXPECT_EQ(f.rate_hz, 1000.0);
  EXPECT_EQ(f.rate_hz, d.rate_hz);
  EXPECT_EQ(f.lcm_url, "udpm://239.255.76.67:7667?ttl=0");
  EXPECT_EQ(f.lcm_url, d.lcm_url);
  EXPECT_EQ(f.command_channel, d.command_channel);
  EXPECT_EQ(f.state_channel, d.state_channel);
  EXPECT_EQ(f.output_channel, d.output_channel);
  EXPECT_EQ(f.stats_channel, d.stats_channel);
  EXPECT_EQ(f.mode, d.mode);
  EXPECT_EQ(f.integrator, d.integrator);
  EXPECT_EQ(f.watchdog_ms, d.watchdog_ms);
  EXPECT_EQ(f.safe_torque, d.safe_torque);
  EXPECT_EQ(f.overrun, d.overrun);
  EXPECT_EQ(f.max_catch_up, d.max_catch_up);
  EXPECT_EQ(f.stats_period_s, d.stats_period_s);
  EXPECT_FALSE(f.realtime.sched_fifo);
  EXPECT_FALSE(f.realtime.mlockall);
  EXPECT_EQ(f.realtime.cpu, -1);
  EXPECT_EQ(f.period_ns(), 1000000);
  EXPECT_EQ(f.watchdog_ns(), 100000000);
}

TEST(DaemonConfig, EveryBadValueNamesFileLineAndReason) {
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"rate_hz: 0\n", "t.yaml:1:10: rate_hz must be in (0, 20000]"},
      {"rate_hz: fast\n", "t.yaml:1:10: 'rate_hz' must be a number (Hz)"},
      {"mode: simulate\nwatchdog_ms: -1\n", "t.yaml:2:14: watchdog_ms must be > 0"},
      {"safe_torque: {policy: gravity}\n", "t.yaml:1:23: safe_torque.policy must be zero or damping"},
      {"overrun: {policy: skip, max_catch_up: 5000}\n", "overrun.max_catch_up must be in [0, 1000]"},
      {"channels: {output: ''}\n", "channel 'output' is empty"},
      {"realtime: {priority: 120}\n", "realtime.priority must be 1..99"},
      {"realtime: {sched_fifo: maybe}\n", "'sched_fifo' must be true or false"},
      {"rate: 1000\n", "t.yaml:1:1: unknown key 'rate' in the service config"},
      {"rate_hz: [1\n", "t.yaml:"},
  };
  for (const auto& [text, expect] : cases) {
    SCOPED_TRACE(text);
    try {
      load_config_string(text, "t.yaml");
      ADD_FAILURE() << "accepted";
    } catch (const ConfigError& e) {
      EXPECT_NE(std::string(e.what()).find(expect), std::string::npos) << e.what();
    }
  }
  EXPECT_THROW(load_config("/no/such/coopdynd.yaml"), ConfigError);
  const ServiceConfig c = load_config_string("mode: estimate\noverrun: {policy: skip}\n", "t.yaml");
  EXPECT_EQ(c.mode, ServiceMode::kEstimate);
  EXPECT_EQ(c.overrun, OverrunPolicy::kSkip);
}
