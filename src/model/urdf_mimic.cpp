// URDF <mimic> joints: the loop check on the parsed document and Model::mimics.
#include "urdf_mimic.h"

#include <cmath>
#include <map>
#include <string>
#include <vector>

namespace se3 {
namespace {

// The joint a <mimic> joint follows, or nullptr (no mimic, or a leader the URDF lacks).
const urdf::Joint* leader_of(const urdf::ModelInterface& u, const urdf::Joint& j) {
  if (!j.mimic) return nullptr;
  const auto it = u.joints_.find(j.mimic->joint_name);
  return it == u.joints_.end() ? nullptr : it->second.get();
}

}  // namespace

void check_urdf_mimics(const urdf::ModelInterface& u) {
  // Each joint has at most one leader: walking from a joint either ends or enters a cycle. A
  // joint is finished (2) once its walk ended; a walk that meets a joint of its own (1) found
  // a loop.
  std::map<const urdf::Joint*, int> mark;
  for (const auto& kv : u.joints_) {
    std::vector<const urdf::Joint*> path;
    for (const urdf::Joint* j = kv.second.get(); j && mark[j] != 2; j = leader_of(u, *j)) {
      if (mark[j] == 1) {
        std::string names;
        bool in = false;
        for (const urdf::Joint* p : path) {
          in = in || p == j;
          if (in) names += "'" + p->name + "' -> ";
        }
        throw ModelError("URDF: the <mimic> joints " + names + "'" + j->name +
                         "' form a loop (each follows the next): one of them must be a joint of "
                         "its own");
      }
      mark[j] = 1;
      path.push_back(j);
    }
    for (const urdf::Joint* p : path) mark[p] = 2;
  }
}

void read_mimics(const urdf::ModelInterface& u, Model& m) {
  m.mimics.clear();
  std::vector<std::string> own;
  std::vector<JointMimic> all;
  for (const auto& kv : u.joints_) {
    const urdf::Joint& j = *kv.second;
    if (!j.mimic) continue;
    const int follower = m.joint_index(j.name);
    if (follower < 1) continue;  // fixed or locked: nothing to follow
    const int leader = m.joint_index(j.mimic->joint_name);
    if (leader < 1 || leader == follower || !std::isfinite(j.mimic->multiplier) ||
        !std::isfinite(j.mimic->offset)) {
      own.push_back("'" + j.name + "' (of '" + j.mimic->joint_name + "')");
      continue;
    }
    all.push_back({follower, leader, j.mimic->multiplier, j.mimic->offset});
  }
  // Leaders first: a mimic is placed once its leader is placed or is no mimic (no loops here:
  // check_urdf_mimics refused them).
  std::vector<char> placed(m.n + 1, 1);
  for (const JointMimic& mm : all) placed[mm.joint] = 0;
  for (bool more = true; more;) {
    more = false;
    for (const JointMimic& mm : all) {
      if (placed[mm.joint] || !placed[mm.leader]) continue;
      m.mimics.push_back(mm);
      placed[mm.joint] = 1;
      more = true;
    }
  }
  if (!own.empty()) {
    std::string names;
    for (const std::string& s : own) names += (names.empty() ? "" : ", ") + s;
    m.warnings.push_back("URDF: <mimic> joint" + std::string(own.size() > 1 ? "s " : " ") + names +
                         " follow no moving joint (fixed, locked, missing, or a bad number): "
                         "simulated as joints of their own");
  }
}

}  // namespace se3
