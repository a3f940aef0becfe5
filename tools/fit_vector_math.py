#!/usr/bin/env python3
"""Coefficients of src/ops/pin_pass/vector_math.h (the fused PIN pass's math).

1. log1p_exp_negative: g(a) = log(1 + exp(-a)) on [0, 16) as one polynomial in
   t = a - i per unit interval [i, i + 1): Chebyshev interpolation
   (near-minimax) of degree DEGREE, converted to monomials in t and rounded to
   float32. Prints the C++ rows (c[k][i] = coefficient of t^k on interval i).
2. sin on |r| <= pi / 2 as r + r^3 q(r^2), q of degree SINE_DEGREE, by least
   squares on the absolute error.
Both with their worst float32 error. Needs numpy: python3 tools/fit_vector_math.py
"""
import numpy as np

INTERVALS, DEGREE = 16, 4
SINE_DEGREE = 3


def g(a):
    return np.log1p(np.exp(-a))


def fit():
    table = np.zeros((DEGREE + 1, INTERVALS), dtype=np.float32)
    for i in range(INTERVALS):
        cheb = np.polynomial.chebyshev.Chebyshev.interpolate(lambda t: g(i + t), DEGREE, domain=[0, 1])
        table[:, i] = cheb.convert(kind=np.polynomial.Polynomial, domain=[0, 1], window=[0, 1]).coef
    return table


def evaluate(table, a):
    """The kernel's float32 arithmetic (Horner in t)."""
    a = a.astype(np.float32)
    clamped = np.minimum(a, np.float32(15.9999))
    i = clamped.astype(np.int32)
    t = clamped - i.astype(np.float32)
    p = table[DEGREE][i]
    for k in range(DEGREE - 1, -1, -1):
        p = p * t + table[k][i]
    return np.where(a < 16, p, np.float32(0))


def fit_sine():
    r = np.linspace(1e-6, np.pi / 2, 200_001)
    basis = np.vander(r * r, SINE_DEGREE + 1, increasing=True) * (r**3)[:, None]
    q, *_ = np.linalg.lstsq(basis, np.sin(r) - r, rcond=None)
    q = q.astype(np.float32)
    x = np.linspace(-np.pi / 2, np.pi / 2, 2_000_001).astype(np.float32)
    x2, p = x * x, q[-1]
    for c in q[-2::-1]:
        p = p * x2 + c
    error = np.abs((x + x * x2 * p).astype(np.float64) - np.sin(x.astype(np.float64))).max()
    return q, error


if __name__ == "__main__":
    q, sine_error = fit_sine()
    print(f"// sine q (r^0 .. r^{2 * SINE_DEGREE}): worst |error| {sine_error:.2e}")
    print(", ".join(f"{v:.9g}f" for v in q))
    table = fit()
    a = np.linspace(0, 20, 2_000_001)
    error = np.abs(evaluate(table, a).astype(np.float64) - g(a.astype(np.float32).astype(np.float64)))
    print(f"// degree {DEGREE}: worst |error| {error.max():.2e} on [0, 20]")
    for k in range(DEGREE + 1):
        print("{" + ", ".join(f"{v:.9g}f" for v in table[k]) + "},")
