// Scene YAML -> Scene (parse_scene), and for small generated robots the model and initial state
// (scene_model, scene_state); scenes of up to 8 objects and no robot are made into a simulator
// and stepped 20 times (their objects must stay finite). Only SceneError, ModelError,
// ControllerError and Simulator's std::invalid_argument may come out. Cross-checks: the
// nesting and item bounds of check_scene_text are never below what yaml-cpp builds (for texts
// without aliases, whose nodes are shared and would count twice); every continuous joint's
// initial angle lies in (-pi, pi], whatever the scene says. Scenes of up to 16 objects on a
// chain of up to 8 bodies (or none) are then built and stepped twice (any dt, twist, controller
// name): a built simulator's state stays finite, a refused scene says so by SceneError,
// ModelError, ControllerError or std::invalid_argument. More objects are parsed, not built: the
// contact solve reserves rows for 16 contacts per object and a dense matrix of rows x rows, 85 MB
// for 64 objects, seconds of setup under the sanitizers (test/gtest_sim_robustness.cpp steps
// 64, 65 and 130).
#include <yaml-cpp/yaml.h>

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "se3_sim/model/limits.h"
#include "se3_sim/sim/controllers.h"
#include "se3_sim/sim/sim.h"
#include "sim/scene_reader.h"

namespace {

// Deepest collection nesting and node count of a yaml-cpp document, without recursion.
std::pair<int, std::size_t> yaml_depth_and_nodes(const YAML::Node& root) {
  int deepest = 0;
  std::size_t nodes = 0;
  std::vector<std::pair<YAML::Node, int>> pending = {{root, 0}};
  while (!pending.empty() && nodes < 10 * se3::limits::kMaxYamlItems) {
    const auto [n, depth] = pending.back();
    pending.pop_back();
    ++nodes;
    if (!n.IsMap() && !n.IsSequence()) continue;
    const int d = depth + 1;
    if (d > deepest) deepest = d;
    for (const auto& c : n) {
      if (n.IsMap()) {
        pending.push_back({c.first, d});
        pending.push_back({c.second, d});
      } else {
        pending.push_back({YAML::Node(c), d});
      }
    }
  }
  return {deepest, nodes};
}

void check_shape(const std::string& text) {
  if (text.size() > se3::limits::kMaxSceneBytes || text.find('*') != std::string::npos) return;
  const se3::SceneTextShape shape = se3::scene_text_shape(text);
  if (shape.depth > se3::limits::kMaxYamlDepth || shape.items > se3::limits::kMaxYamlItems) return;
  // The reader parses the first document only (and refuses a second); so does this check
  // (YAML::LoadAll of yaml-cpp 0.7 never ends on a text that starts with ',').
  YAML::Node doc;
  try {
    se3::check_scene_text(text, "fuzz.yaml");
    doc = YAML::Load(se3::with_lf_line_ends(text));
  } catch (const std::exception&) {
    return;
  }
  const auto [depth, nodes] = yaml_depth_and_nodes(doc);
  // The text bound guards yaml-cpp's recursion (thousands of levels overflow the stack) with a
  // limit of kMaxYamlDepth = 64, so it must not undercount by much, not be exact: yaml-cpp attaches
  // a node property (tag, anchor) on a line of its own one level down in ways the line scanner
  // reads as a sibling. The check: within a factor of two (and two levels).
  if (depth > 2 * shape.depth + 2 || nodes > 2 * shape.items + 2) {
    std::fprintf(stderr, "scene_text_shape says depth %d, items %zu; yaml-cpp built %d, %zu\n",
                 shape.depth, shape.items, depth, nodes);
    std::abort();
  }
}

void check_angles(const se3::Model& m, const se3::State& x) {
  for (int i = 1; i <= m.n; ++i) {
    const double q = x.q[m.idx_q(i)];
    if (m.continuous(i) && !(q > -M_PI && q <= M_PI)) {
      std::fprintf(stderr, "continuous joint %s starts at %g, outside (-pi, pi]\n",
                   m.joint_name[i].c_str(), q);
      std::abort();
    }
  }
}

// A few steps of a small scene: the state stays finite, the divergence guard covers the objects.
void step_scene(const se3::Scene& s) {
  const std::unique_ptr<se3::Simulator> sim = se3::make_simulator(s);
  check_angles(sim->model(), sim->state());
  for (int k = 0; k < 2 && sim->step(); ++k) {
    bool finite = sim->state().finite();
    for (const se3::ObjectState& o : sim->objects()) {
      finite = finite && o.pose.p.allFinite() && o.twist.allFinite();
    }
    if (!finite) {
      std::fprintf(stderr, "a step the guard passed left a non-finite state\n");
      std::abort();
    }
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  check_shape(text);
  try {
    const se3::Scene s = se3::parse_scene(text, "/nonexistent", "fuzz.yaml");
    const bool chain = s.robot_path.compare(0, 6, "chain:") == 0;
    const int n = chain ? std::atoi(s.robot_path.c_str() + 6) : 0;
    if (chain && n <= 16) {
      const se3::Model m = se3::scene_model(s);
      const se3::State x = se3::scene_state(s, m);
      check_angles(m, x);
    }
    if ((chain ? n <= 8 : s.robot_path.empty() && !s.objects.empty()) && s.objects.size() <= 16) {
      step_scene(s);
    }
    // Scenes of a few objects (deep initial penetration, fast small bodies, tiny or heavy
    // shapes) are stepped: the warnings are built, and the objects stay finite.
    if (s.robot_path.empty() && !s.objects.empty() && s.objects.size() <= 8) {
      auto sim = se3::make_simulator(s);
      (void)sim->deep_penetration_warning();
      sim->step_n(20);
      (void)sim->fast_step_warning();
      for (const se3::ObjectState& o : sim->objects()) {
        if (!o.pose.p.allFinite() || !o.twist.allFinite()) {
          std::fprintf(stderr, "object '%s' is not finite after %llu steps\n", o.name.c_str(),
                       static_cast<unsigned long long>(sim->steps()));
          std::abort();
        }
      }
    }
  } catch (const se3::SceneError&) {
  } catch (const se3::ModelError&) {
  } catch (const se3::ControllerError&) {
  } catch (const std::invalid_argument&) {
  }
  return 0;
}
