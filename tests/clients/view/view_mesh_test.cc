// coopdyn view draws the robots' own <visual>s (meshes through three.js's loaders, boxes), a missing
// mesh as a capsule with a warning, the scene without a run, its couplings' forces, and arrows at a
// scale per kind of wrench chosen from the wrenches shown (with zoom and log lengths): in headless
// Chromium, checked against this process's own reading of the URDF, the mesh files, `coopdyn eval`
// and the CSV.
#include <urdf_parser/urdf_parser.h>

#include <cstdint>
#include <cstring>
#include <set>

#include "tests/clients/view/view_test_util.h"

namespace coopdyn::view_test {
namespace {

// The probe's number `key` inside the object that starts at `at`.
double probe_num_at(const std::string& probe, const std::string& at, const std::string& key) {
  const size_t i = probe.find(at);
  return i == std::string::npos ? NAN : num_after(probe.substr(i), "\"" + key + "\":");
}

// A binary STL's triangle count (its header's), or -1.
long stl_triangles(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  char head[84];
  if (!f.read(head, 84)) return -1;
  uint32_t n;
  std::memcpy(&n, head + 80, 4);
  return static_cast<long>(n);
}

int scene_page(const std::string& scene, const std::string& html, const std::string& err_file, std::string* err,
               const std::string& extra = "") {
  return run("'" + kBin + "' view --scene '" + scene + "' --out '" + html + "' " + extra, err_file, err);
}

// The PR2 of pr2_box is drawn from its URDF's visuals: every mesh file it names is embedded once and
// read (STL), and the triangles of the meshes in the page's scene graph are those of the files, once
// per <visual> that names them (the URDF's boxes and cylinders besides); nothing is left as a capsule and nothing is
// warned about. The page is of the scene alone (no run).
TEST(ViewMeshes, Pr2DrawnFromItsMeshes) {
  REQUIRE_BROWSER();
  TempDir dir("pr2mesh");
  std::string err;
  ASSERT_EQ(scene_page(scene_file("pr2_box"), dir / "p.html", dir / "e", &err, "--hold"), 0) << err;
  EXPECT_EQ(err.find("warning: mesh"), std::string::npos) << err;

  // this process's own count: the URDF's <visual> meshes, resolved beside it
  const std::string urdf = kSrc + "/config/robots/pr2.urdf";
  const urdf::ModelInterfaceSharedPtr model = urdf::parseURDFFile(urdf);
  ASSERT_TRUE(model);
  std::set<std::string> files;
  long triangles = 0;
  int mesh_visuals = 0;
  for (const auto& [name, link] : model->links_)
    for (const auto& v : link->visual_array) {
      if (!v->geometry || v->geometry->type != urdf::Geometry::MESH) continue;
      const std::string uri = static_cast<const urdf::Mesh&>(*v->geometry).filename;
      ASSERT_EQ(uri.rfind("package://", 0), 0u) << uri;
      const std::string path = kSrc + "/config/robots/" + uri.substr(10);
      const long n = stl_triangles(path);
      ASSERT_GT(n, 0) << path;
      triangles += n;
      files.insert(path);
      ++mesh_visuals;
    }
  ASSERT_GT(mesh_visuals, 40);

  DevTools browser(chromium, dir / "b");
  const Browse b = browse(browser, dir / "p.html", "paused=1", true);
  ASSERT_TRUE(b.ok) << b.log.substr(0, 3000);
  const PageState p = page_state(b.dom);
  ASSERT_EQ(p.title, "coopdyn view: pr2_box");
  const std::string vis = between(p.probe, "\"visuals\":{", "}");
  EXPECT_EQ(num_after(vis, "\"mesh_files\":"), static_cast<double>(files.size())) << vis;
  EXPECT_EQ(num_after(vis, "\"meshes_loaded\":"), static_cast<double>(files.size())) << vis;
  EXPECT_EQ(num_after(vis, "\"mesh_triangles\":"), static_cast<double>(triangles)) << vis;
  EXPECT_GT(num_after(vis, "\"triangles\":"), static_cast<double>(triangles)) << "and the boxes and cylinders: " << vis;
  EXPECT_NE(vis.find("\"warnings\":[]"), std::string::npos) << vis;
  EXPECT_EQ(num_after(vis, "\"capsules\":"), 0) << vis;
  std::fprintf(stderr, "pr2_box: %zu mesh files, %d mesh visuals, %ld triangles\n", files.size(), mesh_visuals,
               triangles);
  // the robot is drawn: the canvas is not only the background and the grid
  int lit = 0;
  for (int y = 0; y < b.shot.h; y += 2)
    for (int x = 0; x < b.shot.w; x += 2) {
      const unsigned char* c = b.shot.at(x, y);
      lit += c[0] > 120 && c[1] > 120 && c[2] > 120;
    }
  EXPECT_GT(lit, 2000) << "the PR2's meshes are not in the screenshot";
}

// A robot whose URDF names a mesh that is not there and one that is not a mesh: one warning each,
// naming the file and the link, on stderr (missing) and in the page (both); the links are drawn as
// capsules, the box visual as a box, and the page has no JavaScript error.
TEST(ViewMeshes, MissingMeshIsACapsuleWithAWarning) {
  REQUIRE_BROWSER();
  TempDir dir("missing");
  {
    std::ofstream(dir / "bad.stl") << "this is not an STL file\n";
    std::ofstream u(dir / "two.urdf");
    u << R"(<robot name="two">
  <link name="l0"><inertial><mass value="1"/><inertia ixx="0.01" iyy="0.01" izz="0.01" ixy="0" ixz="0" iyz="0"/>
    </inertial>
    <visual><geometry><box size="0.1 0.1 0.1"/></geometry><material name="red"><color rgba="1 0 0 1"/></material>
      </visual></link>
  <link name="l1"><inertial><origin xyz="0 0 -0.25"/><mass value="1"/>
    <inertia ixx="0.01" iyy="0.01" izz="0.01" ixy="0" ixz="0" iyz="0"/></inertial>
    <visual><geometry><mesh filename="package://nowhere/meshes/upper.stl"/></geometry></visual></link>
  <link name="l2"><inertial><origin xyz="0 0 -0.25"/><mass value="1"/>
    <inertia ixx="0.01" iyy="0.01" izz="0.01" ixy="0" ixz="0" iyz="0"/></inertial>
    <visual><geometry><mesh filename="bad.stl"/></geometry></visual></link>
  <joint name="j1" type="revolute"><parent link="l0"/><child link="l1"/><origin xyz="0 0 -0.5"/><axis xyz="0 1 0"/>
    <limit effort="100" lower="-3" upper="3" velocity="1"/></joint>
  <joint name="j2" type="revolute"><parent link="l1"/><child link="l2"/><origin xyz="0 0 -0.5"/><axis xyz="0 1 0"/>
    <limit effort="100" lower="-3" upper="3" velocity="1"/></joint>
</robot>
)";
    std::ofstream s(dir / "two.yaml");
    s << "name: two\ngravity: [0, 0, -9.81]\nrobots:\n  two: {urdf: two.urdf}\nbodies:\n"
         "  - {name: arm, robot: two, parent: world, placement: {xyz: [0, 0, 1]}, root: fixed, q: {j1: 0.5, j2: "
         "0.3}}\n";
  }
  std::string err;
  ASSERT_EQ(scene_page(dir / "two.yaml", dir / "t.html", dir / "e", &err), 0) << err;
  EXPECT_NE(err.find("warning: mesh 'package://nowhere/meshes/upper.stl' of link 'arm.l1'"), std::string::npos) << err;
  EXPECT_EQ(err.find("upper.stl", err.find("upper.stl") + 1), std::string::npos) << "one warning: " << err;

  DevTools browser(chromium, dir / "b");
  const Browse b = browse(browser, dir / "t.html", "paused=1", false);
  ASSERT_TRUE(b.ok) << b.log.substr(0, 3000);
  const PageState p = page_state(b.dom);
  ASSERT_EQ(p.title, "coopdyn view: two");
  const std::string warn = between(b.dom, "<div id=\"warn\"", "</div>");
  EXPECT_NE(warn.find("package://nowhere/meshes/upper.stl not found of link arm.l1"), std::string::npos) << warn;
  EXPECT_NE(warn.find("bad.stl"), std::string::npos) << warn;
  EXPECT_NE(warn.find("of link arm.l2"), std::string::npos) << warn;
  const std::string vis = between(p.probe, "\"visuals\":{", "}");
  EXPECT_EQ(num_after(vis, "\"meshes_loaded\":"), 0) << vis;
  EXPECT_EQ(num_after(vis, "\"triangles\":"), 12) << "the box alone: " << vis;
  EXPECT_EQ(num_after(vis, "\"capsules\":"), 2) << "l1 and l2 as capsules: " << vis;
}

// OBJ and COLLADA meshes, found through --package-path and ROS_PACKAGE_PATH: both read by three.js's
// loaders, their triangles in the scene graph (a tetrahedron's 4, a COLLADA triangle's 1), no warning.
TEST(ViewMeshes, ObjAndColladaFromPackagePaths) {
  REQUIRE_BROWSER();
  TempDir dir("objdae");
  fs::create_directories(dir.path / "a" / "pa" / "m");
  fs::create_directories(dir.path / "b" / "pb" / "m");
  std::ofstream(dir / "a/pa/m/tet.obj")
      << "v 0 0 0\nv 0.1 0 0\nv 0 0.1 0\nv 0 0 0.1\nf 1 2 3\nf 1 2 4\nf 1 3 4\nf 2 3 4\n";
  std::ofstream(dir / "b/pb/m/tri.dae") << R"(<?xml version="1.0"?>
<COLLADA xmlns="http://www.collada.org/2005/11/COLLADASchema" version="1.4.1">
  <asset><unit meter="1"/><up_axis>Z_UP</up_axis></asset>
  <library_geometries><geometry id="g"><mesh>
    <source id="p"><float_array id="pa" count="9">0 0 0 0.2 0 0 0 0.2 0</float_array>
      <technique_common><accessor source="#pa" count="3" stride="3"><param name="X" type="float"/>
        <param name="Y" type="float"/><param name="Z" type="float"/></accessor></technique_common></source>
    <vertices id="v"><input semantic="POSITION" source="#p"/></vertices>
    <triangles count="1"><input semantic="VERTEX" source="#v" offset="0"/><p>0 1 2</p></triangles>
  </mesh></geometry></library_geometries>
  <library_visual_scenes><visual_scene id="s"><node id="n"><instance_geometry url="#g"/></node></visual_scene>
    </library_visual_scenes>
  <scene><instance_visual_scene url="#s"/></scene>
</COLLADA>
)";
  {
    std::ofstream u(dir / "r.urdf");
    u << R"(<robot name="r">
  <link name="l0"><inertial><mass value="1"/><inertia ixx="0.01" iyy="0.01" izz="0.01" ixy="0" ixz="0" iyz="0"/>
    </inertial>
    <visual><geometry><mesh filename="package://pa/m/tet.obj" scale="2 2 2"/></geometry></visual></link>
  <link name="l1"><inertial><origin xyz="0 0 -0.25"/><mass value="1"/>
    <inertia ixx="0.01" iyy="0.01" izz="0.01" ixy="0" ixz="0" iyz="0"/></inertial>
    <visual><origin xyz="0 0 -0.3"/><geometry><mesh filename="package://pb/m/tri.dae"/></geometry></visual></link>
  <joint name="j1" type="revolute"><parent link="l0"/><child link="l1"/><origin xyz="0 0 -0.5"/><axis xyz="0 1 0"/>
    <limit effort="100" lower="-3" upper="3" velocity="1"/></joint>
</robot>
)";
    std::ofstream(dir / "r.yaml")
        << "name: r\ngravity: [0, 0, -9.81]\nrobots:\n  r: {urdf: r.urdf}\nbodies:\n"
           "  - {name: arm, robot: r, parent: world, placement: {xyz: [0, 0, 1]}, root: fixed, q: {j1: 0.5}}\n";
  }
  std::string err;
  ASSERT_EQ(run("ROS_PACKAGE_PATH='" + dir / "b" + "' '" + kBin + "' view --scene '" + dir / "r.yaml" + "' --out '" +
                    dir / "r.html" + "' --package-path '" + dir / "a" + "'",
                dir / "e", &err),
            0)
      << err;
  EXPECT_EQ(err.find("warning: mesh"), std::string::npos) << err;
  DevTools browser(chromium, dir / "b2");
  const Browse b = browse(browser, dir / "r.html", "paused=1", false);
  ASSERT_TRUE(b.ok) << b.log.substr(0, 3000);
  const PageState p = page_state(b.dom);
  ASSERT_EQ(p.title, "coopdyn view: r");
  const std::string vis = between(p.probe, "\"visuals\":{", "}");
  EXPECT_EQ(num_after(vis, "\"mesh_files\":"), 2) << vis;
  EXPECT_EQ(num_after(vis, "\"meshes_loaded\":"), 2) << vis;
  EXPECT_EQ(num_after(vis, "\"mesh_triangles\":"), 5) << vis;
  EXPECT_NE(vis.find("\"warnings\":[]"), std::string::npos) << vis;
}

// The scene without a run, with the holding torques: one frame at the scene's initial state, its
// status ok, each wrench's force as `coopdyn eval --hold` computes it (its norm: the page shows world
// axes, eval the report frame's), the mimic couplings' forces (the fingers' <mimic>) with the
// pseudo-joints' stresses as eval's; with zero torque the PR2's arms are not held (other forces).
TEST(ViewScene, RendersWithoutARun) {
  REQUIRE_BROWSER();
  TempDir dir("scene");
  std::string err;
  ASSERT_EQ(scene_page(scene_file("pr2_box"), dir / "h.html", dir / "e", &err, "--hold"), 0) << err;
  ASSERT_EQ(scene_page(scene_file("pr2_box"), dir / "z.html", dir / "e2", &err), 0) << err;
  ASSERT_EQ(run("'" + kBin + "' eval --hold --scene '" + scene_file("pr2_box") + "' > '" + dir / "eval.json" + "'",
                dir / "e3"),
            0)
      << slurp(dir / "e3");
  const std::string ev = slurp(dir / "eval.json");
  const System sys = load_scene(scene_file("pr2_box"));
  DevTools browser(chromium, dir / "b");
  double zero_norm = NAN, hold_norm = NAN;
  for (const char* page : {"h.html", "z.html"}) {
    const Browse b = browse(browser, dir / page, "paused=1&wrench=left_hand", false);
    ASSERT_TRUE(b.ok) << b.log.substr(0, 3000);
    const PageState p = page_state(b.dom);
    ASSERT_EQ(p.title, "coopdyn view: pr2_box") << page;
    EXPECT_EQ(num_after(p.probe, "\"frames\":"), 1);
    EXPECT_EQ(between(p.probe, "\"status\":\"", "\""), "ok") << page;
    const std::string ro = between(b.dom, "<span id=\"readout\">", "</span>");
    const Vec3 f = vec_after(ro, "f = (");
    (page[0] == 'h' ? hold_norm : zero_norm) = f.norm();
    if (page[0] != 'h') continue;
    // eval's force of left_hand, in its frame
    const std::string w = ev.substr(ev.find("{\"name\": \"left_hand\""));
    const Vec3 fe = vec_after(w, "\"force\": [");
    EXPECT_NEAR(f.norm(), fe.norm(), 2e-3 * (1 + fe.norm())) << ro << " vs eval " << fe.transpose();
    // the stresses: the pseudo-joints', then each coupling's, as eval's
    const std::string st = between(p.probe, "\"stress\":[", "]");
    std::vector<double> page_st;
    for (const char* c = st.c_str(); *c;) {
      char* end;
      page_st.push_back(std::strtod(c, &end));
      c = *end ? end + 1 : end;
    }
    const int n = num_stresses(sys);
    ASSERT_EQ(static_cast<int>(page_st.size()), n) << st;
    int couplings = 0;
    for (int k = 0; k < n; ++k) {
      const std::string at = "{\"joint\": \"" + stress_name(sys, k) + "\", \"value\": ";
      const double e = num_after(ev, at);
      EXPECT_NEAR(page_st[k], e, 1e-6 * (1 + std::abs(e))) << stress_name(sys, k);
      couplings += b.dom.find("coupling " + stress_name(sys, k)) != std::string::npos;
    }
    EXPECT_GT(couplings, 0) << "the PR2's finger couplings are listed with their forces";
  }
  EXPECT_GT(std::abs(zero_norm - hold_norm), 1e-3 * hold_norm)
      << "zero torque and holding torques give the same grasp force";
}

// The arrows' scale follows the wrenches shown: the car driven hard on its left rear wheel (2000 N*m)
// has one scale for its wheels' wrenches, from the largest force of those shown over the run (0.4 of
// the scene's size, 1-2-5); shown alone, the front left contact gets a smaller one. Its arrow's length
// is |f| over that scale, times a zoom (#zoom=4), or 0.4 size ln(1 + |f| / v0) / ln(101) with log
// lengths (v0 a hundredth of the full scale); the legend shows the scale used.
TEST(ViewArrows, ScaleFollowsTheWrenchesShown) {
  REQUIRE_BROWSER();
  TempDir dir("scales");
  ASSERT_EQ(run("'" + kBin + "' sim --scene '" + scene_file("four_wheel_car") +
                    "' --duration 0.3 --dt 0.01 --torque rl_spin:constant:2000 --out '" + dir / "c.csv" + "'",
                dir / "sim.err"),
            0)
      << slurp(dir / "sim.err");
  std::string err;
  ASSERT_EQ(view(scene_file("four_wheel_car"), dir / "c.csv", dir / "c.html", dir / "e", &err), 0) << err;
  const coopdyn::testing::CsvText table = coopdyn::testing::read_csv_text(dir / "c.csv");
  auto col = [&](const std::string& n) {
    return static_cast<size_t>(std::find(table.head.begin(), table.head.end(), n) - table.head.begin());
  };
  auto fmax = [&](const std::vector<std::string>& names) {  // the largest |f| of these wrenches over the rows
    double m = 0;
    for (const auto& r : table.rows)
      for (const auto& n : names)
        m = std::max(
            m, Vec3(std::stod(r[col(n + ".fx")]), std::stod(r[col(n + ".fy")]), std::stod(r[col(n + ".fz")])).norm());
    return m;
  };
  auto nice_ceil = [](double x) {
    const double e = std::pow(10.0, std::floor(std::log10(x)));
    for (double m : {1.0, 2.0, 5.0, 10.0})
      if (m * e >= x * (1 - 1e-12)) return m * e;
    return 10 * e;
  };
  const System sys = load_scene(scene_file("four_wheel_car"));
  std::vector<std::string> wheel_wrenches;  // the contacts and axles: the "wheels" kind
  for (const auto& o : sys.wrenches.outputs)
    if (o.kind == WrenchKind::kAxle || (o.spec >= 0 && sys.constraints.specs[o.spec].kind == ConstraintKind::kRolling))
      wheel_wrenches.push_back(o.name);
  ASSERT_GE(wheel_wrenches.size(), 4u);

  DevTools browser(chromium, dir / "b");
  const Browse all = browse(browser, dir / "c.html", "t=0.2&paused=1", false);
  const Browse one = browse(browser, dir / "c.html", "t=0.2&paused=1&wrench=fl", false);
  const Browse zoomed = browse(browser, dir / "c.html", "t=0.2&paused=1&wrench=fl&zoom=4", false);
  const Browse logged = browse(browser, dir / "c.html", "t=0.2&paused=1&wrench=fl&log=1", false);
  for (const Browse* b : {&all, &one, &zoomed, &logged}) ASSERT_TRUE(b->ok) << b->log.substr(0, 3000);
  const PageState pa = page_state(all.dom), p1 = page_state(one.dom), pz = page_state(zoomed.dom),
                  pl = page_state(logged.dom);
  const double size = num_after(pa.probe, "\"size\":");
  ASSERT_GT(size, 0);
  const std::string at = "{\"name\":\"fl\",\"group\"";
  const double s_all = probe_num_at(pa.probe, at, "force"), s_one = probe_num_at(p1.probe, at, "force");
  EXPECT_EQ(s_all, nice_ceil(fmax(wheel_wrenches) / (0.4 * size))) << pa.probe;
  EXPECT_EQ(s_one, nice_ceil(fmax({"fl"}) / (0.4 * size))) << p1.probe;
  EXPECT_LT(s_one, s_all) << "the scale did not follow the wrenches shown";
  EXPECT_NE(one.dom.find("<span id=\"fscale\">1 m = " + between(p1.probe, "\"force_scale\":", ",") + " N</span>"),
            std::string::npos);
  EXPECT_EQ(p1.force_scale, s_one);

  // the arrow's length: |f| / scale, x4 zoomed, log
  const auto row = csv_row(dir / "c.csv", 0.2);
  const double f = Vec3(std::stod(row.at("fl.fx")), std::stod(row.at("fl.fy")), std::stod(row.at("fl.fz"))).norm();
  ASSERT_GT(f, 1);
  auto arrow_len = [&](const PageState& p) {
    const std::string o = p.probe.substr(p.probe.find(at));
    return (vec_after(o, "\"tip_f\":[") - vec_after(o, "\"origin\":[")).norm();
  };
  EXPECT_NEAR(arrow_len(p1), f / s_one, 1e-5 * size);
  EXPECT_NEAR(arrow_len(pz), 4 * f / s_one, 1e-5 * size);
  EXPECT_EQ(probe_num_at(pz.probe, at, "zoom"), 4);
  EXPECT_NEAR(arrow_len(pl), 0.4 * size * std::log(1 + f / (0.004 * size * s_one)) / std::log(101.0), 1e-5 * size);
  EXPECT_NE(logged.dom.find("<span id=\"fscale\">log, "), std::string::npos);
}

}  // namespace
}  // namespace coopdyn::view_test
