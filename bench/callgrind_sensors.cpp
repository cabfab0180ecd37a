// Driver for the sensors' instruction count per physics step (docs/ros.md, "Sensors"): steps a
// scene with its sensors; run under valgrind --tool=callgrind with
// --toggle-collect='se3::SensorSet::*' for the sensors alone, or without it (and STEPS twice
// over) for the step.
//
//   callgrind_sensors SCENE.yaml STEPS [RATE]   RATE (Hz) replaces every sensor's rate
//                                               (0: every step); "none": no sensors
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>

#include "se3_sim/sim/sensors.h"
#include "se3_sim/sim/sim.h"

int main(int argc, char** argv) {
  if (argc < 3) {
    std::fprintf(stderr, "usage: callgrind_sensors SCENE.yaml STEPS [RATE|none]\n");
    return 2;
  }
  se3::Scene scene = se3::load_scene(argv[1]);
  const int steps = std::atoi(argv[2]);
  const std::string rate = argc > 3 ? argv[3] : "";
  if (rate == "none") scene.sensors.clear();
  if (!rate.empty() && rate != "none") {
    for (se3::SensorSpec& s : scene.sensors) s.rate = std::atof(rate.c_str());
  }
  auto sim = se3::make_simulator(scene);
  se3::SensorSet sensors(sim->model(), scene.sensors, se3::scene_urdf_text(scene));
  double sum = 0;
  for (int k = 0; k < steps; ++k) {
    sensors.before_step(*sim);
    const bool ok = sim->step();
    sensors.after_step(*sim, ok);
    for (int i = 0; i < sensors.size(); ++i) sum += sensors.reading(i).force.z();
  }
  std::printf("%d steps, t = %g s, %g\n", steps, sim->time(), sum);
  return 0;
}
