// The four-lane AVX loops (chosen at run time) against SSE2's two: a test hashes its results'
// bits, and when it runs on the AVX path it runs its own binary again with SE3_SIM_NO_AVX=1 and
// compares that run's hash with its own. The test binary's main sets self() from argv[0].
#pragma once

#include <gtest/gtest.h>

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>

namespace se3_test {

/// This test binary's path (set by main).
inline const char*& self() {
  static const char* path = nullptr;
  return path;
}

/// The bits of some doubles, as one number (FNV-1a over their bytes).
struct BitsHash {
  std::uint64_t h = 1469598103934665603ull;
  void add(const double* x, std::size_t n) {
    const auto* b = reinterpret_cast<const unsigned char*>(x);
    for (std::size_t k = 0; k < n * sizeof(double); ++k) h = (h ^ b[k]) * 1099511628211ull;
  }
  template <class M>
  void add(const M& a) {
    add(a.data(), static_cast<std::size_t>(a.size()));
  }
};

/// Runs this binary's test `name` with SE3_SIM_NO_AVX=1 and reads the number it printed after
/// "bits " (false: the run failed or printed none).
inline bool bits_on_the_sse2_path(const std::string& name, unsigned long long& bits) {
  if (!self()) return false;
  const std::string cmd =
      std::string("SE3_SIM_NO_AVX=1 '") + self() + "' --gtest_filter=" + name + " 2>/dev/null";
  FILE* out = popen(cmd.c_str(), "r");
  if (!out) return false;
  char line[256];
  bool found = false;
  while (std::fgets(line, sizeof line, out)) {
    const char* at = std::strstr(line, "bits ");
    found = found || (at && std::sscanf(at, "bits %llx", &bits) == 1);
  }
  return pclose(out) == 0 && found;
}

/// Under SE3_SIM_NO_AVX prints h; otherwise expects the SSE2 run of test `name` to print h.
inline void expect_same_bits_on_the_sse2_path(const std::string& name, std::uint64_t h) {
  if (std::getenv("SE3_SIM_NO_AVX")) {
    std::printf("bits %016llx\n", static_cast<unsigned long long>(h));
    return;
  }
  unsigned long long other = 0;
  ASSERT_TRUE(bits_on_the_sse2_path(name, other)) << "the SSE2 run of " << name << " failed";
  EXPECT_EQ(other, static_cast<unsigned long long>(h)) << name;
}

}  // namespace se3_test
