// URDF text -> Model and GeometryModel (parse_urdf_document, model_from_urdf, geometry_from_urdf
// and the string entry points): urdfdom, tinyxml, the tree builder and the geometry builder
// behind the guards of src/model/urdf_guard.h ('%' conversions in any attribute included:
// urdf.dict has them). Only ModelError may come out. Two cross-checks:
//  - the guard's nesting bound (xml_shape) is never below what tinyxml builds, so no text the
//    guard lets through can make tinyxml recurse deeper than limits::kMaxXmlDepth;
//  - a model that loads has finite dynamics at rest, or says why not, without UB.
#include <tinyxml.h>

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "model/urdf_guard.h"
#include "se3_sim/dynamics/dynamics.h"
#include "se3_sim/geometry/geometry.h"
#include "se3_sim/model/limits.h"
#include "se3_sim/model/model.h"

namespace {

// Deepest element nesting of a tinyxml document, without recursion.
int tinyxml_depth(const TiXmlNode* root) {
  int deepest = 0;
  std::vector<std::pair<const TiXmlNode*, int>> pending = {{root, 0}};
  while (!pending.empty()) {
    const auto [node, depth] = pending.back();
    pending.pop_back();
    for (const TiXmlNode* c = node->FirstChild(); c; c = c->NextSibling()) {
      const int d = depth + (c->Type() == TiXmlNode::TINYXML_ELEMENT ? 1 : 0);
      if (d > deepest) deepest = d;
      pending.push_back({c, d});
    }
  }
  return deepest;
}

void check_shape(const std::string& xml) {
  const se3::XmlShape shape = se3::xml_shape(xml);
  if (se3::first_invalid_utf8(xml) < xml.size() || shape.max_depth > se3::limits::kMaxXmlDepth ||
      shape.max_attributes > se3::limits::kMaxXmlAttributes) {
    return;  // refused before tinyxml: nothing to compare
  }
  TiXmlDocument doc;
  doc.Parse(xml.c_str());  // as urdfdom does
  const int depth = tinyxml_depth(&doc);
  if (depth > shape.max_depth) {
    std::fprintf(stderr, "xml_shape says depth %d, tinyxml built %d\n", shape.max_depth, depth);
    std::abort();
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string xml(reinterpret_cast<const char*>(data), size);
  check_shape(xml);
  se3::UrdfOptions opt;
  opt.floating = size % 2 == 1;
  try {
    const se3::UrdfDocument doc = se3::parse_urdf_document(xml);
    const se3::Model m = se3::model_from_urdf(doc, opt);
    m.validate();
    // The geometry path (materials, shapes, stand-ins) over the same document, and the string
    // entry point that parses again; no mesh file is read.
    se3::GeometryOptions gopt;
    gopt.load_meshes = false;
    const se3::GeometryModel g = se3::geometry_from_urdf(m, doc, gopt);
    for (const se3::GeometryObject& o : g.visuals) {
      if (o.body < 0 || o.body > m.n || !o.material.rgba.allFinite()) __builtin_trap();
    }
    if (size < 4096) se3::geometry_from_urdf_string(m, xml, gopt);
    if (m.n <= 64) {
      se3::Data d(m);
      const se3::VecX q = se3::VecX::Zero(m.n), v = se3::VecX::Zero(m.nv);
      se3::aba(m, d, se3::SE3(), q, v, v);
      se3::crba(m, d, se3::SE3(), q);
    }
  } catch (const se3::ModelError&) {
  }
  return 0;
}
