// The geometry of a scene's robot, and the collision shapes its contact constraints may use.
#include "se3_sim/sim.h"

namespace se3 {

GeometryModel scene_geometry(const Scene& scene, const Model& model, const std::string& urdf_xml,
                             const GeometryOptions& opt) {
  if (!urdf_xml.empty()) return geometry_from_urdf_string(model, urdf_xml, opt);
  if (scene.robot_path.compare(0, 6, "chain:") == 0) return chain_geometry(model);
  return geometry_from_urdf_file(model, scene.robot_path, opt);
}

ConstraintSpec scene_constraints(const Scene& scene, const Model& model,
                                 const std::string& urdf_xml) {
  ConstraintSpec spec = scene.constraints;
  if (spec.contacts_from_collisions && !spec.geometry) {
    GeometryOptions opt;
    opt.load_meshes = false;
    spec.geometry = std::make_shared<GeometryModel>(scene_geometry(scene, model, urdf_xml, opt));
  }
  return spec;
}

}  // namespace se3
