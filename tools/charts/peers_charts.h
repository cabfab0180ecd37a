// The peers in the charts (issue 16): MuJoCo's and DART's own integrators as work-precision
// curves on charts_data's scenes, the study of Erez, Tassa and Todorov (ICRA 2015) with se3_sim,
// MuJoCo 2.2 and DART 6.12 in one run, and the stability cases where methods fail.
#pragma once

#include <fstream>
#include <string>
#include <vector>

#include "se3_sim/dynamics/dynamics.h"

namespace se3::charts {

/// Appends to a wp_<scene>.csv (charts_data's columns) the final-state error of every peer
/// engine of this build (tools/peers/engines.h) at the steps dts, against ref at time T.
/// `damped`: the scene has joint damping, so MuJoCo's implicit integrator is run too.
/// `limits`: the model's joint limits are on (MuJoCo's own soft limits; engines without limits
/// are left out).
void peer_work_precision(const Model& m, const State& x0, const State& ref, double T,
                         const std::vector<double>& dts, bool damped, std::ofstream& f,
                         bool limits = false);

/// study.csv: per model (a 20-link planar chain under gravity, Romeo free-floating in zero
/// gravity), engine and step, the real-time factor (simulated s per CPU s) and the
/// consistency (final-state difference to the same engine at a 16x smaller step than the
/// smallest), energy error and angular-momentum error. Prints a summary.
void study(const std::string& outdir, const std::string& root, bool quick);

/// stability_panda.csv (energy error against time of every engine on the undamped Panda at
/// 1 kHz, with where each failed) and stability_minv.csv (DART's inverse mass matrix against
/// the inverse of its own mass matrix, ours against the inverse of ours). Prints a summary.
void stability(const std::string& outdir, const std::string& root, bool quick);

}  // namespace se3::charts
