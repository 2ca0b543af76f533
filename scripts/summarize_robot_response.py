#!/usr/bin/env python3
"""Prints a robot answer of /collision_response/compute (rosservice's YAML) in a few lines: each
robot's joint-velocity jump, the bodies' post-impact velocities, and the contacts on the robots'
links with their impulses and effective masses: 1 / (n^T W n), the mass of the contact's two bodies
together along its normal (the robot's reflected mass and the struck body's combined as
1 / (1/m_robot + 1/m_body), not the robot's own; docs/robots.md). Usage:
summarize_robot_response.py ANSWER.yaml"""
import math
import sys

import yaml


def vector(v):
    return "(" + ", ".join("%+.3f" % v[k] for k in ("x", "y", "z")) + ")"


def main():
    with open(sys.argv[1]) as f:
        answer = yaml.safe_load(f)
    if not answer.get("success"):
        print("the node rejected the request: %s" % answer.get("message"))
        return 1
    for robot in answer["robots"]:
        after, before = robot["joint_state"], robot["joint_state_before"]
        print("robot %s: joint velocities before -> after [rad/s] (generalized impulse [N m s])" %
              robot["name"])
        for name, v0, v1, p in zip(after["name"], before["velocity"], after["velocity"],
                                   after["effort"]):
            if abs(v1 - v0) > 1e-12 or abs(v0) > 1e-12:
                print("  %-20s %+.4f -> %+.4f  (jump %+.4f, %+.4f)" % (name, v0, v1, v1 - v0, p))
        print("  kinetic energy %.4f J -> %.4f J" %
              (robot["kinetic_energy_before"], robot["kinetic_energy_after"]))
    for body in answer["bodies"]:
        if body["inertia"]["m"] > 0:
            print("body %s: velocity after %s m/s, angular %s rad/s" %
                  (body["id"], vector(body["twist"]["linear"]), vector(body["twist"]["angular"])))
    contacts = answer["detected_contacts"]
    masses = answer["effective_masses"]
    impulses = answer["impulses"]
    robots = [r["name"] + "/" for r in answer["robots"]]

    def on_robot(c):
        return any(b.startswith(r) for r in robots for b in (c["body_a"], c["body_b"]))

    listed = [k for k, c in enumerate(contacts) if on_robot(c)]
    others = {}
    for c in contacts:
        if not on_robot(c):
            pair = "%s - %s" % (c["body_a"], c["body_b"])
            others[pair] = others.get(pair, 0) + 1
    print("contacts: %d found from the shapes (where a face touches a face: one per corner of the"
          " touching area)" % len(contacts))
    if others:
        print("  %s: not listed (no robot link)" %
              ", ".join("%d %s" % (n, pair) for pair, n in sorted(others.items())))
    print("  %d on the robot's links, each with its effective mass 1 / (n^T W n): the mass of both"
          " bodies together along the normal, not the robot's own reflected mass:" % len(listed))
    for k in listed:
        c, m, j = contacts[k], masses[k], impulses[k]
        mass = "inf" if isinstance(m, str) or math.isinf(m) else "%.3f kg" % m
        print("    %s - %s: effective mass %s, normal impulse %.4f N s, normal velocity %+.3f -> %+.3f m/s" %
              (c["body_a"], c["body_b"], mass, j["normal_impulse"], j["normal_velocity_before"],
               j["normal_velocity_after"]))
    idle = sum(1 for k in listed if impulses[k]["normal_impulse"] == 0)
    if idle:
        print("  %d of them carry no impulse: the impulses at the others make them separate anyway"
              % idle)
    return 0


if __name__ == "__main__":
    sys.exit(main())
