// coopdyn bench: the cost of one evaluation and of one step of each integrator on a user's scene.
//
// Method (that of Google Benchmark, done here so the binary needs no extra library): per row, a
// warm-up of about a tenth of the row's time, then a batch size chosen so that one repetition lasts
// about min_time / repetitions, then `repetitions` timed batches. The cost of a call is a batch's
// thread CPU time (CLOCK_THREAD_CPUTIME_ID, so that a preemption by another process does not count)
// over its size; the row reports the median, the 10th and 90th percentiles and the median absolute
// deviation over the repetitions, plus the median wall time.
//
// Rows: "evaluate" (the constrained forward dynamics and the reported wrenches, as the daemon's tick
// computes them), then "step:NAME" for every integrator; on a scene with projection each step
// also as "step:NAME+projection" (the scene as written) next to "step:NAME" (projection off). Every
// call starts from the scene's initial state under zero torque (the state is reset inside the timed
// batch: two vector copies).
#include <time.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <functional>
#include <string>
#include <vector>

#include "clients/cli/cli.h"
#include "service/dynamics/integrators.h"
#include "service/dynamics/wrenches.h"
#include "service/scene/scene.h"

namespace coopdyn::cli {

namespace {

double now_s(clockid_t clk) {
  timespec t;
  clock_gettime(clk, &t);
  return t.tv_sec + 1e-9 * t.tv_nsec;
}

struct Row {
  std::string name;
  std::string integrator;  // empty for the evaluation
  bool projection = false;
  long batch = 0;
  int repetitions = 0;
  double median_us = 0, p10_us = 0, p90_us = 0, mad_us = 0, wall_median_us = 0;
};

// the q-quantile of sorted x, linear interpolation
double quantile(const std::vector<double>& x, double q) {
  if (x.empty()) return 0.0;
  const double pos = q * (x.size() - 1);
  const size_t i = static_cast<size_t>(pos);
  const double f = pos - i;
  return i + 1 < x.size() ? x[i] * (1 - f) + x[i + 1] * f : x[i];
}

Row measure(const std::string& name, double min_time, int reps, const std::function<void()>& op) {
  Row r;
  r.name = name;
  r.repetitions = reps;
  // warm-up and calibration: double the batch until it lasts >= min_time / (10 reps)
  long n = 1;
  const double target = min_time / reps;
  double warm = 0.0;
  for (;;) {
    const double t0 = now_s(CLOCK_THREAD_CPUTIME_ID);
    for (long i = 0; i < n; ++i) op();
    const double dt = now_s(CLOCK_THREAD_CPUTIME_ID) - t0;
    warm += dt;
    if (dt >= target / 10 || n >= (1L << 30)) {
      const double per = std::max(dt / n, 1e-9);
      r.batch = std::max(1L, static_cast<long>(target / per));
      if (warm < 0.1 * min_time) {  // warm-up of a tenth of the row's time at least
        const long extra = static_cast<long>((0.1 * min_time - warm) / per);
        for (long i = 0; i < extra; ++i) op();
      }
      break;
    }
    n *= 2;
  }
  std::vector<double> cpu(reps), wall(reps), dev(reps);
  for (int k = 0; k < reps; ++k) {
    const double w0 = now_s(CLOCK_MONOTONIC), c0 = now_s(CLOCK_THREAD_CPUTIME_ID);
    for (long i = 0; i < r.batch; ++i) op();
    const double c1 = now_s(CLOCK_THREAD_CPUTIME_ID), w1 = now_s(CLOCK_MONOTONIC);
    cpu[k] = 1e6 * (c1 - c0) / r.batch;
    wall[k] = 1e6 * (w1 - w0) / r.batch;
  }
  std::sort(cpu.begin(), cpu.end());
  std::sort(wall.begin(), wall.end());
  r.median_us = quantile(cpu, 0.5);
  r.p10_us = quantile(cpu, 0.1);
  r.p90_us = quantile(cpu, 0.9);
  for (int k = 0; k < reps; ++k) dev[k] = std::abs(cpu[k] - r.median_us);
  std::sort(dev.begin(), dev.end());
  r.mad_us = quantile(dev, 0.5);
  r.wall_median_us = quantile(wall, 0.5);
  return r;
}


}  // namespace

void register_bench(Cli& cli) {
  auto [c, a] = cli.add("bench", cmd_bench);
  scene_options(c, a, true);
  number(c, "--min-time", a.min_time, "S", "measured time per row, s (split over the repetitions; plus a tenth for warm-up)",
         Default::kShown);
  number(c, "--repetitions", a.repetitions, "N", "timed repetitions per row", Default::kShown);
  flag(c, "--json", a.json, "print JSON instead of a table");
}

int cmd_bench(const BenchArgs& a) {
  const double min_time = a.min_time;
  const int reps = a.repetitions;
  if (!(min_time > 0) || !std::isfinite(min_time) || reps < 3 || reps > 10000) {
    std::fprintf(stderr, "coopdyn bench: need --min-time > 0 and --repetitions in 3..10000\n");
    return 2;
  }
  System sys;
  if (const int rc = load_cli_scene(a, "bench", &sys)) return rc;
  const bool has_projection = sys.options.projection_iterations > 0 && sys.constraints.rows > 0;
  System sys_np = sys;  // the same scene without projection
  sys_np.options.projection_iterations = 0;

  const Eigen::VectorXd tau = Eigen::VectorXd::Zero(sys.model.nv());
  std::vector<Row> rows;
  {
    Workspace ws(sys);
    WrenchData wd(sys);
    const Diagnostics& d = evaluate(sys, ws, sys.q0, sys.v0, tau);
    if (d.status == Status::kError) {
      std::fprintf(stderr, "coopdyn bench: %s: the initial state does not evaluate: %s\n", a.scene->c_str(),
                   reason_text(d.reason));
      return 3;
    }
    rows.push_back(measure("evaluate", min_time, reps, [&] {
      evaluate(sys, ws, sys.q0, sys.v0, tau);
      compute_wrenches(sys, ws, wd);
    }));
  }
  for (Integrator integ : {Integrator::kSemiImplicitEuler, Integrator::kRk4, Integrator::kImplicitEuler}) {
    const double dt = 1e-3;
    for (int with_proj = 0; with_proj <= (has_projection ? 1 : 0); ++with_proj) {
      const System& s = with_proj ? sys : sys_np;
      Stepper st(s);
      Eigen::VectorXd q = s.q0, v = s.v0;
      const Diagnostics& d = step(s, st, integ, dt, tau, q, v);
      if (d.status == Status::kError) {
        std::fprintf(stderr, "coopdyn bench: %s: one %s step from the initial state fails: %s\n",
                     a.scene->c_str(), integrator_name(integ), reason_text(d.reason));
        return 3;
      }
      const std::string name = std::string("step:") + integrator_name(integ) + (with_proj ? "+projection" : "");
      Row r = measure(name, min_time, reps, [&] {
        q = s.q0;
        v = s.v0;
        step(s, st, integ, dt, tau, q, v);
      });
      r.integrator = integrator_name(integ);
      r.projection = with_proj;
      rows.push_back(r);
    }
  }

  if (a.json) {
    std::printf("{\"scene\": %s, \"name\": %s, \"formulation\": \"%s\", \"nq\": %d, \"nv\": %d, \"constraint_rows\": %d, "
                "\"projection_iterations\": %d, \"dt\": 0.001, \"unit\": \"us\", \"clock\": \"thread_cpu\",\n \"rows\": [",
                json_string(*a.scene).c_str(), json_string(sys.name).c_str(),
                formulation_name(sys.options.formulation), sys.model.nq(), sys.model.nv(), sys.constraints.rows,
                sys.options.projection_iterations);
    for (size_t i = 0; i < rows.size(); ++i) {
      const Row& r = rows[i];
      std::printf("%s\n  {\"name\": %s, \"integrator\": %s, \"projection\": %s, \"median\": %.6g, \"p10\": %.6g, "
                  "\"p90\": %.6g, \"mad\": %.6g, \"wall_median\": %.6g, \"batch\": %ld, \"repetitions\": %d}",
                  i ? "," : "", json_string(r.name).c_str(),
                  r.integrator.empty() ? "null" : json_string(r.integrator).c_str(), r.projection ? "true" : "false",
                  r.median_us, r.p10_us, r.p90_us, r.mad_us, r.wall_median_us, r.batch, r.repetitions);
    }
    std::printf("\n]}\n");
  } else {
    std::printf("scene %s (%s): nv %d, %d constraint rows, formulation %s, projection %s; dt 1 ms, zero torque\n",
                a.scene->c_str(), sys.name.c_str(), sys.model.nv(), sys.constraints.rows,
                formulation_name(sys.options.formulation),
                has_projection ? (std::to_string(sys.options.projection_iterations) + " iterations").c_str() : "off");
    std::printf("CPU time per call, us (%d repetitions per row)\n", reps);
    std::printf("%-34s %10s %10s %10s %10s %10s %10s\n", "row", "median", "p10", "p90", "MAD", "wall", "batch");
    for (const Row& r : rows)
      std::printf("%-34s %10.3f %10.3f %10.3f %10.3f %10.3f %10ld\n", r.name.c_str(), r.median_us, r.p10_us, r.p90_us,
                  r.mad_us, r.wall_median_us, r.batch);
  }
  return 0;
}

}  // namespace coopdyn::cli
