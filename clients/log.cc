// coopdyn log: an lcm-logger file -> one CSV per channel (coopdyn types), a per-channel summary
// (type, count, rate), and PNG plots of the wrenches (joint reactions apart) and the loop timing when matplotlib is
// available (/usr/bin/python3 with python3-matplotlib; optional: the CSVs never need it).
#include <sys/stat.h>
#include <sys/wait.h>

#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <map>
#include <memory>
#include <string>

#include "clients/cli.h"
#include "clients/lcm_log.h"
#include "service/io/codec.h"

namespace coopdyn::cli {

namespace {
struct Channel {
  io::MessageType type = io::MessageType::kUnknown;
  std::string header, path;
  std::FILE* f = nullptr;
  long count = 0, bad = 0;
  int64_t first_us = 0, last_us = 0;
};

// Plots from the CSVs: argv = outdir output.csv stats.csv ('' when absent).
const char* kPlotScript = R"PY(
import csv, sys
import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt
out, out_csv, stats_csv = sys.argv[1], sys.argv[2], sys.argv[3]
def read(path):
    with open(path) as f:
        r = csv.reader(f)
        head = next(r)
        cols = {h: [] for h in head}
        for row in r:
            if len(row) != len(head): continue
            for h, x in zip(head, row): cols[h].append(float(x))
        return head, cols
made = []
if out_csv:
    head, c = read(out_csv)
    t = c["sim_time"]
    kind_names = {0: "load on the end-effector", 1: "world on the base", 2: "on the constrained tip",
                  3: "through the axle, at the wheel centre", 4: "joint reaction, on the link after the joint"}
    wrenches = [(h[:-5], int(c[h][0]) if c[h] else 2) for h in head if h.endswith(".kind")]
    stresses = [h for h in head if h.startswith("stress:")]
    def panels_of(selected):
        panels = []  # (title, unit, [(label, column)]); all-zero panels (a wheel's moments) are left out
        for w, kind in selected:
            for what, comps, unit in (("moment", ("mx", "my", "mz"), "N*m"), ("force", ("fx", "fy", "fz"), "N")):
                cols = [(k, w + "." + k) for k in comps]
                if any(x != 0 for _, col in cols for x in c[col]):
                    panels.append((f"{w}: {what}, {kind_names.get(kind, '')} (in frame {w if kind != 2 else 'of the tip'})", unit, cols))
        return panels
    def figure(panels, path):
        fig, axes = plt.subplots(max(len(panels), 1), 1, figsize=(10, 2.6 * max(len(panels), 1)), sharex=True, squeeze=False)
        for ax, (title, unit, cols) in zip((a[0] for a in axes), panels):
            for label, col in cols: ax.plot(t, c[col], label=label)
            ax.set_ylabel(unit); ax.set_title(title); ax.legend(loc="upper right"); ax.grid(True)
        axes[-1][0].set_xlabel("simulation time [s]")
        fig.tight_layout(); fig.savefig(path, dpi=90); made.append(path); plt.close(fig)
    panels = panels_of([w for w in wrenches if w[1] != 4])
    if stresses:
        panels.append(("pseudo-joint stresses", "N*m or N", [(s[7:], s) for s in stresses]))
    figure(panels, out + "/wrenches.png")
    joints = [w for w in wrenches if w[1] == 4]
    if joints:
        figure(panels_of(joints), out + "/reactions.png")
if stats_csv:
    head, c = read(stats_csv)
    t = [x - c["log_time"][0] for x in c["log_time"]]
    fig, axes = plt.subplots(2, 1, figsize=(10, 6), sharex=True)
    for ax, what in zip(axes, ("lateness", "compute")):
        for p in ("p50", "p99", "p999", "max"):
            ax.plot(t, c[f"{what}_{p}_us"], marker=".", label=p.replace("p999", "p99.9"))
        ax.set_yscale("log"); ax.set_ylabel("us"); ax.grid(True, which="both"); ax.legend(loc="upper right")
        ax.set_title("wake-up lateness" if what == "lateness" else "compute time per tick")
    axes[-1].set_xlabel("time [s] (each point: one stats window)")
    fig.tight_layout(); fig.savefig(out + "/timing.png", dpi=90); made.append(out + "/timing.png")
for m in made: print("coopdyn log: wrote " + m)
)PY";

std::string shell_quote(const std::string& s) {
  std::string o = "'";
  for (char c : s) o += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return o + "'";
}
}  // namespace

void register_log(Cli& cli) {
  Command& c = cli.add("log",
                       "Convert an lcm-logger log to one CSV per channel and plot the wrenches, reactions and timing "
                       "(PNG, when python3 has matplotlib).",
                       cmd_log);
  c.value("--in", "FILE.lcmlog", "the log")->required();
  c.value("--out", "DIR", "directory for the CSVs and plots (default: the log's path without its extension, then _csv)");
  c.flag("--no-plot", "CSVs only");
  c.value("--python", "PATH", "the Python that plots", "/usr/bin/python3");
}

int cmd_log(const Args& a) {
  if (!a.has("in")) {
    std::fprintf(stderr, "coopdyn log: --in FILE (an lcm-logger log) is required\n");
    return 2;
  }
  const std::string in = a.get("in");
  std::string out = a.get("out");
  if (out.empty()) {
    out = in;
    const auto dot = out.rfind('.');
    if (dot != std::string::npos && dot > out.rfind('/') + 1) out = out.substr(0, dot);
    out += "_csv";
  }
  std::map<std::string, Channel> chans;
  int64_t t_first = -1;
  std::string header, row;
  bool made_dir = false, write_failed = false;
  try {
    read_lcm_log(in, [&](const LogMessage& ev) {
      if (!made_dir) {  // once the log reads: a missing log makes no directory
        made_dir = true;
        if (mkdir(out.c_str(), 0755) != 0 && errno != EEXIST) {
          std::fprintf(stderr, "coopdyn log: cannot create directory '%s'\n", out.c_str());
          write_failed = true;
          return false;
        }
      }
      if (t_first < 0) t_first = ev.timestamp_us;
      Channel& c = chans[ev.channel];
      if (c.count == 0) {
        c.first_us = ev.timestamp_us;
        c.type = ev.type;
      }
      ++c.count;
      c.last_us = ev.timestamp_us;
      if (c.type == io::MessageType::kUnknown) return true;
      if (!io::to_csv(c.type, ev.data, ev.len, &header, &row)) {
        ++c.bad;
        return true;
      }
      if (!c.f) {
        c.path = out + "/" + ev.channel + ".csv";
        c.f = std::fopen(c.path.c_str(), "w");
        if (!c.f) {
          std::fprintf(stderr, "coopdyn log: cannot write '%s'\n", c.path.c_str());
          write_failed = true;
          return false;
        }
        c.header = header;
        std::fprintf(c.f, "log_time,%s\n", header.c_str());
      }
      if (header != c.header) {  // a different scene mid-log: its rows do not fit these columns
        ++c.bad;
        return true;
      }
      std::fprintf(c.f, "%.6f,%s\n", static_cast<double>(ev.timestamp_us - t_first) * 1e-6, row.c_str());
      return true;
    });
  } catch (const std::runtime_error& e) {
    std::fprintf(stderr, "coopdyn log: %s\n", e.what());
    return 1;
  }
  if (write_failed) {
    for (auto& [name, c] : chans)
      if (c.f) std::fclose(c.f);
    return 1;
  }
  std::printf("%-20s %-26s %9s %10s  %s\n", "channel", "type", "messages", "rate_hz", "csv");
  std::string out_csv, stats_csv;
  for (auto& [name, c] : chans) {
    if (c.f) std::fclose(c.f);
    const double span = static_cast<double>(c.last_us - c.first_us) * 1e-6;
    const double rate = c.count > 1 && span > 0 ? static_cast<double>(c.count - 1) / span : 0.0;
    std::printf("%-20s %-26s %9ld %10.1f  %s\n", name.c_str(), io::type_name(c.type), c.count, rate,
                c.path.empty() ? "-" : c.path.c_str());
    if (c.bad) std::printf("  (%ld messages of %s did not decode or changed layout; skipped)\n", c.bad, name.c_str());
    if (c.type == io::MessageType::kOutput && out_csv.empty()) out_csv = c.path;
    if (c.type == io::MessageType::kLoopStats && stats_csv.empty()) stats_csv = c.path;
  }
  if (a.has("no-plot") || (out_csv.empty() && stats_csv.empty())) return 0;
  std::fflush(stdout);  // the table before the plotter's own lines
  const std::string py = a.get("python", "/usr/bin/python3");
  if (std::system((shell_quote(py) + " -c 'import matplotlib' >/dev/null 2>&1").c_str()) != 0) {
    std::printf(
        "coopdyn log: no PNG plots: %s cannot import matplotlib (Debian: apt-get install python3-matplotlib); "
        "the CSVs above are complete\n",
        py.c_str());
    return 0;
  }
  const std::string script = out + "/.plot.py";
  if (std::FILE* f = std::fopen(script.c_str(), "w")) {
    std::fputs(kPlotScript, f);
    std::fclose(f);
  }
  const int rc = std::system((shell_quote(py) + " " + shell_quote(script) + " " + shell_quote(out) + " " +
                              shell_quote(out_csv) + " " + shell_quote(stats_csv))
                                 .c_str());
  std::remove(script.c_str());
  if (rc != 0) std::printf("coopdyn log: plotting failed (exit %d); the CSVs are complete\n", rc);
  return 0;
}

}  // namespace coopdyn::cli
