// Bad input from outside (issue 17): every crash, hang and silent failure a fuzzing campaign
// found, each refused with one clear line or handled, and the limits of docs/robustness.md.
// What used to kill the process runs in a child (EXPECT_EXIT forks), so that a regression fails
// this test instead of ending the test binary.
#include <gtest/gtest.h>
#include <pthread.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <functional>
#include <sstream>
#include <string>

#include "../src/sim/scene_reader.h"
#include "error_of.h"
#include "se3_sim/geometry/geometry.h"
#include "se3_sim/model/limits.h"
#include "se3_sim/sim/sim.h"
#include "source_paths.h"

using namespace se3;

namespace {

const std::string kSource = se3_sim_test::source_dir();
const std::string kScenes = kSource + "/config/scenes/";
const std::string kSe3Dyn = se3_sim_test::se3_dyn_exe();

std::string read(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

// A file of this test process in the temporary folder (other runs may share the folder).
std::string temp_file_name(const std::string& name) {
  return ::testing::TempDir() + "se3_robust_" + std::to_string(getpid()) + "_" + name;
}

std::string temp_file(const std::string& name, const std::string& text) {
  const std::string path = temp_file_name(name);
  std::ofstream(path, std::ios::binary) << text;
  return path;
}

using se3_test::error_of;

// Runs f on a thread with a small stack (512 kB), as ROS callbacks and other threads may have:
// what recursed once per link or per level needs far more for the inputs below (the recursive
// tree builder overflowed 8 MB at about 7,000 links).
void on_small_stack(const std::function<void()>& f) {
  pthread_attr_t attr;
  pthread_attr_init(&attr);
  pthread_attr_setstacksize(&attr, 512 * 1024);
  pthread_t t;
  auto* fn = new std::function<void()>(f);
  auto run = [](void* p) -> void* {
    auto* g = static_cast<std::function<void()>*>(p);
    (*g)();
    delete g;
    return nullptr;
  };
  ASSERT_EQ(pthread_create(&t, &attr, run, fn), 0);
  pthread_join(t, nullptr);
  pthread_attr_destroy(&attr);
}

// exit(0) when f's error message holds `expect`, 3 when it holds something else, 4 when f
// throws nothing: for EXPECT_EXIT(..., ExitedWithCode(0), "").
void exit_with_error_containing(const std::function<void()>& f, const std::string& expect) {
  int code = 4;
  on_small_stack([&] {
    try {
      f();
    } catch (const std::exception& e) {
      code = std::string(e.what()).find(expect) != std::string::npos ? 0 : 3;
      if (code) std::fprintf(stderr, "message: %s\n", e.what());
    }
  });
  std::exit(code);
}

std::string link_xml(const std::string& name) {
  return "<link name=\"" + name +
         "\"><inertial><mass value=\"1\"/><inertia ixx=\"1\" iyy=\"1\" izz=\"1\" ixy=\"0\" "
         "ixz=\"0\" iyz=\"0\"/></inertial></link>\n";
}

std::string joint_xml(const std::string& name, const std::string& parent, const std::string& child,
                      const std::string& extra = "") {
  return "<joint name=\"" + name + "\" type=\"revolute\"><parent link=\"" + parent +
         "\"/><child link=\"" + child +
         "\"/><axis xyz=\"0 0 1\"/><limit lower=\"-1\" upper=\"1\" effort=\"1\" velocity=\"1\"/>" +
         extra + "</joint>\n";
}

// A serial chain of n revolute joints; with reversed names the links sort from tip to root.
std::string chain_urdf(int n, bool reversed_names) {
  auto name = [&](int i) {
    char buf[16];
    std::snprintf(buf, sizeof buf, "l%06d", reversed_names ? n - i : i);
    return std::string(buf);
  };
  std::string x = "<robot name=\"chain\">\n";
  for (int i = 0; i <= n; ++i) x += link_xml(name(i));
  for (int i = 0; i < n; ++i) x += joint_xml("j" + std::to_string(i), name(i), name(i + 1));
  return x + "</robot>\n";
}

std::string two_link_urdf(const std::string& joint_extra) {
  return "<robot name=\"two\">" + link_xml("a") + link_xml("b") +
         joint_xml("j", "a", "b", joint_extra) + "</robot>";
}

struct RunResult {
  int code = -1;  ///< exit code; -1 when killed by a signal
  std::string out, err;
};

// Runs se3_dyn with arguments (and stdin from a file when given).
RunResult se3_dyn(const std::string& args, const std::string& stdin_text = "") {
  const std::string out = temp_file("out.txt", "");
  const std::string err = temp_file("err.txt", "");
  std::string cmd = kSe3Dyn + " " + args + " > " + out + " 2> " + err;
  if (!stdin_text.empty()) cmd += " < " + temp_file("stdin.csv", stdin_text);
  const int status = std::system(cmd.c_str());
  RunResult r;
  r.code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  r.out = read(out);
  r.err = read(err);
  return r;
}

}  // namespace

// ---------------------------------------------------------------- URDF: format strings
// urdfdom quotes attributes in messages that console_bridge formats printf-style: "%n" in an
// rgba value wrote through a garbage pointer (segfault), "%s%n" in a mass aborted ("%n in
// writable segment detected"). The simulator node parses robot_description the same way.
TEST(UrdfFormatString, PercentConversionsInAttributesNeitherCrashNorVanish) {
  const std::string bad = "%s%n%x%s%n%p%n";
  const std::string urdfs[] = {
      // accepted by urdfdom with complaints (a bad colour, a bad mass)
      "<robot name=\"r\"><material name=\"m\"><color rgba=\"" + bad + "\"/></material>" +
          link_xml("a") + "</robot>",
      "<robot name=\"r\"><link name=\"a\"><inertial><mass value=\"" + bad +
          "\"/></inertial></link></robot>",
      // rejected by urdfdom
      "<robot name=\"" + bad + "\">" + link_xml("a") + link_xml("b") + "<joint name=\"j\" type=\"" +
          bad + "\"><parent link=\"a\"/><child link=\"b\"/></joint>" + "</robot>",
      "<robot name=\"r\">" + link_xml("a") + link_xml("b") +
          joint_xml("j", "a", "b", "<dynamics damping=\"" + bad + "\"/>") + "</robot>",
      // names and paths with '%' (URL-encoded mesh paths are real)
      "<robot name=\"r%20x\"><link name=\"a%n\"><visual><geometry><mesh filename=\"m%20" + bad +
          ".stl\"/></geometry></visual></link></robot>",
  };
  for (const std::string& xml : urdfs) {
    SCOPED_TRACE(xml);
    EXPECT_EXIT(
        {
          on_small_stack([&] {
            try {
              model_from_urdf_string(xml);
            } catch (const ModelError&) {
            }
          });
          std::exit(0);
        },
        ::testing::ExitedWithCode(0), "");
  }
  // What urdfdom says is kept, with the '%' as written: a rejection names the bad type ...
  const std::string err = error_of<ModelError>([&] { model_from_urdf_string(urdfs[2]); });
  EXPECT_NE(err.find("rejected by urdfdom"), std::string::npos) << err;
  EXPECT_NE(err.find(bad), std::string::npos) << err;
  // ... and what it accepted with a complaint is a warning of the model, not silence.
  const Model m = model_from_urdf_string(urdfs[1]);
  std::string warnings;
  for (const auto& w : m.warnings) warnings += w + "\n";
  EXPECT_NE(warnings.find("mass [" + bad + "]"), std::string::npos) << warnings;
  // Names with '%' survive as written.
  const Model named = model_from_urdf_string(urdfs[4]);
  EXPECT_EQ(named.name, "r%20x");
  EXPECT_EQ(named.links[0].name, "a%n");
  const GeometryModel g = geometry_from_urdf_string(named, urdfs[4]);
  ASSERT_EQ(g.visuals.size(), 1u);
  // The mesh does not exist: its stand-in's warning names it as written.
  EXPECT_TRUE(g.visuals[0].stand_in);
  EXPECT_NE(g.visuals[0].warning.find("'m%20" + bad + ".stl'"), std::string::npos)
      << g.visuals[0].warning;
}

// ---------------------------------------------------------------- stack overflows
// The tree builder recursed once per link: about 7,000 links overflowed an 8 MB stack.
TEST(UrdfDepth, LongChainsLoadWithoutRecursion) {
  for (const bool reversed : {false, true}) {
    SCOPED_TRACE(reversed ? "names sorted tip to root" : "names sorted root to tip");
    const std::string xml = chain_urdf(10000, reversed);
    EXPECT_EXIT(
        {
          int n = -1;
          on_small_stack([&] {
            try {
              n = model_from_urdf_string(xml).n;
            } catch (const std::exception& e) {
              std::fprintf(stderr, "%s\n", e.what());
            }
          });
          std::exit(n == 10000 ? 0 : 1);
        },
        ::testing::ExitedWithCode(0), "");
  }
  // And the bodies come out in the builder's depth-first order.
  const Model m = model_from_urdf_string(chain_urdf(50, false));
  ASSERT_EQ(m.n, 50);
  for (int i = 1; i <= m.n; ++i) {
    EXPECT_EQ(m.parent[i], i - 1);
    EXPECT_EQ(m.joint_name[i], "j" + std::to_string(i - 1));
  }
}

// tinyxml recursed once per element level: 100,000 nested elements overflowed the stack.
TEST(UrdfDepth, DeepXmlIsRefusedBeforeTinyxmlSeesIt) {
  std::string deep = "<robot name=\"d\">";
  for (int i = 0; i < 100000; ++i) deep += "<a>";
  for (int i = 0; i < 100000; ++i) deep += "</a>";
  deep += "</robot>";
  EXPECT_EXIT(exit_with_error_containing([&] { model_from_urdf_string(deep); },
                                         "nested more than 100 deep"),
              ::testing::ExitedWithCode(0), "");
  // An empty element is a level too (tinyxml parses it one call deeper): 100 levels and an
  // empty one inside are 101 (found by fuzz_urdf's cross-check with tinyxml).
  std::string edge = "<robot name=\"e\">";
  for (int i = 1; i < 100; ++i) edge += "<a>";
  std::string inner = "<b/>";
  for (int i = 1; i < 100; ++i) inner += "</a>";
  EXPECT_NE(error_of<ModelError>([&] {
              model_from_urdf_string(edge + inner + "</robot>");
            }).find("nested more than 100 deep"),
            std::string::npos);
  EXPECT_EQ(error_of<ModelError>([&] {
              model_from_urdf_string(edge.substr(0, edge.size() - 3) +
                                     inner.substr(0, inner.size() - 4) + "</robot>");
            }).find("nested"),
            std::string::npos);
  // Nesting tinyxml does not see as elements is not counted: comments, CDATA, quoted values.
  std::string hidden = "<robot name=\"h\"><!--";
  for (int i = 0; i < 1000; ++i) hidden += "<a>";
  hidden += "--><link name=\"x\" a=\"";
  for (int i = 0; i < 1000; ++i) hidden += "&lt;b&gt;";
  hidden += "\"/></robot>";
  EXPECT_NO_THROW(model_from_urdf_string(hidden));
  // tinyxml looks every attribute up among the earlier ones: quadratic in their number.
  std::string wide = "<robot name=\"w\"><link name=\"a\"";
  for (int i = 0; i < 20000; ++i) wide += " x" + std::to_string(i) + "=\"1\"";
  wide += "/></robot>";
  EXPECT_NE(error_of<ModelError>([&] { model_from_urdf_string(wide); }).find("attributes"),
            std::string::npos);
}

// tinyxml reads a UTF-8 lead byte and the next ones as one character whatever they are: "\xe9<"
// hid a '<' from the nesting count, and a lead byte at the end made tinyxml step past the end of
// the text (found by fuzz_urdf). XML text is UTF-8; anything else is refused with its line.
TEST(UrdfLimits, TextThatIsNotUtf8IsRefused) {
  const std::string lead_before_lt =
      "<?xml version=\"1.0\"?>\n<robot name=\"r\"><link name=\"a\"/>"
      "\xe9< <link name=\"b\"/></robot>";
  EXPECT_NE(error_of<ModelError>([&] {
              model_from_urdf_string(lead_before_lt);
            }).find("byte 0xe9 is not UTF-8 (XML text is UTF-8) (line 2)"),
            std::string::npos)
      << error_of<ModelError>([&] { model_from_urdf_string(lead_before_lt); });
  const std::string lead_at_end = "<robot name=\"r\"><link name=\"a\"/>\xf0";
  EXPECT_NE(error_of<ModelError>([&] { model_from_urdf_string(lead_at_end); }).find("UTF-8"),
            std::string::npos);
  // Valid UTF-8 (names, comments) is fine.
  const Model m = model_from_urdf_string(
      "<?xml version=\"1.0\"?><!-- caf\xc3\xa9 \xf0\x9f\xa4\x96 --><robot name=\"r\xc3\xb6"
      "bot\">" +
      link_xml("\xe2\x82\xac") + "</robot>");
  EXPECT_EQ(m.name,
            "r\xc3\xb6"
            "bot");
  EXPECT_NE(error_of<SceneError>([&] {
              parse_scene("name: caf\xe9\n", kScenes, "l1.yaml");
            }).find("l1.yaml:1: byte 233 is not UTF-8"),
            std::string::npos);
}

TEST(UrdfLimits, SizeAndLinkCountAreBounded) {
  const std::string big(limits::kMaxUrdfBytes + 1, ' ');
  EXPECT_NE(error_of<ModelError>([&] { model_from_urdf_string(big); }).find("bytes"),
            std::string::npos);
  const std::string path = temp_file("big.urdf", big);
  EXPECT_NE(error_of<ModelError>([&] { model_from_urdf_file(path); }).find("bytes"),
            std::string::npos);
  std::remove(path.c_str());
  std::string many = "<robot name=\"m\">";
  for (int i = 0; i <= limits::kMaxBodies; ++i)
    many += "<link name=\"" + std::to_string(i) + "\"/>";
  many += "</robot>";
  EXPECT_NE(error_of<ModelError>([&] { model_from_urdf_string(many); }).find("links or joints"),
            std::string::npos);
}

// ---------------------------------------------------------------- URDF: silent acceptance
TEST(UrdfSilent, NegativeDampingFrictionEffortAreErrors) {
  const std::pair<std::string, std::string> cases[] = {
      {"<dynamics damping=\"-0.5\"/>", "negative damping"},
      {"<dynamics friction=\"-1\"/>", "negative friction"},
  };
  for (const auto& c : cases) {
    const std::string err =
        error_of<ModelError>([&] { model_from_urdf_string(two_link_urdf(c.first)); });
    EXPECT_NE(err.find(c.second), std::string::npos) << err;
    EXPECT_NE(err.find("joint 'j'"), std::string::npos) << err;
  }
  const std::string neg_effort = "<robot name=\"two\">" + link_xml("a") + link_xml("b") +
                                 "<joint name=\"j\" type=\"revolute\"><parent link=\"a\"/>"
                                 "<child link=\"b\"/><axis xyz=\"0 0 1\"/><limit lower=\"-1\" "
                                 "upper=\"1\" effort=\"-5\" velocity=\"1\"/></joint></robot>";
  EXPECT_NE(error_of<ModelError>([&] {
              model_from_urdf_string(neg_effort);
            }).find("negative effort limit"),
            std::string::npos);
}

// urdfdom checks neither that a link has one parent nor that links hang from the root.
TEST(UrdfSilent, LinksWithTwoParentsOrOffTheTreeAreErrors) {
  const std::string two_parents = "<robot name=\"t\">" + link_xml("r") + link_xml("a") +
                                  link_xml("b") + joint_xml("j1", "r", "a") +
                                  joint_xml("j2", "b", "a") + joint_xml("j3", "r", "b") +
                                  "</robot>";
  EXPECT_NE(error_of<ModelError>([&] {
              model_from_urdf_string(two_parents);
            }).find("already the child of joint"),
            std::string::npos);
  const std::string loop = "<robot name=\"t\">" + link_xml("r") + link_xml("a") + link_xml("b") +
                           joint_xml("j1", "a", "b") + joint_xml("j2", "b", "a") + "</robot>";
  EXPECT_NE(error_of<ModelError>([&] {
              model_from_urdf_string(loop);
            }).find("the joints 'j2' -> 'j1' form a loop of links"),
            std::string::npos);
  // A joint that is its own link's parent: refused before urdfdom, whose tree would hold itself
  // through shared pointers and leak (found by fuzz_urdf under LeakSanitizer).
  const std::string self = "<robot name=\"t\">" + link_xml("r") + link_xml("a") +
                           joint_xml("j1", "r", "a") + joint_xml("j2", "a", "a") + "</robot>";
  EXPECT_NE(error_of<ModelError>([&] {
              model_from_urdf_string(self);
            }).find("joint 'j2': its parent and child are the same link 'a'"),
            std::string::npos);
}

// ---------------------------------------------------------------- scene YAML
// The old reader recursed once per flow level: about 20,000 overflowed the stack. yaml-cpp
// recurses too; the depth is checked before it parses.
TEST(SceneDepth, DeepNestingIsRefusedBeforeYamlCppParses) {
  const std::string opens[] = {"[", "{a: ", "- "};
  const std::string closes[] = {"]", "}", ""};
  for (int k = 0; k < 3; ++k) {
    std::string text = "robot: chain:2\ngravity:\n  ";
    for (int i = 0; i < 20000; ++i) text += opens[k];
    text += "1";
    for (int i = 0; i < 20000; ++i) text += closes[k];
    text += "\n";
    EXPECT_EXIT(exit_with_error_containing([&] { parse_scene(text, kScenes, "deep.yaml"); },
                                           "deep.yaml:3: lists and maps nested more than 64"),
                ::testing::ExitedWithCode(0), "");
  }
  // A tag or anchor ends at a flow indicator: "!t[[[..." is a tag, then the lists (the bound
  // skipped them as part of the tag; found by fuzz_scene's cross-check with yaml-cpp).
  for (const char* prefix : {"!t", "&a", "!!str"}) {
    SCOPED_TRACE(prefix);
    std::string text = std::string("robot: chain:2\ngravity: ") + prefix;
    for (int i = 0; i < 2000; ++i) text += "[";
    for (int i = 0; i < 2000; ++i) text += "]";
    EXPECT_NE(error_of<SceneError>([&] {
                parse_scene(text, kScenes, "tag.yaml");
              }).find("tag.yaml:2: lists and maps nested more than 64"),
              std::string::npos)
        << error_of<SceneError>([&] { parse_scene(text, kScenes, "tag.yaml"); });
  }
  // Block nesting by indentation, one level per line.
  std::string block = "robot: chain:2\n";
  for (int i = 0; i < 200; ++i) block += std::string(i, ' ') + "k" + std::to_string(i) + ":\n";
  EXPECT_NE(error_of<SceneError>([&] { parse_scene(block, kScenes, "b.yaml"); }).find("nested"),
            std::string::npos);
  // yaml-cpp nests a line that starts with an empty key ": " under an empty value on the line
  // before (blank lines between included): one level per line (found by fuzz_scene).
  std::string empty_keys = "robot: chain:2\nx:\n";
  for (int i = 0; i < 100; ++i) empty_keys += i % 3 == 1 ? ":\r\r\n  \n" : ": \n";
  EXPECT_NE(error_of<SceneError>([&] {
              parse_scene(empty_keys, kScenes, "e.yaml");
            }).find("nested more than 64"),
            std::string::npos);
  std::string siblings = "robot: chain:2\nx:\n";  // with values they are siblings: no nesting
  for (int i = 0; i < 100; ++i) siblings += "  : " + std::to_string(i) + "\n";
  EXPECT_EQ(error_of<SceneError>([&] { parse_scene(siblings, kScenes, "s.yaml"); }).find("nested"),
            std::string::npos);
  // Nesting inside quotes, comments and block scalars is text.
  const std::string text =
      "robot: chain:2\nname: '[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[['\n"
      "# [[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[\n";
  EXPECT_NO_THROW(parse_scene(text, kScenes, "q.yaml"));
}

// The old reader's duplicate-key checks and continuation lines were quadratic: a 10 MB scene
// ran past two minutes. Now a scene is at most 1 MiB and 100,000 items, refused at once beyond.
TEST(SceneLimits, SizeAndItemsAreBounded) {
  std::string huge = "robot: chain:2\ninitial_positions:\n";
  while (huge.size() < 10u << 20) huge += "  j" + std::to_string(huge.size()) + ": 0.5\n";
  EXPECT_NE(error_of<SceneError>([&] {
              parse_scene(huge, kScenes, "huge.yaml");
            }).find("bytes, more than the 1048576 a scene may have"),
            std::string::npos);
  const std::string path = temp_file("huge.yaml", huge);
  EXPECT_NE(error_of<SceneError>([&] { load_scene(path); }).find("bytes"), std::string::npos);
  std::remove(path.c_str());
  // Many short items under the size limit.
  std::string items = "robot: chain:2\ngravity: [";
  while (items.size() < 900000) items += "1,";
  items += "1]\n";
  EXPECT_NE(error_of<SceneError>([&] {
              parse_scene(items, kScenes, "items.yaml");
            }).find("more than 100000 keys, values and list items"),
            std::string::npos);
  // Within the limits, a long scene reads as written: 20,000 keys (quadratic before).
  const int n = 20000;
  std::string keys = "robot: chain:3\ninitial_positions:\n";
  for (int i = 0; i < n; ++i) keys += "  j" + std::to_string(i) + ": " + std::to_string(i) + "\n";
  const Scene s = parse_scene(keys, kScenes, "keys.yaml");
  ASSERT_EQ(s.initial_positions.size(), static_cast<size_t>(n));
  EXPECT_EQ(s.initial_positions[n - 1].first, "j" + std::to_string(n - 1));
  EXPECT_EQ(s.initial_positions[n - 1].second, n - 1);
  // ... and the joints the chain lacks are named.
  const Model m = scene_model(s);
  EXPECT_NE(error_of<SceneError>([&] { scene_state(s, m); })
                .find("keys.yaml: initial_positions "
                      "names joint 'j0'"),
            std::string::npos);
}

// yaml-cpp 0.7's LoadAll returns an empty document forever from a text that starts with ','
// (found by fuzz_scene); YAML::Load reads it as an empty scene. Both are refused with the line.
TEST(SceneLimits, AStrayCommaIsAnErrorNotAHangOrAnEmptyScene) {
  EXPECT_EXIT(
      {
        alarm(20);  // a hang ends the child, and the test fails
        exit_with_error_containing([] { parse_scene(",", kScenes, "comma.yaml"); },
                                   "comma.yaml:1: ',' cannot start a YAML document");
      },
      ::testing::ExitedWithCode(0), "");
  EXPECT_NE(error_of<SceneError>([] {
              parse_scene("robot: chain:2\n, a\n", kScenes, "c.yaml");
            }).find("c.yaml:2:"),
            std::string::npos);
}

TEST(SceneLimits, ControlCharactersAreNotText) {
  const std::string err = error_of<SceneError>(
      [&] { parse_scene(std::string("robot: chain:2\nname: a\0b\n", 24), kScenes, "n.yaml"); });
  EXPECT_NE(err.find("n.yaml:2: control character 0"), std::string::npos) << err;
}

// Three shipped scenes failed to load when saved with Windows line endings.
TEST(SceneCrlf, EveryShippedSceneLoadsTheSameWithCrlf) {
  for (const char* name : {"satellite_arm", "fixed_panda", "fixed_arm", "chain20", "pendulum",
                           "fourbar", "pinned_chain", "quadruped_ground"}) {
    SCOPED_TRACE(name);
    const std::string lf = read(kScenes + name + ".yaml");
    std::string crlf;
    for (const char c : lf) {
      if (c == '\n') crlf += '\r';
      crlf += c;
    }
    const Scene a = parse_scene(lf, kScenes, name);
    const Scene b = parse_scene(crlf, kScenes, name);
    EXPECT_EQ(a.name, b.name);
    EXPECT_EQ(a.robot_path, b.robot_path);
    EXPECT_EQ(a.integrator, b.integrator);
    EXPECT_EQ(a.dt, b.dt);
    EXPECT_EQ(a.gravity, b.gravity);
    EXPECT_EQ(a.initial_positions, b.initial_positions);
    EXPECT_EQ(a.initial_velocities, b.initial_velocities);
    EXPECT_EQ(a.locked_joints, b.locked_joints);
    EXPECT_EQ(a.constraints.bilateral.size(), b.constraints.bilateral.size());
    EXPECT_EQ(a.constraints.contacts.size(), b.constraints.contacts.size());
    EXPECT_TRUE(a.base_pose.isApprox(b.base_pose, 0));
    // Old Mac line ends (CR alone) too.
    std::string cr = lf;
    for (char& c : cr) {
      if (c == '\n') c = '\r';
    }
    EXPECT_EQ(parse_scene(cr, kScenes, name).initial_positions, a.initial_positions);
  }
}

// ---------------------------------------------------------------- bounded work
// `--dt 1e-300` asked for 5e298 steps: the run never ended.
TEST(BoundedWork, AbsurdStepCountsAreRefusedBeforeTheRun) {
  SimulateOptions o;
  o.model = "chain:2";
  o.duration = 1.0;
  o.dt = 1e-300;
  EXPECT_NE(error_of<std::invalid_argument>([&] { simulate_headless(o); }).find("1e-9 s"),
            std::string::npos);
  o.dt = 1e-9;
  o.duration = 1e3;
  EXPECT_NE(error_of<std::invalid_argument>([&] {
              simulate_headless(o);
            }).find("asks for 1e+12 steps, more than the 1e+08"),
            std::string::npos);
  // Steps times bodies: refused before the model's workspace is allocated.
  o.model = "chain:100000";
  o.dt = 1e-3;
  o.duration = 1e3;
  EXPECT_NE(error_of<std::invalid_argument>([&] { simulate_headless(o); }).find("body-steps"),
            std::string::npos);
  o.model = "chain:100001";
  EXPECT_NE(error_of<std::invalid_argument>([&] { simulate_headless(o); }).find("100000"),
            std::string::npos);
  // An adaptive stepper's internal steps count too: a run that needs many per step stops at
  // the limit (here lowered) and says so.
  SimulateOptions a;
  a.model = "chain:3";
  a.integrator = "rkmk45";
  a.tol = 1e-12;
  a.dt = 0.1;
  a.duration = 10;
  a.max_body_steps = 2000;
  const SimulateResult stopped = simulate_headless(a);
  EXPECT_TRUE(stopped.stopped);
  EXPECT_FALSE(stopped.diverged);
  EXPECT_LT(stopped.sim_s, 10.0);
  EXPECT_NE(stopped.status.find("internal steps of 4 bodies passed the 2e+03 body-steps"),
            std::string::npos)
      << stopped.status;
  EXPECT_NE(simulate_result_json(stopped).find("\"status\": \"stopped at t = "), std::string::npos);
  // The same dt in a scene.
  EXPECT_NE(error_of<SceneError>([&] {
              parse_scene("dt: 1e-300\n", kScenes, "dt.yaml");
            }).find("dt.yaml:1: 'dt' is below the smallest step"),
            std::string::npos);
  // A scene value that would overflow an int.
  EXPECT_NE(error_of<SceneError>([&] {
              parse_scene("constraint_options: {pgs_iterations: 1e300}\n", kScenes, "i.yaml");
            }).find("whole number"),
            std::string::npos);
}

// ---------------------------------------------------------------- se3_dyn: silent failures
// A diverged `simulate` exited 1 with nothing on stderr and nothing in --json.
TEST(Se3DynSilent, ADivergedRunSaysSoOnStderrAndInJson) {
  const std::string scene = temp_file("diverge.yaml",
                                      "robot: chain:3\nbase: fixed\n"
                                      "initial_velocities: {j1: 20000, j2: -20000}\n");
  const RunResult r = se3_dyn("simulate --scene " + scene + " --duration 1 --json");
  EXPECT_EQ(r.code, 1);
  EXPECT_NE(r.err.find("se3_dyn: the run diverged at t = "), std::string::npos) << r.err;
  EXPECT_NE(r.out.find("\"diverged\": true"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("\"status\": \""), std::string::npos) << r.out;
  const RunResult ok = se3_dyn("simulate chain:3 --duration 0.01 --json");
  EXPECT_EQ(ok.code, 0) << ok.err;
  EXPECT_NE(ok.out.find("\"diverged\": false, \"status\": null"), std::string::npos) << ok.out;
}

// Issue 35: a scene of objects alone renders them (it read the URDF file ''), and a shipped
// scene's relative energy drift is not divided by a vanishing T(0) (3.9e12 on solo12_meshes,
// 5.7e13 on a UR5); self-contacts count in penetration_max (it was null).
TEST(Se3DynSilent, RobotlessSceneRendersAndDriftHasASaneScale) {
  const std::string png = testing::TempDir() + "/objects_only.png";
  std::remove(png.c_str());
  const RunResult render =
      se3_dyn("render --scene " + kSource + "/config/scenes/ball_on_table.yaml --out " + png);
  EXPECT_EQ(render.code, 0) << render.err;
  EXPECT_EQ(render.err.find("URDF"), std::string::npos) << render.err;
  EXPECT_FALSE(read(png).empty());
  std::remove(png.c_str());
  const RunResult ur5 = se3_dyn("simulate --scene " + kSource +
                                "/config/scenes/ur5_self_collision.yaml --duration 0.05 --json");
  ASSERT_EQ(ur5.code, 0) << ur5.err;
  const auto value = [](const std::string& json, const std::string& key) {
    const size_t at = json.find("\"" + key + "\": ");
    return at == std::string::npos ? std::nan("")
                                   : std::strtod(json.c_str() + at + key.size() + 4, nullptr);
  };
  EXPECT_LT(value(ur5.out, "energy_drift_rel"), 1.0) << ur5.out;
  EXPECT_GE(value(ur5.out, "penetration_max"), 0.0) << ur5.out;  // not null
}

// A free object whose inertia underflows (a 1e-300 m box) is an error naming the scene line
// and the object (it was "link 'speck': a free-floating base ..."), with numbers as %g.
TEST(Se3DynSilent, SingularObjectIsNamedWithItsLine) {
  const std::string scene =
      temp_file("speck.yaml",
                "ground: true\nobjects:\n"
                "  - {name: speck, shape: {box: [1e-300, 1e-300, 1e-300]}, mass: 1}\n");
  const RunResult r = se3_dyn("simulate --scene " + scene + " --duration 0.01");
  EXPECT_EQ(r.code, 1);
  EXPECT_NE(r.err.find("speck.yaml:3: "), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("object 'speck'"), std::string::npos) << r.err;
  EXPECT_EQ(r.err.find("link"), std::string::npos) << r.err;
  EXPECT_LT(r.err.size(), 400u) << r.err;
}

// `eval` printed NaN with exit code 0 when finite inputs overflowed (v = 1e200).
TEST(Se3DynSilent, EvalRefusesResultsThatOverflow) {
  const std::string urdf = kSource + "/data/robots/double_pendulum_simple.urdf";
  const std::string header = "q:joint1,q:joint2,v:joint1,v:joint2,tau:joint1,tau:joint2\n";
  const RunResult r = se3_dyn("eval " + urdf + " --algo aba", header + "0,0,1e200,1e200,0,0\n");
  EXPECT_EQ(r.code, 1);
  EXPECT_NE(r.err.find("line 2: a:joint1 is not finite"), std::string::npos) << r.err;
  EXPECT_EQ(r.out, "");
  const RunResult ok = se3_dyn("eval " + urdf + " --algo aba", header + "0,0,1,1,0,0\n");
  EXPECT_EQ(ok.code, 0) << ok.err;
  EXPECT_EQ(ok.out.find("nan"), std::string::npos);
}

TEST(Se3DynLimits, SizesBeyondTheLimitsAreRefusedWithTheLimit) {
  const RunResult chain = se3_dyn("info chain:100001");
  EXPECT_EQ(chain.code, 1);
  EXPECT_NE(chain.err.find("chain:N needs 1 <= N <= 100000"), std::string::npos) << chain.err;
  const RunResult dense = se3_dyn("eval chain:3000 --algo crba", "q:j1\n");
  EXPECT_EQ(dense.code, 1);
  EXPECT_NE(dense.err.find("more than the 2000"), std::string::npos) << dense.err;
  const RunResult steps = se3_dyn("simulate chain:2 --dt 1e-300 --duration 1");
  EXPECT_EQ(steps.code, 1);
  EXPECT_NE(steps.err.find("smallest step"), std::string::npos) << steps.err;
  // Out of memory is a sentence, not std::bad_alloc or an abort: under a 1 GB address-space
  // limit, a 30,000-body chain either runs or says it does not fit. (Not under ASan, whose
  // shadow memory needs terabytes of address space.)
#if defined(__SANITIZE_ADDRESS__)
  GTEST_SKIP() << "address-space limit and AddressSanitizer do not mix";
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
  GTEST_SKIP() << "address-space limit and AddressSanitizer do not mix";
#endif
#endif
  const std::string cmd = "ulimit -v 1000000; " + kSe3Dyn +
                          " simulate chain:30000 --duration 0.002 --dt 0.001 > /dev/null 2> " +
                          temp_file("oom.txt", "");
  const int status = std::system(("bash -c '" + cmd + "'").c_str());
  ASSERT_TRUE(WIFEXITED(status));
  const int code = WEXITSTATUS(status);
  const std::string err = read(temp_file_name("oom.txt"));
  EXPECT_TRUE(code == 0 || (code == 1 && err.find("se3_dyn: out of memory") == 0))
      << "exit " << code << ": " << err;
}

// The scene reader's text bound counts a '[' or '{' inside a block plain scalar as text, as YAML
// does: in `positio["n: [...]` it is the key's, and the '"' after it opens no quoted scalar that
// would hide the rest of the file from the count (fuzz_scene found it: 17 items counted where
// yaml-cpp builds 39 nodes; the fuzz check allows a factor of two).
TEST(Robustness, SceneTextBoundReadsBracketsInPlainScalarsAsText) {
  std::ifstream in(se3_sim_test::source_dir() +
                   "/fuzz/corpus/scene/bracket_quote_in_plain_key.yaml");
  std::stringstream text;
  text << in.rdbuf();
  ASSERT_GT(text.str().size(), 100u);
  const se3::SceneTextShape shape = se3::scene_text_shape(text.str());
  EXPECT_GE(2 * shape.items + 2, 39u);
  EXPECT_GE(shape.depth, 2);
}

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  // Death tests fork; "threadsafe" re-runs the binary for each, so the children start clean.
  testing::FLAGS_gtest_death_test_style = "threadsafe";
  return RUN_ALL_TESTS();
}

// ---------------------------------------------------------------- files, meshes, URDF paths
namespace {

// A robot whose URDF puts printf conversions in a material's rgba (urdfdom quotes the value in
// a complaint); the link has a visual using it and a box collision.
std::string percent_rgba_urdf() {
  return "<robot name=\"r\"><material name=\"m\"><color rgba=\"%s%n%x%s%n%p%n\"/></material>"
         "<link name=\"a\"><inertial><mass value=\"1\"/><inertia ixx=\"1\" iyy=\"1\" izz=\"1\" "
         "ixy=\"0\" ixz=\"0\" iyz=\"0\"/></inertial><visual><geometry><box size=\"0.1 0.1 "
         "0.1\"/></geometry><material name=\"m\"/></visual><collision><geometry><box "
         "size=\"0.1 0.1 0.1\"/></geometry></collision></link></robot>";
}

// A scene of `robot` (a file) with a free base over the ground, contact from its collisions.
std::string contact_scene(const std::string& robot) {
  return "robot: " + robot +
         "\nbase: free\nbase_pose: {position: [0, 0, 0.3], orientation: [0, 0, 0, 1]}\n"
         "integrator: contact_semi_implicit\ndt: 0.001\n"
         "ground: {normal: [0, 0, 1], offset: 0.0, mu: 0.8, from_collisions: true}\n";
}

// A fresh folder of this test process under the temporary folder.
std::string temp_dir(const std::string& name) {
  const std::string d = temp_file_name(name);
  std::system(("rm -rf '" + d + "' && mkdir -p '" + d + "'").c_str());
  return d;
}

}  // namespace

// The geometry once parsed the URDF a second time under its own console handler, which let
// console_bridge format urdfdom's messages: the "%n" rgba that the model path warns about
// crashed `se3_dyn render` (rc 139), the renderer node and every contact scene. One guarded
// parse now feeds both.
TEST(UrdfFormatString, PercentRgbaOnTheGeometryRenderAndContactPaths) {
  const std::string xml = percent_rgba_urdf();
  EXPECT_EXIT(
      {
        const UrdfDocument doc = parse_urdf_document(xml);
        const Model m = model_from_urdf(doc);
        const GeometryModel a = geometry_from_urdf(m, doc);
        const GeometryModel b = geometry_from_urdf_string(m, xml);
        std::exit(a.visuals.size() == 1 && b.visuals.size() == 1 && a.collisions.size() == 1 ? 0
                                                                                             : 2);
      },
      ::testing::ExitedWithCode(0), "");
  const std::string urdf = temp_file("percent.urdf", xml);
  const RunResult info = se3_dyn("info " + urdf);
  EXPECT_EQ(info.code, 0) << info.err;
  const RunResult render = se3_dyn("render " + urdf + " --out " + temp_file_name("percent.png"));
  EXPECT_EQ(render.code, 0) << render.err;
  const std::string scene = temp_file("percent_scene.yaml", contact_scene(urdf));
  EXPECT_EXIT(
      {
        auto sim = make_simulator(load_scene(scene));
        sim->step();
        std::exit(0);
      },
      ::testing::ExitedWithCode(0), "");
  const RunResult sim = se3_dyn("simulate --scene " + scene + " --duration 0.01");
  EXPECT_EQ(sim.code, 0) << sim.err;
}

// A FIFO or a device where a file is expected blocked the reader forever (a FIFO's open waits
// for a writer): every outside file is opened only when it is a regular file, and the error
// says what it is. Each load runs in a child that an alarm ends, so a regression fails, not
// hangs.
TEST(SpecialFiles, UrdfSceneAndMeshPathsThatAreNotRegularFilesAreNamed) {
  const std::string dir = temp_dir("special");
  const std::string fifo = dir + "/robot.urdf";
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  const std::string mesh_fifo = dir + "/mesh.stl";
  ASSERT_EQ(::mkfifo(mesh_fifo.c_str(), 0600), 0);
  struct Case {
    std::function<void()> load;
    std::string expect;
  };
  const Case cases[] = {
      {[&] { model_from_urdf_file(fifo); }, "cannot read URDF file '" + fifo + "': a FIFO"},
      {[&] { model_from_urdf_file(dir); }, "'" + dir + "': a directory"},
      {[&] { model_from_urdf_file("/dev/null"); }, "'/dev/null': a character device"},
      {[&] { model_from_urdf_file(dir + "/none.urdf"); }, "none.urdf': not found"},
      {[&] { load_scene(fifo); }, "cannot read scene file '" + fifo + "': a FIFO"},
      {[&] {
         Shape s;
         std::string err;
         if (!load_mesh_shape(mesh_fifo, Vec3::Ones(), nullptr, s, &err)) throw ModelError(err);
       },
       "'" + mesh_fifo + "' is a FIFO"},
      {[&] {
         Shape s;
         std::string err;
         if (!load_mesh_shape(dir, Vec3::Ones(), nullptr, s, &err)) throw ModelError(err);
       },
       "'" + dir + "' is a directory"},
      {[&] {
         std::string err;
         MeshLimits lim;
         lim.isolate = false;
         if (!load_mesh(mesh_fifo, &err, lim)) throw ModelError(err);
       },
       "'" + mesh_fifo + "': a FIFO"},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.expect);
    EXPECT_EXIT(
        {
          ::alarm(10);
          exit_with_error_containing(c.load, c.expect);
        },
        ::testing::ExitedWithCode(0), "");
  }
  const RunResult info = se3_dyn("info " + fifo);
  EXPECT_EQ(info.code, 1);
  EXPECT_NE(info.err.find(fifo + "': a FIFO"), std::string::npos) << info.err;
}

// An OBJ's material file that is a FIFO blocked the mesh child for its 60 s; one outside the
// mesh's folder (mtllib ../../etc/...) was read. Assimp now reads through an IOSystem that
// opens only regular files in the mesh's folder tree: the mesh loads with its default
// material and a warning naming the file.
TEST(SpecialFiles, ObjMaterialFilesAreRegularFilesBesideTheMesh) {
  const std::string dir = temp_dir("mtl");
  const std::string fifo = dir + "/fifo.mtl";
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  const std::string tri = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";
  std::ofstream(dir + "/a.obj") << "mtllib fifo.mtl\n" << tri;
  std::ofstream(dir + "/b.obj") << "mtllib ../../../../../../../../etc/hostname\n" << tri;
  for (const auto& [file, expect] :
       {std::pair<std::string, std::string>{dir + "/a.obj", fifo + "': a FIFO"},
        {dir + "/b.obj", "outside the mesh's folder"}}) {
    SCOPED_TRACE(file);
    MeshLimits lim;
    lim.seconds = 20;
    std::string err;
    const auto mesh = load_mesh(file, &err, lim);
    ASSERT_TRUE(mesh) << err;
    EXPECT_EQ(mesh->triangle_count(), 1u);
    EXPECT_NE(mesh->warning.find(expect), std::string::npos) << mesh->warning;
  }
}

// 30,000 copies of one triangle (240 kB) took 50-60 s: assimp's smoothing and vertex joining
// look, for every vertex, at every vertex at its position. Repeated and degenerate faces are
// dropped first, in linear time, and the smoothing's work is bounded (a fan of 30,000
// distinct triangles around one vertex keeps one normal a face), each with a warning.
TEST(DegenerateMeshes, RepeatedFacesAreDroppedAndSmoothingIsBounded) {
  std::string dup = "v 0 0 0\nv 1 0 0\nv 0 1 0\n";
  for (int i = 0; i < 30000; ++i) dup += "f 1 2 3\n";
  dup += "f 1 1 2\n";  // degenerate
  std::string err;
  const auto m = decode_mesh(dup.data(), dup.size(), "obj", {}, &err);
  ASSERT_TRUE(m) << err;
  EXPECT_EQ(m->triangle_count(), 1u);
  EXPECT_EQ(m->positions.size(), 3u);
  EXPECT_NE(m->warning.find("29999 duplicate faces dropped"), std::string::npos) << m->warning;
  EXPECT_NE(m->warning.find("1 degenerate faces dropped"), std::string::npos) << m->warning;
  // A reversed copy is a back face, not a duplicate; a rotated one is the same face.
  std::string two = "v 0 0 0\nv 1 0 0\nv 0 1 0\n";
  for (int i = 0; i < 10000; ++i) two += "f 1 2 3\nf 3 2 1\nf 2 3 1\n";
  const auto t = decode_mesh(two.data(), two.size(), "obj", {}, &err);
  ASSERT_TRUE(t) << err;
  EXPECT_EQ(t->triangle_count(), 2u);

  std::string fan = "v 0 0 0\n";
  const int n = 30000;
  for (int i = 0; i <= n; ++i) {
    const double a = 2 * M_PI * i / n;
    fan += "v " + std::to_string(std::cos(a)) + " " + std::to_string(std::sin(a)) + " 0\n";
  }
  for (int i = 0; i < n; ++i) {
    fan += "f 1 " + std::to_string(i + 2) + " " + std::to_string(i + 3) + "\n";
  }
  const auto f = decode_mesh(fan.data(), fan.size(), "obj", {}, &err);
  ASSERT_TRUE(f) << err;
  EXPECT_GT(f->triangle_count(), std::size_t(n) - 100);  // a few rounded to degenerate
  EXPECT_NE(f->warning.find("normals not smoothed"), std::string::npos) << f->warning;
  for (const Vec3f& nrm : f->normals) EXPECT_NEAR(std::abs(nrm.z()), 1.0f, 1e-4f);
  // Below the bound the smoothing runs as before: no warning on a shipped mesh.
  const std::string stl =
      read(kSource +
           "/data/meshes/example-robot-data/robots/panda_description/meshes/collision/link4.stl");
  if (!stl.empty()) {
    const auto c = decode_mesh(stl.data(), stl.size(), "stl", {}, &err);
    ASSERT_TRUE(c) << err;
    EXPECT_EQ(c->warning, "");
  }
}

// A collision mesh that cannot be found said "collision object 'base_0': a mesh without
// triangles"; a robot file that is not a URDF said "Error document empty." without the file.
TEST(FileMessages, MissingCollisionMeshAndNonUrdfFileNameTheFile) {
  const std::string urdf = temp_file(
      "missing_mesh.urdf",
      "<robot name=\"r\"><link name=\"base\"><inertial><mass value=\"1\"/><inertia ixx=\"1\" "
      "iyy=\"1\" izz=\"1\" ixy=\"0\" ixz=\"0\" iyz=\"0\"/></inertial><collision><geometry><mesh "
      "filename=\"no_such_mesh.stl\"/></geometry></collision></link></robot>");
  const std::string scene = temp_file("missing_mesh.yaml", contact_scene(urdf));
  const std::string err = error_of<SceneError>([&] { make_simulator(load_scene(scene)); });
  EXPECT_NE(err.find("link 'base'"), std::string::npos) << err;
  EXPECT_NE(err.find("no_such_mesh.stl"), std::string::npos) << err;
  EXPECT_NE(err.find("not found"), std::string::npos) << err;
  const std::string passwd = temp_file("passwd", "root:x:0:0:root:/root:/bin/bash\n");
  const std::string not_urdf = error_of<ModelError>([&] { model_from_urdf_file(passwd); });
  EXPECT_NE(not_urdf.find("URDF file '" + passwd + "'"), std::string::npos) << not_urdf;
}

// package://PKG/../../ resolved outside the package; a mesh path that is a directory, FIFO or
// device was "not found". Both name what they are.
TEST(ResourceNames, PackageNamesStayInTheirPackageAndPathsSayWhatTheyAre) {
  const std::string root = temp_dir("pkgs");
  std::system(("mkdir -p '" + root + "/esc_pkg/meshes/dir.stl'").c_str());
  std::ofstream(root + "/esc_pkg/package.xml") << "<package><name>esc_pkg</name></package>";
  std::ofstream(root + "/esc_pkg/meshes/a.stl") << "solid a\nendsolid a\n";
  std::ofstream(root + "/outside.stl") << "solid a\nendsolid a\n";
  ResourcePaths paths;
  paths.package_path = {root};
  paths.use_ros_package_path = false;
  std::string err;
  EXPECT_EQ(resolve_resource("package://esc_pkg/meshes/../meshes/a.stl", paths, &err),
            root + "/esc_pkg/meshes/a.stl")
      << err;
  for (const std::string uri :
       {"package://esc_pkg/../outside.stl", "package://esc_pkg/meshes/../../outside.stl",
        "package://esc_pkg/../../../../../../etc/hostname"}) {
    err.clear();
    EXPECT_EQ(resolve_resource(uri, paths, &err), "") << uri;
    EXPECT_NE(err.find("leaves its package folder"), std::string::npos) << err;
  }
  err.clear();
  EXPECT_EQ(resolve_resource("package://esc_pkg/meshes/dir.stl", paths, &err), "");
  EXPECT_NE(err.find("is a directory"), std::string::npos) << err;
  err.clear();
  EXPECT_EQ(resolve_resource("/dev/zero", paths, &err), "");
  EXPECT_NE(err.find("'/dev/zero' is a character device"), std::string::npos) << err;
  EXPECT_TRUE(is_mesh_file_type("a.STL") && is_mesh_file_type("package://p/m.dae") &&
              is_mesh_file_type("x.obj"));
  EXPECT_FALSE(is_mesh_file_type("/etc/shadow") || is_mesh_file_type("package.xml.bak") ||
               is_mesh_file_type("a.urdf"));
}
