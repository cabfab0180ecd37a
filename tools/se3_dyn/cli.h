// Shared pieces of the se3_dyn command-line tool (docs/design.md, "se3_dyn").
#pragma once

#include <iosfwd>
#include <stdexcept>
#include <string>
#include <vector>

#include "se3_sim/model/model.h"

namespace se3_dyn {

/// Bad input: one line on stderr, exit code 1.
struct InputError : std::runtime_error {
  using std::runtime_error::runtime_error;
};
/// Bad command line: one line on stderr, exit code 2.
struct UsageError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

/// Command-line arguments after the subcommand: positionals and --options.
struct Args {
  std::vector<std::string> positional;
  std::vector<std::pair<std::string, std::string>> options;  ///< flags have value ""

  /// Parses argv[first..]; `flags` take no value, every other --name takes one.
  Args(int argc, char** argv, int first, const std::vector<std::string>& flags,
       const std::vector<std::string>& valued);
  bool has(const std::string& name) const;
  std::string get(const std::string& name, const std::string& def = "") const;
  double get_double(const std::string& name, double def) const;
};

/// Loads a model for se3_dyn: URDF file (or chain:N), free base on request, --gravity, and the
/// column-name rules (no ':' or ',' in joint names, none starting with "base_").
se3::Model load_model(const Args& args, se3::UrdfDocument* doc = nullptr);
/// N of "chain:N" (1 <= N <= limits::kMaxBodies), else InputError.
int chain_length(const std::string& spec);
se3::Vec3 parse_vec3(const std::string& s, const std::string& what);

/// `eval`'s work on a stream: CSV with a header row in, CSV out (written only when every row
/// was good). algo is rnea, aba, crba or minv. Throws InputError naming the line and column for
/// bad input, input beyond limits::kMaxCsvBytes, or a result that is not finite (inputs so
/// large that the dynamics overflow).
void eval_csv(const se3::Model& m, const std::string& algo, std::istream& in, std::ostream& out);

int cmd_info(int argc, char** argv);
int cmd_eval(int argc, char** argv);
int cmd_bench(int argc, char** argv);
int cmd_simulate(int argc, char** argv);
int cmd_render(int argc, char** argv);

}  // namespace se3_dyn
