// Teleoperation from a terminal: decoding keyboard and xterm (SGR) mouse input, and turning
// it into joint torque commands and camera commands.
//
// No ROS here: the node (src/nodes/teleop_node.cpp) owns the terminal, the clock and the
// topics; this layer is pure logic and is unit-tested on recorded byte sequences with an
// injected clock (every call that depends on time takes `now`, in seconds, from any monotonic
// clock).
#pragma once

#include <cstddef>
#include <string>
#include <string_view>
#include <vector>

namespace se3 {

struct Model;

namespace teleop {

// ------------------------------------------------------------------------------ input events

enum class KeyCode {
  Char,       ///< a printable ASCII character, in Event::ch
  Control,    ///< Ctrl+letter or another C0 control byte, in Event::ch (e.g. 0x03 for Ctrl-C)
  Tab,        ///< 0x09
  BackTab,    ///< Shift-Tab: ESC [ Z
  Enter,      ///< CR or LF
  Backspace,  ///< DEL (0x7f) or BS (0x08)
  Escape,     ///< a lone ESC (see InputDecoder::flush) or ESC followed by an unrelated byte
  Up,
  Down,
  Right,
  Left,
};

enum class MouseButton { Left, Middle, Right, None };

enum class MouseAction {
  Press,
  Release,
  Motion,  ///< pointer moved; `button` is the button held (None for a plain hover)
  WheelUp,
  WheelDown,
  WheelLeft,
  WheelRight,
};

struct KeyEvent {
  KeyCode code = KeyCode::Char;
  char ch = 0;  ///< for Char and Control
};

struct MouseEvent {
  MouseAction action = MouseAction::Press;
  MouseButton button = MouseButton::None;
  int x = 0;  ///< column, 1-based, as the terminal reports it
  int y = 0;  ///< row, 1-based
  bool shift = false, alt = false, ctrl = false;
};

struct Event {
  enum class Type { Key, Mouse } type = Type::Key;
  KeyEvent key;
  MouseEvent mouse;

  static Event make_key(KeyCode code, char ch = 0);
  static Event make_mouse(const MouseEvent& m);
};

/// Incremental decoder of terminal input bytes (raw mode) into key and mouse events.
///
/// Understood: printable ASCII, Tab, Enter (CR or LF), Backspace (DEL or BS), other C0
/// controls, arrows in both cursor modes (ESC [ A..D, ESC O A..D, also with modifier
/// parameters such as ESC [ 1 ; 2 A), Shift-Tab (ESC [ Z), SGR mouse reports
/// (ESC [ < b ; x ; y M for press/motion/wheel, ... m for release) and legacy X10 mouse
/// reports (ESC [ M b x y with three raw bytes). Every other well-formed escape sequence
/// (function keys, Home, focus reports, ...) is consumed silently. A sequence broken by a
/// byte that cannot belong to it is dropped and that byte is decoded afresh, so garbage
/// never swallows the input that follows it. Bytes may arrive split anywhere between calls.
class InputDecoder {
 public:
  /// Decodes `bytes` and appends the completed events to `out`.
  void feed(std::string_view bytes, std::vector<Event>& out);
  std::vector<Event> feed(std::string_view bytes);

  /// True while an escape sequence is incomplete (more bytes are awaited).
  bool pending() const { return state_ != State::Ground; }
  /// True when the only byte held is a lone ESC: if nothing follows within a few tens of
  /// milliseconds the user pressed the Escape key, and the caller should call flush().
  bool lone_escape() const { return state_ == State::Escape; }
  /// Ends an incomplete sequence: a lone ESC becomes an Escape key, anything else is dropped.
  void flush(std::vector<Event>& out);
  void reset();

 private:
  enum class State { Ground, Escape, Csi, Ss3, X10Mouse };
  static constexpr std::size_t kMaxSequence = 32;

  void ground(unsigned char c, std::vector<Event>& out);
  void finish_csi(unsigned char final_byte, std::vector<Event>& out);
  void finish_x10(std::vector<Event>& out);

  State state_ = State::Ground;
  std::string seq_;  ///< parameter and intermediate bytes of the CSI sequence being read
  unsigned char x10_[3] = {0, 0, 0};
  int x10_count_ = 0;
  MouseButton x10_last_button_ = MouseButton::None;
};

/// Decodes an SGR mouse button code with its position (exposed for tests and tools).
MouseEvent decode_mouse_code(int code, int x, int y, bool release);

// ------------------------------------------------------------------------------ controller

struct Params {
  /// Torque step of + and - as a fraction of the selected joint's effort limit (0.05: 20
  /// presses from zero to the limit; a 87 N m joint steps by 4.35 N m, a 12 N m one by 0.6).
  double step = 0.05;
  double min_step = 1e-4, max_step = 1.0;  ///< bounds of the fraction
  double step_factor = 2.0;                ///< ] and * multiply the step by it, [ and / divide
  double default_effort_limit = 10.0;      ///< limit of joints whose URDF effort is inf or <= 0
  double timeout = 1.0;            ///< dead-man (s): no input for this long zeroes all; <= 0 off
  double drag_columns = 40.0;      ///< a horizontal drag of this many columns = full limit
  double camera_yaw_step = 0.1;    ///< rad per a / d press
  double camera_pitch_step = 0.1;  ///< rad per w / s press
  double camera_zoom_step = 0.1;   ///< zoom factor delta per z / x press (+0.1 = 10 % closer)
  double camera_drag_yaw = 0.05;   ///< rad per column of right-button drag
  double camera_drag_pitch = 0.1;  ///< rad per row of right-button drag
};

/// One step of the renderer's camera (the node sends it as geometry_msgs/Twist on
/// renderer/camera_command: angular.z = yaw, angular.y = pitch, linear.x = zoom).
struct CameraCommand {
  double yaw = 0;    ///< rad, about the world z axis through the camera target
  double pitch = 0;  ///< rad, positive looks from higher up
  double zoom = 0;   ///< factor delta: +0.1 moves 10 % closer, -0.1 10 % farther
};

struct JointInfo {
  std::string name;
  double limit = 0;       ///< effort limit used for clamping (> 0)
  bool from_urdf = true;  ///< false when the default limit was substituted
};

/// Joints of a model (bodies 1..n in the model's order) with their effort limits; a limit that
/// is not finite or not positive is replaced by `default_limit`.
std::vector<JointInfo> joints_from_model(const Model& model, double default_limit);

/// The teleop state: joints, selection, commanded torques, step, dead-man and pending camera
/// commands. Feed it events with handle(), call update() regularly (before reading the
/// torques to publish them).
class Controller {
 public:
  Controller(std::vector<JointInfo> joints, const Params& params = {});

  /// Applies one input event received at time `now` (s).
  void handle(const Event& ev, double now);
  void handle(const std::vector<Event>& evs, double now);
  /// Applies the dead-man: when the last input is `timeout` or more seconds before `now`,
  /// every torque becomes zero.
  void update(double now);

  const std::vector<JointInfo>& joints() const { return joints_; }
  const std::vector<double>& torques() const { return torques_; }
  int selected() const { return selected_; }  ///< 0-based index into joints()
  /// The step as a fraction of the effort limit (the same for every joint).
  double step() const { return step_; }
  /// The torque step of joint `index` (N m or N): step() times its effort limit.
  double joint_step(int index) const;
  bool quit_requested() const { return quit_; }
  /// True after the dead-man zeroed the torques, until the next input.
  bool dead_man_tripped() const { return tripped_; }
  const Params& params() const { return params_; }

  /// Camera commands produced since the last call, oldest first.
  std::vector<CameraCommand> take_camera_commands();

  // Direct operations (what the keys and the mouse do).
  void select(int index);  ///< ignored when out of range
  void select_next();
  void select_previous();
  void nudge(double steps);                ///< selected torque += steps * step, clamped
  void set_torque(int index, double tau);  ///< clamped to the joint's limit
  void zero_all();
  void scale_step(double factor);

  /// The help panel: title, keys, step and timeout, one line per joint with its torque,
  /// limit and a bar; the selected joint is marked with '>'. Lines end with '\n'. It fits a
  /// terminal of `cols` x `rows` (no line longer than cols - 1, at most `rows` lines with the
  /// footer's): the help shrinks first, then the joint list shows a window around the selected
  /// joint with the number of joints above and below it.
  std::string panel(const std::string& title = "se3_sim teleop", int cols = 80, int rows = 24,
                    const std::string& footer = "") const;

 private:
  void handle_key(const KeyEvent& k);
  void handle_mouse(const MouseEvent& m);

  std::vector<JointInfo> joints_;
  Params params_;
  std::vector<double> torques_;
  int selected_ = 0;
  double step_ = 0.05;  ///< fraction of the effort limit
  bool quit_ = false;
  bool tripped_ = false;
  bool any_input_ = false;
  double last_input_ = 0;
  std::vector<CameraCommand> camera_;

  // Mouse gesture state.
  MouseButton held_ = MouseButton::None;
  int press_x_ = 0, press_y_ = 0;  ///< where the held button went down
  int last_x_ = 0, last_y_ = 0;    ///< last reported position while held
  bool moved_ = false;             ///< the held button has been dragged
};

}  // namespace teleop
}  // namespace se3
