"""Plots of docs/real-data.md: measured vs predicted joint torque on the validation data.

    .venv/bin/python examples/plot_real_data.py --in out/real --out docs/figures

Reads tx40.json and lwr.json written by `cargo run --release -p ivdyn-lab --example real_data`.
"""
import argparse
import json
import os

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402


def plot(rep, path):
    n = len(rep["joints"])
    s = rep["series"]
    t = np.asarray(s["t"])
    meas = np.asarray(s["measured"]).reshape(len(t), n)
    pred = np.asarray(s["predicted"]).reshape(len(t), n)
    cons = s.get("predicted_consistent")
    cons = None if cons is None else np.asarray(cons).reshape(len(t), n)
    cols = 2
    rows = (n + 1) // cols
    fig, axes = plt.subplots(rows, cols, figsize=(11, 2.3 * rows), sharex=True)
    for j, ax in enumerate(axes.flat):
        if j >= n:
            ax.axis("off")
            continue
        ax.plot(t, meas[:, j], "k-", lw=1.0, label="measured")
        ax.plot(t, pred[:, j], "C1--", lw=1.0, label=f"predicted ({rep['method']})")
        if cons is not None:
            ax.plot(t, cons[:, j], "C2:", lw=1.2, label="predicted, physically consistent")
        ax.set_title(
            f"{rep['joints'][j]}: R² {rep['validation']['r2'][j]:.3f} (floor {rep['floor_r2'][j]:.2f}), "
            f"RMS {rep['validation']['rms'][j]:.2f} N m"
            + ("" if cons is None else f"; consistent R² {rep['consistent']['validation']['r2'][j]:.3f}"),
            fontsize=9,
        )
        ax.set_ylabel("N m", fontsize=8)
        ax.tick_params(labelsize=8)
    axes.flat[0].legend(fontsize=8)
    for ax in axes[-1]:
        ax.set_xlabel("t [s]", fontsize=8)
    fig.suptitle(f"{rep['dataset']}: validation ({rep['method']}; {rep['split']})", fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    print("wrote", path)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--in", dest="inp", default="out/real")
    ap.add_argument("--out", default="docs/figures")
    a = ap.parse_args()
    os.makedirs(a.out, exist_ok=True)
    for name in ("tx40", "lwr"):
        with open(os.path.join(a.inp, f"{name}.json")) as f:
            plot(json.load(f), os.path.join(a.out, f"real_{name}_validation.png"))


if __name__ == "__main__":
    main()
