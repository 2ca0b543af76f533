#!/usr/bin/python3
"""Writes test/data/cube_tosses/tosses.bag: a few of the real cube tosses as a user would record them.

The tosses are rows of benchmark/data/cube_tosses/tosses.csv.gz (columns toss,t,x,y,z,qw,qx,qy,qz;
z up; the ContactNets data set, BSD 3-Clause: benchmark/data/cube_tosses/README.md and LICENSE),
published unchanged, one after another in the bag: toss number k of TOSSES (k = 0, 1, ...)
starts at START + SPACING * k seconds, its sample at CSV time t stamped START + SPACING * k + t
(t is written to 1 us in the CSV: the stamps are exact in nanoseconds), each sample twice:

  /tf        tf2_msgs/TFMessage, one transform world -> cube (the cube's pose in the world frame)
  /cube/pose geometry_msgs/PoseStamped, header.frame_id world (the same pose)

with the bag's receive time equal to the stamp. The numbers are the CSV's decimal values parsed as
doubles, so a reader recovers them exactly. Deterministic: the same CSV gives the same bytes.

TOSSES are the six tosses of at most 100 frames, lowest index first, whose first landing the
benchmark can use (a flight of at least 6 frames before the first contact, and a clear flight of at
least 4 frames starting within 0.15 s after it; the criteria of benchmark/toss_data.h, simplified).

Usage: scripts/make_tosses_bag.py [--check | --held-out N]
  --check       print the chosen tosses, write nothing
  --held-out N  print toss N's first landing as the README's calibration section uses it, write
                nothing: the cube's state at the last frame before the first contact (a ballistic
                fit to the flight before it: gravity fixed, constant angular velocity) with the
                table moved to z = 0, and the measured state after the landing (the same fit to
                the first clear flight after it, at its first frame)
Needs python3-rosbag, python3-tf2-msgs, python3-geometry-msgs (Debian).
"""
import csv
import gzip
import math
import os
import sys

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
CSV = os.path.join(REPO, "benchmark", "data", "cube_tosses", "tosses.csv.gz")
BAG = os.path.join(REPO, "test", "data", "cube_tosses", "tosses.bag")
START = 100  # [s] the first toss's first stamp (not 0: a zero stamp means "latest" to tf)
SPACING = 10  # [s] between the tosses' first stamps (every toss lasts under 3 s)
COUNT = 6
MAX_FRAMES = 100
HALF_WIDTH = 0.0524  # [m] the cube's half side
CLEARANCE = 0.002  # [m]


def read_tosses():
    tosses = {}
    with gzip.open(CSV, "rt", newline="") as f:
        for row in csv.DictReader(f):
            tosses.setdefault(int(row["toss"]), []).append(row)
    return tosses


def lowest_corner(row):
    w, x, y, z = (float(row[k]) for k in ("qw", "qx", "qy", "qz"))
    # third row of the rotation matrix: the world z of the body axes
    r = (2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y))
    return float(row["z"]) - HALF_WIDTH * sum(abs(c) for c in r)


def usable(rows):
    """The simplified extraction criteria (see the module's doc)."""
    heights = [lowest_corner(r) for r in rows]
    rest = sorted(heights[-10:])
    table = 0.5 * (rest[4] + rest[5])
    flying = [h > table + CLEARANCE for h in heights]
    if False not in flying:
        return False
    contact = flying.index(False)
    if contact < 6:
        return False
    t_contact = float(rows[contact]["t"])
    i = contact
    while i < len(rows) and float(rows[i]["t"]) <= t_contact + 0.15:
        if flying[i] and all(flying[i:i + 4]) and i + 4 <= len(rows):
            return True
        i += 1
    return False


def quaternion_product(a, b):
    w1, x1, y1, z1 = a
    w2, x2, y2, z2 = b
    return (w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2, w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
            w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2, w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2)


def rotation_vector(q):
    n = math.sqrt(sum(c * c for c in q))
    q = [c / n for c in q]
    if q[0] < 0:
        q = [-c for c in q]
    s = math.sqrt(sum(c * c for c in q[1:]))
    angle = 2 * math.atan2(s, q[0])
    return [0.0, 0.0, 0.0] if s < 1e-12 else [angle * c / s for c in q[1:]]


def ballistic_fit(rows, frames, t_ref):
    """Least squares over the frames: the centre p + v (t - t_ref) + g/2 (t - t_ref)^2 (g = -9.81
    along z), the rotation exp(w (t - t_ref)) q_ref with q_ref the frame at t_ref. Returns p, v,
    w, q_ref and the centre's RMS residual [m]."""
    t = [float(rows[i]["t"]) - t_ref for i in frames]
    n, st, stt = len(t), sum(t), sum(x * x for x in t)
    p, v, squares = [], [], 0.0
    for c in "xyz":
        y = [float(rows[i][c]) - (0.5 * -9.81 * s * s if c == "z" else 0.0)
             for i, s in zip(frames, t)]
        sy, sty = sum(y), sum(a * b for a, b in zip(t, y))
        v.append((n * sty - st * sy) / (n * stt - st * st))
        p.append((sy - v[-1] * st) / n)
        squares += sum((p[-1] + v[-1] * s - yy) ** 2 for s, yy in zip(t, y))
    ref = min(range(n), key=lambda j: abs(t[j]))
    q_ref = [float(rows[frames[ref]][k]) for k in ("qw", "qx", "qy", "qz")]
    inverse = (q_ref[0], -q_ref[1], -q_ref[2], -q_ref[3])
    turns = [rotation_vector(quaternion_product([float(rows[i][k]) for k in ("qw", "qx", "qy", "qz")],
                                                inverse)) for i in frames]
    w = [sum(s * r[k] for s, r in zip(t, turns)) / stt for k in range(3)]
    return p, v, w, q_ref, math.sqrt(squares / n)


def held_out(rows):
    heights = [lowest_corner(r) for r in rows]
    rest = sorted(heights[-10:])
    table = 0.5 * (rest[4] + rest[5])
    flying = [h > table + CLEARANCE for h in heights]
    contact = flying.index(False)
    before = float(rows[contact - 1]["t"])
    p, v, w, q, rms = ballistic_fit(rows, list(range(max(0, contact - 30), contact)), before)
    print("table at z = %.5f m; first contact at frame %d; the fit over the %d frames before: "
          "RMS %.1e m" % (table, contact, min(contact, 30), rms))
    print("before (t = %.6f s, lowest corner %.4f m above the table):" % (before, heights[contact - 1] - table))
    print("  position (%.4f, %.4f, %.4f), orientation w %.7f x %.7f y %.7f z %.7f"
          % (p[0], p[1], p[2] - table, q[0], q[1], q[2], q[3]))
    print("  v (%.3f, %.3f, %.3f) m/s, w (%.2f, %.2f, %.2f) rad/s" % (tuple(v) + tuple(w)))
    first = contact
    while not (first + 4 <= len(rows) and all(flying[first:first + 4])):
        first += 1
    last = first
    while last < len(rows) and flying[last] and last < first + 30:
        last += 1
    after = float(rows[first]["t"])
    p, v, w, q, rms = ballistic_fit(rows, list(range(first, last)), after)
    print("after (t = %.6f s, %.4f s later; the fit over %d frames: RMS %.1e m):"
          % (after, after - before, last - first, rms))
    print("  v (%.3f, %.3f, %.3f) m/s, w (%.2f, %.2f, %.2f) rad/s" % (tuple(v) + tuple(w)))


def chosen(tosses):
    return [n for n in sorted(tosses) if len(tosses[n]) <= MAX_FRAMES and usable(tosses[n])][:COUNT]


def main():
    tosses = read_tosses()
    if "--held-out" in sys.argv[1:]:
        held_out(tosses[int(sys.argv[sys.argv.index("--held-out") + 1])])
        return 0
    picks = chosen(tosses)
    print("tosses %s (%d samples)" % (picks, sum(len(tosses[n]) for n in picks)))
    if "--check" in sys.argv[1:]:
        return 0
    import rosbag
    import rospy
    from geometry_msgs.msg import PoseStamped, TransformStamped
    from tf2_msgs.msg import TFMessage

    os.makedirs(os.path.dirname(BAG), exist_ok=True)
    with rosbag.Bag(BAG, "w", compression=rosbag.Compression.BZ2) as bag:
        seq = 0
        for k, n in enumerate(picks):
            for row in tosses[n]:
                micro = int(round(float(row["t"]) * 1e6))
                nanos = (START + SPACING * k) * 10**9 + micro * 1000
                stamp = rospy.Time(nanos // 10**9, nanos % 10**9)
                x, y, z, qw, qx, qy, qz = (float(row[c]) for c in ("x", "y", "z", "qw", "qx", "qy", "qz"))
                transform = TransformStamped()
                transform.header.seq = seq
                transform.header.stamp = stamp
                transform.header.frame_id = "world"
                transform.child_frame_id = "cube"
                transform.transform.translation.x, transform.transform.translation.y, \
                    transform.transform.translation.z = x, y, z
                r = transform.transform.rotation
                r.w, r.x, r.y, r.z = qw, qx, qy, qz
                bag.write("/tf", TFMessage(transforms=[transform]), stamp)
                pose = PoseStamped()
                pose.header = transform.header
                pose.pose.position.x, pose.pose.position.y, pose.pose.position.z = x, y, z
                o = pose.pose.orientation
                o.w, o.x, o.y, o.z = qw, qx, qy, qz
                bag.write("/cube/pose", pose, stamp)
                seq += 1
    print("wrote %s (%d bytes)" % (os.path.relpath(BAG, REPO), os.path.getsize(BAG)))
    return 0


if __name__ == "__main__":
    sys.exit(main())
