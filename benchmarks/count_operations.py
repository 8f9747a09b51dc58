"""Print our counted operations next to the paper's formulas (a Markdown table).

    python benchmarks/count_operations.py > /tmp/counts.md

Counts come from running the kernels on counting numbers
(:func:`manipcad.operation_counts`); the paper's are its formulas (section 4).
"""

from __future__ import annotations

import numpy as np

from manipcad import operation_counts

PAPER = {
    "rnea": (lambda n: 95 * n - 101, lambda n: 84 * n - 97),
    "aba": (lambda n: 249 * n - 272, lambda n: 231 * n - 294),
    "crba": (lambda n: n**3 / 6 + 9 / 2 * n**2 + 544 / 3 * n - 155,
             lambda n: n**3 / 6 + 7 / 2 * n**2 + 499 / 3 * n - 159),
}
NOTE = {"crba": "paper: mass matrix + Cholesky solve; ours: mass matrix only"}


def linear_fit(algorithm: str, key: str) -> tuple[int, int]:
    """(slope, intercept) of our count, exact for the O(n) algorithms."""
    a, b = (operation_counts(algorithm, n)[key] for n in (5, 6))
    return b - a, a - 5 * (b - a)


def main() -> None:
    print("| algorithm | n | ours mul | ours add | paper mul | paper add |")
    print("|---|---|---|---|---|---|")
    for alg in ("rnea", "aba", "crba"):
        for n in (6, 7, 20, 100):
            c = operation_counts(alg, n)
            pm, pa = (int(np.rint(f(n))) for f in PAPER[alg])
            print(f"| {alg} | {n} | {c['mul']} | {c['add']} | {pm} | {pa} |")
    print()
    for alg in ("rnea", "aba"):
        (sm, im), (sa, ia) = linear_fit(alg, "mul"), linear_fit(alg, "add")
        print(f"- {alg}: ours mul = {sm}n {im:+d}, add = {sa}n {ia:+d}")
    for alg, note in NOTE.items():
        print(f"- {alg}: {note}")


if __name__ == "__main__":
    main()
