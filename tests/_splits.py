"""Graded panel cuts for the oracle quadratures of the flat and tube lights' tests."""


def graded_splits(lo, hi, at, width, ratio, count) -> list:
    """`lo`, `hi` and the points `at` and `at +- width * ratio^k` (k < count) inside (lo, hi):
    panels that shrink geometrically toward `at`, where the integrand peaks over `width`, so
    each panel resolves its part (plain floats or mpmath numbers)."""
    pts = {lo, hi}
    for k in range(count):
        for x in (at - width * ratio**k, at, at + width * ratio**k):
            if lo < x < hi:
                pts.add(x)
    return sorted(pts)
