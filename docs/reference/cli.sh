#!/bin/bash
# docs/reference/cli.sh BIN_DIR > docs/reference/cli.md
# The command-line reference: the prose is written here, each option table comes from the --help of
# the built programs in BIN_DIR (coopdyn, coopdynd), so the page says what the programs say.
# A test (Cli.ReferencePageIsWhatItsScriptWritesFromTheHelp) checks that the committed page is what this script writes.
set -euo pipefail
bin=${1:?usage: docs/reference/cli.sh BIN_DIR}

# The Options of a CLI11 --help as a Markdown table: option, default (REQUIRED, =VALUE, or the
# help's "default: ..." moved out of the meaning), meaning.
options() {
  "$@" --help | awk '
# The Options of a CLI11 --help as a Markdown table: option, default, meaning.
function flush() {
  if (name == "") return
  def = ""
  if (required) def = "required"
  else if (eq != "") def = "`" eq "`"
  else if (match(desc, /\(default: [^)]*\)/)) {
    def = substr(desc, RSTART + 10, RLENGTH - 11)
    desc = substr(desc, 1, RSTART - 1) substr(desc, RSTART + RLENGTH)
    sub(/ +$/, "", desc)
  } else if (match(desc, /; default: [^)]*\)/)) {
    def = substr(desc, RSTART + 11, RLENGTH - 12)
    desc = substr(desc, 1, RSTART - 1) substr(desc, RSTART + RLENGTH - 1)
  } else def = type == "" ? "off" : "not set"
  print "| `" name (type != "" ? " " type : "") "` | " def " | " desc " |"
  name = ""
}
/^Options:/ { on = 1; print "| option | default | meaning |"; print "|---|---|---|"; next }
on && /^$/ { flush(); exit }
on && /^  -/ {
  flush()
  line = substr($0, 3)
  split(line, parts, /  +/)
  spec = parts[1]; desc = parts[2]
  if (spec ~ /^-h,--help/ || spec ~ /^--version/) next
  required = sub(/ REQUIRED$/, "", spec)
  sub(/ Excludes:.*$/, "", spec)  # CLI11 lists the options it excludes; the prose says so
  n = split(spec, w, " ")
  name = w[1]; type = ""; eq = ""
  if (n > 1) {
    type = w[2]
    if ((i = index(type, "=")) > 0) { eq = substr(type, i + 1); type = substr(type, 1, i - 1) }
  }
  next
}
on && /^     / { d = $0; sub(/^ +/, "", d); desc = desc (desc == "" ? "" : " ") d; next }
END { flush() }
'
}

cat <<'EOF'
<!-- written by docs/reference/cli.sh from the programs' --help: edit the script, then
     docs/reference/cli.sh build/bin > docs/reference/cli.md -->
# Command-line reference

Two programs: `coopdyn` (offline commands and the clients of the daemon) and `coopdynd` (the
service). `coopdyn --help` lists the commands, `coopdyn COMMAND --help` and `coopdynd --help` print
the options with their defaults (stdout, exit 0); `--version` prints the version of
`project(coopdyn VERSION ...)`. An unknown flag, a missing or malformed value is an error that
names the option (stderr, exit 2, nothing run). The options below are those of `--help`; the guide
pages say what the outputs mean.

Every command that reads a scene takes `--scene FILE` (YAML, `config/scenes/`;
[format](../../config/scenes/README.md)) and `--formulation NAME` to override the scene's
`formulation:` key (`mobile_platform`, `classic`, `pseudo_joint` or `svd`).

## Profiles

`--torque` and `--steer` (of `sim` and `send`) take a `PROFILE`, repeatable; the terms of one joint
add up. In `sim` a joint without any term gets 0 (`--hold` adds the holding torques to every
joint); in `send` it is left to the daemon's safe torque (`--others zero`: 0):

| profile | value |
|---|---|
| `JOINT:constant:VALUE` | VALUE all the time |
| `JOINT:step:VALUE:T0` | 0 until T0, then VALUE |
| `JOINT:pulse:VALUE:T0:T1` | VALUE from T0 to T1, else 0 |
| `JOINT:ramp:VALUE:T0:T1` | 0 until T0, linear to VALUE at T1 |
| `FILE.csv` | header `t,JOINT,...`; piecewise constant between rows |

`JOINT` is a velocity coordinate of the scene (`coopdyn eval` lists them as `coordinates.v`). Every
positional list (`eval --state`'s and `control --state`'s `q`, `v`, `tau`) is in the scene's
coordinate order, `coordinates.q` and `coordinates.v`: each arm's joints from base to tip, except in
the `mobile_platform` form, where an arm's chain is rooted at the load and its joints run from tip
to base (`arm.q6 ... arm.q1`). A state file may give each list as an object by name instead,
`{"q": {"arm1.q1": 0.3}}`, in any form. A torque is N*m or N
along the joint axis; a `--steer` value is the position target (rad or m) of a locked joint, a
pseudo-joint whose scene entry declares a `target_limit` (a car's `fl_steer`). The timing of
profiles: [conventions.md](../conventions.md#time-and-torque-profiles).

## `coopdyn eval`

Evaluate one state and print it as JSON: accelerations, wrenches, stresses, contacts, free
directions, diagnostics. Exit 3 on an error status. [Guide](../guide/scenes.md#coopdyn-eval-one-state).

EOF
options "$bin/coopdyn" eval
cat <<'EOF'

## `coopdyn sim`

Simulate with a fixed step and write the per-step CSV ([conventions.md](../conventions.md#per-step-csv)).
Exit 3 on a numerical failure. [Guide](../guide/scenes.md#coopdyn-sim-a-run).

EOF
options "$bin/coopdyn" sim
cat <<'EOF'

## `coopdyn bench`

Time one evaluation (dynamics and wrenches, as the daemon's tick) and one step of each integrator:
median, p10, p90 and MAD of the CPU time per call. [Guide](../guide/speed.md#time-your-own-scene).

EOF
options "$bin/coopdyn" bench
cat <<'EOF'

## `coopdyn send`

Publish torque commands (or measured states, for estimate mode) to coopdynd at a fixed rate and
read back what the daemon did with them. Exit 4 when commands went unused and the daemon counted
rejections (naming its counters), 1 when no daemon answers on the URL.
[Guide](../guide/service.md#3-send-a-1-nm-pulse).

EOF
options "$bin/coopdyn" send
cat <<'EOF'

## `coopdyn log`

Convert an lcm-logger log to one CSV per channel and plot the wrenches, reactions and timing (PNG,
when the Python has matplotlib); or plot a per-step CSV. [Guide](../guide/service.md#4-convert-and-plot).

EOF
options "$bin/coopdyn" log
cat <<'EOF'

## `coopdyn view`

The scene in 3D with its wrenches: a self-contained HTML page of a sim CSV or a daemon log, or a
live page served over HTTP and a WebSocket. Exactly one of `--csv`, `--log`, `--live`.
[Guide](../guide/viewer.md).

EOF
options "$bin/coopdyn" view
cat <<'EOF'

`GET /stats` of a live viewer gives its counters (received, skipped by the rate, framed, sent,
dropped, clients, queued, buffered).

## `coopdyn control`

Send one `control_t` to coopdynd and wait for its acknowledgement. Exit 3 when refused, 1 when none
comes within `--timeout` (2 s). [Guide](../guide/service.md#6-control-the-simulation).

EOF
options "$bin/coopdyn" control
cat <<'EOF'

## `coopdyn track`

The reference controller in the loop: move the load along a circle while holding the squeeze
between the arms. [Guide](../guide/service.md#a-controller-in-the-loop).

EOF
options "$bin/coopdyn" track
cat <<'EOF'

## `coopdyn spy`

Run lcm-spy with coopdyn's message types on the daemon's URL. Needs a Java runtime, `liblcm-java`,
`libjchart2d-java` and `coopdyn_types.jar` (built only when a JDK and `liblcm-java` were present when
cmake configured the build). [Guide](../guide/service.md#5-watch-it-live).

EOF
options "$bin/coopdyn" spy
cat <<'EOF'

## `coopdynd`

The real-time service: runs a scene at a fixed rate; LCM in (torque commands or measured states,
controls) and out (wrenches, stresses, accelerations, loop statistics). Options override the config
file ([config.md](config.md)). A broken scene or config stops it at start-up with
`file:line:col: reason` and a non-zero exit; SIGINT or SIGTERM stops it with one summary line.
It logs `running; SIGINT or SIGTERM stops` only once its receive process has subscribed to the
inputs (`receive process PID subscribed to URL (CHANNELS)` before it): an input sent after that line
is received. A receive process that exits before it subscribes, or has not subscribed within 10 s,
stops it with exit 1 and a line naming the URL and channels that did not come up.
[Guide](../guide/service.md).

EOF
options "$bin/coopdynd"
cat <<'EOF'

`coopdynd --rx-child ...` is the isolated receive process the daemon starts itself
([threat model](../guide/service.md#threat-model-what-a-host-on-the-lan-can-and-cannot-do)); it is
not meant to be run by hand.
EOF
