#!/usr/bin/env python3
"""Figures for the paper reproduction from the JSON written by
`cargo run --release -p ivdyn-lab --example paper_reproduction`.

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
    # y range: the truth +- 1.5 |truth|; for a zero truth, the scale of the nonzero truths
    # with the same unit
    scale = {}
    for b in idx:
        u = unit(names[b])
        t = abs(tr["truth"][b])
        scale[u] = max(scale.get(u, 0.0), t if t > 1e-9 else 0.0)
    for ax, b in zip(axes.flat, idx):
        truth = tr["truth"][b]
        if est != 0:
            ax.semilogx(n, np.array(tr["estimates"][0])[:, b], lw=1.0, color="0.65", label=tr["estimators"][0])
        e = np.array(tr["estimates"][est])[:, b]
        ax.semilogx(n, e, lw=1.4, color="C0", label=tr["estimators"][est])
        ax.axhline(truth, color="k", ls="--", lw=1, label="truth")
        late = np.abs(e[len(e) // 2:] - truth).max() if len(e) else 1.0
        span = abs(truth) if abs(truth) > 1e-9 else (0.5 * scale[unit(names[b])] or 1.5 * late or 1e-3)
        ax.set_ylim(truth - 1.5 * span, truth + 1.5 * span)
        ax.set_title(names[b], fontsize=9)
        ax.set_xlabel("samples N (1 kHz)")
        ax.set_ylabel(unit(names[b]))
        ax.grid(alpha=0.3)
    for ax in list(axes.flat)[len(idx):]:
        ax.axis("off")
    axes.flat[0].legend(fontsize=7)
    fig.suptitle(title)
    fig.tight_layout()
    fig.savefig(fname, dpi=100)
    plt.close(fig)


def fig_montecarlo(mc, fname):
    names = mc["names"]
    runs = mc["runs"]
    idx = [b for b in link6(names) if all(abs(r["truth"][b]) > 1e-9 for r in runs)]
    cps = np.array(mc["checkpoints"])
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
        ax.set_yscale("symlog", linthresh=10)
        ax.set_ylim(-1000, 1000)
        ax.grid(alpha=0.3)
    for ax in list(axes.flat)[len(idx):]:
        ax.axis("off")
    axes.flat[0].legend(fontsize=7)
    fig.suptitle(f"Monte Carlo over {len(runs)} seeds: mean +- std of the error in % of the truth (symlog)")
    fig.tight_layout()
    fig.savefig(fname, dpi=100)
    plt.close(fig)


def tables(mc, out):
    """Markdown tables: mean +- std and the worst seed of the relative error (link-6 combos
    with a nonzero truth), per sample count."""
    names = mc["names"]
    cps = mc["checkpoints"]
    runs = mc["runs"]
    lines = []
    for c, n in enumerate(cps):
        lines.append(f"\n**N = {n}** ({len(runs)} seeds): error in % of the truth, mean +- std [worst seed]\n")
        lines.append("| combination | " + " | ".join(mc["estimators"]) + " |")
        lines.append("|---|" + "---|" * len(mc["estimators"]))
        for b in link6(names):
            if not all(abs(r["truth"][b]) > 1e-9 for r in runs):
                continue
            cells = []
            for k in range(len(mc["estimators"])):
                e = np.array([100 * (r["estimates"][k][c][b] - r["truth"][b]) / abs(r["truth"][b]) for r in runs])
                cells.append(f"{e.mean():+.1f} +- {e.std(ddof=1):.1f} [{np.abs(e).max():.1f}]")
            lines.append(f"| {names[b]} | " + " | ".join(cells) + " |")
    with open(out, "w") as f:
        f.write("\n".join(lines) + "\n")


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--in", dest="inp", default="out/paper")
    ap.add_argument("--out", default="docs/figures")
    a = ap.parse_args()
    os.makedirs(a.out, exist_ok=True)
    with open(os.path.join(a.inp, "traces.json")) as f:
        tr = json.load(f)
    fig_traces(tr, 0, os.path.join(a.out, "fig2_lsm.png"), "Fig. 2 (reproduced): LSM estimates of the link-6 combinations")
    fig_traces(tr, 1, os.path.join(a.out, "fig3_ivm_eq35.png"), "Fig. 3 (reproduced): IVM, eq-35 instrument (LSM in grey)")
    fig_traces(tr, 2, os.path.join(a.out, "fig3_ivm_nominal.png"), "Fig. 3 (variant): IVM, nominal-model instrument (LSM in grey)")
    fig_traces(tr, 3, os.path.join(a.out, "fig3_ivm_planned.png"), "Fig. 3 (variant): IVM, planned-acceleration instrument (LSM in grey)")
    mcf = os.path.join(a.inp, "montecarlo.json")
    if os.path.exists(mcf):
        with open(mcf) as f:
            mc = json.load(f)
        fig_montecarlo(mc, os.path.join(a.out, "paper_montecarlo.png"))
        tables(mc, os.path.join(a.inp, "tables.md"))
    print("wrote", a.out)


if __name__ == "__main__":
    main()
