#pragma once
// Where the gtests, fuzz targets and benchmarks find the package's files and the se3_dyn program:
// the source folder and the devel space of the build that compiled them. Both are compiled into
// one generated source (CMakeLists.txt, se3_sim_test_paths) rather than passed as -D definitions,
// so that no other compile command names an absolute path and ccache serves those compiles to
// another clone of the repository.
#include <string>

namespace se3_sim_test {
std::string source_dir();
std::string se3_dyn_exe();
}  // namespace se3_sim_test
