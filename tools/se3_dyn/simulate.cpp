// se3_dyn simulate and render: thin front ends over the library's simulate_headless and
// render_to_png.
#include <algorithm>
#include <cmath>
#include <cstdio>

#include "cli.h"
#include "se3_sim/render/render.h"
#include "se3_sim/sim/scene_collision.h"
#include "se3_sim/sim/sim.h"

namespace se3_dyn {

int cmd_simulate(int argc, char** argv) {
  const Args args(argc, argv, 2, {"floating", "json", "random"},
                  {"scene", "integrator", "dt", "duration", "tol", "seed", "gravity", "out"});
  se3::SimulateOptions o;
  if (args.positional.size() > 1 || (args.positional.empty() && !args.has("scene"))) {
    throw UsageError("expected MODEL.urdf, --scene SCENE.yaml, or both");
  }
  o.scene = args.get("scene");
  if (!args.positional.empty()) o.model = args.positional[0];  // replaces the scene's robot
  if (!args.has("duration")) throw UsageError("--duration T is required");
  o.floating = args.has("floating");
  o.integrator = args.get("integrator");
  o.dt = args.get_double("dt", 0.0);
  o.duration = args.get_double("duration", 1.0);
  o.tol = args.get_double("tol", 0.0);
  const double seed = args.get_double("seed", 1.0);
  if (seed < 0 || seed != std::floor(seed)) throw UsageError("--seed needs a whole number");
  o.seed = static_cast<unsigned>(seed);
  o.random_initial = args.has("random");
  if (o.dt < 0 || o.duration < 0 || o.tol < 0) {
    throw UsageError("--dt, --duration and --tol must not be negative");
  }
  if (args.has("gravity")) {
    o.has_gravity = true;
    o.gravity = parse_vec3(args.get("gravity"), "--gravity");
  }
  o.out_csv = args.get("out");
  const se3::SimulateResult r = se3::simulate_headless(o);
  if (args.has("json")) {
    std::printf("%s\n", se3::simulate_result_json(r).c_str());
  } else {
    auto fig = [](double x) {
      char b[32];
      if (std::isnan(x)) return std::string("n/a");
      std::snprintf(b, sizeof b, "%.3e", x);
      return std::string(b);
    };
    std::printf(
        "integrator %s, dt %g s, %llu steps, %.6g s simulated in %.4g s wall "
        "(%.3g s wall per simulated second)\n",
        r.integrator.c_str(), r.dt, static_cast<unsigned long long>(r.steps), r.sim_s, r.wall_s,
        r.sim_s > 0 ? r.wall_s / r.sim_s : 0.0);
    std::printf(
        "energy drift (rel. to max(T(0), M g L, T max)): %s\nmomentum drift (rel.): %s\n"
        "constraint error max: %s\n",
        fig(r.energy_drift_rel).c_str(), fig(r.momentum_drift_rel).c_str(),
        fig(r.constraint_error_max).c_str());
    std::string by = se3::steps_by_scheme(r);  // "rkmk4": 9800, ... without the quotes
    by.erase(std::remove(by.begin(), by.end(), '"'), by.end());
    std::printf("steps by scheme: %s; limit impacts located: %llu\n", by.c_str(),
                static_cast<unsigned long long>(r.events));
    if (!std::isnan(r.penetration_max)) {
      std::printf("penetration max: %s m\n", fig(r.penetration_max).c_str());
    }
    if (r.fast_steps > 0) {
      std::printf("fast steps (an object moved farther than its size: may tunnel): %llu\n",
                  static_cast<unsigned long long>(r.fast_steps));
    }
    if (r.diverged) std::printf("diverged: %s\n", r.status.c_str());
  }
  if (r.diverged) {
    std::fflush(stdout);
    std::fprintf(stderr, "se3_dyn: the run diverged at t = %.6g s (step %llu): %s\n", r.sim_s,
                 static_cast<unsigned long long>(r.steps), r.status.c_str());
    return 1;
  }
  if (r.stopped) {
    std::fflush(stdout);
    std::fprintf(stderr, "se3_dyn: %s\n", r.status.c_str());
    return 1;
  }
  return 0;
}

int cmd_render(int argc, char** argv) {
  const Args args(argc, argv, 2, {"floating"},
                  {"scene", "camera", "out", "gravity", "package-path"});
  if (!args.has("out")) throw UsageError("--out frame.png is required");
  se3::render::RenderOptions opt;
  std::string err;
  se3::Model model;
  se3::GeometryModel geometry;
  // Mesh names: package:// on --package-path, then ROS_PACKAGE_PATH; relative to the URDF.
  se3::GeometryOptions gopt;
  gopt.paths.package_path = se3::split_path_list(args.get("package-path"));
  if (args.has("scene")) {
    const se3::Scene scene = se3::load_scene(args.get("scene"));
    model = se3::scene_model(scene);
    geometry = se3::scene_geometry(scene, model, "", gopt);
    for (se3::GeometryObject& g : se3::scene_object_geometry(scene.objects)) {  // at their poses
      geometry.visuals.push_back(std::move(g));
    }
    const se3::State s = se3::scene_state(scene, model);
    opt.base = s.base;
    opt.q = s.q;
    if (scene.has_base_visual) {  // drawn on the base link, as the simulator node publishes it
      se3::render::Marker box;
      box.type = se3::render::Marker::Type::Box;
      box.a = s.base.act(scene.base_visual_origin);
      box.R = s.base.R;
      box.size3 = scene.base_visual_box;
      box.color = scene.base_visual_color;
      opt.markers.push_back(box);
    }
  } else {
    se3::UrdfDocument doc;  // parsed once, for the model and its geometry
    model = load_model(args, &doc);
    geometry = doc.urdf ? se3::geometry_from_urdf(model, doc, gopt) : se3::chain_geometry(model);
  }
  for (const std::string& w : geometry.warnings) std::fprintf(stderr, "warning: %s\n", w.c_str());
  if (args.has("camera") && !se3::render::parse_camera_spec(args.get("camera"), opt, &err)) {
    throw UsageError("--camera: " + err);
  }
  if (se3::render::render_to_png(model, geometry, opt, args.get("out"), &err) != 0) {
    throw InputError(err);
  }
  std::printf("wrote %s\n", args.get("out").c_str());
  return 0;
}

}  // namespace se3_dyn
