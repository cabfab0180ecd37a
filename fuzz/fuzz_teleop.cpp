// The teleop terminal decoder (InputDecoder: keys, escape sequences, X10 mouse) and the
// controller it drives. Bytes are fed in pieces split at each 0xff byte (a read() boundary);
// the torques must stay finite and within each joint's limit, the panel must render.
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <string_view>
#include <vector>

#include "se3_sim/teleop/teleop.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace se3::teleop;
  std::vector<JointInfo> joints(3);
  for (int i = 0; i < 3; ++i) {
    joints[i].name = "j" + std::to_string(i);
    joints[i].limit = i == 2 ? 0.5 : 10.0 * (i + 1);
  }
  Controller c(joints);
  InputDecoder dec;
  std::vector<Event> events;
  const auto* p = reinterpret_cast<const char*>(data);
  double now = 0;
  size_t start = 0;
  for (size_t i = 0; i <= size; ++i) {
    if (i < size && data[i] != 0xff) continue;
    events.clear();
    dec.feed(std::string_view(p + start, i - start), events);
    if (i == size) dec.flush(events);
    now += 0.01;
    c.handle(events, now);
    c.update(now);
    start = i + 1;
  }
  for (size_t k = 0; k < joints.size(); ++k) {
    const double t = c.torques()[k];
    if (!std::isfinite(t) || std::abs(t) > joints[k].limit * (1 + 1e-12)) std::abort();
  }
  (void)c.panel();
  (void)c.take_camera_commands();
  return 0;
}
