#!/usr/bin/env python3
"""Fig. 3 of the paper (one panel: link 6's Izz) from Python: recursive LSM and IVM
estimates on the simulated arm, in about ten lines. Writes out/python_paper_zz6.png.

    .venv/bin/python examples/python_paper.py
"""
import os

import matplotlib

matplotlib.use("Agg")
import ivdyn  # noqa: E402

sim = ivdyn.paper.setup(seed=0)                          # nominal-error seed 0
n = ivdyn.paper.log_points(100, 100_000, per_decade=20)  # sample counts (1 kHz)
est = ivdyn.paper.recursive_traces(0, 0, n)              # (4 estimators, len(n), 18)
ax = ivdyn.plot.paper_traces(sim.base_names, sim.truth_base, n, est, ivdyn.paper.ESTIMATORS,
                             estimator=1, param="link6.Izz")   # IVM (eq-35) over LSM in grey
ax.set_ylabel("kg m^2")
ax.figure.tight_layout()
os.makedirs("out", exist_ok=True)
ax.figure.savefig("out/python_paper_zz6.png", dpi=100)
b = sim.base_names.index("link6.Izz")
print(f"ZZ6 truth {sim.truth_base[b]:.4g}; after {n[-1]} samples:",
      ", ".join(f"{lab} {est[k, -1, b]:.4g}" for k, lab in enumerate(ivdyn.paper.ESTIMATORS)))
print("wrote out/python_paper_zz6.png")
