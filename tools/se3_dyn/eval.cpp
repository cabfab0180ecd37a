// se3_dyn info and eval: the model summary and CSV in, CSV out (docs/design.md).
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <iostream>
#include <map>
#include <sstream>

#include "cli.h"
#include "se3_sim/dynamics/dynamics.h"
#include "se3_sim/model/limits.h"

namespace se3_dyn {
namespace {

const char* kTwist[6] = {"wx", "wy", "wz", "vx", "vy", "vz"};
const char* kWrench[6] = {"nx", "ny", "nz", "fx", "fy", "fz"};

std::vector<std::string> split_csv(const std::string& line) {
  std::vector<std::string> out;
  std::string cur;
  for (char ch : line) {
    if (ch == ',') {
      out.push_back(cur);
      cur.clear();
    } else if (ch != '\r') {
      cur += ch;
    }
  }
  out.push_back(cur);
  for (auto& s : out) {
    const auto b = s.find_first_not_of(" \t");
    const auto e = s.find_last_not_of(" \t");
    s = b == std::string::npos ? "" : s.substr(b, e - b + 1);
  }
  return out;
}

// A field quoted in a message: printable, at most 60 characters.
std::string shown(const std::string& s) {
  std::string out;
  for (const char ch : s) {
    const auto c = static_cast<unsigned char>(ch);
    out += (c < 0x20 || c == 0x7f) ? '?' : ch;
    if (out.size() >= 60) return out + "...";
  }
  return out;
}

// One line of input without its '\n' (false at the end); counts the bytes against budget so
// that no input, however long its lines, makes eval read past limits::kMaxCsvBytes.
bool read_line(std::istream& in, std::string& line, std::size_t& budget) {
  line.clear();
  std::streambuf* sb = in.rdbuf();
  bool any = false;
  for (int c = sb->sbumpc(); c != std::char_traits<char>::eof(); c = sb->sbumpc()) {
    any = true;
    if (budget == 0) {
      throw InputError("more than " + std::to_string(se3::limits::kMaxCsvBytes) +
                       " bytes of input (docs/robustness.md)");
    }
    --budget;
    if (c == '\n') return true;
    line += static_cast<char>(c);
  }
  return any;
}

// Coordinate names: base_wx ... base_vz for a free base, then joint names.
std::vector<std::string> coordinate_names(const se3::Model& m) {
  std::vector<std::string> names;
  if (m.floating) {
    for (const char* c : kTwist) names.push_back(std::string("base_") + c);
  }
  for (int i = 1; i <= m.n; ++i) names.push_back(m.joint_name[i]);
  return names;
}

}  // namespace

int cmd_info(int argc, char** argv) {
  const Args args(argc, argv, 2, {"floating"}, {"gravity"});
  const se3::Model m = load_model(args);
  std::printf("model: %s\nroot link: %s\nbase: %s\n", m.name.c_str(), m.root_link.c_str(),
              m.floating ? "free-floating (6 dof)" : "fixed");
  std::printf("bodies: %d (base + %d moving), links: %zu (fixed ones merged)\n", m.n + 1, m.n,
              m.links.size());
  std::printf("joints: %d moving, dof (nv): %d\n", m.n, m.nv);
  std::printf("total mass: %.6g kg\n", m.total_mass());
  for (int i = 1; i <= m.n; ++i) {
    std::printf("  %3d %-28s %-9s parent %-24s limits [%g, %g] effort %g damping %g friction %g\n",
                i, m.joint_name[i].c_str(), m.joints[i].name(), m.body_name[m.parent[i]].c_str(),
                m.lower[i], m.upper[i], m.effort[i], m.damping[i], m.friction[i]);
  }
  for (const auto& w : m.warnings) std::printf("warning: %s\n", w.c_str());
  return 0;
}

int cmd_eval(int argc, char** argv) {
  const Args args(argc, argv, 2, {"floating"}, {"algo", "gravity"});
  const std::string algo = args.get("algo");
  if (algo != "rnea" && algo != "aba" && algo != "crba" && algo != "minv") {
    throw UsageError("--algo must be rnea, aba, crba or minv");
  }
  const se3::Model m = load_model(args);
  std::ostringstream out;
  eval_csv(m, algo, std::cin, out);
  std::cout << out.str();
  return 0;
}

void eval_csv(const se3::Model& m, const std::string& algo, std::istream& input,
              std::ostream& output) {
  if ((algo == "crba" || algo == "minv") && m.nv > se3::limits::kMaxDenseNv) {
    throw InputError("--algo " + algo + " prints nv x nv numbers per row: nv = " +
                     std::to_string(m.nv) + " is more than the " +
                     std::to_string(se3::limits::kMaxDenseNv) + " it allows (docs/robustness.md)");
  }
  se3::Data d(m);
  const int n = m.n, off = m.nv_base();
  const bool needs_v = algo == "rnea" || algo == "aba";

  std::string line;
  std::size_t budget = se3::limits::kMaxCsvBytes;
  if (!read_line(input, line, budget)) {
    throw InputError("empty input: a CSV header row is needed");
  }
  const std::vector<std::string> header = split_csv(line);
  std::map<std::string, int> col;
  for (size_t k = 0; k < header.size(); ++k) {
    const std::string& h = header[k];
    const auto colon = h.find(':');
    if (colon != std::string::npos) {
      const std::string kind = h.substr(0, colon), joint = h.substr(colon + 1);
      if ((kind == "q" || kind == "v" || kind == "a" || kind == "tau") &&
          m.joint_index(joint) < 0) {
        throw InputError("column '" + shown(h) + "' names an unknown joint '" + shown(joint) + "'");
      }
    }
    if (col.count(h)) throw InputError("column '" + shown(h) + "' appears twice");
    col[h] = static_cast<int>(k);
  }
  auto need = [&](const std::string& name) {
    auto it = col.find(name);
    if (it == col.end()) throw InputError("missing column '" + name + "'");
    return it->second;
  };
  // Column indices of every input, -1 for an optional absent one.
  std::vector<int> c_pose, c_twist, c_q, c_v, c_in, c_base_in;
  if (m.floating) {
    for (const char* s :
         {"base_x", "base_y", "base_z", "base_qx", "base_qy", "base_qz", "base_qw"}) {
      c_pose.push_back(need(s));
    }
    if (needs_v) {
      for (const char* s : kTwist) c_twist.push_back(need(std::string("base_") + s));
    }
    if (algo == "rnea") {
      for (const char* s : kTwist) c_base_in.push_back(need(std::string("base_d") + s));
    } else if (algo == "aba") {
      for (const char* s : kWrench) {
        auto it = col.find(std::string("base_") + s);
        c_base_in.push_back(it == col.end() ? -1 : it->second);
      }
    }
  }
  for (int i = 1; i <= n; ++i) {
    const std::string& j = m.joint_name[i];
    c_q.push_back(need("q:" + j));
    if (needs_v) c_v.push_back(need("v:" + j));
    if (algo == "rnea") c_in.push_back(need("a:" + j));
    if (algo == "aba") c_in.push_back(need("tau:" + j));
  }

  // Output header.
  const std::vector<std::string> coords = coordinate_names(m);
  std::ostringstream out;
  std::vector<std::string> out_cols;
  if (algo == "aba" || algo == "rnea") {
    if (m.floating) {
      for (int k = 0; k < 6; ++k) {
        out_cols.push_back(std::string(algo == "aba" ? "base_d" : "base_") +
                           (algo == "aba" ? kTwist[k] : kWrench[k]));
      }
    }
    for (int i = 1; i <= n; ++i)
      out_cols.push_back((algo == "aba" ? "a:" : "tau:") + m.joint_name[i]);
  } else {
    const std::string pre = algo == "crba" ? "M:" : "Minv:";
    for (const auto& a : coords) {
      for (const auto& b : coords) out_cols.push_back(pre + a + ":" + b);
    }
  }
  for (size_t k = 0; k < out_cols.size(); ++k) out << (k ? "," : "") << out_cols[k];
  out << "\n";

  se3::VecX q(n), v = se3::VecX::Zero(m.nv), in = se3::VecX::Zero(m.nv);
  char buf[40];
  int lineno = 1;
  while (read_line(input, line, budget)) {
    ++lineno;
    if (line.find_first_not_of(" \t\r") == std::string::npos) continue;
    const std::vector<std::string> f = split_csv(line);
    if (f.size() != header.size()) {
      throw InputError("line " + std::to_string(lineno) + ": " + std::to_string(f.size()) +
                       " fields, the header has " + std::to_string(header.size()));
    }
    auto num = [&](int k) {
      const std::string& s = f[k];
      char* end = nullptr;
      const double x = std::strtod(s.c_str(), &end);
      if (s.empty() || *end != '\0' || !std::isfinite(x)) {
        throw InputError("line " + std::to_string(lineno) + ", column '" + shown(header[k]) +
                         "': not a finite number: '" + shown(s) + "'");
      }
      return x;
    };
    se3::SE3 base;
    if (m.floating) {
      const double qx = num(c_pose[3]), qy = num(c_pose[4]), qz = num(c_pose[5]),
                   qw = num(c_pose[6]);
      const double norm = std::sqrt(qx * qx + qy * qy + qz * qz + qw * qw);
      if (std::abs(norm - 1.0) > 1e-6) {
        throw InputError("line " + std::to_string(lineno) + ": base quaternion norm " +
                         std::to_string(norm) + " is not 1 (tolerance 1e-6)");
      }
      base.R = se3::rotation_from_quaternion(qx, qy, qz, qw);
      base.p = se3::Vec3(num(c_pose[0]), num(c_pose[1]), num(c_pose[2]));
      for (size_t k = 0; k < c_twist.size(); ++k) v[k] = num(c_twist[k]);
      for (size_t k = 0; k < c_base_in.size(); ++k) {
        in[k] = c_base_in[k] < 0 ? 0.0 : num(c_base_in[k]);
      }
    }
    for (int i = 0; i < n; ++i) {
      q[i] = num(c_q[i]);
      if (needs_v) v[off + i] = num(c_v[i]);
      if (!c_in.empty()) in[off + i] = num(c_in[i]);
    }
    const double* res = nullptr;
    if (algo == "rnea") {
      res = se3::rnea(m, d, base, q, v, in).data();
    } else if (algo == "aba") {
      res = se3::aba(m, d, base, q, v, in).data();
    } else if (algo == "crba") {
      res = se3::crba(m, d, base, q).data();  // symmetric: column-major = row-major
    } else {
      res = se3::minv(m, d, base, q).data();
    }
    for (size_t k = 0; k < out_cols.size(); ++k) {
      if (!std::isfinite(res[k])) {
        throw InputError("line " + std::to_string(lineno) + ": " + out_cols[k] +
                         " is not finite: the inputs are too large for double precision");
      }
      std::snprintf(buf, sizeof buf, "%.17g", res[k]);
      out << (k ? "," : "") << buf;
    }
    out << "\n";
    if (static_cast<std::size_t>(out.tellp()) > se3::limits::kMaxCsvBytes) {
      throw InputError("line " + std::to_string(lineno) + ": the output passes " +
                       std::to_string(se3::limits::kMaxCsvBytes) +
                       " bytes (docs/robustness.md); split the input");
    }
  }
  output << out.str();
}

}  // namespace se3_dyn
