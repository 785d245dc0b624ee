// coopdyn view: the scene in 3D over a run, as one self-contained HTML page (three.js inlined), from
// a `coopdyn sim` CSV, a daemon log (output_t messages, clients/view/view_log.cc) or live from the
// daemon's LCM outputs (clients/view/view_live.cc). The geometry of every frame is computed here
// (forward kinematics of each sample's q) and embedded as JSON; the page only draws it.
#pragma once

#include <array>
#include <string>
#include <vector>

#include "service/dynamics/system.h"

namespace coopdyn::io {
struct DecodedOutput;
}

namespace coopdyn::cli {

// A <visual> of a URDF link placed in the scene (clients/view/view_visuals.cc).
struct ViewVisual {
  std::string link;           // PREFIX.LINK, the model's name of its link
  std::string kind;           // "mesh" | "box" | "cylinder" | "sphere"
  std::string uri, file;      // mesh: the filename as the URDF gives it; the file found ("" none: a capsule)
  int body = -1;              // index into ViewVisuals::bodies
  Transform X_BV;             // the visual's frame in its body's frame (<origin>, a fixed link's place)
  Vec3 size = Vec3::Zero();   // box: edges; cylinder: (radius, length, 0) along z; sphere: (radius, 0, 0)
  Vec3 scale = Vec3::Ones();  // mesh: <mesh scale>
  std::array<double, 4> rgba = {-1, 0, 0, 0};  // <material><color>; rgba[0] < 0: none given
};
struct ViewVisuals {
  std::vector<int> bodies;    // the model's bodies that carry visuals
  std::vector<ViewVisual> visuals;
  std::vector<std::string> warnings;  // what is not drawn as the URDF says (a missing mesh: its file and link)
  std::vector<int> bare;      // bodies of links without a <visual> in a robot drawn by its visuals (at least
                              // half its links with mass have one): no capsule
};
// The visuals of every robot the scene at scene_path places (its `bodies` and `arms` with a `robot`
// whose `urdf` is given), meshes resolved from the URDF's folder, package_paths and ROS_PACKAGE_PATH
// (package://NAME/REST as DIR/NAME/REST). Never throws: what cannot be read is a warning.
ViewVisuals read_view_visuals(const System& sys, const std::string& scene_path, const std::vector<std::string>& package_paths);

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
  struct Pseudo {  // a pseudo-joint (the paper's (22)-(26)): its lock's generalized force is the stress there
    std::string name, unit;  // the joint's name; "N*m" (revolute) or "N" (prismatic)
    int body = -1;           // the body after the joint: its origin is the joint's place
    int dof = -1;            // velocity index
    bool coupling = false;   // a joint coupling (<mimic>): its force on the mimicking joint, the joint's place
  };
  struct Contact {  // a wheel's rolling contact (service/dynamics/contacts.h), in constraint order
    std::string name;  // the rolling constraint's name (its wrench's, its CSV columns' NAME.*)
    int spec = -1;     // index in sys.constraints.specs
    double mu = 0;     // friction coefficient; 0: none given (no utilisation)
  };
  struct Ground {  // a plane the wheels roll on {x : n . x = d}, in the world
    Vec3 n = Vec3::UnitZ();
    double d = 0;
    std::vector<int> contacts;  // the contacts on it (indices into `contacts`)
  };
  std::vector<Shape> shapes;
  std::vector<Segment> segments;
  std::vector<Pseudo> pseudos;  // the pseudo-joints, then the joint couplings (Workspace::stress's order)
  std::vector<Contact> contacts;
  std::vector<Ground> grounds;  // the distinct planes of the contacts (none without wheels)
  std::vector<int> wrenches;  // the outputs drawn as arrows (every one but the joint reactions)
  ViewVisuals visuals;        // the URDFs' visuals; none: links drawn as capsules
  // per frame
  std::vector<double> t;
  std::vector<std::string> status;
  std::vector<std::vector<double>> shape_pose;  // 7 per shape: position, quaternion x y z w
  std::vector<std::vector<double>> seg_ends;    // 6 per segment: both ends
  std::vector<std::vector<double>> body_pose;   // 7 per body of visuals.bodies: position, quaternion x y z w
  std::vector<std::vector<double>> wrench_W;    // 9 per drawn wrench: origin, force, moment (world)
  std::vector<std::vector<double>> wrench_F;    // 6 per drawn wrench: [moment; force] in its report frame,
                                                // the source's numbers (the page's plot)
  std::vector<std::vector<double>> contact_p;   // 3 per contact: its point on the ground (world)
  std::vector<std::vector<double>> contact_u;   // 2 per contact: utilisation |f_t| / (mu f_n) and the
                                                // friction needed |f_t| / f_n (-1: undefined, as in
                                                // contacts.h); empty: not in the source
  std::vector<std::vector<int>> contact_state;  // 1 per contact: ContactState (0 ok, 1 slip, 2 lift_off);
                                                // empty: not in the source
  std::vector<std::vector<double>> pseudo_p;    // 3 per pseudo-joint: its place (world)
  std::vector<std::vector<double>> stress;      // 1 per pseudo-joint, N*m or N; empty: not in the source
  std::vector<std::vector<double>> wrench_sigma;  // 6 per drawn wrench: the standard deviation of each
                                                 // component of wrench_F (same frame and units); empty:
                                                 // not in the source (no declared noise)
  std::vector<std::vector<double>> wrench_bound;  // 6 per drawn wrench: the friction bound of each
                                                 // component (output_t wrench_bound); empty: none
  std::vector<std::vector<double>> wrench_R;     // 4 per drawn wrench: its report frame's orientation in
                                                 // the world (quaternion x y z w), the axes of sigma and
                                                 // bound; empty when the frame has neither
  std::vector<std::vector<int>> indet;          // 1 per drawn wrench: bit k, component k of [m; f] is
                                                // not determined by the physics; empty: not in the source
  std::vector<std::string> free;                // the free directions by class ("2 wheel_normal"); "" none
  std::vector<std::string> limits;              // the joint limits exceeded ("arm1.q1 velocity"); "" none
  std::vector<std::string> note;                // what the status line adds ("no state; the pose of
                                                // t = 1.5 s held"); "" none
  void clear_frames();                          // the per-frame vectors emptied, the geometry kept
};

// One instant of a run, whatever its source: the state and the wrenches the page draws.
struct ViewSample {
  double t = 0;            // s, simulation time
  std::string status;      // "ok" | "indeterminate" | "error"
  Eigen::VectorXd q;       // (nq) in the scene's order
  std::vector<Vec6> w;     // per drawn wrench (ViewFrames::wrenches): [moment; force] in its report frame
  std::vector<double> stress;  // per pseudo-joint (ViewFrames::pseudos); empty: unknown (a sim CSV)
  std::vector<int> indet;      // per drawn wrench, indeterminate_mask; empty: unknown
  std::string free;            // the free directions by class, "" none
  std::string limits;          // the joint limits exceeded ("arm1.q1 velocity, ..."), "" none or unknown
  std::vector<double> contact_u;  // per contact (ViewFrames::contacts): utilisation, friction needed;
                                  // empty: unknown
  std::vector<int> contact_state;  // per contact, ContactState; empty: unknown
  std::vector<Vec6> sigma;  // per drawn wrench: standard deviation of each component of w; empty: none
  std::vector<Vec6> bound;  // per drawn wrench: its friction bound (joints at rest); empty: none
  std::string note;         // what the status line adds; "" none
  bool pose_held = false;   // q is an earlier sample's (this one's was not a configuration)
};

// The shapes, links and drawn wrenches of the scene, no frames yet.
// `vis`: the visuals to draw (copied), whose bodies' poses every frame then carries.
ViewFrames view_geometry(const System& sys, const ViewVisuals* vis = nullptr);
// Appends the frame of sample s to vf (normalises s.q). `data` is a workspace of sys.model.
void add_view_frame(const System& sys, Data& data, ViewSample& s, ViewFrames* vf);
// At most max_frames of the samples (evenly, the first and the last always), with their geometry.
ViewFrames view_frames_of(const System& sys, std::vector<ViewSample>& samples, int max_frames, const ViewVisuals* vis = nullptr);
// Frame i as the JSON object the live page appends: {"t":..,"status":..,"sp":[..],"seg":[..],"w":[..],..}.
std::string view_frame_json(const ViewFrames& vf, size_t i);

// Reads a `coopdyn sim` CSV written for `sys`: keeps at most max_frames rows (evenly, the first and
// the last always) and computes their geometry. Throws std::runtime_error naming the file on a
// missing column, a column of another scene, a malformed row or no rows.
ViewFrames read_view_frames(const System& sys, const std::string& csv_path, int max_frames, const ViewVisuals* vis = nullptr);

// The sample of one output_t of coopdynd running `sys` (`geo`: view_geometry(sys)): time, status,
// q, the drawn wrenches, the stresses, the indeterminate components and the free directions. An
// error output (no state, a stale one, a failed evaluation: its numbers are no values) has no
// wrenches (zeros: no arrows; the page's plot has a gap there), the reason as its note, and, when
// it has no state (no_state, state_stale: its q is no state) or its q is not a configuration of the
// scene, the pose of `held` (the last valid sample; the scene's initial pose when null). False, with the reason in *why, when it is of
// another scene (other coordinates or wrenches, by name) or a valid output's q is not a
// configuration of it. Used by --log and --live (clients/view/view_log.cc).
bool sample_of_output(const System& sys, const ViewFrames& geo, const io::DecodedOutput& o, ViewSample* s,
                      std::string* why, const ViewSample* held = nullptr);

// Reads the output_t messages on `channel` of an lcm-logger file recorded from coopdynd running
// `sys` (clients/view/view_log.cc). Throws std::runtime_error naming the file when it cannot be read,
// holds no output_t on that channel (the message lists the channels it has), or its outputs are of
// another scene (other coordinates or wrenches).
std::vector<ViewSample> read_log_samples(const System& sys, const std::string& log_path, const std::string& channel);

// The page: `three_js` is the text of three.min.js, inlined; `source` names the run (the file). A
// live page (live = true) has vf's frames as a placeholder, opens a WebSocket to the server it was
// loaded from and appends the frames it receives.
// `loaders`: the text of three.js's STLLoader, ColladaLoader and OBJLoader (read_three_loaders), inlined
// when a visual has a mesh; the mesh files are embedded (base64), so the page stays one file.
std::string view_page(const System& sys, const ViewFrames& vf, const std::string& three_js,
                      const std::string& source, bool live = false, const std::string& loaders = "");
// three.js's mesh loaders beside three_js_path (../examples/js/loaders/, Debian libjs-three); "" and a
// warning in *why when one is missing.
std::string read_three_loaders(const std::string& three_js_path, std::string* why);

// Reads and checks three.js; prints the reason (naming the file) and returns false when it cannot.
bool read_three_js(const std::string& path, std::string* text);

// coopdyn view --live (clients/view/view_live.cc): serves the live page and a WebSocket of frames.
int run_view_live(const System& sys, const ViewVisuals& vis, const std::string& three_js, const std::string& loaders,
                  const std::string& listen,
                  const std::string& lcm_url, const std::string& channel, double max_rate_hz, int queue_frames);

}  // namespace coopdyn::cli
