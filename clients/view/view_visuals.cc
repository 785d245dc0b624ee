// coopdyn view: the <visual> elements of the scene's URDFs, found and attached to the model's bodies.
#include <urdf_parser/urdf_parser.h>
#include <yaml-cpp/yaml.h>

#include <Eigen/Geometry>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <sstream>

#include "clients/view/view.h"

namespace coopdyn::cli {

namespace fs = std::filesystem;

namespace {

bool is_file(const fs::path& p) {
  std::error_code ec;
  return fs::is_regular_file(p, ec);
}

// The mesh a <mesh filename> names: package://NAME/REST under the URDF's folder, each --package-path
// and each ROS_PACKAGE_PATH entry (as DIR/NAME/REST, or DIR/REST when DIR itself is NAME); a relative
// path from the URDF's folder; file:// and absolute paths as they are. "" when none exists.
std::string resolve_mesh(const std::string& uri, const fs::path& urdf_dir,
                         const std::vector<std::string>& package_paths) {
  std::string u = uri;
  if (u.rfind("file://", 0) == 0) return is_file(u.substr(7)) ? u.substr(7) : "";
  if (u.rfind("package://", 0) == 0) {
    u = u.substr(10);
    const size_t slash = u.find('/');
    if (slash == std::string::npos) return "";
    const std::string pkg = u.substr(0, slash), rest = u.substr(slash + 1);
    std::vector<std::string> dirs = {urdf_dir.string()};
    dirs.insert(dirs.end(), package_paths.begin(), package_paths.end());
    if (const char* ros = std::getenv("ROS_PACKAGE_PATH")) {
      std::stringstream ss(ros);
      for (std::string d; std::getline(ss, d, ':');)
        if (!d.empty()) dirs.push_back(d);
    }
    for (const std::string& d : dirs) {
      if (is_file(fs::path(d) / pkg / rest)) return (fs::path(d) / pkg / rest).string();
      if (fs::path(d).filename() == pkg && is_file(fs::path(d) / rest)) return (fs::path(d) / rest).string();
    }
    return "";
  }
  const fs::path p = fs::path(u).is_absolute() ? fs::path(u) : urdf_dir / u;
  return is_file(p) ? p.string() : "";
}

// The prefix -> URDF path of every robot placed in the scene (`bodies` and `arms` entries with a
// `robot` whose `urdf` is given), paths as the scene gives them, from the scene's folder.
std::vector<std::pair<std::string, std::string>> placed_urdfs(const std::string& scene_path) {
  std::vector<std::pair<std::string, std::string>> out;
  const YAML::Node root = YAML::LoadFile(scene_path);
  const fs::path dir = fs::path(scene_path).parent_path();
  std::map<std::string, std::string> urdf_of;
  if (root["robots"] && root["robots"].IsMap())
    for (const auto& kv : root["robots"])
      if (kv.second.IsMap() && kv.second["urdf"])
        urdf_of[kv.first.as<std::string>()] = (dir / kv.second["urdf"].as<std::string>()).string();
  for (const char* key : {"bodies", "arms"}) {
    if (!root[key] || !root[key].IsSequence()) continue;
    for (const auto& b : root[key])
      if (b.IsMap() && b["name"] && b["robot"] && urdf_of.count(b["robot"].as<std::string>()))
        out.emplace_back(b["name"].as<std::string>(), urdf_of[b["robot"].as<std::string>()]);
  }
  return out;
}

Transform pose_of(const urdf::Pose& p) {
  double x, y, z, w;
  p.rotation.getQuaternion(x, y, z, w);
  return Transform(Eigen::Quaterniond(w, x, y, z).normalized().toRotationMatrix(),
                   Vec3(p.position.x, p.position.y, p.position.z));
}

// One <visual> as the page draws it; false (with *why) when its geometry is none of mesh, box,
// cylinder, sphere.
bool visual_of(const urdf::Visual& v, const fs::path& urdf_dir, const std::vector<std::string>& package_paths,
               ViewVisual* out, std::string* why) {
  out->X_BV = pose_of(v.origin);
  if (v.material) {
    const urdf::Color& c = v.material->color;
    if (c.r || c.g || c.b || c.a) out->rgba = {c.r, c.g, c.b, c.a};
  }
  const urdf::Geometry* g = v.geometry.get();
  if (!g) {
    *why = "no <geometry>";
    return false;
  }
  switch (g->type) {
    case urdf::Geometry::BOX: {
      const auto& b = static_cast<const urdf::Box&>(*g);
      out->kind = "box";
      out->size = Vec3(b.dim.x, b.dim.y, b.dim.z);
      return true;
    }
    case urdf::Geometry::CYLINDER: {
      const auto& c = static_cast<const urdf::Cylinder&>(*g);
      out->kind = "cylinder";
      out->size = Vec3(c.radius, c.length, 0);
      return true;
    }
    case urdf::Geometry::SPHERE:
      out->kind = "sphere";
      out->size = Vec3(static_cast<const urdf::Sphere&>(*g).radius, 0, 0);
      return true;
    case urdf::Geometry::MESH: {
      const auto& m = static_cast<const urdf::Mesh&>(*g);
      out->kind = "mesh";
      out->uri = m.filename;
      out->scale = Vec3(m.scale.x, m.scale.y, m.scale.z);
      out->file = resolve_mesh(m.filename, urdf_dir, package_paths);
      return true;
    }
  }
  *why = "an unknown geometry";
  return false;
}

}  // namespace

ViewVisuals read_view_visuals(const System& sys, const std::string& scene_path,
                              const std::vector<std::string>& package_paths) {
  ViewVisuals vis;
  std::vector<std::pair<std::string, std::string>> placed;
  try {
    placed = placed_urdfs(scene_path);
  } catch (const std::exception& e) {
    vis.warnings.push_back(scene_path + ": its robots' visuals not read (" + e.what() + "): links drawn as capsules");
    return vis;
  }
  const Model& m = sys.model;
  std::map<int, int> slot;  // body -> index in vis.bodies
  for (const auto& [prefix, path] : placed) {
    urdf::ModelInterfaceSharedPtr model;
    try {
      model = urdf::parseURDFFile(path);
    } catch (const std::exception&) {
    }
    if (!model) {
      vis.warnings.push_back(path + ": visuals not read (urdfdom cannot parse it): links of '" + prefix +
                             "' drawn as capsules");
      continue;
    }
    const fs::path dir = fs::path(path).parent_path();
    int massive = 0, massive_drawn = 0;
    std::vector<int> bare;
    for (const auto& [lname, link] : model->links_) {
      if (!link || !link->inertial || !(link->inertial->mass > 0)) continue;
      ++massive;
      massive_drawn += !link->visual_array.empty() || link->visual;
    }
    for (const auto& [lname, link] : model->links_) {
      if (!link) continue;
      // the link's body (every link is a body PREFIX.LINK, or a frame fixed in one)
      int body = m.body_index(prefix + "." + lname);
      Transform X_BL;
      if (body < 0) {
        const int f = m.frame_index(prefix + "." + lname);
        if (f < 0 || m.frames[f].body < 0) continue;  // a link the scene does not place
        body = m.frames[f].body;
        X_BL = m.frames[f].X_BF;
      }
      std::vector<urdf::VisualSharedPtr> vs = link->visual_array;
      if (vs.empty() && link->visual) vs.push_back(link->visual);
      if (vs.empty() && X_BL.p.norm() == 0 && X_BL.R.isIdentity()) bare.push_back(body);
      for (const auto& v : vs) {
        if (!v) continue;
        ViewVisual out;
        out.link = prefix + "." + lname;
        std::string why;
        if (!visual_of(*v, dir, package_paths, &out, &why)) {
          vis.warnings.push_back(path + ": link '" + lname + "': a <visual> with " + why + " is not drawn");
          continue;
        }
        if (out.kind == "mesh" && out.file.empty())
          vis.warnings.push_back(
              "mesh '" + out.uri + "' of link '" + out.link + "' (" + path +
              ") not found (searched the URDF's folder, --package-path, ROS_PACKAGE_PATH): drawn as a capsule");
        out.X_BV = X_BL * out.X_BV;
        if (!slot.count(body)) {
          slot[body] = static_cast<int>(vis.bodies.size());
          vis.bodies.push_back(body);
        }
        out.body = slot[body];
        vis.visuals.push_back(std::move(out));
      }
    }
    if (2 * massive_drawn >= massive && massive_drawn > 0) vis.bare.insert(vis.bare.end(), bare.begin(), bare.end());
  }
  return vis;
}

}  // namespace coopdyn::cli
