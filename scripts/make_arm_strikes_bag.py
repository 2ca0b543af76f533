#!/usr/bin/python3
"""Writes test/data/arm_strikes/strikes.bag: the synthetic arm strikes as a user would record them.

The strikes are test/data/arm_strikes/strike_<k>.csv (columns t,shoulder,elbow: time [s] and the
joint positions [rad] of the 2R arm of test/calibration/striking_arm.urdf striking the fixed sphere
of test/data/arm_strikes/post.yaml; made by test_robot_identification, see the folder's README),
published one after another on /joint_states as sensor_msgs/JointState (name [shoulder, elbow],
position the CSV's values, no velocity or effort): strike k at CSV time t is stamped
START + SPACING * k + t seconds, with the bag's receive time equal to the stamp, so that the
strikes are apart by untracked time (the arm moved back) that identify cuts the stream at.
Deterministic: the same CSV files give the same bytes.

Usage: scripts/make_arm_strikes_bag.py
Needs python3-rosbag, python3-sensor-msgs (Debian).
"""
import csv
import os

import genpy
import rosbag
from sensor_msgs.msg import JointState

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
FOLDER = os.path.join(REPO, "test", "data", "arm_strikes")
BAG = os.path.join(FOLDER, "strikes.bag")
START = 100  # [s] the first strike's first stamp (not 0: an unset stamp)
SPACING = 10  # [s] between the strikes' first stamps (each lasts 0.3 s)
COUNT = 6


def main():
    with rosbag.Bag(BAG, "w", compression=rosbag.Compression.BZ2) as bag:
        for k in range(COUNT):
            with open(os.path.join(FOLDER, "strike_%d.csv" % k), newline="") as f:
                reader = csv.reader(f)
                header = next(reader)
                names = header[1:]
                for row in reader:
                    # Stamps in integer nanoseconds: t is a multiple of 2 ms.
                    stamp = genpy.Time(0, int(round((START + SPACING * k + float(row[0])) * 1e9)))
                    message = JointState()
                    message.header.stamp = stamp
                    message.name = names
                    message.position = [float(v) for v in row[1:]]
                    bag.write("/joint_states", message, stamp)
    print("wrote %s" % BAG)


if __name__ == "__main__":
    main()
