// Teleop state: selection, torques, step, dead-man, mouse gestures and camera commands.
#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <limits>
#include <stdexcept>

#include "se3_sim/model.h"
#include "se3_sim/teleop.h"

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

void Controller::nudge(double steps) {
  if (joints_.empty()) return;
  double tau = torques_[selected_] + steps * step_;
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

}  // namespace

std::string Controller::panel(const std::string& title) const {
  std::string p;
  p += title + ": " + std::to_string(joints_.size()) + " joints   step " + fmt("%g", step_);
  if (params_.timeout > 0)
    p += fmt("   dead-man %g s", params_.timeout);
  else
    p += "   dead-man off";
  if (!any_input_)
    p += "   [waiting for input]";
  else if (tripped_)
    p += "   [IDLE: no input, torques zero]";
  else
    p += "   [ACTIVE]";
  p += "\n";
  p += "keys:   1-9,0 select joint 1-10   Tab/Down/Right next   Shift-Tab/Up/Left previous\n";
  p += "        + or = raise, - lower by one step   Backspace zero joint   space zero all\n";
  p += "        ] or * step x" + fmt("%g", params_.step_factor) + "   [ or / step /" +
       fmt("%g", params_.step_factor) + "   q or Ctrl-C quit\n";
  p += "mouse:  left drag: torque = limit * columns / " + fmt("%g", params_.drag_columns) +
       "   left click: zero joint   wheel: select\n";
  p += "        middle click: zero all\n";
  p += "camera: a/d yaw   w/s pitch   z/x zoom in/out   right-button drag orbits\n";
  p += "\n";
  p += "    #  joint                    torque (N m or N)       limit\n";
  for (std::size_t i = 0; i < joints_.size(); ++i) {
    const auto& j = joints_[i];
    std::string name = j.name.size() > 28 ? j.name.substr(0, 25) + "..." : j.name;
    name.resize(28, ' ');
    char head[32];
    std::snprintf(head, sizeof head, "%c %3zu  ", static_cast<int>(i) == selected_ ? '>' : ' ',
                  i + 1);
    p += head + name + fmt(" %+11.3f %11.3f", torques_[i], j.limit) + (j.from_urdf ? " " : "*") +
         " " + bar(torques_[i], j.limit, 10) + "\n";
  }
  bool any_default = false;
  for (const auto& j : joints_) any_default = any_default || !j.from_urdf;
  if (any_default)
    p += fmt("  * no effort limit in the URDF: default limit %g used\n",
             params_.default_effort_limit);
  return p;
}

}  // namespace teleop
}  // namespace se3
