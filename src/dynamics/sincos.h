// Batched sine and cosine of joint angles for the dynamics hot paths (joint_transforms needs
// cos q_i and sin q_i of every joint first). Two lanes at a time (SSE2 on x86-64, NEON on arm64),
// no FMA needed.
#pragma once

namespace se3 {
namespace detail {

/// Bound B of the fast path: for |x| <= kSinCosBound every result is within 1 ulp of the
/// correctly rounded sin/cos (error budget 0.70 ulp, measured max 0.67 ulp against long double,
/// test/gtest_sincos.cpp). Beyond B the element gets std::sin/std::cos; NaN/Inf give NaN (as
/// std::sin/std::cos) without touching errno.
constexpr double kSinCosBound = 1048576.0;  // 2^20

/// s[i] = sin(x[i]), c[i] = cos(x[i]) for 0 <= i < n (n <= 0: nothing). Pure, thread-safe, no
/// allocation. Any alignment. s or c may be the same array as x (in place); other overlaps are
/// not allowed. sin(+-0) = +-0, sin(x) = x for tiny x (subnormals too), results in [-1, 1].
void sincos_n(const double* x, int n, double* s, double* c);

/// The same for one element, one lane at a time: sincos_n's results bit for bit (the scalar
/// reference of its two-lane kernel, test/gtest_sincos.cpp).
void sincos_reference(double x, double* s, double* c);

}  // namespace detail
}  // namespace se3
