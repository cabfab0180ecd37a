// Teleop state: selection, torques, step, dead-man, mouse gestures and camera commands.
#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <limits>
#include <stdexcept>

#include "se3_sim/model/model.h"
#include "se3_sim/teleop/teleop.h"

namespace se3 {
namespace teleop {

std::vector<JointInfo> joints_from_model(const Model& model, double default_limit) {
  if (!(default_limit > 0) || !std::isfinite(default_limit))
    throw std::invalid_argument("teleop: default effort limit must be positive and finite");
  std::vector<JointInfo> joints;
  for (int i = 1; i <= model.n; ++i) {
    JointInfo j;
    j.name = i < static_cast<int>(model.joint_name.size()) ? model.joint_name[i] : "";
    if (j.name.empty()) j.name = "joint_" + std::to_string(i);
    const double e = i < static_cast<int>(model.effort.size())
                         ? model.effort[i]
                         : std::numeric_limits<double>::infinity();
    j.from_urdf = std::isfinite(e) && e > 0;
    j.limit = j.from_urdf ? e : default_limit;
    joints.push_back(j);
  }
  return joints;
}

Controller::Controller(std::vector<JointInfo> joints, const Params& params)
    : joints_(std::move(joints)), params_(params), torques_(joints_.size(), 0.0) {
  for (auto& j : joints_)
    if (!(j.limit > 0) || !std::isfinite(j.limit)) {
      j.limit = params_.default_effort_limit;
      j.from_urdf = false;
    }
  if (!(params_.min_step > 0) || params_.max_step < params_.min_step)
    throw std::invalid_argument("teleop: bad step bounds");
  step_ = std::clamp(params_.step, params_.min_step, params_.max_step);
  if (!(params_.step_factor > 1)) params_.step_factor = 2.0;
  if (!(params_.drag_columns > 0)) params_.drag_columns = 40.0;
}

void Controller::select(int index) {
  if (index >= 0 && index < static_cast<int>(joints_.size())) selected_ = index;
}

void Controller::select_next() {
  if (!joints_.empty()) selected_ = (selected_ + 1) % static_cast<int>(joints_.size());
}

void Controller::select_previous() {
  const int n = static_cast<int>(joints_.size());
  if (n > 0) selected_ = (selected_ + n - 1) % n;
}

void Controller::set_torque(int index, double tau) {
  if (index < 0 || index >= static_cast<int>(joints_.size()) || std::isnan(tau)) return;
  const double lim = joints_[index].limit;
  torques_[index] = std::clamp(tau, -lim, lim);
}

double Controller::joint_step(int index) const {
  if (index < 0 || index >= static_cast<int>(joints_.size())) return 0.0;
  return step_ * joints_[index].limit;
}

void Controller::nudge(double steps) {
  if (joints_.empty()) return;
  double tau = torques_[selected_] + steps * joint_step(selected_);
  // Keep sums of steps free of rounding dust (0.1 + 0.2 shows as 0.3).
  tau = std::round(tau * 1e9) / 1e9;
  set_torque(selected_, tau);
}

void Controller::zero_all() {
  std::fill(torques_.begin(), torques_.end(), 0.0);
}

void Controller::scale_step(double factor) {
  if (factor > 0 && std::isfinite(factor))
    step_ = std::clamp(step_ * factor, params_.min_step, params_.max_step);
}

std::vector<CameraCommand> Controller::take_camera_commands() {
  std::vector<CameraCommand> out;
  out.swap(camera_);
  return out;
}

void Controller::handle(const std::vector<Event>& evs, double now) {
  for (const auto& e : evs) handle(e, now);
}

void Controller::handle(const Event& ev, double now) {
  any_input_ = true;
  last_input_ = now;
  tripped_ = false;
  if (ev.type == Event::Type::Key)
    handle_key(ev.key);
  else
    handle_mouse(ev.mouse);
}

void Controller::update(double now) {
  if (params_.timeout > 0 && any_input_ && now - last_input_ >= params_.timeout) {
    zero_all();
    tripped_ = true;
  }
}

void Controller::handle_key(const KeyEvent& k) {
  switch (k.code) {
    case KeyCode::Tab:
    case KeyCode::Right:
    case KeyCode::Down:
      select_next();
      return;
    case KeyCode::BackTab:
    case KeyCode::Left:
    case KeyCode::Up:
      select_previous();
      return;
    case KeyCode::Backspace:
      set_torque(selected_, 0.0);
      return;
    case KeyCode::Control:
      if (k.ch == 0x03 || k.ch == 0x04) {  // Ctrl-C, Ctrl-D
        zero_all();
        quit_ = true;
      }
      return;
    case KeyCode::Char:
      break;
    default:
      return;
  }
  const char c = static_cast<char>(std::tolower(static_cast<unsigned char>(k.ch)));
  CameraCommand cam;
  switch (c) {
    case '1':
    case '2':
    case '3':
    case '4':
    case '5':
    case '6':
    case '7':
    case '8':
    case '9':
      select(c - '1');
      return;
    case '0':
      select(9);
      return;
    case '+':
    case '=':
      nudge(+1);
      return;
    case '-':
    case '_':
      nudge(-1);
      return;
    case ' ':
      zero_all();
      return;
    case ']':
    case '*':
      scale_step(params_.step_factor);
      return;
    case '[':
    case '/':
      scale_step(1.0 / params_.step_factor);
      return;
    case 'q':
      zero_all();
      quit_ = true;
      return;
    case 'a':
      cam.yaw = params_.camera_yaw_step;
      break;
    case 'd':
      cam.yaw = -params_.camera_yaw_step;
      break;
    case 'w':
      cam.pitch = params_.camera_pitch_step;
      break;
    case 's':
      cam.pitch = -params_.camera_pitch_step;
      break;
    case 'z':
      cam.zoom = params_.camera_zoom_step;
      break;
    case 'x':
      cam.zoom = -params_.camera_zoom_step;
      break;
    default:
      return;
  }
  camera_.push_back(cam);
}

void Controller::handle_mouse(const MouseEvent& m) {
  switch (m.action) {
    case MouseAction::WheelUp:
      select_previous();
      return;
    case MouseAction::WheelDown:
      select_next();
      return;
    case MouseAction::WheelLeft:
    case MouseAction::WheelRight:
      return;
    case MouseAction::Press:
      if (m.button == MouseButton::None) return;
      held_ = m.button;
      press_x_ = last_x_ = m.x;
      press_y_ = last_y_ = m.y;
      moved_ = false;
      return;
    case MouseAction::Motion:
      if (m.button == MouseButton::None) return;  // hover
      if (held_ != m.button) {
        // The press was not seen (e.g. it happened before the mouse was enabled): the
        // gesture starts here.
        held_ = m.button;
        press_x_ = last_x_ = m.x;
        press_y_ = last_y_ = m.y;
        moved_ = false;
        return;
      }
      if (m.x == last_x_ && m.y == last_y_) return;
      moved_ = true;
      if (held_ == MouseButton::Left) {
        if (!joints_.empty()) {
          const double lim = joints_[selected_].limit;
          set_torque(selected_, lim * (m.x - press_x_) / params_.drag_columns);
        }
      } else if (held_ == MouseButton::Right) {
        CameraCommand cam;
        cam.yaw = -params_.camera_drag_yaw * (m.x - last_x_);
        cam.pitch = -params_.camera_drag_pitch * (m.y - last_y_);
        camera_.push_back(cam);
      }
      last_x_ = m.x;
      last_y_ = m.y;
      return;
    case MouseAction::Release: {
      const bool click = !moved_ && held_ != MouseButton::None &&
                         (m.button == held_ || m.button == MouseButton::None);
      if (click && held_ == MouseButton::Left) set_torque(selected_, 0.0);
      if (click && held_ == MouseButton::Middle) zero_all();
      held_ = MouseButton::None;
      moved_ = false;
      return;
    }
  }
}

namespace {

std::string fmt(const char* f, double a, double b = 0, double c = 0) {
  char buf[160];
  std::snprintf(buf, sizeof buf, f, a, b, c);
  return buf;
}

/// A bar of 2*half+1 characters: '|' in the middle, '#' from the middle towards the value.
std::string bar(double tau, double limit, int half) {
  std::string s(2 * half + 1, ' ');
  s[half] = '|';
  const int k = static_cast<int>(std::lround(std::min(1.0, std::abs(tau) / limit) * half));
  for (int i = 1; i <= k; ++i) s[tau > 0 ? half + i : half - i] = '#';
  return "[" + s + "]";
}

/// Appends `line` cut to `width` characters, and a newline.
void add_line(std::string& out, const std::string& line, int width) {
  out.append(line, 0, static_cast<std::size_t>(std::max(0, width)));
  out += '\n';
}

}  // namespace

std::string Controller::panel(const std::string& title, int cols, int rows,
                              const std::string& footer) const {
  // A terminal that reports no size (0) is taken as 80 x 24; below 20 x 8 nothing fits well.
  cols = cols > 0 ? std::max(cols, 20) : 80;
  rows = rows > 0 ? std::max(rows, 8) : 24;
  const int width = cols - 1;  // a full-width line would wrap on some terminals

  std::string head = title + "  " + std::to_string(joints_.size()) + " joints  ";
  if (params_.timeout > 0)
    head += fmt("dead-man %g s", params_.timeout);
  else
    head += "dead-man off";
  if (!any_input_)
    head += "  [waiting for input]";
  else if (tripped_)
    head += "  [IDLE: no input, torques zero]";
  else
    head += "  [ACTIVE]";

  // Help, most needed first; lines are dropped from the end when the terminal is short.
  const std::string f = fmt("%g", params_.step_factor);
  const std::vector<std::string> help = {
      "keys   1-9,0 joint  Tab/arrows next/previous  + or = raise  - lower  q quit",
      "       Backspace zero joint  space zero all  ] or * step x" + f + "  [ or / step /" + f,
      "mouse  left drag: torque = limit x columns/" + fmt("%g", params_.drag_columns) +
          "  click: zero  middle: zero all",
      "camera a/d yaw  w/s pitch  z/x zoom  right drag orbits  wheel: select joint",
  };
  bool any_default = false;
  for (const auto& j : joints_) any_default = any_default || !j.from_urdf;
  const std::string note = any_default ? fmt("* no effort limit in the URDF: default limit %g used",
                                             params_.default_effort_limit)
                                       : std::string();

  std::vector<std::string> footer_lines;
  for (std::size_t a = 0; a < footer.size();) {
    const std::size_t b = footer.find('\n', a);
    footer_lines.push_back(footer.substr(a, b == std::string::npos ? b : b - a));
    if (b == std::string::npos) break;
    a = b + 1;
  }
  if (!footer_lines.empty() && footer_lines.back().empty()) footer_lines.pop_back();

  // Rows: head, help, blank, table header, joints (with "more" markers), note, footer.
  const int n = static_cast<int>(joints_.size());
  const int fixed = 1 + 1 + (note.empty() ? 0 : 1) + static_cast<int>(footer_lines.size());
  // All joints if they fit beside some help; else a window, with the two key lines kept when
  // the terminal has room for a useful window beside them.
  const int all_help = static_cast<int>(help.size()) + 1;  // with the blank line after it
  int help_rows = std::min(all_help, std::max(0, rows - fixed - n));
  if (help_rows < 2 && rows - fixed >= 12) help_rows = 2;
  const int joint_rows = std::max(3, rows - fixed - help_rows);
  int first = 0, last = n;  // the joints shown: [first, last)
  if (n > joint_rows) {
    const int shown = std::max(1, joint_rows - 2);  // two rows for "N more" markers
    first = std::clamp(selected_ - shown / 2, 0, n - shown);
    last = first + shown;
  }

  // Joint line: "> 12  name  +torque  limit* [bar]"; the name and the bar share what is left.
  constexpr int kNumbers = 7 + 1 + 11 + 1 + 10 + 2;  // marker+index, torque, limit, '*', spaces
  const int rest = width - kNumbers;
  const int name_w = std::clamp(rest / 2, 8, 28);
  const int half = std::clamp((rest - name_w - 3) / 2, 0, 12);

  std::string p;
  add_line(p, head, width);
  for (int k = 0; k < help_rows; ++k) {
    add_line(p, k < static_cast<int>(help.size()) ? help[k] : std::string(), width);
  }
  std::string th = "    #  joint";
  th.resize(7 + name_w, ' ');
  add_line(p, th + "      torque      limit  step " + fmt("%g", step_ * 100) + " % of limit",
           width);
  if (first > 0) add_line(p, fmt("       ... %g more above", first), width);
  for (int i = first; i < last; ++i) {
    const auto& j = joints_[i];
    std::string name =
        static_cast<int>(j.name.size()) > name_w ? j.name.substr(0, name_w - 3) + "..." : j.name;
    name.resize(name_w, ' ');
    char lead[32];
    std::snprintf(lead, sizeof lead, "%c %3d  ", i == selected_ ? '>' : ' ', i + 1);
    std::string line =
        lead + name + fmt(" %+11.3f %10.3f", torques_[i], j.limit) + (j.from_urdf ? " " : "*");
    if (half > 0) line += " " + bar(torques_[i], j.limit, half);
    add_line(p, line, width);
  }
  if (last < n) add_line(p, fmt("       ... %g more below", n - last), width);
  if (!note.empty()) add_line(p, note, width);
  for (const auto& l : footer_lines) add_line(p, l, width);
  return p;
}

}  // namespace teleop
}  // namespace se3
