#!/usr/bin/env python3
"""Independent optimum for the downlink manager's knapsack test (test-only, host-only).

Generates seeded multiple-knapsack instances and solves each with Martello and Toth's MTM
(the Fortran code wrapped by the PyPI package `mknapsack`), writing one line per instance:

    capacities=c1,c2,... weights=w1,... profits=p1,... optimum=V

`tests/downlink_vs_mtm.rs` reads the committed file and checks that the branch and bound finds
the same optimum. Regenerate (and check the committed file is reproducible) with:

    python3 -m venv /tmp/mknap && /tmp/mknap/bin/pip install mknapsack 'numpy<2'
    /tmp/mknap/bin/python firmware/lander/tests/mtm/crosscheck.py > firmware/lander/tests/mtm/instances.txt

(mknapsack 1.1.12's compiled module needs numpy 1.x.) `LANDER_MKNAPSACK_PYTHON=/tmp/mknap/bin/python
cargo test -p lander --test downlink_vs_mtm -- --ignored` runs this script and compares its output
with the committed file.
"""
import random
import sys

from mknapsack import solve_multiple_knapsack

INSTANCES = 40


def instance(seed):
    rng = random.Random(seed)
    n = rng.randint(14, 21)
    m = rng.randint(2, 3)
    weights = [rng.randint(10, 1000) for _ in range(n)]
    # Uncorrelated profits, as a data product's value is not tied to its size. (Weakly
    # correlated instances of this size are much harder for both solvers: see the README.)
    profits = [rng.randint(10, 1000) for _ in range(n)]
    total = sum(weights)
    capacities = []
    for _ in range(m):
        c = int(total * rng.uniform(0.4, 0.6) / m)
        capacities.append(max(c, max(weights)))
    return capacities, weights, profits


def main():
    for seed in range(INSTANCES):
        capacities, weights, profits = instance(seed)
        assignment = solve_multiple_knapsack(profits, weights, capacities, method="mtm")
        optimum = sum(p for p, k in zip(profits, assignment) if k > 0)
        # The assignment MTM returns must itself be feasible.
        for j in range(len(capacities)):
            load = sum(w for w, k in zip(weights, assignment) if k == j + 1)
            assert load <= capacities[j], (seed, j, load, capacities[j])
        print(
            "capacities=%s weights=%s profits=%s optimum=%d"
            % (
                ",".join(map(str, capacities)),
                ",".join(map(str, weights)),
                ",".join(map(str, profits)),
                optimum,
            )
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
