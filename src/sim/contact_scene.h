// Scene keys of constraints.h (constraints, joint_limits, ground, contacts, constraint_options),
// read by parse_scene (scene.cpp) through this one entry point.
#pragma once

#include <string>
#include <vector>

#include "scene_reader.h"
#include "se3_sim/solver/constraints.h"

namespace se3 {

/// The top-level scene keys handled here.
const std::vector<std::string>& constraint_scene_keys();

/// Reads the top-level field f (one of constraint_scene_keys()) into spec. Throws SceneError
/// naming file and line.
void parse_constraint_key(const SceneReader& r, const SceneReader::Field& f, ConstraintSpec& spec);

}  // namespace se3
