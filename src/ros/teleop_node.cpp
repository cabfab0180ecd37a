// The teleop node (teleop_node.h): drives joint torques (and the renderer's camera) from the
// keyboard and the mouse of the terminal it runs in.
//
// Publishes torque_command (se3_sim/JointTorques) at ~rate and one renderer/camera_command
// (geometry_msgs/Twist: angular.z = yaw step, angular.y = pitch step, linear.x = zoom factor
// delta) per camera key press or right-button drag step. Reads robot_description for the
// joints and their effort limits. The terminal goes into raw mode with xterm SGR mouse
// reporting on an alternate screen; all of it is undone on exit, on SIGINT/SIGTERM/SIGHUP and
// on crash signals. Without a terminal on stdin it says so and exits with code 0.
//
// Private parameters: ~rate (Hz, 20), ~timeout (dead-man, s, 1.0; <= 0 disables it),
// ~step (torque step per key press as a fraction of the joint's effort limit, 0.05),
// ~default_effort_limit (10.0, for joints whose URDF
// effort is missing, zero or infinite), ~drag_columns (40: columns of mouse drag for the
// full effort limit), ~description_timeout (30 s to wait for a non-empty robot_description).
#include "se3_sim/ros/teleop_node.h"

#include <fcntl.h>
#include <geometry_msgs/Twist.h>
#include <poll.h>
#include <ros/ros.h>
#include <signal.h>
#include <sys/ioctl.h>
#include <termios.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <string>
#include <string_view>
#include <vector>

#include "se3_sim/JointTorques.h"
#include "se3_sim/model/model.h"
#include "se3_sim/teleop/teleop.h"

namespace {

// ------------------------------------------------------------------ terminal (signal-safe part)
// Everything the signal handlers touch is a plain global, and they only call write(2), poll(2)
// and tcsetattr(3), which are async-signal-safe.

int g_in_fd = -1;   // the terminal we read (stdin)
int g_out_fd = -1;  // the same terminal, opened for writing
struct termios g_saved;
volatile sig_atomic_t g_raw = 0;          // 1 while the terminal is ours
volatile sig_atomic_t g_stop_signal = 0;  // the signal that asked us to stop

// Alternate screen, hidden cursor, mouse: press/release (1000), drag motion (1002), SGR
// coordinates (1006). kLeave undoes them in reverse order.
const char kEnter[] = "\x1b[?1049h\x1b[?25l\x1b[?1000h\x1b[?1002h\x1b[?1006h";
const char kLeave[] = "\x1b[?1006l\x1b[?1002l\x1b[?1000l\x1b[?25h\x1b[?1049l";

/// Writes all of buf, waiting (up to about a second in total) while the terminal is full.
bool write_all(int fd, const char* buf, size_t n) {
  int waits = 0;
  while (n > 0) {
    const ssize_t k = write(fd, buf, n);
    if (k > 0) {
      buf += k;
      n -= static_cast<size_t>(k);
    } else if (k < 0 && errno == EINTR) {
      continue;
    } else if (k < 0 && (errno == EAGAIN || errno == EWOULDBLOCK) && waits < 10) {
      struct pollfd p = {fd, POLLOUT, 0};
      poll(&p, 1, 100);
      ++waits;
    } else {
      return false;
    }
  }
  return true;
}

void restore_terminal() {
  if (!g_raw) return;
  g_raw = 0;
  write_all(g_out_fd, kLeave, sizeof kLeave - 1);
  tcsetattr(g_in_fd, TCSANOW, &g_saved);
}

void on_stop_signal(int sig) {
  if (g_stop_signal) {  // a second request: do not wait for the main loop any more
    restore_terminal();
    _exit(1);
  }
  g_stop_signal = sig;
}

void on_crash_signal(int sig) {
  restore_terminal();
  // The handler was installed with SA_RESETHAND: re-raising ends the process as the signal
  // would have, core dump included.
  raise(sig);
}

void install_handlers() {
  struct sigaction sa;
  std::memset(&sa, 0, sizeof sa);
  sigemptyset(&sa.sa_mask);
  sa.sa_handler = on_stop_signal;
  for (int s : {SIGINT, SIGTERM, SIGHUP, SIGQUIT}) sigaction(s, &sa, nullptr);
  sa.sa_handler = on_crash_signal;
  sa.sa_flags = SA_RESETHAND;
  for (int s : {SIGSEGV, SIGBUS, SIGFPE, SIGILL, SIGABRT}) sigaction(s, &sa, nullptr);
  // A full terminal or a closed one must not kill us before the terminal is restored.
  signal(SIGPIPE, SIG_IGN);
  signal(SIGTTOU, SIG_IGN);
}

/// Puts the terminal in raw input mode (no echo, no line editing, no signal keys: Ctrl-C
/// arrives as a byte) but keeps output processing, so '\n' still returns the carriage for
/// log lines; then switches on the alternate screen and mouse reporting.
bool enter_raw_mode() {
  if (tcgetattr(g_in_fd, &g_saved) != 0) return false;
  struct termios raw = g_saved;
  raw.c_iflag &=
      ~static_cast<tcflag_t>(IGNBRK | BRKINT | PARMRK | ISTRIP | INLCR | IGNCR | ICRNL | IXON);
  raw.c_lflag &= ~static_cast<tcflag_t>(ECHO | ECHONL | ICANON | ISIG | IEXTEN);
  raw.c_cc[VMIN] = 1;
  raw.c_cc[VTIME] = 0;
  std::atexit(restore_terminal);
  g_raw = 1;  // set first: a signal arriving from here on restores
  if (tcsetattr(g_in_fd, TCSANOW, &raw) != 0) {
    g_raw = 0;
    return false;
  }
  write_all(g_out_fd, kEnter, sizeof kEnter - 1);
  return true;
}

/// Opens the terminal behind stdin for writing, so the panel goes to it even when stdout is
/// redirected (roslaunch with output="log"). Non-blocking: a stalled terminal never holds up
/// the publishing loop (a frame that does not fit is dropped).
int open_terminal_for_output() {
  const char* name = ttyname(STDIN_FILENO);
  if (name) {
    const int fd = open(name, O_WRONLY | O_NOCTTY | O_NONBLOCK | O_CLOEXEC);
    if (fd >= 0) return fd;
  }
  return isatty(STDOUT_FILENO) ? STDOUT_FILENO : STDIN_FILENO;
}

double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

/// The panel as one frame: cursor home, each line cleared to its end, the rest of the screen
/// cleared. The last line gets no newline, which would scroll a panel as tall as the terminal.
std::string frame(std::string panel) {
  while (!panel.empty() && panel.back() == '\n') panel.pop_back();
  std::string f = "\x1b[H";
  for (char c : panel) {
    if (c == '\n') f += "\x1b[K";
    f += c;
  }
  f += "\x1b[K\x1b[J";
  return f;
}

se3_sim::JointTorques torque_message(const se3::teleop::Controller& ctl) {
  se3_sim::JointTorques msg;
  msg.header.stamp = ros::Time::now();
  for (size_t i = 0; i < ctl.joints().size(); ++i) {
    msg.name.push_back(ctl.joints()[i].name);
    msg.effort.push_back(ctl.torques()[i]);
  }
  msg.has_base_wrench = false;
  return msg;
}

int run_node(int argc, char** argv) {
  if (!isatty(STDIN_FILENO)) {
    std::fprintf(stderr,
                 "teleop_node: standard input is not a terminal, so there are no keys or mouse "
                 "to read; run it in a terminal (roslaunch se3_sim teleop.launch). Exiting.\n");
    return 0;
  }
  install_handlers();
  ros::init(argc, argv, "teleop", ros::init_options::NoSigintHandler);
  ros::NodeHandle nh, pnh("~");

  se3::teleop::Params params;
  double rate = pnh.param("rate", 20.0);
  params.timeout = pnh.param("timeout", params.timeout);
  params.step = pnh.param("step", params.step);
  params.default_effort_limit = pnh.param("default_effort_limit", params.default_effort_limit);
  params.drag_columns = pnh.param("drag_columns", params.drag_columns);
  if (!(rate > 0) || !std::isfinite(rate)) {
    ROS_ERROR("teleop: ~rate must be positive (got %g)", rate);
    return 1;
  }
  if (!(params.step > 0 && params.step <= 1)) {
    ROS_ERROR("teleop: ~step is a fraction of each joint's effort limit, in (0, 1] (got %g)",
              params.step);
    return 1;
  }
  if (!(params.default_effort_limit > 0) || !(params.drag_columns > 0)) {
    ROS_ERROR("teleop: ~default_effort_limit and ~drag_columns must be positive");
    return 1;
  }

  // robot_description may come late (the simulator publishes a scene's robot once loaded).
  const double description_timeout = pnh.param("description_timeout", 30.0);
  const std::string description = nh.resolveName("robot_description");
  std::string xml;
  const auto wait0 = std::chrono::steady_clock::now();
  bool told = false;
  while (ros::ok() && !g_stop_signal) {
    if (nh.getParam("robot_description", xml) && !xml.empty()) break;
    if (seconds_since(wait0) >= description_timeout) {
      ROS_ERROR("teleop: parameter %s is not set (or empty) after %g s: load a URDF there first",
                description.c_str(), description_timeout);
      return 1;
    }
    if (!told) ROS_INFO("teleop: waiting for %s ...", description.c_str());
    told = true;
    ros::WallDuration(0.2).sleep();
  }
  if (xml.empty()) return 0;  // stopped while waiting

  // Only joint names and effort limits matter here: a fixed base is the simpler reading; a
  // URDF that only loads with a free base (e.g. a floating root joint) is read that way.
  std::vector<se3::teleop::JointInfo> joints;
  try {
    se3::Model model;
    try {
      model = se3::model_from_urdf_string(xml);
    } catch (const std::exception& fixed_error) {
      se3::UrdfOptions floating;
      floating.floating = true;
      try {
        model = se3::model_from_urdf_string(xml, floating);
      } catch (const std::exception&) {
        throw se3::ModelError(fixed_error.what());  // the fixed-base reason is the clearer one
      }
    }
    joints = se3::teleop::joints_from_model(model, params.default_effort_limit);
  } catch (const std::exception& e) {
    ROS_ERROR("teleop: cannot use %s: %s", description.c_str(), e.what());
    return 1;
  }
  if (joints.empty()) {
    ROS_ERROR("teleop: robot_description has no moving joints to drive");
    return 1;
  }
  se3::teleop::Controller ctl(joints, params);
  se3::teleop::InputDecoder decoder;

  ros::Publisher torque_pub = nh.advertise<se3_sim::JointTorques>("torque_command", 10);
  ros::Publisher camera_pub = nh.advertise<geometry_msgs::Twist>("renderer/camera_command", 10);

  g_in_fd = STDIN_FILENO;
  g_out_fd = open_terminal_for_output();
  if (!enter_raw_mode()) {
    ROS_ERROR("teleop: cannot put the terminal in raw mode: %s", std::strerror(errno));
    return 1;
  }

  const auto t0 = std::chrono::steady_clock::now();
  const double period = 1.0 / rate;
  double next_tick = 0.0;
  double last_byte = 0.0;
  const std::string title = "se3_sim teleop (" + ros::this_node::getName() + ")";
  std::string shown;
  bool input_closed = false;
  std::vector<se3::teleop::Event> events;

  while (ros::ok() && !g_stop_signal && !ctl.quit_requested() && !input_closed) {
    double now = seconds_since(t0);
    double wait = next_tick - now;
    if (decoder.lone_escape()) wait = std::min(wait, last_byte + 0.05 - now);
    struct pollfd p = {g_in_fd, POLLIN, 0};
    const int ready = poll(&p, 1, std::max(0, static_cast<int>(std::ceil(wait * 1000))));
    now = seconds_since(t0);
    events.clear();
    if (ready > 0 && (p.revents & (POLLIN | POLLHUP | POLLERR))) {
      char buf[512];
      const ssize_t n = read(g_in_fd, buf, sizeof buf);
      if (n > 0) {
        decoder.feed(std::string_view(buf, static_cast<size_t>(n)), events);
        last_byte = now;
      } else if (n == 0 || (errno != EINTR && errno != EAGAIN)) {
        input_closed = true;  // the terminal went away
      }
    }
    // A lone ESC with nothing after it for 50 ms was the Escape key, not a sequence.
    if (decoder.lone_escape() && now - last_byte >= 0.05) decoder.flush(events);
    if (!events.empty()) ctl.handle(events, now);

    for (const auto& c : ctl.take_camera_commands()) {
      geometry_msgs::Twist t;
      t.angular.z = c.yaw;
      t.angular.y = c.pitch;
      t.linear.x = c.zoom;
      camera_pub.publish(t);
    }

    const bool tick = now >= next_tick;
    if (tick) {
      ctl.update(now);
      torque_pub.publish(torque_message(ctl));
      next_tick += period;
      if (next_tick <= now) next_tick = now + period;  // fell behind: do not burst
    }
    if (tick || !events.empty()) {
      char status[200];
      const unsigned subs = torque_pub.getNumSubscribers();
      std::snprintf(status, sizeof status, "-> %s at %g Hz (%u subscriber%s), camera %s",
                    torque_pub.getTopic().c_str(), rate, subs, subs == 1 ? "" : "s",
                    camera_pub.getTopic().c_str());
      // The panel fits the terminal as it is now (80 x 24 when it does not say).
      struct winsize ws = {};
      if (ioctl(g_out_fd, TIOCGWINSZ, &ws) != 0) ws = {};
      const std::string f = frame(ctl.panel(title, ws.ws_col, ws.ws_row, status));
      if (f != shown && g_raw) {
        write_all(g_out_fd, f.data(), f.size());
        shown = f;
      }
    }
    ros::spinOnce();
  }

  // Leave the robot unloaded: a last all-zero command, given a moment to go out.
  ctl.zero_all();
  if (ros::ok()) {
    torque_pub.publish(torque_message(ctl));
    ros::WallDuration(0.3).sleep();
  }
  restore_terminal();
  const char* why = g_stop_signal  ? "stopped by a signal"
                    : input_closed ? "the terminal closed"
                    : !ros::ok()   ? "ROS shut down"
                                   : "quit";
  std::fprintf(stderr, "teleop: %s; torques zeroed, terminal restored.\n", why);
  ros::shutdown();
  return 0;
}

}  // namespace

namespace se3_ros {

int run_teleop(int argc, char** argv) {
  try {
    return run_node(argc, argv);
  } catch (const std::exception& e) {
    restore_terminal();
    std::fprintf(stderr, "teleop_node: %s\n", e.what());
    return 1;
  }
}

}  // namespace se3_ros
