// URDF <mimic> joints (urdf_mimic.cpp): checked when the document is parsed (a loop of mimics
// is refused), read into Model::mimics when the model is built.
#pragma once

#include <urdf_model/model.h>

#include "se3_sim/model/model.h"

namespace se3 {

/// Throws ModelError when <mimic> joints follow each other round a loop (a -> b -> a), naming
/// the joints of the loop in order. A mimic of a joint the URDF lacks is left to read_mimics.
void check_urdf_mimics(const urdf::ModelInterface& u);

/// Model::mimics of a finalized model m built from u: every <mimic> joint that moves whose
/// leader moves, leaders before their mimics (a chain of mimics in order). A mimic of a joint
/// that does not move (fixed, locked, missing) stays a joint of its own: one warning in
/// m.warnings naming them all.
void read_mimics(const urdf::ModelInterface& u, Model& m);

}  // namespace se3
