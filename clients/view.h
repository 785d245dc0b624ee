// coopdyn view: the scene in 3D over the run of a `coopdyn sim` CSV, as one self-contained HTML page
// (three.js inlined). The geometry of every frame is computed here (forward kinematics of each
// CSV row's q) and embedded as JSON; the page only draws it.
#pragma once

#include <array>
#include <string>
#include <vector>

#include "service/dynamics/system.h"

namespace coopdyn::cli {

// What the page draws, in world coordinates.
struct ViewFrames {
  struct Shape {  // a load (box sized from its inertia) or a wheel (disk)
    std::string name, kind;  // kind: "box" | "wheel"
    int body = -1;
    Transform X_BS;          // the shape's frame in the body frame (box: principal axes at the
                             // centre of mass; wheel: y along the axle, at the wheel centre)
    Vec3 size = Vec3::Zero();  // box: edge lengths; wheel: (radius, width, 0)
  };
  struct Segment {  // a link drawn as a capsule between two points fixed in bodies
    std::string name;
    int body_a = -1, body_b = -1;  // -1: the world
    Vec3 p_a = Vec3::Zero(), p_b = Vec3::Zero();  // in the body frames
  };
  std::vector<Shape> shapes;
  std::vector<Segment> segments;
  std::vector<int> wrenches;  // the outputs drawn as arrows (every one but the joint reactions)
  // per frame
  std::vector<double> t;
  std::vector<std::string> status;
  std::vector<std::vector<double>> shape_pose;  // 7 per shape: position, quaternion x y z w
  std::vector<std::vector<double>> seg_ends;    // 6 per segment: both ends
  std::vector<std::vector<double>> wrench_W;    // 9 per drawn wrench: origin, force, moment (world)
};

// Reads a `coopdyn sim` CSV written for `sys`: keeps at most max_frames rows (evenly, the first and
// the last always) and computes their geometry. Throws std::runtime_error naming the file on a
// missing column, a column of another scene, a malformed row or no rows.
ViewFrames read_view_frames(const System& sys, const std::string& csv_path, int max_frames);

// The page: `three_js` is the text of three.min.js, inlined.
std::string view_page(const System& sys, const ViewFrames& vf, const std::string& three_js,
                      const std::string& csv_name);

}  // namespace coopdyn::cli
