#!/usr/bin/python3
"""Prints a ComputeResponse answer, as `rosservice call` prints it (YAML), in a few readable lines.

Usage: scripts/summarize_response.py ANSWER.yaml [REQUEST.yaml]
With the request, the restitution of each contact is shown beside its normal velocities.
"""
import sys

import yaml


def vec(v):
    return "(%+.4f, %+.4f, %+.4f)" % (v.get("x", 0.0), v.get("y", 0.0), v.get("z", 0.0))


def main():
    answer = yaml.safe_load(open(sys.argv[1]))
    request = yaml.safe_load(open(sys.argv[2])) if len(sys.argv) > 2 else {}
    if not answer.get("success"):
        print("failed: %s" % answer.get("message"))
        return 1
    contacts = list(request.get("contacts") or []) + list(answer.get("detected_contacts") or [])
    masses = {b["id"]: (b.get("inertia") or {}).get("m", 0.0) for b in request.get("bodies", [])}
    for body in answer["bodies"]:
        if masses.get(body["id"], 1.0) == 0.0:
            continue  # immovable: its velocity is prescribed
        twist = body["twist"]
        print("%s after the impact: v = %s m/s, w = %s rad/s"
              % (body["id"], vec(twist["linear"]), vec(twist["angular"])))
    for i, impulse in enumerate(answer["impulses"]):
        contact = contacts[i] if i < len(contacts) else {}
        name = "contact %d" % i
        if contact:
            name += " (%s on %s)" % (contact["body_b"], contact["body_a"])
        frictionless = contact and not contact.get("static_friction") and not contact.get(
            "dynamic_friction")
        state = "sticking" if impulse["sticking"] else "frictionless" if frictionless else "sliding"
        print("%s: normal impulse %.4f N s, friction impulse %s N s, %s"
              % (name, impulse["normal_impulse"], vec(impulse["friction_impulse"]), state))
        restitution = " (e = %g)" % contact["restitution"] if "restitution" in contact else ""
        print("  normal velocity at the point: %+.4f m/s before, %+.4f m/s after%s"
              % (impulse["normal_velocity_before"], impulse["normal_velocity_after"], restitution))
    print("kinetic energy: %.4f J before, %.4f J after; solved by %s in %.1f us"
          % (answer["kinetic_energy_before"], answer["kinetic_energy_after"],
             ", ".join(island["method"] for island in answer["islands"]) or "nothing",
             answer["solve_time"] * 1e6))
    for warning in answer.get("warnings") or []:
        print("warning: %s" % warning)
    return 0


if __name__ == "__main__":
    sys.exit(main())
