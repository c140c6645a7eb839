#!/usr/bin/env python3
"""Plots of the chapter-III device runs (studies/devices/*.toml) from their device.csv files.

    softhom macro studies/devices/cpasmo_gent_coarse.toml --out out/cpasmo_gent      # also _yeoh, _ogden
    softhom macro studies/devices/gripper_coarse.toml --out out/gripper
    softhom macro studies/devices/gripper_creep_ramp3min_coarse.toml --out out/creep3  # also 10, 20 min
    /usr/bin/python3 studies/plot_devices.py out/cpasmo_* out/gripper out/creep* [-o DIR]

Each directory is classified by its summary.json ("device.kind") and its scene name. Writes into DIR
(default studies/figures):
  devices_cpasmo_height.png  maximum height vs pressure, one curve per cPASMO run (Fig. 13b), and the
                             well expansion by region at the last pressure (Fig. 12);
  devices_gripper_angle.png  finger angle vs pressure and vs channel volume change (Fig. 17c, 18a) of
                             the elastic runs, and angle vs pressure of the creep ramps (Fig. 18b).
"""
import csv
import json
import os
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402


def read(path):
    with open(path) as f:
        rows = list(csv.DictReader(f))
    return {k: [float(r[k]) for r in rows] for k in rows[0]} if rows else {}


def label_of(run):
    with open(os.path.join(run, "summary.json")) as f:
        s = json.load(f)
    scene = os.path.splitext(os.path.basename(s.get("scene_file") or run))[0]
    return s.get("device", {}).get("kind", ""), scene, s


def main(argv):
    out = os.path.join(os.path.dirname(os.path.abspath(__file__)), "figures")
    if "-o" in argv:
        i = argv.index("-o")
        out = argv[i + 1]
        del argv[i:i + 2]
    cpasmo, gripper, creep = [], [], []
    for run in argv:
        kind, scene, _ = label_of(run)
        data = read(os.path.join(run, "device.csv"))
        if kind == "cpasmo":
            cpasmo.append((scene, data))
        elif kind == "gripper":
            (creep if "creep" in scene else gripper).append((scene, data))
    os.makedirs(out, exist_ok=True)
    if cpasmo:
        fig, (a, b) = plt.subplots(1, 2, figsize=(10, 4))
        for scene, d in cpasmo:
            a.plot(d["pressure_kPa"], d["max_height_mm"], "o-", label=scene)
            regions = sorted(k for k in d if k.startswith("well_expansion_region"))
            b.plot(range(1, len(regions) + 1), [d[k][-1] for k in regions], "s-", label=scene)
        a.set(xlabel="channel pressure [kPa]", ylabel="maximum height [mm]", title="cPASMO: height vs pressure")
        b.set(xlabel="region (1: outer rim ... 7: centre)", ylabel="well opening area change [%]",
              title="well expansion at the last pressure")
        for ax in (a, b):
            ax.grid(alpha=0.3)
            ax.legend(fontsize=7)
        fig.tight_layout()
        fig.savefig(os.path.join(out, "devices_cpasmo_height.png"), dpi=300)
        print("wrote", os.path.join(out, "devices_cpasmo_height.png"))
    if gripper or creep:
        fig, axes = plt.subplots(1, 3, figsize=(14, 4))
        for scene, d in gripper:
            axes[0].plot(d["pressure_kPa"], d["finger_angle_deg"], "o-", label=scene)
            axes[1].plot(d["channel_volume_change_mm3"], d["finger_angle_deg"], "o-", label=scene)
        for scene, d in creep:
            axes[2].plot(d["t_s"], d["finger_angle_deg"], "o-", label=scene)
        axes[0].set(xlabel="channel pressure [kPa]", ylabel="finger angle α [deg]", title="gripper: angle vs pressure")
        axes[1].set(xlabel="channel volume change [mm³ = µL]", ylabel="finger angle α [deg]", title="angle vs volume change")
        axes[2].set(xlabel="time [s]", ylabel="finger angle α [deg]", title="QLV creep: ramps of 3, 10, 20 min")
        for ax in axes:
            ax.grid(alpha=0.3)
            ax.legend(fontsize=7)
        fig.tight_layout()
        fig.savefig(os.path.join(out, "devices_gripper_angle.png"), dpi=300)
        print("wrote", os.path.join(out, "devices_gripper_angle.png"))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
