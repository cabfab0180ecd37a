// se3_dyn's shared pieces (cli.h): arguments, model loading with the column-name rules.
#include "cli.h"

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>

#include "se3_sim/model/limits.h"

namespace se3_dyn {

Args::Args(int argc, char** argv, int first, const std::vector<std::string>& flags,
           const std::vector<std::string>& valued) {
  auto in = [](const std::vector<std::string>& v, const std::string& s) {
    for (const auto& x : v) {
      if (x == s) return true;
    }
    return false;
  };
  for (int i = first; i < argc; ++i) {
    const std::string a = argv[i];
    if (a.size() > 2 && a.compare(0, 2, "--") == 0) {
      std::string name = a.substr(2), value;
      const auto eq = name.find('=');
      if (eq != std::string::npos) {
        value = name.substr(eq + 1);
        name = name.substr(0, eq);
        if (!in(valued, name)) throw UsageError("unknown option --" + name);
      } else if (in(flags, name)) {
      } else if (in(valued, name)) {
        if (i + 1 >= argc) throw UsageError("option --" + name + " needs a value");
        value = argv[++i];
      } else {
        throw UsageError("unknown option --" + name);
      }
      options.emplace_back(name, value);
    } else {
      positional.push_back(a);
    }
  }
}

bool Args::has(const std::string& name) const {
  for (const auto& o : options) {
    if (o.first == name) return true;
  }
  return false;
}

std::string Args::get(const std::string& name, const std::string& def) const {
  for (auto it = options.rbegin(); it != options.rend(); ++it) {
    if (it->first == name) return it->second;
  }
  return def;
}

double Args::get_double(const std::string& name, double def) const {
  if (!has(name)) return def;
  const std::string s = get(name);
  char* end = nullptr;
  const double x = std::strtod(s.c_str(), &end);
  if (s.empty() || *end != '\0' || !std::isfinite(x)) {
    throw UsageError("--" + name + " needs a number, got '" + s + "'");
  }
  return x;
}

se3::Vec3 parse_vec3(const std::string& s, const std::string& what) {
  se3::Vec3 v;
  const char* p = s.c_str();
  for (int k = 0; k < 3; ++k) {
    char* end = nullptr;
    v[k] = std::strtod(p, &end);
    if (end == p || !std::isfinite(v[k])) throw UsageError(what + " needs x,y,z, got '" + s + "'");
    p = end;
    if (k < 2) {
      if (*p != ',') throw UsageError(what + " needs x,y,z, got '" + s + "'");
      ++p;
    }
  }
  if (*p != '\0') throw UsageError(what + " needs x,y,z, got '" + s + "'");
  return v;
}

int chain_length(const std::string& spec) {
  char* end = nullptr;
  errno = 0;
  const long n = std::strtol(spec.c_str() + 6, &end, 10);
  if (spec.size() == 6 || *end != '\0' || errno != 0 || n < 1 || n > se3::limits::kMaxBodies) {
    throw InputError("chain:N needs 1 <= N <= " + std::to_string(se3::limits::kMaxBodies) +
                     " (docs/robustness.md), got '" + spec + "'");
  }
  return static_cast<int>(n);
}

se3::Model load_model(const Args& args, se3::UrdfDocument* doc) {
  if (args.positional.size() != 1) throw UsageError("expected one MODEL.urdf");
  const std::string& path = args.positional[0];
  const bool floating = args.has("floating");
  se3::Model m;
  if (path.compare(0, 6, "chain:") == 0) {
    m = se3::make_chain(chain_length(path), floating);
  } else {
    se3::UrdfOptions opt;
    opt.floating = floating;
    const se3::UrdfDocument parsed = se3::read_urdf_document(path);
    m = se3::model_from_urdf(parsed, opt);
    if (doc) *doc = parsed;
  }
  for (int i = 1; i <= m.n; ++i) {
    const std::string& j = m.joint_name[i];
    if (j.find(':') != std::string::npos || j.find(',') != std::string::npos ||
        j.compare(0, 5, "base_") == 0) {
      throw InputError("joint '" + j +
                       "': names with ':' or ',' or starting with 'base_' break se3_dyn's "
                       "columns");
    }
  }
  if (args.has("gravity")) m.gravity = parse_vec3(args.get("gravity"), "--gravity");
  return m;
}

}  // namespace se3_dyn
