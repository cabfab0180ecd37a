// SceneReader (scene_reader.h): the limits pass over scene text, yaml-cpp, typed values.
#include "scene_reader.h"

#include <yaml-cpp/eventhandler.h>
#include <yaml-cpp/parser.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <sstream>
#include <unordered_set>

#include "se3_sim/geometry/geometry.h"
#include "se3_sim/model/limits.h"

namespace se3 {
namespace {

// A value or key quoted in a message: one line, at most 60 characters.
std::string shown(const std::string& s) {
  std::string out;
  for (const char ch : s) {
    const auto c = static_cast<unsigned char>(ch);
    out += (c < 0x20 || c == 0x7f) ? '?' : ch;
    if (out.size() >= 60) {
      out += "...";
      break;
    }
  }
  return out;
}

// Where each document starts (the first two); every other event is ignored.
class DocumentStarts : public YAML::EventHandler {
 public:
  void OnDocumentStart(const YAML::Mark& m) override {
    if (count < 2) mark[count] = m;
    ++count;
  }
  void OnDocumentEnd() override {}
  void OnNull(const YAML::Mark&, YAML::anchor_t) override {}
  void OnAlias(const YAML::Mark&, YAML::anchor_t) override {}
  void OnScalar(const YAML::Mark&, const std::string&, YAML::anchor_t,
                const std::string&) override {}
  void OnSequenceStart(const YAML::Mark&, const std::string&, YAML::anchor_t,
                       YAML::EmitterStyle::value) override {}
  void OnSequenceEnd() override {}
  void OnMapStart(const YAML::Mark&, const std::string&, YAML::anchor_t,
                  YAML::EmitterStyle::value) override {}
  void OnMapEnd() override {}

  int count = 0;
  YAML::Mark mark[2];
};

int line_of(const YAML::Node& n, int fallback) {
  if (!n || n.IsNull()) return fallback;
  const YAML::Mark m = n.Mark();
  return m.is_null() || m.line < 0 ? fallback : m.line + 1;
}

std::string where(const SceneReader::Field& f) {
  return f.key.empty() ? std::string("the scene") : "'" + f.key + "'";
}

// One pass over scene text that bounds, without recursion, how deeply yaml-cpp will nest and
// how many nodes it will make. Conservative: every position gets an upper bound of the number
// of collections around it.
//  - Block context: a stack of (column, depth) of the node starts seen on earlier lines. A line
//    starting at column c takes the nearest entry at or left of c: one level deeper than it (a
//    value map, or a list at the same column as its key). `- `, `? ` and `: ` start a node one
//    level deeper further along the line; those starts are pushed too.
//  - Flow context: each '[' or '{' adds two levels (a collection, and the single-pair map that
//    `a: b` inside a flow list makes).
//  - Quoted scalars (possibly over several lines), comments and block scalars (`|`, `>`)
//    are skipped as yaml-cpp skips them; a quote counts only where a node starts.
//  - yaml-cpp reads a line that starts with `: ` (an empty key), after a line that ended with an
//    empty value (`key:` or `?`), as that value: a map one level deeper. So ": \n: \n: \n"
//    nests once per line (found by fuzz_scene's cross-check); such a line takes the depth of the
//    empty value before it, blank and comment lines between them included.
// Items: every separator (`,` `[` `{` `:` `-` `?`) and every line; yaml-cpp makes at most about
// two nodes per item.
class TextLimits {
 public:
  TextLimits(const std::string& text, const std::string& file) : s_(text), file_(file) {}

  void run() {
    if (s_.size() > limits::kMaxSceneBytes && throwing) {
      throw SceneError(file_ + ": " + std::to_string(s_.size()) + " bytes, more than the " +
                       std::to_string(limits::kMaxSceneBytes) +
                       " a scene may have (docs/robustness.md)");
    }
    const size_t bad = first_invalid_utf8(s_);
    if (bad < s_.size() && throwing) {
      throw SceneError(file_ + ":" +
                       std::to_string(1 + std::count(s_.begin(), s_.begin() + bad, '\n')) +
                       ": byte " + std::to_string(static_cast<unsigned char>(s_[bad])) +
                       " is not UTF-8 (YAML text is UTF-8)");
    }
    size_t i = 0;
    if (s_.compare(0, 3, "\xEF\xBB\xBF") == 0) i = 3;  // a UTF-8 byte order mark
    const size_t n = s_.size();
    while (i < n) {
      ++line_;
      size_t end = i;
      while (end < n && s_[end] != '\n' && s_[end] != '\r') ++end;
      do_line(i, end);
      i = end;
      if (i < n) i += (s_[i] == '\r' && i + 1 < n && s_[i + 1] == '\n') ? 2 : 1;
    }
  }

  int max_depth() const { return max_depth_; }
  std::size_t items() const { return items_; }

  // With throwing = false, run() only measures (for scene_text_shape).
  bool throwing = true;

 private:
  struct Start {
    int col;
    int depth;
  };

  void fail(const std::string& what) const {
    if (throwing) throw SceneError(file_ + ":" + std::to_string(line_) + ": " + what);
  }

  void deeper(int depth) {
    max_depth_ = std::max(max_depth_, depth);
    if (depth > limits::kMaxYamlDepth) {
      fail("lists and maps nested more than " + std::to_string(limits::kMaxYamlDepth) +
           " deep (docs/robustness.md)");
    }
  }

  void item() {
    if (++items_ > limits::kMaxYamlItems) {
      fail("more than " + std::to_string(limits::kMaxYamlItems) +
           " keys, values and list items (docs/robustness.md)");
    }
  }

  void push(int col, int depth) {
    while (!starts_.empty() && starts_.back().col >= col) starts_.pop_back();
    starts_.push_back({col, depth});
  }

  void do_line(size_t b, size_t e) {
    for (size_t k = b; k < e; ++k) {
      const auto c = static_cast<unsigned char>(s_[k]);
      if ((c < 0x20 && c != '\t') || c == 0x7f) {
        fail("control character " + std::to_string(c) + " (a scene is YAML text)");
        break;
      }
    }
    int indent = 0;
    size_t p = b;
    while (p < e && s_[p] == ' ') ++p, ++indent;
    size_t q = p;
    while (q < e && (s_[q] == ' ' || s_[q] == '\t')) ++q;
    const bool blank = q == e || (s_[q] == '#' && quote_ == 0);
    if (block_scalar_ >= 0) {
      if (blank || indent > block_scalar_) return;  // text of a `|` or `>` scalar
      block_scalar_ = -1;
    }
    if (blank && quote_ == 0) return;
    item();
    const int empty_value = empty_value_depth_;
    empty_value_depth_ = -1;
    int depth;  // collections around the node that starts here
    if (quote_ == 0 && flow_ == 0) {
      while (!starts_.empty() && starts_.back().col > indent) starts_.pop_back();
      depth = (starts_.empty() ? 0 : starts_.back().depth) + 1;
      if (starts_.empty() || starts_.back().col < indent) starts_.push_back({indent, depth});
      const bool empty_key = s_[p] == ':' && (p + 1 == e || s_[p + 1] == ' ' || s_[p + 1] == '\t');
      if (empty_key && empty_value > depth) depth = empty_value;
    } else {
      depth = flow_ > 0 ? flow_base_ + 2 * flow_ : (starts_.empty() ? 1 : starts_.back().depth);
    }
    deeper(depth);
    bool node_start = quote_ == 0;
    int owner = indent;  // column of the key or entry a block scalar would belong to
    for (size_t k = p; k < e; ++k) {
      const char c = s_[k];
      if (quote_ != 0) {
        if (quote_ == '\'' && c == '\'') {
          if (k + 1 < e && s_[k + 1] == '\'') {
            ++k;
          } else {
            quote_ = 0;
          }
        } else if (quote_ == '"' && c == '\\') {
          ++k;
        } else if (quote_ == '"' && c == '"') {
          quote_ = 0;
        }
        continue;
      }
      if (c == ' ' || c == '\t') continue;
      const bool after_blank = k == b || s_[k - 1] == ' ' || s_[k - 1] == '\t';
      const bool before_blank = k + 1 >= e || s_[k + 1] == ' ' || s_[k + 1] == '\t';
      const int col = static_cast<int>(k - b);
      if (c == '#' && after_blank) break;
      empty_value_depth_ = -1;  // the line has something after its last indicator
      switch (c) {
        case '[':
        case '{':
          if (flow_ == 0 && !node_start) break;  // inside a block plain scalar: its text
          item();
          if (flow_ == 0) flow_base_ = depth;
          ++flow_;
          deeper(flow_base_ + 2 * flow_);
          node_start = true;
          continue;
        case ']':
        case '}':
          item();
          if (flow_ > 0) --flow_;
          node_start = false;
          continue;
        case ',':
          item();
          node_start = flow_ > 0;
          continue;
        case '"':
        case '\'':
          if (node_start) {
            quote_ = c;
            owner = col;
          }
          node_start = false;
          continue;
        case '-':
        case '?':
        case ':':
          item();
          if (flow_ == 0 && before_blank && (c == ':' || node_start)) {
            if (c != ':') owner = col;
            ++depth;
            deeper(depth);
            // The node after the indicator starts deeper: later lines aligned with it nest there.
            size_t next = k + 1;
            while (next < e && (s_[next] == ' ' || s_[next] == '\t')) ++next;
            if (next < e && s_[next] != '#') push(static_cast<int>(next - b), depth);
            if (c != '-') empty_value_depth_ = depth;  // kept only if nothing follows
            node_start = true;
          } else if (node_start) {
            owner = col;
            node_start = false;
          }
          continue;
        default:
          break;
      }
      if (node_start && flow_ == 0 && (c == '|' || c == '>')) {
        block_scalar_ = owner;  // the rest of the line is the block scalar's header
        return;
      }
      if (node_start && (c == '&' || c == '!')) {  // an anchor or tag before the node
        // It ends at a blank or a flow indicator (neither may be in its name), or before a
        // ':' that ends the line or meets a blank (yaml-cpp then reads a mapping key there).
        while (k + 1 < e && s_[k + 1] != ' ' && s_[k + 1] != '\t' && s_[k + 1] != '[' &&
               s_[k + 1] != ']' && s_[k + 1] != '{' && s_[k + 1] != '}' && s_[k + 1] != ',' &&
               !(s_[k + 1] == ':' && (k + 2 >= e || s_[k + 2] == ' ' || s_[k + 2] == '\t'))) {
          ++k;
        }
        continue;
      }
      if (node_start) owner = col;
      node_start = false;
    }
  }

  const std::string& s_;
  const std::string& file_;
  int line_ = 0;
  int max_depth_ = 0;
  std::size_t items_ = 0;
  char quote_ = 0;
  int flow_ = 0, flow_base_ = 0;
  int block_scalar_ = -1;
  int empty_value_depth_ = -1;  // the depth of a block `:` or `?` that ended the last line
  std::vector<Start> starts_;
};

}  // namespace

void check_scene_text(const std::string& text, const std::string& file) {
  TextLimits(text, file).run();
}

std::string with_lf_line_ends(const std::string& text) {
  std::string lf;
  lf.reserve(text.size());
  for (size_t i = 0; i < text.size(); ++i) {
    if (text[i] != '\r') {
      lf += text[i];
    } else if (i + 1 >= text.size() || text[i + 1] != '\n') {
      lf += '\n';
    }
  }
  return lf;
}

SceneTextShape scene_text_shape(const std::string& text) {
  const std::string file;
  TextLimits t(text, file);
  t.throwing = false;
  t.run();
  return {t.max_depth(), t.items()};
}

SceneReader::Field SceneReader::document(const std::string& text) const {
  check_scene_text(text, file_);
  const std::string lf = with_lf_line_ends(text);
  YAML::Node doc;
  try {
    // First count the documents (at most two) without building nodes: yaml-cpp 0.7 returns the
    // same empty document forever from a text that starts with ',' (YAML::LoadAll never ends),
    // so a document that starts where the one before it started is refused.
    std::istringstream in(lf);
    YAML::Parser parser(in);
    DocumentStarts starts;
    while (starts.count < 2 && parser.HandleNextDocument(starts)) {
    }
    if (starts.count == 2) {
      const YAML::Mark& m = starts.mark[0];
      if (starts.mark[1].pos == m.pos) {
        const std::string at = m.pos >= 0 && static_cast<size_t>(m.pos) < lf.size()
                                   ? shown(lf.substr(static_cast<size_t>(m.pos), 1))
                                   : std::string("?");
        fail(m.line + 1, "'" + at + "' cannot start a YAML document (column " +
                             std::to_string(m.column + 1) + ")");
      }
      fail(starts.mark[1].line + 1, "a scene is one YAML document ('---' starts a second one)");
    }
    doc = YAML::Load(lf);
  } catch (const YAML::Exception& e) {
    const int line = e.mark.is_null() ? 0 : e.mark.line + 1;
    fail(line,
         e.msg + (e.mark.is_null() ? "" : " (column " + std::to_string(e.mark.column + 1) + ")"));
  }
  Field root;
  root.line = 1;
  if (!doc || doc.IsNull()) {
    root.node = YAML::Node(YAML::NodeType::Map);
    return root;
  }
  root.node = doc;
  root.line = line_of(doc, 1);
  if (!root.node.IsMap()) fail(root.line, "the top level of a scene must be a map of keys");
  return root;
}

void SceneReader::fail(const Field& f, const std::string& what) const {
  fail(f.line, what);
}

void SceneReader::fail(int line, const std::string& what) const {
  throw SceneError(file_ + (line > 0 ? ":" + std::to_string(line) : std::string()) + ": " + what);
}

std::vector<SceneReader::Field> SceneReader::fields(const Field& map,
                                                    const std::vector<std::string>& known,
                                                    bool allow_null) const {
  std::vector<Field> out;
  if (allow_null && is_null(map)) return out;
  if (!map.node.IsMap()) fail(map, where(map) + " needs a map {key: value, ...}");
  std::unordered_set<std::string> seen;
  for (const auto& kv : map.node) {
    const YAML::Node k = kv.first;
    const int kline = line_of(k, map.line);
    if (!k.IsScalar()) fail(kline, "a key in " + where(map) + " is not a name");
    const std::string name = k.Scalar();
    if (!seen.insert(name).second) {
      fail(kline, "duplicate key '" + shown(name) + "' in " + where(map));
    }
    if (!known.empty() && std::find(known.begin(), known.end(), name) == known.end()) {
      std::string list;
      for (const auto& s : known) list += (list.empty() ? "" : ", ") + s;
      fail(kline, "unknown key '" + shown(name) + "' in " +
                      (map.key.empty() ? std::string("the scene") : map.key) + " (known: " + list +
                      ")");
    }
    Field f;
    f.name = name;
    f.key = map.key.empty() ? name : map.key + "." + name;
    f.node = kv.second;
    f.line = line_of(f.node, kline);
    out.push_back(std::move(f));
  }
  return out;
}

std::vector<SceneReader::Field> SceneReader::items(const Field& list, std::size_t max_items,
                                                   bool allow_null) const {
  std::vector<Field> out;
  if (allow_null && is_null(list)) return out;
  if (!list.node.IsSequence()) fail(list, where(list) + " needs a list");
  if (list.node.size() > max_items) {
    fail(list, where(list) + " has more than " + std::to_string(max_items) + " items");
  }
  std::size_t i = 0;
  for (const YAML::Node& n : list.node) {
    Field f;
    f.name = "[" + std::to_string(i) + "]";
    f.key = list.key + f.name;
    f.node = n;
    f.line = line_of(n, list.line);
    out.push_back(std::move(f));
    ++i;
  }
  return out;
}

double SceneReader::number(const Field& f) const {
  if (is_null(f) || !f.node.IsScalar()) fail(f, where(f) + " needs a number");
  const std::string& s = f.node.Scalar();
  char* end = nullptr;
  errno = 0;
  const double x = std::strtod(s.c_str(), &end);
  if (s.empty() || end != s.c_str() + s.size() || !std::isfinite(x)) {
    fail(f, where(f) + " needs a finite number, got '" + shown(s) + "'");
  }
  return x;
}

double SceneReader::positive(const Field& f) const {
  const double x = number(f);
  if (!(x > 0)) fail(f, where(f) + " must be positive");
  return x;
}

double SceneReader::non_negative(const Field& f) const {
  const double x = number(f);
  if (!(x >= 0)) fail(f, where(f) + " must be >= 0");
  return x;
}

double SceneReader::in_range(const Field& f, double lo, double hi) const {
  const double x = number(f);
  if (!(x >= lo && x <= hi)) {
    char buf[96];
    std::snprintf(buf, sizeof buf, " must be in [%g, %g]", lo, hi);
    fail(f, where(f) + buf);
  }
  return x;
}

long SceneReader::integer(const Field& f, long lo, long hi) const {
  const double x = number(f);
  if (x != std::floor(x) || x < static_cast<double>(lo) || x > static_cast<double>(hi)) {
    fail(f, where(f) + " needs a whole number from " + std::to_string(lo) + " to " +
                std::to_string(hi));
  }
  return static_cast<long>(x);
}

std::string SceneReader::text(const Field& f) const {
  if (is_null(f) || !f.node.IsScalar() || f.node.Scalar().empty()) {
    fail(f, where(f) + " needs a value");
  }
  const std::string& s = f.node.Scalar();
  if (s.find('\0') != std::string::npos) fail(f, where(f) + " contains a NUL character");
  return s;
}

bool SceneReader::boolean(const Field& f) const {
  const std::string v = text(f);
  for (const char* t : {"true", "True", "TRUE", "yes", "Yes", "YES", "on", "On", "ON"}) {
    if (v == t) return true;
  }
  for (const char* t : {"false", "False", "FALSE", "no", "No", "NO", "off", "Off", "OFF"}) {
    if (v == t) return false;
  }
  fail(f, where(f) + " needs true or false, got '" + shown(v) + "'");
}

std::vector<double> SceneReader::numbers(const Field& f, std::size_t min_size,
                                         std::size_t max_size) const {
  const std::string need = std::to_string(min_size) +
                           (min_size == max_size ? "" : " to " + std::to_string(max_size)) +
                           " numbers";
  if (is_null(f) || !f.node.IsSequence()) fail(f, where(f) + " needs a list of " + need);
  if (f.node.size() < min_size || f.node.size() > max_size) {
    fail(f, where(f) + " needs " + need + ", got " + std::to_string(f.node.size()));
  }
  std::vector<double> v;
  for (const Field& x : items(f, max_size)) v.push_back(number(x));
  return v;
}

Vec3 SceneReader::vec3(const Field& f) const {
  const auto v = numbers(f, 3, 3);
  return Vec3(v[0], v[1], v[2]);
}

std::vector<std::pair<std::string, double>> SceneReader::joint_map(const Field& f) const {
  std::vector<std::pair<std::string, double>> out;
  if (!is_null(f) && !f.node.IsMap()) fail(f, where(f) + " needs a map {joint: value, ...}");
  for (const Field& j : fields(f, {}, true)) out.emplace_back(j.name, number(j));
  return out;
}

bool scene_ros_reference(const std::string& written, const std::string& base_dir, std::string* out,
                         std::string* error) {
  std::string uri = written;
  if (written.compare(0, 7, "$(find ") == 0) {  // roslaunch's substitution: $(find PKG)/rest
    const std::size_t close = written.find(')');
    if (close == std::string::npos) {
      *out = "";
      *error = "'" + written + "' has no ')' after $(find PKG";
      return true;
    }
    std::string pkg = written.substr(7, close - 7);
    while (!pkg.empty() && pkg.back() == ' ') pkg.pop_back();
    uri = "package://" + pkg + written.substr(close + 1);
  } else if (written.compare(0, 10, "package://") != 0 && written.compare(0, 7, "file://") != 0) {
    return false;
  }
  ResourcePaths paths;
  paths.base_dir = base_dir;
  *out = resolve_resource(uri, paths, error);
  return true;
}

}  // namespace se3
