#!/usr/bin/python3
"""Plots identify's predicted against measured velocities after each impact (docs/calibration.md).

    plot_identification.py DATA.csv OUT.png

DATA.csv is the file identify writes beside its --plot PNG. For object landings: one row per
landing, the measured velocities and those predicted with the coefficients fitted on all landings
("fitted") and on the folds without the landing ("held_out", empty without cross-validation); two
panels, linear and angular. For a robot's impacts (a "joint" column): one row per joint and
impact, its velocity after the impact measured, "fitted" and "held_out" as above; one panel, a
colour per joint. Exits 3 with a message if matplotlib is missing.
"""
import csv
import sys


def main():
    if len(sys.argv) != 3:
        sys.exit("usage: plot_identification.py DATA.csv OUT.png")
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        print("plot_identification.py: matplotlib is missing (apt-get install python3-matplotlib);"
              " no plot", file=sys.stderr)
        sys.exit(3)
    with open(sys.argv[1], newline="") as f:
        rows = list(csv.DictReader(f))
    if not rows:
        sys.exit("plot_identification.py: %s has no landings or impacts" % sys.argv[1])
    if "joint" in rows[0]:
        fig = plot_joints(plt, rows)
    else:
        fig = plot_landings(plt, rows)
    fig.tight_layout()
    fig.savefig(sys.argv[2], dpi=100)
    print("plot_identification.py: wrote %s" % sys.argv[2])


def plot_joints(plt, rows):
    """A robot's impacts: each joint's velocity after each impact, predicted against measured."""
    kind = "held_out" if all(r["held_out"] != "" for r in rows) else "fitted"
    fig, ax = plt.subplots(figsize=(5.6, 5.2))
    joints = list(dict.fromkeys(r["joint"] for r in rows))
    colours = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    lo, hi = 0.0, 0.0
    for i, joint in enumerate(joints):
        m = [float(r["measured"]) for r in rows if r["joint"] == joint]
        p = [float(r[kind]) for r in rows if r["joint"] == joint]
        ax.scatter(m, p, s=14, alpha=0.7, color=colours[i % len(colours)], label=joint)
        lo, hi = min(lo, *m, *p), max(hi, *m, *p)
    ax.plot([lo, hi], [lo, hi], "k--", linewidth=0.8)
    ax.set_xlabel("measured after the impact [rad/s; m/s for a prismatic joint]")
    ax.set_ylabel("predicted (%s)" % kind.replace("_", "-"))
    ax.set_aspect("equal", adjustable="datalim")
    ax.legend(title="joint")
    impacts = len({(r["pair"], r["source"]) for r in rows})
    fig.suptitle("identify: %d robot impacts, %s predictions" % (impacts, kind.replace("_", "-")))
    return fig


def plot_landings(plt, rows):
    """Object landings: linear and angular velocities after each landing."""
    held = all(r["held_out_vx"] != "" for r in rows)
    kind = "held_out" if held else "fitted"
    fig, axes = plt.subplots(1, 2, figsize=(10, 4.8))
    for ax, prefix, unit, title in ((axes[0], "v", "m/s", "linear velocity"),
                                    (axes[1], "w", "rad/s", "angular velocity")):
        lo, hi = 0.0, 0.0
        for axis, colour in zip("xyz", ("tab:red", "tab:green", "tab:blue")):
            m = [float(r["measured_%s%s" % (prefix, axis)]) for r in rows]
            p = [float(r["%s_%s%s" % (kind, prefix, axis)]) for r in rows]
            ax.scatter(m, p, s=8, alpha=0.6, color=colour, label=axis)
            lo, hi = min(lo, *m, *p), max(hi, *m, *p)
        ax.plot([lo, hi], [lo, hi], "k--", linewidth=0.8)
        ax.set_xlabel("measured after the landing [%s]" % unit)
        ax.set_ylabel("predicted (%s) [%s]" % (kind.replace("_", "-"), unit))
        ax.set_title(title)
        ax.set_aspect("equal", adjustable="datalim")
        ax.legend()
    fig.suptitle("identify: %d landings, %s predictions" % (len(rows), kind.replace("_", "-")))
    return fig


if __name__ == "__main__":
    main()
