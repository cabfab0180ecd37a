// The geometry of a scene's robot, and the collision shapes its contact constraints may use.
#include <cmath>

#include "se3_sim/sim/sim.h"

namespace se3 {

GeometryModel scene_geometry(const Scene& scene, const Model& model, const std::string& urdf_xml,
                             const GeometryOptions& opt) {
  if (!urdf_xml.empty()) {
    if (scene.urdf_dir.empty() || !opt.paths.base_dir.empty()) {
      return geometry_from_urdf_string(model, urdf_xml, opt);
    }
    GeometryOptions with_dir = opt;
    with_dir.paths.base_dir = scene.urdf_dir;
    return geometry_from_urdf_string(model, urdf_xml, with_dir);
  }
  if (scene.robot_path.empty()) return GeometryModel();  // objects only: no robot to draw
  if (scene.robot_path.compare(0, 6, "chain:") == 0) return chain_geometry(model);
  return geometry_from_urdf_file(model, scene.robot_path, opt);
}

ConstraintSpec scene_constraints(const Scene& scene, const Model& model,
                                 const std::string& urdf_xml) {
  ConstraintSpec spec = scene.constraints;
  // Joint position limits are on unless the scene says joint_limits: false (a robot without
  // any limit gets no limit rows, and so no constraint step).
  if (!spec.joint_limits_given) {
    spec.joint_limits = false;
    for (int i = 1; i <= model.n; ++i) {
      spec.joint_limits =
          spec.joint_limits || std::isfinite(model.lower[i]) || std::isfinite(model.upper[i]);
    }
  }
  if (spec.contacts_from_collisions && !spec.geometry) {
    GeometryOptions opt;
    opt.load_meshes = false;
    spec.geometry = std::make_shared<GeometryModel>(scene_geometry(scene, model, urdf_xml, opt));
  }
  return spec;
}

}  // namespace se3
