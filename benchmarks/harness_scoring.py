"""Speed of version-consistency scoring (thesis eqs. 4.2-4.4) on a 1,000,000-point trajectory.

Goal: below 0.1 s. Prints the best of several repetitions for the bare score (equal step axes) and for a
comparison whose run stopped early (step axes aligned by intersection first).

    python benchmarks/harness_scoring.py
"""
import time

import numpy as np

from harness.analysis.consistency import compare_trajectory, score

N = 1_000_000


def best_of(function, repeat=7) -> float:
    times = []
    for _ in range(repeat):
        start = time.perf_counter()
        function()
        times.append(time.perf_counter() - start)
    return min(times)


def main():
    rng = np.random.default_rng(0)
    steps = np.arange(N, dtype=float) * 100
    reference = np.cumsum(rng.normal(size=N))
    run = reference + rng.normal(scale=0.01, size=N)
    bare = best_of(lambda: score(reference, run))
    same_axis = best_of(lambda: compare_trajectory("thermo", "thermo", "ke", steps, reference, steps, run))
    early = best_of(lambda: compare_trajectory("thermo", "thermo", "ke", steps, reference, steps[: N - 1000],
                                               run[: N - 1000]))
    print(f"score(), {N:,} points:                        {bare * 1e3:7.1f} ms (goal < 100 ms)")
    print(f"compare_trajectory, same step axis:            {same_axis * 1e3:7.1f} ms")
    print(f"compare_trajectory, run stopped early (align): {early * 1e3:7.1f} ms")


if __name__ == "__main__":
    main()
