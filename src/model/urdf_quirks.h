// Quirks of real URDFs (the README's table), met with one warning each and a sensible reading
// instead of a refusal. Two passes around urdfdom (urdf_model.cpp):
//  - urdf_text_quirks, on the text before urdfdom: `inf` (or +inf, Infinity) in a <limit>
//    attribute, which urdfdom refuses as "not a valid float", is read as no limit; a xacro file
//    (not expanded) is refused with what to do.
//  - urdf_model_quirks, on urdfdom's model: lower >= upper (a CAD exporter's 0 0) means no
//    position limits; effort or velocity 0 means no such limit; a joint that moves only
//    massless links (no inertial anywhere below it: a sensor or tool frame on a continuous
//    joint) is locked at 0 (the nearest limit), since it has no dynamics; a link whose inertial
//    breaks the triangle inequality is kept as given.
// Each kind of quirk gives one warning naming every joint or link it concerns.
#pragma once

#include <urdf_model/model.h>

#include <string>
#include <utility>
#include <vector>

namespace se3 {

/// The URDF text with the quirks urdfdom would refuse rewritten (the text itself when there
/// are none). Throws ModelError for a xacro file.
std::string urdf_text_quirks(const std::string& xml, std::vector<std::string>& warnings);

/// Reads the quirks of a parsed URDF: rewrites its limits in place (lower >= upper: none;
/// the text pass's stand-in for an infinite lower/upper: none), appends to `lock` the joints that
/// move only massless links (with the position they are locked at) and the warnings.
void urdf_model_quirks(urdf::ModelInterface& u, std::vector<std::pair<std::string, double>>& lock,
                       std::vector<std::string>& warnings);

/// Merges the per-link warnings of one kind (inertias that break the triangle inequality) into
/// one line naming every link.
void group_quirk_warnings(std::vector<std::string>& warnings);

}  // namespace se3
