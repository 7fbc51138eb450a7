#!/usr/bin/env python3
"""Score `ivdyn diagnose` on a generated case set (python/tools/make_cad_cases.py) and print a
table: per case, the true effects against the named ones (effect and joint sets), whether the
nominal model was re-fitted, the worst joint's final / oracle RMS and the wall time.

A case is *right* when the named (effect, joint) pairs are exactly the true ones (a payload
counts as one pair with no joint). Oracle RMS: `oracle_rms_exact` (the true effects on the
nominal, wrong model) and `oracle_rms_true_model` (the true effects on the true rigid-body
model: what a perfect diagnosis with a perfect re-fit leaves).

    python python/tools/score_diagnose_cases.py /tmp/cad_cases --part tune [--bin target/release/ivdyn] [--drives | --no-drives]

`--part heldout` runs the held-out third of split.json: run it once, at the end.
"""
import argparse
import json
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time


def pairs(effects):
    """{(effect name, joint)} of a list of diagnosis.json / cases.json effects."""
    out = set()
    for e in effects:
        if e["name"] == "payload" or not e["joints"]:
            out.add((e["name"], ""))
        for j in e["joints"]:
            out.add((e["name"], j))
    return out


def short(p):
    return ", ".join(f"{e}@{j.replace('_joint', '')}" if j else e for e, j in sorted(p)) or "none"


def run_case(binary, manifest, case, tmp, extra=()):
    """`ivdyn diagnose` on one case, with the options its log needs (`diagnose_args`: the
    effort as motor current) and `extra`."""
    out = os.path.join(tmp, case["name"])
    cmd = [binary, "diagnose", "--urdf", case["urdf"], "--base", manifest["base"], "--tip", manifest["tip"],
           "--log", os.path.join(manifest["_dir"], case["log"]), "--out", out, "--no-report",
           *case.get("diagnose_args", []), *extra]
    t0 = time.time()
    res = subprocess.run(cmd, capture_output=True, text=True)
    secs = time.time() - t0
    if res.returncode != 0:
        return None, secs, res.stderr.strip().splitlines()[-1:] or ["failed"]
    with open(os.path.join(out, "diagnosis.json")) as f:
        return json.load(f), secs, []


def vocabulary_args(args):
    """The diagnose flag choosing the effect vocabulary: none leaves it to diagnose (the
    drive effects on logs of at least 20 s with white torque noise)."""
    return ["--drives"] if args.drives else ["--no-drives"] if args.no_drives else []


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("root", help="directory written by make_cad_cases.py (split.json, <robot>/cases.json)")
    ap.add_argument("--part", choices=["tune", "heldout", "all"], default="tune")
    ap.add_argument("--bin", default=os.environ.get("IVDYN_BIN", "target/release/ivdyn"))
    vocab = ap.add_mutually_exclusive_group()
    vocab.add_argument("--drives", action="store_true", help="search the drive vocabulary too (diagnose --drives)")
    vocab.add_argument("--no-drives", action="store_true",
                       help="the basic vocabulary only (diagnose --no-drives); default: as diagnose decides per log")
    args = ap.parse_args(argv)
    with open(os.path.join(args.root, "split.json")) as f:
        split = json.load(f)
    ids = split["tune"] + split["heldout"] if args.part == "all" else split[args.part]
    manifests = {}
    rows, right, ratios, ratios_true, times, false_alarm_clean = [], 0, [], [], [], []
    found = true_pairs = extra = 0
    cpu0 = resource.getrusage(resource.RUSAGE_CHILDREN)
    print("| case | truth | named | missed | extra | refit | final/oracle | final/oracle (true model) | time |")
    print("|---|---|---|---|---|---|---|---|---|")
    with tempfile.TemporaryDirectory() as tmp:
        for cid in ids:
            robot, name = cid.split("/")
            if robot not in manifests:
                with open(os.path.join(args.root, robot, "cases.json")) as f:
                    manifests[robot] = json.load(f)
                manifests[robot]["_dir"] = os.path.join(args.root, robot)
            m = manifests[robot]
            case = next(c for c in m["cases"] if c["name"] == name)
            d, secs, err = run_case(args.bin, m, case, os.path.join(tmp, robot), vocabulary_args(args))
            truth = pairs(case["effects"])
            true_pairs += len(truth)
            if d is None:
                print(f"| {cid} | {short(truth)} | ERROR {err[0]} | | | | | | {secs:.2f} s |")
                continue
            named = pairs(d["effects"])
            ok = named == truth
            right += ok
            found += len(named & truth)
            extra += len(named - truth)
            if not truth:
                false_alarm_clean.append(bool(named))
            worst = max(a / b for a, b in zip(d["final_rms"], case["oracle"]["oracle_rms_exact"]))
            worst_t = max(a / b for a, b in zip(d["final_rms"], case["oracle"]["oracle_rms_true_model"]))
            ratios.append(worst)
            ratios_true.append(worst_t)
            times.append(secs)
            refit = "yes" if d.get("nominal_refit") else "no"
            print(f"| {cid} | {short(truth)} | {short(named)} | {short(truth - named) if truth - named else ''} | "
                  f"{short(named - truth) if named - truth else ''} | {refit} | {worst:.2f} | {worst_t:.2f} | "
                  f"{secs:.2f} s |")
    n = len(ratios)
    cpu1 = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = cpu1.ru_utime - cpu0.ru_utime + cpu1.ru_stime - cpu0.ru_stime
    if n:
        print(f"\n{args.part}: {right} of {len(ids)} cases named exactly right; "
              f"false alarms on {sum(false_alarm_clean)} of {len(false_alarm_clean)} effect-free logs; "
              f"median worst-joint final/oracle {statistics.median(ratios):.2f} "
              f"(true-model oracle {statistics.median(ratios_true):.2f}); "
              f"median time {statistics.median(times):.2f} s (CLI end to end, --no-report); "
              f"true (effect, joint) pairs named {found} of {true_pairs}, extra pairs {extra}; "
              f"CPU of the diagnoses {cpu / len(ids):.2f} s per case (user + sys)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
