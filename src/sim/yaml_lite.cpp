#include "yaml_lite.h"

#include <sstream>

namespace se3 {
namespace yaml_lite {
namespace {

struct Line {
  int number;
  int indent;
  std::string text;  ///< without indentation, comment and trailing blanks
};

[[noreturn]] void fail(int line, const std::string& what) {
  throw Error("line " + std::to_string(line) + ": " + what);
}

std::string trim(const std::string& s) {
  const auto a = s.find_first_not_of(" \t");
  if (a == std::string::npos) return "";
  const auto b = s.find_last_not_of(" \t\r");
  return s.substr(a, b - a + 1);
}

// Removes a comment: '#' at the start or after a blank, outside quotes.
std::string strip_comment(const std::string& s) {
  char quote = 0;
  for (size_t i = 0; i < s.size(); ++i) {
    const char c = s[i];
    if (quote) {
      if (c == quote) quote = 0;
    } else if (c == '"' || c == '\'') {
      quote = c;
    } else if (c == '#' && (i == 0 || s[i - 1] == ' ' || s[i - 1] == '\t')) {
      return s.substr(0, i);
    }
  }
  return s;
}

// Open brackets minus closed ones, outside quotes.
int flow_depth(const std::string& s) {
  char quote = 0;
  int depth = 0;
  for (const char c : s) {
    if (quote) {
      if (c == quote) quote = 0;
    } else if (c == '"' || c == '\'') {
      quote = c;
    } else if (c == '[' || c == '{') {
      ++depth;
    } else if (c == ']' || c == '}') {
      --depth;
    }
  }
  return depth;
}

std::vector<Line> split_lines(const std::string& text) {
  std::vector<Line> out;
  std::istringstream in(text);
  std::string raw;
  int number = 0;
  while (std::getline(in, raw)) {
    ++number;
    std::string s = strip_comment(raw);
    if (trim(s).empty()) continue;
    // A flow collection ([..] or {..}) may continue over the following lines.
    const int first = number;
    while (flow_depth(s) > 0) {
      if (!std::getline(in, raw)) fail(first, "unterminated '[' or '{'");
      ++number;
      s += " " + trim(strip_comment(raw));
    }
    int indent = 0;
    while (indent < static_cast<int>(s.size()) && s[indent] == ' ') ++indent;
    if (s[indent] == '\t') fail(number, "tabs are not allowed for indentation");
    const std::string body = trim(s);
    if (body == "---" || body == "...") continue;
    if (body[0] == '&' || body[0] == '*' || body[0] == '|' || body[0] == '>' || body[0] == '!') {
      fail(number, "unsupported YAML construct '" + body.substr(0, 1) + "'");
    }
    out.push_back({first, indent, body});
  }
  return out;
}

// Flow-style values: [..], {..}, quoted or plain scalars.
class FlowParser {
 public:
  FlowParser(const std::string& s, int line) : s_(s), line_(line) {}

  Node parse_all() {
    Node n = value(false);
    skip();
    if (i_ != s_.size()) fail(line_, "unexpected '" + s_.substr(i_) + "'");
    return n;
  }

 private:
  void skip() {
    while (i_ < s_.size() && (s_[i_] == ' ' || s_[i_] == '\t')) ++i_;
  }

  Node value(bool in_flow) {
    skip();
    Node n;
    n.line = line_;
    if (i_ >= s_.size()) return n;
    const char c = s_[i_];
    if (c == '[') {
      ++i_;
      n.kind = Node::Kind::List;
      skip();
      if (i_ < s_.size() && s_[i_] == ']') {
        ++i_;
        return n;
      }
      while (true) {
        n.list.push_back(value(true));
        skip();
        if (i_ >= s_.size()) fail(line_, "unterminated '['");
        if (s_[i_] == ',') {
          ++i_;
          continue;
        }
        if (s_[i_] == ']') {
          ++i_;
          return n;
        }
        fail(line_, "expected ',' or ']' in a list");
      }
    }
    if (c == '{') {
      ++i_;
      n.kind = Node::Kind::Map;
      skip();
      if (i_ < s_.size() && s_[i_] == '}') {
        ++i_;
        return n;
      }
      while (true) {
        skip();
        const Node key = scalar(true, true);
        skip();
        if (i_ >= s_.size() || s_[i_] != ':') fail(line_, "expected ':' after key in '{...}'");
        ++i_;
        for (const auto& kv : n.map) {
          if (kv.first == key.value) fail(line_, "duplicate key '" + key.value + "'");
        }
        n.map.emplace_back(key.value, value(true));
        skip();
        if (i_ >= s_.size()) fail(line_, "unterminated '{'");
        if (s_[i_] == ',') {
          ++i_;
          continue;
        }
        if (s_[i_] == '}') {
          ++i_;
          return n;
        }
        fail(line_, "expected ',' or '}' in a map");
      }
    }
    return scalar(in_flow, false);
  }

  Node scalar(bool in_flow, bool is_key) {
    Node n;
    n.line = line_;
    skip();
    if (i_ < s_.size() && (s_[i_] == '"' || s_[i_] == '\'')) {
      const char q = s_[i_++];
      const size_t end = s_.find(q, i_);
      if (end == std::string::npos) fail(line_, "unterminated quote");
      n.value = s_.substr(i_, end - i_);
      n.quoted = true;
      i_ = end + 1;
      return n;
    }
    const size_t start = i_;
    while (i_ < s_.size()) {
      const char c = s_[i_];
      if (in_flow && (c == ',' || c == ']' || c == '}')) break;
      if (is_key && c == ':') break;
      ++i_;
    }
    n.value = trim(s_.substr(start, i_ - start));
    return n;
  }

  const std::string& s_;
  int line_;
  size_t i_ = 0;
};

// Position of the "key:" separator (a ':' followed by a blank or the end), outside quotes and
// brackets; npos when the line is not a key.
size_t key_colon(const std::string& s) {
  char quote = 0;
  int depth = 0;
  for (size_t i = 0; i < s.size(); ++i) {
    const char c = s[i];
    if (quote) {
      if (c == quote) quote = 0;
      continue;
    }
    if (c == '"' || c == '\'') quote = c;
    if (c == '[' || c == '{') ++depth;
    if (c == ']' || c == '}') --depth;
    if (c == ':' && depth == 0 && (i + 1 == s.size() || s[i + 1] == ' ')) return i;
  }
  return std::string::npos;
}

class BlockParser {
 public:
  explicit BlockParser(std::vector<Line> lines) : lines_(std::move(lines)) {}

  Node document() {
    Node root;
    root.kind = Node::Kind::Map;
    if (lines_.empty()) return root;
    root = block(lines_[0].indent);
    if (k_ != lines_.size()) fail(lines_[k_].number, "bad indentation");
    if (!root.is_map()) fail(lines_[0].number, "the top level must be a map of keys");
    return root;
  }

 private:
  Node block(int indent) {
    Node n;
    n.line = lines_[k_].number;
    const bool list =
        lines_[k_].text[0] == '-' && (lines_[k_].text.size() == 1 || lines_[k_].text[1] == ' ');
    n.kind = list ? Node::Kind::List : Node::Kind::Map;
    while (k_ < lines_.size() && lines_[k_].indent == indent) {
      const Line& L = lines_[k_];
      const bool item = L.text[0] == '-' && (L.text.size() == 1 || L.text[1] == ' ');
      if (item != list) fail(L.number, "mixing list items and keys at one level");
      if (list) {
        const std::string rest = trim(L.text.substr(1));
        if (key_colon(rest) != std::string::npos) {
          fail(L.number, "maps inside block lists are not supported; use {key: value}");
        }
        ++k_;
        n.list.push_back(FlowParser(rest, L.number).parse_all());
        continue;
      }
      const size_t colon = key_colon(L.text);
      if (colon == std::string::npos) fail(L.number, "expected 'key: value'");
      std::string key = trim(L.text.substr(0, colon));
      if (key.size() >= 2 && (key[0] == '"' || key[0] == '\'') && key.back() == key[0]) {
        key = key.substr(1, key.size() - 2);
      }
      for (const auto& kv : n.map) {
        if (kv.first == key) fail(L.number, "duplicate key '" + key + "'");
      }
      const std::string rest = trim(L.text.substr(colon + 1));
      ++k_;
      if (!rest.empty()) {
        n.map.emplace_back(key, FlowParser(rest, L.number).parse_all());
      } else if (k_ < lines_.size() && lines_[k_].indent > indent) {
        n.map.emplace_back(key, block(lines_[k_].indent));
      } else {
        Node empty;
        empty.line = L.number;
        n.map.emplace_back(key, empty);
      }
    }
    if (k_ < lines_.size() && lines_[k_].indent > indent) {
      fail(lines_[k_].number, "bad indentation");
    }
    return n;
  }

  std::vector<Line> lines_;
  size_t k_ = 0;
};

}  // namespace

Node parse(const std::string& text) {
  return BlockParser(split_lines(text)).document();
}

}  // namespace yaml_lite
}  // namespace se3
