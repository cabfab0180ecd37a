// `se3_dyn eval`'s CSV reader and the dynamics behind it (eval_csv, tools/se3_dyn/eval.cpp). The
// first byte picks a model (fixed double pendulum, free Panda, free chain), the second the
// algorithm; the rest is the CSV. Only InputError may come out, and good output is finite.
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <sstream>
#include <string>

#include "../test/source_paths.h"
#include "se3_sim/model/model.h"
#include "tools/se3_dyn/cli.h"

namespace {

const se3::Model& model(int k) {
  static const se3::Model models[3] = {
      se3::model_from_urdf_file(se3_sim_test::source_dir() +
                                "/data/robots/double_pendulum_simple.urdf"),
      se3::model_from_urdf_file(se3_sim_test::source_dir() + "/data/robots/panda.urdf", {true, {}}),
      se3::make_chain(3, true)};
  return models[k % 3];
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size < 2) return 0;
  static const char* algos[4] = {"rnea", "aba", "crba", "minv"};
  const se3::Model& m = model(data[0]);
  const std::string algo = algos[data[1] % 4];
  std::istringstream in(std::string(reinterpret_cast<const char*>(data) + 2, size - 2));
  std::ostringstream out;
  try {
    se3_dyn::eval_csv(m, algo, in, out);
  } catch (const se3_dyn::InputError&) {
    return 0;
  }
  const std::string text = out.str();
  if (text.find("nan") != std::string::npos || text.find("inf") != std::string::npos) {
    std::abort();  // a number that is not one got through
  }
  return 0;
}
