#!/bin/bash
# Regenerates config/robots/{pr2,baxter,tiago_pro}.urdf from Gepetto/example-robot-data with
# bench/peers/strip_urdf.py (visual, collision, gazebo, transmission and top-level material elements
# removed, every number as published, source and licence in a header comment):
#   bench/peers/prepare_robots.sh EXAMPLE_ROBOT_DATA_GIT_DIR [APACHE_LICENSE_FILE]
# EXAMPLE_ROBOT_DATA_GIT_DIR: a git (or bare) clone of github.com/Gepetto/example-robot-data
# APACHE_LICENSE_FILE: the Apache License 2.0 text (default Debian's /usr/share/common-licenses/Apache-2.0)
# The commit is pinned; the outputs are written into config/robots/ of this repository.
set -euo pipefail
PEERS=$(cd "$(dirname "$0")" && pwd)
ERD=${1:?usage: prepare_robots.sh EXAMPLE_ROBOT_DATA_GIT_DIR [APACHE_LICENSE_FILE] (a clone of github.com/Gepetto/example-robot-data)}
APACHE=${2:-/usr/share/common-licenses/Apache-2.0}
COMMIT=39aa94379908fa743da90b21dc9e1fb8308f746b
OUT=$PEERS/../../config/robots
TMP=$(mktemp -d)
trap 'rm -rf "$TMP"' EXIT
show() { git -C "$ERD" show "$COMMIT:$1" > "$TMP/$2"; }
show LICENSE erd_LICENSE
show robots/baxter_description/LICENSE baxter_LICENSE
show robots/pr2_description/urdf/pr2.urdf pr2.urdf
show robots/baxter_description/urdf/baxter.urdf baxter.urdf
show robots/tiago_pro_description/robots/tiago_pro.urdf tiago_pro.urdf
ERD_ARGS=(--repo Gepetto/example-robot-data --commit "$COMMIT")

python3 "$PEERS/strip_urdf.py" "$TMP/pr2.urdf" "$OUT/pr2.urdf" "${ERD_ARGS[@]}" \
  --path robots/pr2_description/urdf/pr2.urdf \
  --title "Willow Garage PR2: two 7-DOF arms on the prismatic torso_lift_joint; the base's four casters and their eight wheels are fixed joints in this file (Gepetto's version), so the base cannot roll: root fixed or floating." \
  --licence "BSD 3-Clause (the repository's LICENSE, reproduced below)" --licence-text "$TMP/erd_LICENSE" \
  --upstream "github.com/PR2/pr2_common, pr2_description (Willow Garage; its package.xml declares 'BSD' without a licence text), expanded by xacro."

python3 "$PEERS/strip_urdf.py" "$TMP/baxter.urdf" "$OUT/baxter.urdf" "${ERD_ARGS[@]}" \
  --path robots/baxter_description/urdf/baxter.urdf \
  --title "Rethink Robotics Baxter: two 7-DOF arms on a fixed torso (head pan and two parallel grippers with a mimic finger each)." \
  --licence "BSD 3-Clause (robots/baxter_description/LICENSE, reproduced below)" --licence-text "$TMP/baxter_LICENSE" \
  --upstream "github.com/RethinkRobotics/baxter_common, baxter_description, expanded by xacro."

python3 "$PEERS/strip_urdf.py" "$TMP/tiago_pro.urdf" "$OUT/tiago_pro.urdf" "${ERD_ARGS[@]}" \
  --path robots/tiago_pro_description/robots/tiago_pro.urdf \
  --title "PAL Robotics TIAGo Pro: two 7-DOF arms on the prismatic torso_lift_joint, a base on four wheels (continuous joints; their suspension joints are fixed in this file; the real base is omnidirectional)." \
  --licence "Apache-2.0, as the file's own header below says (Copyright (c) 2024 PAL Robotics S.L.); the Apache License 2.0 text follows. The source repository's robots/tiago_pro_description/README.md says CC-BY-NC-ND 3.0, apparently copied from its TIAGo README; this copy follows the copyright holder's notice in the file" \
  --licence-text "$APACHE" \
  --upstream "PAL Robotics tiago_pro_description, expanded by xacro." \
  --wheel wheel_front_right_link --wheel wheel_front_left_link --wheel wheel_rear_right_link --wheel wheel_rear_left_link
