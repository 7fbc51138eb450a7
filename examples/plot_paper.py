#!/usr/bin/env python3
"""Figures for the paper reproduction from the JSON written by
`cargo run --release -p ivdyn --example paper_reproduction`.

Usage: python examples/plot_paper.py [--in out/paper] [--out docs/figures]
"""
import argparse
import json
import os

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

UNITS = {"m*c": "kg m", "I": "kg m^2", "fc": "N m", "fv": "N m s/rad", "m": "kg"}


def unit(name):
    last = name.split(".")[-1] if "+" not in name and "-" not in name[1:] else name
    for k, u in UNITS.items():
        if k in last:
            return u
    return ""


def link6(names):
    return [i for i, n in enumerate(names) if "link6" in n or "joint6" in n]


def fig_traces(tr, est, fname, title):
    names = tr["names"]
    idx = link6(names)
    n = np.array(tr["n"])
    cols = 3
    rows = int(np.ceil(len(idx) / cols))
    fig, axes = plt.subplots(rows, cols, figsize=(4.2 * cols, 2.9 * rows), squeeze=False)
    for ax, b in zip(axes.flat, idx):
        truth = tr["truth"][b]
        e = np.array(tr["estimates"][est])[:, b]
        ax.semilogx(n, e, lw=1.4, label=tr["estimators"][est])
        ax.axhline(truth, color="k", ls="--", lw=1, label="truth")
        span = max(abs(truth), 1e-6)
        ax.set_ylim(truth - 1.5 * span, truth + 1.5 * span)
        ax.set_title(names[b], fontsize=9)
        ax.set_xlabel("samples N (1 kHz)")
        ax.set_ylabel(unit(names[b]))
        ax.grid(alpha=0.3)
    for ax in list(axes.flat)[len(idx):]:
        ax.axis("off")
    axes.flat[0].legend(fontsize=8)
    fig.suptitle(title)
    fig.tight_layout()
    fig.savefig(fname, dpi=110)
    plt.close(fig)


def fig_montecarlo(mc, fname):
    names = mc["names"]
    idx = link6(names)
    cps = np.array(mc["checkpoints"])
    runs = mc["runs"]
    cols = 3
    rows = int(np.ceil(len(idx) / cols))
    fig, axes = plt.subplots(rows, cols, figsize=(4.2 * cols, 2.9 * rows), squeeze=False)
    for ax, b in zip(axes.flat, idx):
        for k, label in enumerate(mc["estimators"]):
            err = np.array([[100 * (r["estimates"][k][c][b] - r["truth"][b]) / abs(r["truth"][b])
                             for c in range(len(cps))] for r in runs])
            ax.errorbar(cps * (1 + 0.06 * (k - 1)), err.mean(0), yerr=err.std(0, ddof=1), capsize=3,
                        marker="o", ms=3, lw=1.2, label=label)
        ax.axhline(0, color="k", lw=0.8)
        ax.set_xscale("log")
        ax.set_title(names[b], fontsize=9)
        ax.set_xlabel("samples N")
        ax.set_ylabel("error (% of truth)")
        ax.set_ylim(-150, 150)
        ax.grid(alpha=0.3)
    for ax in list(axes.flat)[len(idx):]:
        ax.axis("off")
    axes.flat[0].legend(fontsize=7)
    fig.suptitle(f"Monte Carlo over {len(runs)} seeds: mean +- std of the relative error")
    fig.tight_layout()
    fig.savefig(fname, dpi=110)
    plt.close(fig)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--in", dest="inp", default="out/paper")
    ap.add_argument("--out", default="docs/figures")
    a = ap.parse_args()
    os.makedirs(a.out, exist_ok=True)
    with open(os.path.join(a.inp, "traces.json")) as f:
        tr = json.load(f)
    fig_traces(tr, 0, os.path.join(a.out, "fig2_lsm.png"), "Fig. 2 (reproduced): LSM estimates of the link-6 combinations")
    fig_traces(tr, 1, os.path.join(a.out, "fig3_ivm_eq35.png"), "Fig. 3 (reproduced): IVM, eq-35 instrument")
    fig_traces(tr, 2, os.path.join(a.out, "fig3_ivm_planned.png"), "Fig. 3 (variant): IVM, planned-acceleration instrument")
    mcf = os.path.join(a.inp, "montecarlo.json")
    if os.path.exists(mcf):
        with open(mcf) as f:
            fig_montecarlo(json.load(f), os.path.join(a.out, "paper_montecarlo.png"))
    print("wrote", a.out)


if __name__ == "__main__":
    main()
