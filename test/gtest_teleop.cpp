// Teleop library: the input decoder on recorded terminal byte sequences, and the controller
// (joint selection, torque sign, clamping, mouse gestures, camera commands, dead-man with an
// injected clock).
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include "se3_sim/model/model.h"
#include "se3_sim/teleop/teleop.h"

using namespace se3::teleop;

namespace {

std::vector<Event> decode(const std::string& bytes) {
  InputDecoder d;
  return d.feed(bytes);
}

/// Decodes `bytes` one byte at a time (every split point).
std::vector<Event> decode_bytewise(const std::string& bytes) {
  InputDecoder d;
  std::vector<Event> out;
  for (char c : bytes) d.feed(std::string_view(&c, 1), out);
  return out;
}

/// A compact text form of events, to compare whole sequences at once.
std::string show(const std::vector<Event>& evs) {
  std::string s;
  for (const auto& e : evs) {
    if (!s.empty()) s += ' ';
    if (e.type == Event::Type::Key) {
      switch (e.key.code) {
        case KeyCode::Char:
          s += std::string("'") + e.key.ch + "'";
          break;
        case KeyCode::Control:
          s += "^" + std::to_string(static_cast<int>(e.key.ch));
          break;
        case KeyCode::Tab:
          s += "Tab";
          break;
        case KeyCode::BackTab:
          s += "BackTab";
          break;
        case KeyCode::Enter:
          s += "Enter";
          break;
        case KeyCode::Backspace:
          s += "BS";
          break;
        case KeyCode::Escape:
          s += "Esc";
          break;
        case KeyCode::Up:
          s += "Up";
          break;
        case KeyCode::Down:
          s += "Down";
          break;
        case KeyCode::Right:
          s += "Right";
          break;
        case KeyCode::Left:
          s += "Left";
          break;
      }
    } else {
      const auto& m = e.mouse;
      static const char* actions[] = {"press",     "release",   "motion",    "wheelup",
                                      "wheeldown", "wheelleft", "wheelright"};
      static const char* buttons[] = {"L", "M", "R", "-"};
      s += std::string(actions[static_cast<int>(m.action)]) + ":" +
           buttons[static_cast<int>(m.button)] + "@" + std::to_string(m.x) + "," +
           std::to_string(m.y);
      if (m.shift) s += "+S";
      if (m.alt) s += "+A";
      if (m.ctrl) s += "+C";
    }
  }
  return s;
}

void expect_decodes(const std::string& bytes, const std::string& expected) {
  EXPECT_EQ(show(decode(bytes)), expected) << "whole";
  EXPECT_EQ(show(decode_bytewise(bytes)), expected) << "byte by byte";
  // Every split into two chunks.
  for (std::size_t k = 1; k < bytes.size(); ++k) {
    InputDecoder d;
    std::vector<Event> out;
    d.feed(bytes.substr(0, k), out);
    d.feed(bytes.substr(k), out);
    EXPECT_EQ(show(out), expected) << "split at " << k;
  }
}

}  // namespace

// ----------------------------------------------------------------------------------- decoder

TEST(TeleopDecoder, PrintableAndControlKeys) {
  expect_decodes("12+-= q", "'1' '2' '+' '-' '=' ' ' 'q'");
  expect_decodes("\t\r\n\x7f\x08", "Tab Enter Enter BS BS");
  expect_decodes("\x03\x04", "^3 ^4");
}

TEST(TeleopDecoder, ArrowsInBothCursorModes) {
  expect_decodes("\x1b[A\x1b[B\x1b[C\x1b[D", "Up Down Right Left");
  expect_decodes("\x1bOA\x1bOB\x1bOC\x1bOD", "Up Down Right Left");
  expect_decodes("\x1b[1;2A\x1b[1;5D", "Up Left");  // with Shift / Ctrl modifiers
  expect_decodes("\x1b[Z", "BackTab");
}

TEST(TeleopDecoder, SgrMousePressDragReleaseWheel) {
  // Recorded from xterm with ?1002h ?1006h: left press at column 10 row 5, drag right by two
  // cells, release; then wheel up and down; right button press/drag/release.
  expect_decodes("\x1b[<0;10;5M\x1b[<32;11;5M\x1b[<32;12;5M\x1b[<0;12;5m",
                 "press:L@10,5 motion:L@11,5 motion:L@12,5 release:L@12,5");
  expect_decodes("\x1b[<64;3;4M\x1b[<65;3;4M", "wheelup:-@3,4 wheeldown:-@3,4");
  expect_decodes("\x1b[<2;100;40M\x1b[<34;101;39M\x1b[<2;101;39m",
                 "press:R@100,40 motion:R@101,39 release:R@101,39");
  expect_decodes("\x1b[<1;7;8M\x1b[<1;7;8m", "press:M@7,8 release:M@7,8");
  // Modifiers: shift 4, meta 8, ctrl 16.
  expect_decodes("\x1b[<4;1;1M\x1b[<24;1;1M", "press:L@1,1+S press:L@1,1+A+C");
  // Large coordinates (SGR has no 223-column limit).
  expect_decodes("\x1b[<0;300;250M", "press:L@300,250");
}

TEST(TeleopDecoder, LegacyX10Mouse) {
  // ESC [ M Cb Cx Cy, each value + 32: press left at (10, 5), release (code 3).
  const std::string press = std::string("\x1b[M") + char(32 + 0) + char(32 + 10) + char(32 + 5);
  const std::string drag = std::string("\x1b[M") + char(32 + 32) + char(32 + 12) + char(32 + 5);
  const std::string release = std::string("\x1b[M") + char(32 + 3) + char(32 + 12) + char(32 + 5);
  expect_decodes(press + drag + release + "q", "press:L@10,5 motion:L@12,5 release:L@12,5 'q'");
}

TEST(TeleopDecoder, GarbageIsIgnoredWithoutLosingWhatFollows) {
  // Unknown but well-formed sequences are swallowed whole.
  expect_decodes("\x1b[15~1\x1b[?25h2\x1bOP3\x1b[I\x1b[O4", "'1' '2' '3' '4'");
  // A broken SGR report (bad field count, zero column) is dropped.
  expect_decodes("\x1b[<0;10M+\x1b[<0;0;5M-\x1b[<0;1;1;1M=", "'+' '-' '='");
  // A sequence cut by a control byte: the byte is decoded afresh.
  expect_decodes("\x1b[12\t+", "Tab '+'");
  // ... or by a new escape sequence.
  expect_decodes("\x1b[<0;1\x1b[A", "Up");
  expect_decodes("\x1b[\x1b[<64;1;1M", "wheelup:-@1,1");
  // High bytes (UTF-8 text) are dropped.
  expect_decodes("\xc3\xa9+", "'+'");
  // An over-long parameter string is consumed to its final byte and ignored.
  expect_decodes("\x1b[" + std::string(200, '9') + "A-", "'-'");
  // ESC followed by an unrelated byte: a lone Escape, then the byte.
  expect_decodes("\x1bq", "Esc 'q'");
  expect_decodes("\x1b\x1b[B", "Esc Down");
}

TEST(TeleopDecoder, LoneEscapeIsPendingUntilFlushed) {
  InputDecoder d;
  std::vector<Event> out;
  d.feed("\x1b", out);
  EXPECT_TRUE(out.empty());
  EXPECT_TRUE(d.pending());
  EXPECT_TRUE(d.lone_escape());
  d.flush(out);
  EXPECT_EQ(show(out), "Esc");
  EXPECT_FALSE(d.pending());
  out.clear();
  d.feed("\x1b[<0;1", out);
  EXPECT_TRUE(d.pending());
  EXPECT_FALSE(d.lone_escape());
  d.flush(out);  // an incomplete sequence is dropped
  EXPECT_TRUE(out.empty());
  d.feed("+", out);
  EXPECT_EQ(show(out), "'+'");
}

TEST(TeleopDecoder, MouseCodeTable) {
  EXPECT_EQ(decode_mouse_code(0, 1, 1, false).button, MouseButton::Left);
  EXPECT_EQ(decode_mouse_code(1, 1, 1, false).button, MouseButton::Middle);
  EXPECT_EQ(decode_mouse_code(2, 1, 1, false).button, MouseButton::Right);
  EXPECT_EQ(decode_mouse_code(35, 1, 1, false).action, MouseAction::Motion);
  EXPECT_EQ(decode_mouse_code(35, 1, 1, false).button, MouseButton::None);
  EXPECT_EQ(decode_mouse_code(64, 1, 1, false).action, MouseAction::WheelUp);
  EXPECT_EQ(decode_mouse_code(65, 1, 1, false).action, MouseAction::WheelDown);
  EXPECT_EQ(decode_mouse_code(66, 1, 1, false).action, MouseAction::WheelLeft);
  EXPECT_EQ(decode_mouse_code(67, 1, 1, false).action, MouseAction::WheelRight);
  EXPECT_EQ(decode_mouse_code(0, 1, 1, true).action, MouseAction::Release);
}

// -------------------------------------------------------------------------------- controller

namespace {

std::vector<JointInfo> three_joints() {
  return {{"a", 87.0, true}, {"b", 12.0, true}, {"c", 5.0, true}};
}

/// Feeds raw terminal bytes at time t.
void type(Controller& c, InputDecoder& d, const std::string& bytes, double t) {
  c.handle(d.feed(bytes), t);
}

}  // namespace

TEST(TeleopController, JointsFromModel) {
  se3::Model m;
  m.n = 3;
  m.joint_name = {"", "j1", "j2", "j3"};
  m.effort = {0.0, 50.0, std::numeric_limits<double>::infinity(), 0.0};
  const auto j = joints_from_model(m, 7.5);
  ASSERT_EQ(j.size(), 3u);
  EXPECT_EQ(j[0].name, "j1");
  EXPECT_DOUBLE_EQ(j[0].limit, 50.0);
  EXPECT_TRUE(j[0].from_urdf);
  EXPECT_DOUBLE_EQ(j[1].limit, 7.5);  // inf: no limit given
  EXPECT_FALSE(j[1].from_urdf);
  EXPECT_DOUBLE_EQ(j[2].limit, 7.5);  // zero: treated as none
  EXPECT_THROW(joints_from_model(m, 0.0), std::invalid_argument);
}

TEST(TeleopController, DigitsSelectAndPlusMinusActOnTheSelectedJoint) {
  Params p;
  p.step = 0.25;  // a quarter of each joint's limit: a 21.75, b 3, c 1.25
  Controller c(three_joints(), p);
  InputDecoder d;
  EXPECT_EQ(c.selected(), 0);
  type(c, d, "2+++", 0.0);
  EXPECT_EQ(c.selected(), 1);
  EXPECT_EQ(c.torques(), (std::vector<double>{0, 9, 0}));
  type(c, d, "1-", 0.1);
  EXPECT_EQ(c.torques(), (std::vector<double>{-21.75, 9, 0}));
  type(c, d, "=", 0.2);  // '=' raises too (unshifted '+')
  EXPECT_EQ(c.torques(), (std::vector<double>{0, 9, 0}));
  type(c, d, "9", 0.3);  // no joint 9: selection unchanged
  EXPECT_EQ(c.selected(), 0);
  type(c, d, "3-\x7f", 0.4);  // Backspace zeroes the selected joint
  EXPECT_EQ(c.torques(), (std::vector<double>{0, 9, 0}));
  type(c, d, " ", 0.5);  // space zeroes all
  EXPECT_EQ(c.torques(), (std::vector<double>{0, 0, 0}));
}

TEST(TeleopController, TabAndArrowsWrapAround) {
  Controller c(three_joints());
  InputDecoder d;
  type(c, d, "\t", 0);
  EXPECT_EQ(c.selected(), 1);
  type(c, d, "\x1b[B\x1b[C", 0);
  EXPECT_EQ(c.selected(), 0);  // 1 -> 2 -> wraps to 0
  type(c, d, "\x1b[A", 0);
  EXPECT_EQ(c.selected(), 2);
  type(c, d, "\x1b[D\x1b[Z", 0);
  EXPECT_EQ(c.selected(), 0);
}

TEST(TeleopController, TorquesAreClampedToEffortLimits) {
  Params p;
  p.step = 0.5;
  Controller c(three_joints(), p);
  InputDecoder d;
  type(c, d, "2" + std::string(10, '+'), 0);
  EXPECT_DOUBLE_EQ(c.torques()[1], 12.0);
  type(c, d, std::string(10, '-'), 0);
  EXPECT_DOUBLE_EQ(c.torques()[1], -12.0);
  c.set_torque(0, 1e9);
  EXPECT_DOUBLE_EQ(c.torques()[0], 87.0);
}

TEST(TeleopController, StepScaling) {
  Params p;
  p.step = 0.1;
  Controller c(three_joints(), p);
  InputDecoder d;
  type(c, d, "]]", 0);
  EXPECT_DOUBLE_EQ(c.step(), 0.4);
  type(c, d, "/[[", 0);
  EXPECT_DOUBLE_EQ(c.step(), 0.05);
  type(c, d, "*+", 0);
  EXPECT_DOUBLE_EQ(c.torques()[0], 8.7);
  for (int i = 0; i < 100; ++i) c.scale_step(0.5);
  EXPECT_DOUBLE_EQ(c.step(), p.min_step);
  for (int i = 0; i < 100; ++i) c.scale_step(2);
  EXPECT_DOUBLE_EQ(c.step(), 1.0);  // one press: the whole limit
}

// The step is a fraction of each joint's own effort limit: the same number of presses takes
// an 87 N m joint and a 12 N m one to the same fraction of their limits.
TEST(TeleopController, StepScalesWithEachJointsEffortLimit) {
  std::vector<JointInfo> j = three_joints();
  j[2].limit = std::numeric_limits<double>::infinity();  // no URDF limit: the default, 10
  Controller c(j);                                       // default step 0.05
  EXPECT_DOUBLE_EQ(c.joint_step(0), 0.05 * 87);
  EXPECT_DOUBLE_EQ(c.joint_step(1), 0.05 * 12);
  EXPECT_DOUBLE_EQ(c.joint_step(2), 0.05 * 10);
  InputDecoder d;
  type(c, d, "1++++2++++3++++", 0);
  EXPECT_NEAR(c.torques()[0], 0.2 * 87, 1e-9);
  EXPECT_NEAR(c.torques()[1], 0.2 * 12, 1e-9);
  EXPECT_NEAR(c.torques()[2], 0.2 * 10, 1e-9);
  type(c, d, "1" + std::string(20, '+'), 0);  // twenty presses from zero reach the limit
  EXPECT_DOUBLE_EQ(c.torques()[0], 87.0);
}

TEST(TeleopController, MouseDragSetsTorqueProportionally) {
  Controller c(three_joints());  // drag_columns = 40
  InputDecoder d;
  // Press at column 10, drag to 30: +20 columns = half the limit of joint a (87).
  type(c, d, "\x1b[<0;10;5M\x1b[<32;20;5M\x1b[<32;30;6M", 0);
  EXPECT_DOUBLE_EQ(c.torques()[0], 43.5);
  // Back left of the press point: negative; far out: clamped.
  type(c, d, "\x1b[<32;6;6M", 0);
  EXPECT_DOUBLE_EQ(c.torques()[0], -8.7);
  type(c, d, "\x1b[<32;200;6M", 0);
  EXPECT_DOUBLE_EQ(c.torques()[0], 87.0);
  // Release after a drag keeps the torque.
  type(c, d, "\x1b[<0;200;6m", 0);
  EXPECT_DOUBLE_EQ(c.torques()[0], 87.0);
  // A click (press + release, no motion) zeroes the selected joint.
  type(c, d, "\x1b[<0;50;5M\x1b[<0;50;5m", 0);
  EXPECT_DOUBLE_EQ(c.torques()[0], 0.0);
}

TEST(TeleopController, WheelChangesSelectionAndMiddleClickZeroesAll) {
  Controller c(three_joints());
  InputDecoder d;
  type(c, d, "\x1b[<65;1;1M", 0);
  EXPECT_EQ(c.selected(), 1);
  type(c, d, "+\x1b[<65;1;1M+\x1b[<64;1;1M\x1b[<64;1;1M", 0);
  EXPECT_EQ(c.selected(), 0);
  EXPECT_EQ(c.torques(), (std::vector<double>{0, 0.6, 0.25}));  // 5 % of 12 and of 5
  type(c, d, "\x1b[<1;4;4M\x1b[<1;4;4m", 0);
  EXPECT_EQ(c.torques(), (std::vector<double>{0, 0, 0}));
}

TEST(TeleopController, CameraKeysAndRightDrag) {
  Controller c(three_joints());
  InputDecoder d;
  type(c, d, "adwszx", 0);
  auto cam = c.take_camera_commands();
  ASSERT_EQ(cam.size(), 6u);
  EXPECT_GT(cam[0].yaw, 0);
  EXPECT_LT(cam[1].yaw, 0);
  EXPECT_GT(cam[2].pitch, 0);
  EXPECT_LT(cam[3].pitch, 0);
  EXPECT_GT(cam[4].zoom, 0);
  EXPECT_LT(cam[5].zoom, 0);
  EXPECT_DOUBLE_EQ(cam[4].zoom, 0.1);
  EXPECT_TRUE(c.take_camera_commands().empty());
  // Right drag: two columns right and one row up; torques untouched.
  type(c, d, "\x1b[<2;10;10M\x1b[<34;12;9M\x1b[<2;12;9m", 0);
  cam = c.take_camera_commands();
  ASSERT_EQ(cam.size(), 1u);
  EXPECT_DOUBLE_EQ(cam[0].yaw, -0.1);
  EXPECT_DOUBLE_EQ(cam[0].pitch, 0.1);
  EXPECT_EQ(c.torques(), (std::vector<double>{0, 0, 0}));
}

TEST(TeleopController, DeadManZeroesTorquesAfterTimeout) {
  Params p;
  p.timeout = 1.0;
  p.step = 0.1;  // 8.7 N m on joint a
  Controller c(three_joints(), p);
  InputDecoder d;
  c.update(100.0);  // no input yet: nothing to do
  EXPECT_FALSE(c.dead_man_tripped());
  type(c, d, "++", 10.0);
  c.update(10.5);
  EXPECT_DOUBLE_EQ(c.torques()[0], 17.4);
  type(c, d, "+", 10.9);  // input resets the timer
  c.update(11.8);
  EXPECT_DOUBLE_EQ(c.torques()[0], 26.1);
  EXPECT_FALSE(c.dead_man_tripped());
  c.update(11.95);
  EXPECT_DOUBLE_EQ(c.torques()[0], 0.0);
  EXPECT_TRUE(c.dead_man_tripped());
  EXPECT_NE(c.panel().find("IDLE"), std::string::npos);
  type(c, d, "+", 12.0);  // starts again from zero
  EXPECT_FALSE(c.dead_man_tripped());
  EXPECT_DOUBLE_EQ(c.torques()[0], 8.7);
  // A mouse drag keeps it alive like keys do.
  type(c, d, "\x1b[<0;10;1M", 12.5);
  type(c, d, "\x1b[<32;14;1M", 13.4);
  c.update(14.3);
  EXPECT_NEAR(c.torques()[0], 8.7, 1e-12);
  c.update(14.45);
  EXPECT_DOUBLE_EQ(c.torques()[0], 0.0);
}

TEST(TeleopController, DeadManOffWhenTimeoutIsZero) {
  Params p;
  p.timeout = 0.0;
  Controller c(three_joints(), p);
  InputDecoder d;
  type(c, d, "+", 0.0);
  c.update(1e6);
  EXPECT_DOUBLE_EQ(c.torques()[0], 4.35);
}

TEST(TeleopController, QuitZeroesTorques) {
  for (const std::string quit : {"q", "Q", "\x03", "\x04"}) {
    Controller c(three_joints());
    InputDecoder d;
    type(c, d, "+", 0);
    EXPECT_FALSE(c.quit_requested());
    type(c, d, quit, 0);
    EXPECT_TRUE(c.quit_requested());
    EXPECT_EQ(c.torques(), (std::vector<double>{0, 0, 0}));
  }
}

TEST(TeleopController, PanelShowsKeysSelectionTorquesAndLimits) {
  std::vector<JointInfo> j = three_joints();
  j[2].limit = std::numeric_limits<double>::infinity();  // replaced by the default
  Params p;
  p.default_effort_limit = 4.0;
  Controller c(j, p);
  InputDecoder d;
  type(c, d, "2++", 0);
  const std::string s = c.panel();
  EXPECT_NE(s.find("+ or = raise"), std::string::npos);
  EXPECT_NE(s.find("q quit"), std::string::npos);
  EXPECT_NE(s.find("step 5 % of limit"), std::string::npos) << s;
  EXPECT_NE(s.find(">   2  b"), std::string::npos) << s;
  EXPECT_NE(s.find("+1.200"), std::string::npos) << s;
  EXPECT_NE(s.find("12.000"), std::string::npos) << s;
  EXPECT_NE(s.find("4.000*"), std::string::npos) << s;
  EXPECT_NE(s.find("default limit 4"), std::string::npos) << s;
}

namespace {

std::vector<std::string> lines_of(const std::string& s) {
  std::vector<std::string> out;
  std::size_t a = 0;
  while (a < s.size()) {
    const std::size_t b = s.find('\n', a);
    out.push_back(s.substr(a, b - a));
    a = b == std::string::npos ? s.size() : b + 1;
  }
  return out;
}

}  // namespace

// The panel fits the terminal: no line reaches the last column (it would wrap), no more lines
// than rows, and with more joints than rows a window around the selected joint with the count
// of those above and below.
TEST(TeleopController, PanelFitsTheTerminal) {
  std::vector<JointInfo> j;
  for (int i = 0; i < 37; ++i) {  // Romeo's 37 joints, with long names
    j.push_back({"a_rather_long_joint_name_number_" + std::to_string(i), 10.0 + i, true});
  }
  Controller c(j);
  InputDecoder d;
  type(c, d, "\x1b[B\x1b[B", 0);  // joint 3
  const std::string footer =
      "-> /torque_command at 20 Hz (1 subscriber), camera "
      "/renderer/camera_command";
  for (const auto& size : {std::pair<int, int>{80, 24}, {100, 40}, {40, 10}, {20, 8}}) {
    for (int sel : {2, 20, 36}) {
      c.select(sel);
      const auto lines =
          lines_of(c.panel("se3_sim teleop (/teleop)", size.first, size.second, footer));
      EXPECT_LE(static_cast<int>(lines.size()), size.second) << size.first << "x" << size.second;
      bool selected_shown = false;
      for (const auto& l : lines) {
        EXPECT_LT(static_cast<int>(l.size()), size.first) << "'" << l << "'";
        char lead[16];
        std::snprintf(lead, sizeof lead, "> %3d", sel + 1);
        selected_shown = selected_shown || l.compare(0, 5, lead) == 0;
      }
      EXPECT_TRUE(selected_shown) << size.first << "x" << size.second << " joint " << sel + 1;
    }
  }
  c.select(20);
  const std::string s = c.panel("t", 80, 24, footer);
  EXPECT_NE(s.find("more above"), std::string::npos) << s;
  EXPECT_NE(s.find("more below"), std::string::npos) << s;
  EXPECT_NE(s.find("+ or = raise"), std::string::npos) << s;  // 80 x 24 keeps the help
  EXPECT_NE(s.find(footer), std::string::npos) << s;
  // A terminal that reports no size is taken as 80 x 24.
  EXPECT_EQ(c.panel("t", 0, 0, footer), s);
  // Few joints on a big terminal: all of them, no markers.
  Controller small(three_joints());
  const std::string t = small.panel("t", 120, 50);
  EXPECT_EQ(t.find("more"), std::string::npos) << t;
  EXPECT_NE(t.find("  3  c"), std::string::npos) << t;
}

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
