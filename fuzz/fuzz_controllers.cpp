// A controller_config file (ros_control's YAML: parse_controllers_text, src/sim/controllers.cpp)
// and the controllers it makes on the fixed Panda (ControllerSet), run for a few steps. Only
// ControllerError may come out of the parse and the binding, and the simulator stays finite.
#include <cstdint>
#include <cstdlib>
#include <memory>
#include <string>

#include "../test/source_paths.h"
#include "se3_sim/sim/sim.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static const se3::Scene scene =
      se3::load_scene(se3_sim_test::source_dir() + "/config/scenes/fixed_panda.yaml");
  static const std::unique_ptr<se3::Simulator> sim = se3::make_simulator(scene);
  std::vector<se3::ControllerSpec> specs;
  try {
    specs = se3::parse_controllers_text(std::string(reinterpret_cast<const char*>(data), size), {},
                                        "fuzz.yaml");
    sim->reset();
    sim->set_controllers(specs);
  } catch (const se3::ControllerError&) {
    return 0;
  }
  sim->step_n(3);
  if (!sim->state().finite()) std::abort();
  sim->set_controllers({});
  return 0;
}
