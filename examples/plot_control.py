"""Figures of docs/control.md from the JSON written by the control_fig5 example.

    cargo run --release -p ivdyn-lab --example control_fig5
    .venv/bin/python examples/plot_control.py [out/control] [docs/figures]
"""
import json
import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

src = Path(sys.argv[1] if len(sys.argv) > 1 else "out/control")
dst = Path(sys.argv[2] if len(sys.argv) > 2 else "docs/figures")
dst.mkdir(parents=True, exist_ok=True)
STYLE = {
    "pd": ("tab:gray", "-"),
    "pd_gravity": ("tab:brown", "-"),
    "ct_nominal": ("tab:red", "-"),
    "ct_estimated": ("tab:blue", "-"),
    "ct_true": ("k", "--"),
}


def events(ax, d):
    ax.axvline(d["grasp_time"], color="tab:green", lw=0.8, ls=":")
    if d["switch_time"] is not None:
        ax.axvline(d["switch_time"], color="tab:blue", lw=0.8, ls=":")


for name, joint in [("paper", 2), ("panda", 2)]:
    f = src / f"{name}.json"
    if not f.exists():
        print(f"skip {f}")
        continue
    d = json.loads(f.read_text())
    runs = {r["key"]: r for r in d["runs"]}
    fig, axs = plt.subplots(3, 1, figsize=(8, 9), sharex=True)
    t = np.array(runs["ct_true"]["t"])
    qd = np.array(runs["ct_true"]["q_des"])[:, joint]
    axs[0].plot(t, qd, "k", lw=1, label="desired")
    for k in ["pd", "ct_nominal", "ct_estimated"]:
        r = runs[k]
        axs[0].plot(r["t"], np.array(r["q"])[:, joint], color=STYLE[k][0], lw=0.8, label=r["label"])
    axs[0].set_ylabel(f"joint {joint + 1} position (rad)")
    axs[0].legend(fontsize=8, loc="upper right")
    for k, r in runs.items():
        e = 1e3 * np.array(r["err"])[:, joint]
        axs[1].plot(r["t"], e, color=STYLE[k][0], ls=STYLE[k][1], lw=0.8, label=r["label"])
    axs[1].set_ylabel(f"joint {joint + 1} error (mrad)")
    axs[1].legend(fontsize=8, loc="upper right")
    for k in ["ct_nominal", "ct_estimated", "ct_true"]:
        r = runs[k]
        e = 1e3 * np.array(r["err"])[:, joint]
        axs[2].plot(r["t"], e, color=STYLE[k][0], ls=STYLE[k][1], lw=0.8, label=r["label"])
    sw = d["switch_time"] or d["grasp_time"]
    bt = np.array(runs["ct_nominal"]["t"])
    be = 1e3 * np.abs(np.array(runs["ct_nominal"]["err"])[:, joint])
    lim = 1.2 * be[bt >= sw].max()
    axs[2].set_ylim(-lim, lim)
    axs[2].set_ylabel(f"joint {joint + 1} error (mrad), zoom")
    axs[2].set_xlabel("time (s)")
    axs[2].legend(fontsize=8, loc="upper right")
    for ax in axs:
        events(ax, d)
        ax.grid(alpha=0.3)
    fig.suptitle(
        f"{name}: {d['payload_mass']} kg payload grasped at {d['grasp_time']} s (green), "
        f"switch to the estimate at {sw:.2f} s (blue)",
        fontsize=10,
    )
    fig.tight_layout()
    fig.savefig(dst / f"control_fig5_{name}.png", dpi=120)
    plt.close(fig)

    es = d["estimates"]
    b = es["mass_index"]
    if b is not None and es["t"]:
        te = np.array(es["t"])
        th = np.array(es["theta"])[:, b]
        sd = np.array(es["mass_std"])
        fig, ax = plt.subplots(figsize=(8, 3.5))
        ax.plot(te, th, color="tab:blue", lw=1, label="IV estimate (planned-acceleration instrument)")
        ok = np.isfinite(sd)
        ax.fill_between(te[ok], (th - 2 * sd)[ok], (th + 2 * sd)[ok], color="tab:blue", alpha=0.2, label="+- 2 std (from P)")
        m = d["payload_mass"]
        ax.axhline(m, color="k", lw=0.8, label="true payload mass")
        ax.axhspan(0.95 * m, 1.05 * m, color="tab:green", alpha=0.15, label="+- 5 %")
        events(ax, d)
        ax.set_ylim(-0.5 * m, 2.0 * m)
        ax.set_xlabel("time (s)")
        ax.set_ylabel("estimated payload mass (kg)")
        ax.set_title(f"{name}: online estimate of the payload mass (change of the last link)", fontsize=10)
        ax.legend(fontsize=8, loc="lower right")
        ax.grid(alpha=0.3)
        fig.tight_layout()
        fig.savefig(dst / f"control_estimate_{name}.png", dpi=120)
        plt.close(fig)
    print(f"wrote {dst}/control_fig5_{name}.png, control_estimate_{name}.png")
