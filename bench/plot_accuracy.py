#!/usr/bin/python3
"""Error against run time: plots, summary CSV and the Markdown block of bench/README.md.

Reads bench/results/accuracy_<scene>.csv (written by accuracy_sweep), writes
  docs/accuracy_<scene>.png            log-log: state error and wrench error against CPU time per
                                       simulated second, one curve per formulation x integrator
  bench/results/accuracy_summary.csv   per scene: answer, reference convergence, cheapest run that
                                       meets each tolerance
  bench/results/accuracy_tables.md     every run of every scene, one table per scene
  bench/README.md                      the generated summary of "Error against run time", between the
                                       markers <!-- accuracy:begin --> and <!-- accuracy:end -->

Usage: plot_accuracy.py REPO_ROOT [--seconds S] [--machine TEXT] [--scenes SCENE...] [--plots-only]
  --scenes: re-plot only these (the summary and the table are rebuilt from every scene's CSV, so the
            other scenes' parts come out unchanged); without --seconds the "Last regenerated" line is
            kept as it was
  --plots-only: the PNGs only (bench/README.md and the summary CSV untouched)
"""
import argparse
import csv
import math
import os
import re
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

SCENES = ["two_puma_load", "two_5dof_arms_load", "planar_arms_load", "four_bar", "unicycle", "two_wheel_vehicle",
          "two_wheel_vehicle_turn"]
INTEGRATORS = ["semi_implicit_euler", "rk4", "implicit_euler"]
FORMULATIONS = ["mobile_platform", "classic", "pseudo_joint", "svd"]
COLOR = {"semi_implicit_euler": "tab:blue", "rk4": "tab:green", "implicit_euler": "tab:red"}
STYLE = {"mobile_platform": ("-", "o"), "classic": ("--", "s"), "pseudo_joint": ("-.", "^"), "svd": (":", "D")}
# tolerances for "the cheapest run that is good enough": state error (max |q - q_ref|, |v - v_ref|,
# SI units) and wrench error relative to the largest reference force component
TOLERANCES = [("1e-3 / 1e-2", 1e-3, 1e-2), ("1e-6 / 1e-5", 1e-6, 1e-5)]
FLOOR = 1e-16  # errors below are drawn at the floor (log axes)
plt.rcParams.update({"font.size": 12, "axes.titlesize": 12, "axes.labelsize": 12, "legend.fontsize": 11,
                     "xtick.labelsize": 11, "ytick.labelsize": 11})


def step_text(dt_ms):
    """A step readably: 4 ms, 0.125 ms, 1.95 us (= 4 ms / 2048)."""
    if dt_ms >= 0.1:
        return f"{dt_ms:g} ms"
    text = f"{dt_ms * 1e3:.3g} \u00b5s"
    k = 4.0 / dt_ms
    if abs(k - round(k)) < 1e-6 * k:
        text += f" (4 ms / {round(k)})"
    return text


def reference_text(ref):
    """'rk4@0.00195312ms/classic' -> 'RK4 at a 1.95 us step (4 ms / 2048), classic form'."""
    m = re.fullmatch(r"(\w+)@([0-9.eE+-]+)ms(?:/(\w+))?", ref.strip())
    if not m:
        return ref
    integ, dt, form = m.group(1), float(m.group(2)), m.group(3)
    return f"{integ.upper() if integ == 'rk4' else integ} at a {step_text(dt)} step" + (f", {form} form" if form else "")


def fnum(s):
    return float(s) if s not in ("", None) else None


def read(path):
    with open(path) as f:
        return list(csv.DictReader(f))


def g(x, digits=2):
    if x is None:
        return "-"
    if x == 0:
        return "0"
    return f"{x:.{digits}g}"


def plot_scene(scene, rows, out_png):
    sweep = [r for r in rows if r["role"] == "sweep"]
    panels = [("state_err", "state error: max |q - q*|, |v - v*| (SI)"),
              ("wrench_err", "tip wrench error: max |F - F*| (N, N*m)")]
    if any(fnum(r["stress_err"]) for r in sweep if r["status"] == "ok"):
        panels.append(("stress_err", "pseudo-joint stress error (N*m, N)"))
    # two panels side by side, or three in a 2 x 2 grid; the legend below them, never over the data
    ncol = 2
    nrow = (len(panels) + 1) // 2
    fig, grid = plt.subplots(nrow, ncol, figsize=(13, 5.6 * nrow + 1.8), squeeze=False)
    axes = [a for row in grid for a in row]
    for a in axes[len(panels):]:
        a.axis("off")
    errors = []
    handles = {}
    for ax, (key, label) in zip(axes, panels):
        labeled = False  # step labels on the first RK4 curve only, where they do not collide
        placed = []
        for form in FORMULATIONS:
            for integ in INTEGRATORS:
                pts = [r for r in sweep if r["formulation"] == form and r["integrator"] == integ]
                if not pts:
                    continue
                ok = [r for r in pts if r["status"] == "ok"]
                if key == "state_err":
                    errors += [f"{form}/{integ} @ {float(r['dt_ms']):g} ms: {r['error_reason']} at {r['error_time_s']} s"
                               for r in pts if r["status"] != "ok"]
                if not ok:
                    continue
                xs = [float(r["cpu_s_per_sim_s"]) for r in ok]
                ys = [max(float(r[key]), FLOOR) for r in ok]
                ls, mk = STYLE[form]
                (h,) = ax.plot(xs, ys, linestyle=ls, marker=mk, color=COLOR[integ], markersize=5, lw=1.4)
                handles[f"{form} / {integ}"] = h
                if integ == "rk4" and not labeled:
                    labeled = True
                    for r, x, y in zip(ok, xs, ys):
                        lx, ly = math.log10(x), math.log10(y)
                        if any(abs(lx - px) < 0.45 and abs(ly - py) < 0.3 for px, py in placed):
                            continue  # would overlap a label already placed
                        placed.append((lx, ly))
                        ax.annotate(step_text(float(r["dt_ms"])), (x, y), textcoords="offset points", xytext=(5, -13),
                                    fontsize=10, color=COLOR[integ],
                                    bbox=dict(boxstyle="round,pad=0.1", fc="white", ec="none", alpha=0.8))
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel("CPU time per simulated second (s)")
        ax.set_title(label)
        ax.grid(True, which="major", alpha=0.4)
        ax.grid(True, which="minor", alpha=0.1)
    ref = [r for r in rows if r["role"] in ("reference", "reference_2x")]
    answer = "the analytic answer" if not ref else f"a reference run, {reference_text(sweep[0]['reference'])}"
    fig.suptitle(f"{scene}: {sweep[0]['scenario']}, {float(sweep[0]['duration_s']):g} s simulated, against {answer}\n"
                 f"steps 0.125-4 ms (labelled on the RK4 curve); errors at common samples every 4 ms", fontsize=13)
    legend_ax = axes[len(panels)] if len(panels) < len(axes) else None
    if legend_ax is not None:  # the free cell of the grid
        legend_ax.legend(list(handles.values()), list(handles.keys()), loc="center", fontsize=12, frameon=False,
                         title="formulation / integrator")
        bottom = 0.04
    else:
        fig.legend(list(handles.values()), list(handles.keys()), loc="lower center", ncol=3, fontsize=11, frameon=False)
        bottom = 0.06 + 0.045 * math.ceil(len(handles) / 3)
    if errors:
        fig.text(0.01, 0.005, "error status (not plotted): " + "; ".join(errors)[:300], fontsize=9, color="tab:red")
    fig.tight_layout(rect=(0, bottom, 1, 0.92))
    fig.savefig(out_png, dpi=90)
    plt.close(fig)


def cheapest(sweep, tol_state, tol_wrench):
    ok = [r for r in sweep if r["status"] == "ok" and float(r["state_err"]) <= tol_state
          and float(r["wrench_rel_err"]) <= tol_wrench]
    return min(ok, key=lambda r: float(r["cpu_s_per_sim_s"])) if ok else None


def scene_table(scene, rows):
    sweep = [r for r in rows if r["role"] == "sweep"]
    dts = sorted({float(r["dt_ms"]) for r in sweep})
    out = [f"**{scene}** ({sweep[0]['scenario']}, {float(sweep[0]['duration_s']):g} s). Cell: state error / "
           "tip wrench error relative to the largest reference component / CPU ms per simulated s; `err` = the "
           "run ended in an error status.", "",
           "| formulation / integrator | " + " | ".join(f"{d:g} ms" for d in dts) + " |",
           "|---|" + "---|" * len(dts)]
    for form in FORMULATIONS:
        for integ in INTEGRATORS:
            pts = {float(r["dt_ms"]): r for r in sweep if r["formulation"] == form and r["integrator"] == integ}
            if not pts:
                continue
            cells = []
            for d in dts:
                r = pts.get(d)
                if r is None:
                    cells.append("")
                elif r["status"] != "ok":
                    cells.append(f"err ({r['error_reason']} at {float(r['error_time_s']):.3g} s)")
                else:
                    cells.append(f"{g(fnum(r['state_err']))} / {g(fnum(r['wrench_rel_err']))} / "
                                 f"{g(1e3 * float(r['cpu_s_per_sim_s']), 3)}")
            out.append(f"| {form} / {integ} | " + " | ".join(cells) + " |")
    return out


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("root")
    ap.add_argument("--seconds", type=float, default=None, help="wall time of the whole regeneration")
    ap.add_argument("--machine", default="")
    ap.add_argument("--scenes", nargs="*", default=None, help="re-plot only these scenes")
    ap.add_argument("--plots-only", action="store_true", help="write the PNGs only")
    a = ap.parse_args()
    res = os.path.join(a.root, "bench", "results")
    docs = os.path.join(a.root, "docs")
    os.makedirs(docs, exist_ok=True)

    summary = []
    md_summary = ["| scene | answer | reference converged (2x step vs ref: state / wrench rel) | not swept | "
                  + " | ".join(f"cheapest with state <= {t[1]:g}, wrench rel <= {t[2]:g}" for t in TOLERANCES) + " |",
                  "|---|---|---|---|" + "---|" * len(TOLERANCES)]
    tables = []
    for scene in SCENES:
        path = os.path.join(res, f"accuracy_{scene}.csv")
        if not os.path.exists(path):
            print(f"missing {path}", file=sys.stderr)
            continue
        rows = read(path)
        sweep = [r for r in rows if r["role"] == "sweep"]
        if not sweep:
            continue
        if a.scenes is None or scene in a.scenes:
            plot_scene(scene, rows, os.path.join(docs, f"accuracy_{scene}.png"))
        refs2 = [r for r in rows if r["role"] == "reference_2x"]
        conv = "; ".join(f"{r['formulation']}: {g(fnum(r['state_err']))} / {g(fnum(r['wrench_rel_err']))}" for r in refs2)
        answer = "analytic" if not refs2 else f"RK4 at {float(refs2[0]['dt_ms']) / 2:.4g} ms"
        skipped = "; ".join(f"{r['formulation']} ({r['error_reason'].split(': ')[-1]})"
                            for r in rows if r["role"] == "skipped")
        cells = []
        for name, ts, tw in TOLERANCES:
            best = cheapest(sweep, ts, tw)
            srow = {"scene": scene, "scenario": sweep[0]["scenario"], "duration_s": sweep[0]["duration_s"],
                    "answer": answer, "reference_2x_vs_reference": conv if refs2 else "analytic",
                    "not_swept": skipped, "tol_state": ts, "tol_wrench_rel": tw}
            if best:
                srow.update({k: best[k] for k in ("formulation", "integrator", "dt_ms", "cpu_s_per_sim_s", "state_err",
                                                  "wrench_err", "wrench_rel_err", "constraint_drift", "energy_drift_J")})
                cells.append(f"{best['formulation']} / {best['integrator']} / {float(best['dt_ms']):g} ms: "
                             f"{g(1e3 * float(best['cpu_s_per_sim_s']), 3)} ms per s (state {g(fnum(best['state_err']))}, "
                             f"wrench {g(fnum(best['wrench_rel_err']))})")
            else:
                cells.append("none in the sweep")
            summary.append(srow)
        md_summary.append(f"| {scene} | {answer} | {conv if refs2 else '-'} | {skipped or '-'} | " + " | ".join(cells) + " |")
        tables += [""] + scene_table(scene, rows)

    if a.plots_only:
        print("wrote the plots in docs/")
        return
    keys = ["scene", "scenario", "duration_s", "answer", "reference_2x_vs_reference", "not_swept", "tol_state",
            "tol_wrench_rel", "formulation", "integrator", "dt_ms", "cpu_s_per_sim_s", "state_err", "wrench_err",
            "wrench_rel_err", "constraint_drift", "energy_drift_J"]
    with open(os.path.join(res, "accuracy_summary.csv"), "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=keys)
        w.writeheader()
        for s in summary:
            w.writerow({k: s.get(k, "") for k in keys})

    readme = os.path.join(a.root, "bench", "README.md")
    text = open(readme).read()
    block = ["<!-- accuracy:begin (generated by bench/accuracy.sh; edits here are overwritten) -->", ""]
    if a.seconds is not None:
        block += [f"Last regenerated in {a.seconds:.0f} s wall time{(' on ' + a.machine) if a.machine else ''}.", ""]
    else:  # a partial run: the whole run's line stays
        m = re.search(r"^Last regenerated in .*$", text, re.M)
        block += [m.group(0), ""] if m else []
    with open(os.path.join(res, "accuracy_tables.md"), "w") as f:
        f.write("# Error against run time, every run\n\nGenerated by bench/accuracy.sh (bench/README.md, \"Error against run time\").\n" + "\n".join(tables) + "\n")
    block += md_summary + ["", "Every run of every scene: [results/accuracy_tables.md](results/accuracy_tables.md).", "", "<!-- accuracy:end -->"]
    b, e = text.find("<!-- accuracy:begin"), text.find("<!-- accuracy:end -->")
    if b < 0 or e < 0:
        text = text.rstrip("\n") + "\n\n## Error against run time\n\n" + "\n".join(block) + "\n"
    else:
        text = text[:b] + "\n".join(block) + text[e + len("<!-- accuracy:end -->"):]
    open(readme, "w").write(text)
    print(f"wrote {len(summary) // len(TOLERANCES)} scenes: plots in docs/, summary in bench/results/, table in bench/README.md")


if __name__ == "__main__":
    main()
