// Readers of the scene keys `objects:` and `srdf:` (scene_objects.cpp), used by scene.cpp.
#pragma once

#include <string>
#include <vector>

#include "scene_reader.h"
#include "se3_sim/sim/scene_objects.h"

namespace se3 {

/// The `objects:` block list; mesh paths relative to base_dir. Throws SceneError naming the
/// file, line and key (unknown shape, non-positive size or mass, missing mesh file, duplicate
/// name, non-unit quaternion, ...).
void read_scene_objects(const SceneReader& r, const SceneReader::Field& v,
                        const std::string& base_dir, std::vector<SceneObject>& out);
/// One entry of `objects:` (a map of its keys), checked as read_scene_objects checks each; a
/// map without `name` gets default_name (none: an error).
SceneObject read_scene_object(const SceneReader& r, const SceneReader::Field& v,
                              const std::string& base_dir, const std::string& default_name = "");
/// A 3x3 inertia about a centre: [ixx, iyy, izz], six values (ixx, iyy, izz, ixy, ixz, iyz) or
/// a symmetric 3x3 list; positive definite and within the triangle inequality.
Mat3 read_inertia(const SceneReader& r, const SceneReader::Field& f);
/// `srdf: PATH` (relative to base_dir): the file, which must exist.
std::string read_scene_srdf(const SceneReader& r, const SceneReader::Field& v,
                            const std::string& base_dir);

}  // namespace se3
