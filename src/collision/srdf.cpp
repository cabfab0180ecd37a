// SRDF <disable_collisions link1=".." link2=".." reason=".."/> pairs (collision.h), read with
// tinyxml2.
#include <tinyxml2.h>

#include <stdexcept>

#include "se3_sim/collision/collision.h"

namespace se3 {

std::vector<std::pair<std::string, std::string>> srdf_disabled_pairs(const std::string& xml) {
  tinyxml2::XMLDocument doc;
  if (doc.Parse(xml.data(), xml.size()) != tinyxml2::XML_SUCCESS) {
    const char* why = doc.ErrorStr();
    std::string line = why ? why : "malformed XML";
    for (char& c : line) {
      if (c == '\n' || c == '\r') c = ' ';
    }
    throw std::invalid_argument("SRDF: " + line);
  }
  const tinyxml2::XMLElement* robot = doc.FirstChildElement("robot");
  if (!robot) throw std::invalid_argument("SRDF: no <robot> element");
  std::vector<std::pair<std::string, std::string>> out;
  for (const tinyxml2::XMLElement* e = robot->FirstChildElement("disable_collisions"); e;
       e = e->NextSiblingElement("disable_collisions")) {
    const char* a = e->Attribute("link1");
    const char* b = e->Attribute("link2");
    if (!a || !b || !*a || !*b) {
      throw std::invalid_argument("SRDF: line " + std::to_string(e->GetLineNum()) +
                                  ": <disable_collisions> needs link1 and link2");
    }
    out.emplace_back(a, b);
  }
  return out;
}

}  // namespace se3
