#!/usr/bin/python3
"""Publishes fixed transforms for the tests, as tf2_ros's static_transform_publisher would (Debian's
ROS packages do not ship that executable).

    frames_publisher.py [--dynamic] PARENT CHILD X Y Z YAW PITCH ROLL [PARENT CHILD ...]

Transforms before --dynamic go once on /tf_static (latched); those after it on /tf at 20 Hz,
constant (as a robot's odometry publishes them, standing still). Lengths in m, angles in rad.
"""
import math
import sys

import rospy
import tf2_ros
from geometry_msgs.msg import TransformStamped


def transform(parent, child, x, y, z, yaw, pitch, roll):
    t = TransformStamped()
    t.header.frame_id = parent
    t.child_frame_id = child
    t.transform.translation.x, t.transform.translation.y, t.transform.translation.z = x, y, z
    # ZYX Euler angles to a quaternion.
    cy, sy = math.cos(yaw / 2), math.sin(yaw / 2)
    cp, sp = math.cos(pitch / 2), math.sin(pitch / 2)
    cr, sr = math.cos(roll / 2), math.sin(roll / 2)
    t.transform.rotation.w = cr * cp * cy + sr * sp * sy
    t.transform.rotation.x = sr * cp * cy - cr * sp * sy
    t.transform.rotation.y = cr * sp * cy + sr * cp * sy
    t.transform.rotation.z = cr * cp * sy - sr * sp * cy
    return t


def parse(args):
    if len(args) % 8 != 0:
        sys.exit("usage: frames_publisher.py [--dynamic] PARENT CHILD X Y Z YAW PITCH ROLL ...")
    return [transform(args[i], args[i + 1], *map(float, args[i + 2:i + 8]))
            for i in range(0, len(args), 8)]


def main():
    args = rospy.myargv()[1:]
    split = args.index("--dynamic") if "--dynamic" in args else len(args)
    static, dynamic = parse(args[:split]), parse(args[split + 1:])
    rospy.init_node("frames_publisher")
    static_broadcaster = tf2_ros.StaticTransformBroadcaster()
    now = rospy.Time.now()
    for t in static:
        t.header.stamp = now
    static_broadcaster.sendTransform(static)
    broadcaster = tf2_ros.TransformBroadcaster()
    rate = rospy.Rate(20)
    while not rospy.is_shutdown():
        now = rospy.Time.now()
        for t in dynamic:
            t.header.stamp = now
        if dynamic:
            broadcaster.sendTransform(dynamic)
        try:
            rate.sleep()
        except rospy.ROSInterruptException:
            break


if __name__ == "__main__":
    main()
