// se3_dyn: the library on the command line, no ROS master needed (docs/design.md).
#include <cmath>
#include <cstdio>
#include <cstring>
#include <iostream>
#include <new>

#include "cli.h"
#include "se3_sim/integrate/integrate.h"

namespace {

const char* kUsage =
    "usage: se3_dyn <command> ...\n"
    "  info MODEL.urdf [--floating]\n"
    "  eval MODEL.urdf --algo rnea|aba|crba|minv [--floating] [--gravity gx,gy,gz] < in.csv\n"
    "  bench MODEL.urdf [--floating] [--algo fk,rnea,aba,crba,minv] [--json]\n"
    "  simulate (MODEL.urdf [--floating] | --scene SCENE.yaml | both) [--integrator NAME]\n"
    "           [--dt H] --duration T [--tol E] [--seed S] [--random] [--gravity gx,gy,gz]\n"
    "           [--out traj.csv] [--json]\n"
    "  render (MODEL.urdf [--floating] | --scene S) [--camera ex,ey,ez,tx,ty,tz[,f_px]]\n"
    "         [--package-path DIR[:DIR]] --out frame.png\n"
    "MODEL.urdf may also be chain:N, a generated chain of N bodies (N <= 100000).\n"
    "With both MODEL.urdf and --scene, the model replaces the scene's robot.\n"
    "Limits on sizes and work: docs/robustness.md.\n";

}  // namespace

int main(int argc, char** argv) {
  using namespace se3_dyn;
  if (argc < 2 || !std::strcmp(argv[1], "-h") || !std::strcmp(argv[1], "--help")) {
    std::FILE* out = argc < 2 ? stderr : stdout;
    std::fputs(kUsage, out);
    std::fprintf(out, "integrators (--integrator NAME; the registry's list):\n%s",
                 se3::stepper_help().c_str());
    return argc < 2 ? 2 : 0;
  }
  const std::string cmd = argv[1];
  try {
    if (cmd == "info") return cmd_info(argc, argv);
    if (cmd == "eval") return cmd_eval(argc, argv);
    if (cmd == "bench") return cmd_bench(argc, argv);
    if (cmd == "simulate") return cmd_simulate(argc, argv);
    if (cmd == "render") return cmd_render(argc, argv);
    throw UsageError("unknown command '" + cmd + "' (info, eval, bench, simulate, render)");
  } catch (const UsageError& e) {
    std::fprintf(stderr, "se3_dyn: %s (se3_dyn --help)\n", e.what());
    return 2;
  } catch (const std::bad_alloc&) {
    std::fprintf(stderr,
                 "se3_dyn: out of memory: the model or the run is too large for this machine "
                 "(limits: docs/robustness.md)\n");
    return 1;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "se3_dyn: %s\n", e.what());
    return 1;
  }
}
