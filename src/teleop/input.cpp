// Terminal input decoder: a byte-at-a-time state machine (ground, ESC, CSI, SS3, X10 mouse).
#include <cstdlib>

#include "se3_sim/teleop/teleop.h"

namespace se3 {
namespace teleop {

namespace {

constexpr unsigned char kEsc = 0x1b;

bool is_param_byte(unsigned char c) {
  return c >= 0x30 && c <= 0x3f;
}  // 0-9 : ; < = > ?
bool is_intermediate_byte(unsigned char c) {
  return c >= 0x20 && c <= 0x2f;
}  // space ! " # ... /
bool is_final_byte(unsigned char c) {
  return c >= 0x40 && c <= 0x7e;
}

/// Parses "a;b;c" (decimal, non-negative) into exactly three numbers.
bool parse_three(std::string_view s, int v[3]) {
  int k = 0;
  std::size_t i = 0;
  while (k < 3) {
    if (i >= s.size() || s[i] < '0' || s[i] > '9') return false;
    long value = 0;
    while (i < s.size() && s[i] >= '0' && s[i] <= '9') {
      value = value * 10 + (s[i] - '0');
      if (value > 1000000) return false;
      ++i;
    }
    v[k++] = static_cast<int>(value);
    if (k < 3) {
      if (i >= s.size() || s[i] != ';') return false;
      ++i;
    }
  }
  return i == s.size();
}

bool digits_and_semicolons(std::string_view s) {
  for (char c : s)
    if (!((c >= '0' && c <= '9') || c == ';')) return false;
  return true;
}

bool arrow(unsigned char final_byte, KeyCode& code) {
  switch (final_byte) {
    case 'A':
      code = KeyCode::Up;
      return true;
    case 'B':
      code = KeyCode::Down;
      return true;
    case 'C':
      code = KeyCode::Right;
      return true;
    case 'D':
      code = KeyCode::Left;
      return true;
    default:
      return false;
  }
}

}  // namespace

Event Event::make_key(KeyCode code, char ch) {
  Event e;
  e.type = Type::Key;
  e.key.code = code;
  e.key.ch = ch;
  return e;
}

Event Event::make_mouse(const MouseEvent& m) {
  Event e;
  e.type = Type::Mouse;
  e.mouse = m;
  return e;
}

MouseEvent decode_mouse_code(int code, int x, int y, bool release) {
  MouseEvent m;
  m.x = x;
  m.y = y;
  m.shift = (code & 4) != 0;
  m.alt = (code & 8) != 0;
  m.ctrl = (code & 16) != 0;
  const bool motion = (code & 32) != 0;
  const int low = code & 3;
  if (code & 64) {  // wheel (64..67); with 128 too these are buttons 10/11: treat alike
    static const MouseAction wheel[4] = {MouseAction::WheelUp, MouseAction::WheelDown,
                                         MouseAction::WheelLeft, MouseAction::WheelRight};
    m.action = wheel[low];
    m.button = MouseButton::None;
    return m;
  }
  if (code & 128) {
    m.button = MouseButton::None;  // extra buttons 8 and 9: no meaning here
  } else {
    static const MouseButton buttons[4] = {MouseButton::Left, MouseButton::Middle,
                                           MouseButton::Right, MouseButton::None};
    m.button = buttons[low];
  }
  m.action = release ? MouseAction::Release : motion ? MouseAction::Motion : MouseAction::Press;
  return m;
}

std::vector<Event> InputDecoder::feed(std::string_view bytes) {
  std::vector<Event> out;
  feed(bytes, out);
  return out;
}

void InputDecoder::reset() {
  state_ = State::Ground;
  seq_.clear();
  x10_count_ = 0;
}

void InputDecoder::flush(std::vector<Event>& out) {
  if (state_ == State::Escape) out.push_back(Event::make_key(KeyCode::Escape));
  reset();
}

void InputDecoder::ground(unsigned char c, std::vector<Event>& out) {
  if (c == kEsc) {
    state_ = State::Escape;
  } else if (c == '\t') {
    out.push_back(Event::make_key(KeyCode::Tab));
  } else if (c == '\r' || c == '\n') {
    out.push_back(Event::make_key(KeyCode::Enter));
  } else if (c == 0x7f || c == 0x08) {
    out.push_back(Event::make_key(KeyCode::Backspace));
  } else if (c >= 0x20 && c < 0x7f) {
    out.push_back(Event::make_key(KeyCode::Char, static_cast<char>(c)));
  } else if (c < 0x20) {
    out.push_back(Event::make_key(KeyCode::Control, static_cast<char>(c)));
  }
  // Bytes >= 0x80 (UTF-8 text, 8-bit controls) have no meaning here and are dropped.
}

void InputDecoder::feed(std::string_view bytes, std::vector<Event>& out) {
  for (char ch : bytes) {
    const auto c = static_cast<unsigned char>(ch);
    switch (state_) {
      case State::Ground:
        ground(c, out);
        break;

      case State::Escape:
        if (c == '[') {
          state_ = State::Csi;
          seq_.clear();
        } else if (c == 'O') {
          state_ = State::Ss3;
          seq_.clear();
        } else {
          // The ESC stood alone (Escape key, or Alt+key): report it and decode c afresh.
          out.push_back(Event::make_key(KeyCode::Escape));
          state_ = State::Ground;
          ground(c, out);
        }
        break;

      case State::Csi:
        if (is_param_byte(c) || is_intermediate_byte(c)) {
          // An over-long sequence is still consumed up to its final byte, but not stored:
          // its content no longer matters because it cannot be one we understand.
          if (seq_.size() <= kMaxSequence) seq_.push_back(static_cast<char>(c));
        } else if (is_final_byte(c)) {
          if (c == 'M' && seq_.empty()) {
            state_ = State::X10Mouse;
            x10_count_ = 0;
          } else {
            finish_csi(c, out);
            state_ = State::Ground;
          }
        } else {
          // A control byte, DEL or a high byte cannot be part of a CSI sequence: drop what
          // was collected and decode this byte as new input.
          state_ = State::Ground;
          ground(c, out);
        }
        break;

      case State::Ss3:
        if (is_param_byte(c)) {
          if (seq_.size() <= kMaxSequence) seq_.push_back(static_cast<char>(c));
        } else if (is_final_byte(c)) {
          KeyCode code;
          if (arrow(c, code)) out.push_back(Event::make_key(code));
          state_ = State::Ground;
        } else {
          state_ = State::Ground;
          ground(c, out);
        }
        break;

      case State::X10Mouse:
        if (c < 0x20) {  // each of the three bytes is value + 32: a control byte breaks it
          state_ = State::Ground;
          ground(c, out);
          break;
        }
        x10_[x10_count_++] = c;
        if (x10_count_ == 3) {
          finish_x10(out);
          state_ = State::Ground;
        }
        break;
    }
  }
}

void InputDecoder::finish_csi(unsigned char final_byte, std::vector<Event>& out) {
  const std::string_view s(seq_);
  if (s.size() > kMaxSequence) return;
  if ((final_byte == 'M' || final_byte == 'm') && !s.empty() && s[0] == '<') {
    int v[3];
    if (parse_three(s.substr(1), v) && v[1] >= 1 && v[2] >= 1)
      out.push_back(Event::make_mouse(decode_mouse_code(v[0], v[1], v[2], final_byte == 'm')));
    return;
  }
  if (!digits_and_semicolons(s)) return;  // private sequences (ESC [ ? ..., ESC [ > ...)
  KeyCode code;
  if (arrow(final_byte, code)) {
    out.push_back(Event::make_key(code));
  } else if (final_byte == 'Z' && s.empty()) {
    out.push_back(Event::make_key(KeyCode::BackTab));
  }
  // Everything else (F-keys, Home/End, Insert/Delete/Page keys, focus reports, cursor
  // position reports) is recognised as a complete sequence and ignored.
}

void InputDecoder::finish_x10(std::vector<Event>& out) {
  const int code = x10_[0] - 32;
  const int x = x10_[1] - 32;
  const int y = x10_[2] - 32;
  if (x < 1 || y < 1) return;
  const bool release = (code & 3) == 3 && (code & (32 | 64)) == 0;
  MouseEvent m = decode_mouse_code(code, x, y, release);
  if (release) {
    // X10 reports do not say which button went up: it is the one that went down last.
    m.button = x10_last_button_;
    x10_last_button_ = MouseButton::None;
  } else if (m.action == MouseAction::Press) {
    x10_last_button_ = m.button;
  }
  out.push_back(Event::make_mouse(m));
}

}  // namespace teleop
}  // namespace se3
