#!/usr/bin/env python3
"""Derives the constants of src/dynamics/sincos.cpp (needs python3-mpmath; about 3 minutes).

1. pi/2 = P1 + P2 + P3 + P4: P1 the bits 2^0..2^-32, P2 the bits 2^-33..2^-53, P3 the bits
   2^-54..2^-85 (so k P1, k P2, k P3 are exact for k < 2^20), P4 the rest rounded.
2. The smallest |x - k pi/2| over the doubles x next to k pi/2, per binade of k < 2^20: how
   much the argument reduction cancels.
3. Weighted minimax (Remez) fits on z = A^2 in [0, 0.7854^2]:
     sin A = A + A z P(z), P of degree 5, weight: relative error of sin;
     cos A = 1 - z/2 + z^2 Q(z), Q of degree 5, weight: relative error of cos.
   Rounded to doubles one coefficient at a time, refitting the remaining ones each time.
"""
import math

import mpmath as mp

mp.mp.dps = 40
F = 300  # fixed-point bits for the exact integer work


def pi_half_parts():
    with mp.workprec(F + 64):
        ph = int(mp.floor(mp.pi / 2 * mp.mpf(2) ** F))
        exact = mp.pi / 2

        def trunc(bit):  # pi/2 truncated to a multiple of 2^-bit, as a fixed-point integer
            return (ph >> (F - bit)) << (F - bit)

        p1, p12, p123 = trunc(32), trunc(53), trunc(85)
        parts = [p1, p12 - p1, p123 - p12]
        values = [float(mp.mpf(v) / mp.mpf(2) ** F) for v in parts]
        for v, iv in zip(values, parts):
            assert mp.mpf(v) == mp.mpf(iv) / mp.mpf(2) ** F  # exact in a double
        p4 = float(exact - mp.mpf(p123) / mp.mpf(2) ** F)
        tail = exact - sum(mp.mpf(v) for v in values) - mp.mpf(p4)
    for name, v, iv, bit in zip(("P1", "P2", "P3"), values, parts, (32, 53, 85)):
        print("%s = %s  (%d bits)" % (name, v.hex(), (iv >> (F - bit)).bit_length()))
    print("P4 = %s  (pi/2 - P1 - P2 - P3 - P4 = 2^%.1f)" % (p4.hex(), float(mp.log(abs(tail), 2))))
    return ph


def hardest_reductions(ph, kbits=20):
    best = {}
    for k in range(1, 1 << kbits):
        v = k * ph  # k pi/2 in units of 2^-F
        e = v.bit_length() - 1 - F  # 2^e <= k pi/2 < 2^(e+1)
        u = 1 << (F + e - 52)  # ulp of the doubles there, in units of 2^-F
        m = v // u
        for mm in (m, m + 1):
            lr = math.log2(abs(mm * u - v)) - F
            b = k.bit_length()
            if b not in best or lr < best[b][0]:
                best[b] = (lr, k, mm * 2.0 ** (e - 52))
    for b in sorted(best):
        lr, k, x = best[b]
        print("k in [2^%d, 2^%d): min |r| = 2^%.2f at k = %d, x = %r" % (b - 1, b, lr, k, x))


L = mp.mpf("0.7854") ** 2


def fsin(z):  # (sin(sqrt z)/sqrt z - 1)/z
    return mp.fsum((-1) ** n * z ** (n - 1) / mp.factorial(2 * n + 1) for n in range(1, 40))


def wsin(z):
    if z == 0:
        return mp.mpf(0)
    a = mp.sqrt(z)
    return z * a / mp.sin(a)


def fcos(z):  # (cos(sqrt z) - 1 + z/2)/z^2
    return mp.fsum((-1) ** n * z ** (n - 2) / mp.factorial(2 * n) for n in range(2, 40))


def wcos(z):
    return z * z / mp.cos(mp.sqrt(z))


def peval(c, z):
    r = mp.mpf(0)
    for a in reversed(c):
        r = r * z + a
    return r


def remez(f, w, n, iters=10):
    """Coefficients of the degree-n polynomial minimizing max |w (p - f)| on [0, L]."""
    m = n + 2
    ref = [L * (1 - mp.cos(mp.pi * (i + 1) / m)) / 2 for i in range(m)]
    c = None
    for _ in range(iters):
        A = mp.matrix(m, m)
        rhs = mp.matrix(m, 1)
        for i, z in enumerate(ref):
            for j in range(n + 1):
                A[i, j] = z ** j
            A[i, n + 1] = (-1) ** i / w(z)
            rhs[i] = f(z)
        sol = mp.lu_solve(A, rhs)
        c = [sol[j] for j in range(n + 1)]

        def err(z):
            return w(z) * (peval(c, z) - f(z))

        N = 3000
        zs = [L * i / N for i in range(N + 1)]
        es = [err(z) for z in zs]
        ext = []
        for i in range(N + 1):
            v = es[i]
            if v == 0:
                continue
            if (i == 0 or abs(v) >= abs(es[i - 1])) and (i == N or abs(v) >= abs(es[i + 1])):
                lo, hi = zs[max(i - 1, 0)], zs[min(i + 1, N)]
                sgn = 1 if v > 0 else -1
                for _ in range(60):  # golden-section search for the extremum
                    m1, m2 = lo + (hi - lo) * 0.382, lo + (hi - lo) * 0.618
                    if sgn * err(m1) > sgn * err(m2):
                        hi = m2
                    else:
                        lo = m1
                zz = (lo + hi) / 2
                ext.append((zz, err(zz)))
        alt = []  # alternating extrema
        for z, e in ext:
            if alt and (alt[-1][1] > 0) == (e > 0):
                if abs(e) > abs(alt[-1][1]):
                    alt[-1] = (z, e)
            else:
                alt.append((z, e))
        while len(alt) > m:
            alt.pop(0 if abs(alt[0][1]) < abs(alt[-1][1]) else -1)
        if len(alt) != m:
            break
        ref = [z for z, _ in alt]
    return c


def max_error(c, f, w, N=20000):
    return max(abs(w(L * i / N) * (peval(c, L * i / N) - f(L * i / N))) for i in range(N + 1))


def fit_rounded(f, w, n, name):
    fixed = []
    last = None
    for i in range(n):
        fx = list(fixed)

        def g(z, i=i, fx=fx):
            z = z if z != 0 else L * mp.mpf("1e-30")
            return (f(z) - peval(fx, z)) / z ** i

        c = remez(g, lambda z, i=i: w(z) * z ** i, n - i)
        fixed.append(mp.mpf(float(c[0])))
        last = c[1]
    zs = [L * j / 600 for j in range(601)]

    def total(a):
        return max(abs(w(z) * (peval(fixed + [a], z) - f(z))) for z in zs)

    lo, hi = last * (1 - mp.mpf("1e-4")), last * (1 + mp.mpf("1e-4"))
    for _ in range(80):  # the last coefficient by ternary search
        m1, m2 = lo + (hi - lo) / 3, hi - (hi - lo) / 3
        if total(m1) < total(m2):
            hi = m2
        else:
            lo = m1
    fixed.append(mp.mpf(float((lo + hi) / 2)))
    print("%s: relative error 2^%.2f" % (name, float(mp.log(max_error(fixed, f, w), 2))))
    for i, x in enumerate(fixed):
        print("  %s%d = %s" % (name, i + 1, float(x).hex()))


if __name__ == "__main__":
    ph = pi_half_parts()
    print("2/pi = %s" % float(2 / mp.pi).hex())
    hardest_reductions(ph)
    fit_rounded(fsin, wsin, 5, "S")
    fit_rounded(fcos, wcos, 5, "C")
