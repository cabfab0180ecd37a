// The batched sine/cosine of src/dynamics/sincos.h against long double sinl/cosl (64-bit
// mantissa on x86-64): errors in ulps of the double result over random arguments, the doubles
// next to k pi/2 for every k up to the fast-path bound B, and special values; the fallback
// beyond B and for NaN/Inf; odd lengths, unaligned and in-place arrays.
#include <gtest/gtest.h>

#include <algorithm>
#include <cerrno>
#include <cfloat>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>
#include <random>
#include <vector>

#include "../src/dynamics/sincos.h"

namespace {

using se3::detail::kSinCosBound;
using se3::detail::sincos_n;

constexpr long double kHalfPi = 1.570796326794896619231321691639751442L;

/// |got - ref| in ulps of the double binade of ref (subnormal spacing below DBL_MIN).
double ulp_error(double got, long double ref) {
  if (ref == 0) return got == 0 ? 0 : std::numeric_limits<double>::infinity();
  int e;
  std::frexp(ref, &e);  // |ref| in [2^(e-1), 2^e)
  const long double ulp = std::ldexp(1.0L, std::max(e - 53, -1074));
  return static_cast<double>(std::fabs(static_cast<long double>(got) - ref) / ulp);
}

struct MaxError {
  double sin = 0, cos = 0, x_sin = 0, x_cos = 0;
  long count = 0;
  void print(const char* what) const {
    std::printf(
        "sincos_n %s: max error sin %.4f ulp (x = %.17g), cos %.4f ulp (x = %.17g), "
        "%ld arguments\n",
        what, sin, x_sin, cos, x_cos, count);
  }
  double max() const { return std::max(sin, cos); }
};

/// The error budget of src/dynamics/sincos.cpp is 0.70 ulp; a larger error means the
/// implementation no longer does what its analysis says, even while within the 1 ulp contract.
constexpr double kBudget = 0.75;

/// sincos_n over xs in chunks of 1..9 elements (every tail length and offset), each result
/// against sinl/cosl; also |result| <= 1.
MaxError measure(const std::vector<double>& xs) {
  std::vector<double> s(xs.size()), c(xs.size());
  for (size_t i = 0, len = 1; i < xs.size(); i += len, len = len % 9 + 1) {
    const size_t m = std::min(len, xs.size() - i);
    sincos_n(xs.data() + i, static_cast<int>(m), s.data() + i, c.data() + i);
  }
  MaxError r;
  for (size_t i = 0; i < xs.size(); ++i) {
    const long double x = xs[i];
    const double es = ulp_error(s[i], sinl(x)), ec = ulp_error(c[i], cosl(x));
    if (es > r.sin) {
      r.sin = es;
      r.x_sin = xs[i];
    }
    if (ec > r.cos) {
      r.cos = ec;
      r.x_cos = xs[i];
    }
    EXPECT_LE(std::fabs(s[i]), 1.0) << xs[i];
    EXPECT_LE(std::fabs(c[i]), 1.0) << xs[i];
  }
  r.count = static_cast<long>(xs.size());
  return r;
}

std::vector<double> uniform(double lo, double hi, int n, unsigned seed) {
  std::mt19937_64 g(seed);
  std::uniform_real_distribution<double> u(lo, hi);
  std::vector<double> xs(n);
  for (double& x : xs) x = u(g);
  return xs;
}

// The two-lane kernel against its scalar reference (the same algorithm one lane at a time, the
// portable fallback): identical bits on every kind of argument, in every chunk length.
TEST(SinCos, TwoLaneKernelEqualsItsScalarReferenceBitForBit) {
  std::vector<double> xs = uniform(-kSinCosBound, kSinCosBound, 200000, 7);
  for (double r : {M_PI / 4, 10.0, 1e3}) {
    const std::vector<double> u = uniform(-r, r, 100000, 8);
    xs.insert(xs.end(), u.begin(), u.end());
  }
  for (long k = 1; k < 20000; k += 7) {
    const double x = static_cast<double>(k * kHalfPi);
    for (double y : {std::nextafter(x, 0.0), x, std::nextafter(x, 2 * x)}) {
      xs.push_back(y);
      xs.push_back(-y);
    }
  }
  for (double x :
       {0.0, -0.0, 0x1p-1074, -DBL_MIN / 3, 1e-300, 0x1p-27, kSinCosBound,
        std::nextafter(kSinCosBound, 1e300), -3e6, 1e300, std::numeric_limits<double>::infinity(),
        -std::numeric_limits<double>::infinity(), std::numeric_limits<double>::quiet_NaN()}) {
    xs.push_back(x);
  }
  std::vector<double> s(xs.size()), c(xs.size());
  for (size_t i = 0, len = 1; i < xs.size(); i += len, len = len % 9 + 1) {
    const size_t m = std::min(len, xs.size() - i);
    sincos_n(xs.data() + i, static_cast<int>(m), s.data() + i, c.data() + i);
  }
  long differ = 0;
  for (size_t i = 0; i < xs.size(); ++i) {
    double rs, rc;
    se3::detail::sincos_reference(xs[i], &rs, &rc);
    if (std::memcmp(&rs, &s[i], sizeof rs) != 0 || std::memcmp(&rc, &c[i], sizeof rc) != 0) {
      if (++differ < 5) ADD_FAILURE() << "x = " << xs[i] << ": " << s[i] << " " << rs;
    }
  }
  EXPECT_EQ(differ, 0);
  std::printf("sincos_n against sincos_reference: %zu arguments, %ld differ\n", xs.size(), differ);
}

TEST(SinCos, UlpMeasureSeesOneUlp) {
  // The measure the tests rely on: the correctly rounded value is within 0.5 ulp, its
  // neighbours about 1 ulp off, also across a binade edge and for subnormals.
  for (double x : {0.3, 1.0, 2.0, 1e-3, 700.0}) {
    const long double ref = sinl(static_cast<long double>(x));
    const double d = static_cast<double>(ref);
    EXPECT_LE(ulp_error(d, ref), 0.5);
    EXPECT_GT(ulp_error(std::nextafter(d, 2.0), ref), 0.5);
    EXPECT_GT(ulp_error(std::nextafter(d, -2.0), ref), 0.5);
    EXPECT_LT(ulp_error(std::nextafter(d, 2.0), ref), 1.5);
  }
  EXPECT_EQ(ulp_error(1.0, 1.0L - 0x1p-60L), std::ldexp(1.0, -7));  // 2^-60 in ulps of 2^-53
  EXPECT_EQ(ulp_error(0x1p-1073, 0x1p-1074L), 1.0);
}

TEST(SinCos, RandomArgumentsWithinOneUlp) {
  const struct {
    const char* name;
    double range;
    int n;
  } ranges[] = {{"[-pi/4, pi/4]", M_PI / 4, 1000000},
                {"[-pi, pi]", M_PI, 2000000},
                {"[-10, 10]", 10, 2000000},
                {"[-1e3, 1e3]", 1e3, 2000000},
                {"[-B, B]", kSinCosBound, 2000000}};
  unsigned seed = 1;
  for (const auto& r : ranges) {
    const MaxError e = measure(uniform(-r.range, r.range, r.n, seed++));
    e.print(r.name);
    EXPECT_LE(e.max(), 1.0) << r.name;
    EXPECT_LE(e.max(), kBudget) << r.name;
  }
  // Magnitudes spread over 2^-40 .. 2^20 (every binade of the reduction), both signs.
  std::mt19937_64 g(99);
  std::uniform_real_distribution<double> u(-40, 20);
  std::vector<double> xs(1000000);
  for (size_t i = 0; i < xs.size(); ++i) {
    const double v = std::min(std::exp2(u(g)), kSinCosBound);
    xs[i] = i % 2 ? v : -v;
  }
  const MaxError e = measure(xs);
  e.print("log-uniform 2^-40..B");
  EXPECT_LE(e.max(), 1.0);
  EXPECT_LE(e.max(), kBudget);
}

TEST(SinCos, NearMultiplesOfHalfPiWithinOneUlp) {
  // The doubles nearest k pi/2 and two neighbours each side, for every k with k pi/2 <= B:
  // the largest cancellation in the argument reduction (the worst, |x - k pi/2| = 2^-60.5,
  // is x = 45.553093477052, k = 29). Also their negatives for small k.
  std::vector<double> xs;
  const long kmax = static_cast<long>(kSinCosBound / kHalfPi);
  for (long k = 1; k <= kmax; ++k) {
    double x = static_cast<double>(k * kHalfPi);
    x = std::nextafter(std::nextafter(x, 0.0), 0.0);
    for (int j = 0; j < 5; ++j, x = std::nextafter(x, 2 * x)) {
      if (x <= kSinCosBound) xs.push_back(x);
      if (k < 1000) xs.push_back(-x);
    }
  }
  xs.push_back(45.553093477052);
  const MaxError e = measure(xs);
  e.print("next to k pi/2, k <= B 2/pi");
  EXPECT_LE(e.max(), 1.0);
  EXPECT_LE(e.max(), kBudget);
}

TEST(SinCos, ZerosTinyAndSubnormals) {
  const double tiny[] = {0x1p-1074, 0x1p-1060, DBL_MIN / 3, DBL_MIN, 1e-300, 1e-100,
                         1e-20,     0x1p-30,   0x1p-27,     0x1p-26, 1e-8};
  for (double t : tiny) {
    for (double x : {t, -t}) {
      double s, c;
      sincos_n(&x, 1, &s, &c);
      EXPECT_EQ(s, x) << x;  // sin x rounds to x for |x| <= 2^-26
      if (std::fabs(x) <= 0x1p-27) {
        EXPECT_EQ(c, 1.0) << x;
      }
      EXPECT_LE(ulp_error(c, cosl(static_cast<long double>(x))), 1.0) << x;
    }
  }
  const double zeros[] = {0.0, -0.0};
  double s[2], c[2];
  sincos_n(zeros, 2, s, c);
  EXPECT_EQ(s[0], 0.0);
  EXPECT_FALSE(std::signbit(s[0]));
  EXPECT_EQ(s[1], 0.0);
  EXPECT_TRUE(std::signbit(s[1]));  // sin(-0) = -0
  EXPECT_EQ(c[0], 1.0);
  EXPECT_EQ(c[1], 1.0);
  sincos_n(zeros + 1, 1, s, c);  // the one-element tail
  EXPECT_TRUE(std::signbit(s[0]) && s[0] == 0.0);
  EXPECT_EQ(c[0], 1.0);
}

TEST(SinCos, BoundAndFallback) {
  const double B = kSinCosBound, inf = std::numeric_limits<double>::infinity();
  const double nan = std::numeric_limits<double>::quiet_NaN();
  // In range up to B (fast path), std::sin/std::cos beyond, NaN for NaN/Inf; mixed in one
  // array so that fast and fallback lanes share pairs.
  const std::vector<double> xs = {B,
                                  std::nextafter(B, 0.0),
                                  -B,
                                  std::nextafter(B, inf),
                                  -std::nextafter(B, inf),
                                  0.5,
                                  2 * B,
                                  1e7,
                                  -3.0,
                                  1e22,
                                  DBL_MAX,
                                  -DBL_MAX,
                                  1.0,
                                  nan,
                                  inf,
                                  -inf,
                                  2.0,
                                  -nan};
  std::vector<double> s(xs.size()), c(xs.size());
  errno = 0;
  sincos_n(xs.data(), static_cast<int>(xs.size()), s.data(), c.data());
  EXPECT_EQ(errno, 0);
  for (size_t i = 0; i < xs.size(); ++i) {
    const double x = xs[i];
    if (std::isnan(x) || std::isinf(x)) {
      EXPECT_TRUE(std::isnan(s[i]) && std::isnan(c[i])) << x;
    } else if (std::fabs(x) <= B) {
      EXPECT_LE(ulp_error(s[i], sinl(static_cast<long double>(x))), 1.0) << x;
      EXPECT_LE(ulp_error(c[i], cosl(static_cast<long double>(x))), 1.0) << x;
    } else {
      EXPECT_EQ(s[i], std::sin(x)) << x;
      EXPECT_EQ(c[i], std::cos(x)) << x;
    }
  }
  // Every element alone (pairs, the one-element tail and the fallback loop give the same bits).
  for (size_t i = 0; i < xs.size(); ++i) {
    double s1, c1;
    sincos_n(&xs[i], 1, &s1, &c1);
    EXPECT_EQ(std::memcmp(&s1, &s[i], sizeof s1), 0) << xs[i];
    EXPECT_EQ(std::memcmp(&c1, &c[i], sizeof c1), 0) << xs[i];
  }
}

TEST(SinCos, LengthsAlignmentAndInPlace) {
  const std::vector<double> xs = uniform(-20, 20, 64, 7);
  std::vector<double> s_ref(xs.size()), c_ref(xs.size());
  for (size_t i = 0; i < xs.size(); ++i) sincos_n(&xs[i], 1, &s_ref[i], &c_ref[i]);
  for (size_t i = 0; i < xs.size(); ++i) {
    EXPECT_LE(ulp_error(s_ref[i], sinl(static_cast<long double>(xs[i]))), 1.0);
    EXPECT_LE(ulp_error(c_ref[i], cosl(static_cast<long double>(xs[i]))), 1.0);
  }
  // n = 0..9 and 64 at offsets 0..3 doubles (8 but not 16 byte aligned for odd offsets):
  // the same bits as one at a time, nothing written outside [0, n).
  const double guard = -7.0;
  for (int n : {0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 64}) {
    for (int off = 0; off < 4; ++off) {
      std::vector<double> in(80, 0.25), s(80, guard), c(80, guard);
      std::copy(xs.begin(), xs.begin() + n, in.begin() + off);
      sincos_n(in.data() + off, n, s.data() + off, c.data() + off);
      for (int i = 0; i < 80; ++i) {
        if (i >= off && i < off + n) {
          EXPECT_EQ(s[i], s_ref[i - off]) << "n " << n << " off " << off << " i " << i;
          EXPECT_EQ(c[i], c_ref[i - off]) << "n " << n << " off " << off << " i " << i;
        } else {
          EXPECT_EQ(s[i], guard) << "n " << n << " off " << off << " i " << i;
          EXPECT_EQ(c[i], guard) << "n " << n << " off " << off << " i " << i;
        }
      }
    }
  }
  // In place: s is x, then c is x; with a fallback lane too.
  for (int which = 0; which < 2; ++which) {
    std::vector<double> in(xs.begin(), xs.begin() + 9), other(9);
    in[4] = 1e9;
    const double s4 = std::sin(1e9), c4 = std::cos(1e9);
    if (which == 0) {
      sincos_n(in.data(), 9, in.data(), other.data());
    } else {
      sincos_n(in.data(), 9, other.data(), in.data());
    }
    const std::vector<double>& s = which == 0 ? in : other;
    const std::vector<double>& c = which == 0 ? other : in;
    for (int i = 0; i < 9; ++i) {
      EXPECT_EQ(s[i], i == 4 ? s4 : s_ref[i]) << "in place " << which << " i " << i;
      EXPECT_EQ(c[i], i == 4 ? c4 : c_ref[i]) << "in place " << which << " i " << i;
    }
  }
}

}  // namespace

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
