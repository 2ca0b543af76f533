#!/usr/bin/python3
"""Prints a ComputeEpisode answer, as `rosservice call` prints it (YAML), in a few readable lines:
each impact (time, contacts, impulses), then how the episode ended and each body's outcome.

Usage: scripts/summarize_episode.py ANSWER.yaml [REQUEST.yaml]
With the request, immovable bodies (mass 0) are left out of the outcomes.
"""
import sys

import yaml

SHOWN_IMPACTS = 12  # the rest are counted


def vec(v):
    return "(%+.4f, %+.4f, %+.4f)" % (v.get("x", 0.0), v.get("y", 0.0), v.get("z", 0.0))


def main():
    answer = yaml.safe_load(open(sys.argv[1]))
    request = yaml.safe_load(open(sys.argv[2])) if len(sys.argv) > 2 else {}
    if not answer.get("success"):
        print("failed: %s" % answer.get("message"))
        return 1
    masses = {b["id"]: (b.get("inertia") or {}).get("m", 0.0) for b in request.get("bodies", [])}
    impacts = answer.get("impacts") or []
    for k, impact in enumerate(impacts[:SHOWN_IMPACTS]):
        contacts = impact["contacts"]
        print("impact %d at t = %.2f ms: %d contact%s" % (k + 1, impact["time"] * 1e3, len(contacts),
                                                          "" if len(contacts) == 1 else "s"))
        for contact, impulse in zip(contacts, impact["impulses"]):
            print("  %s on %s at %s m: normal impulse %.4f N s, friction %s N s%s"
                  % (contact["body_b"], contact["body_a"], vec(contact["point"]),
                     impulse["normal_impulse"], vec(impulse["friction_impulse"]),
                     ", sticking" if impulse["sticking"] else ""))
    if len(impacts) > SHOWN_IMPACTS:
        print("... %d more impacts" % (len(impacts) - SHOWN_IMPACTS))
    if answer.get("accumulated_impacts"):
        print("%d more impacts closed as a geometric series (bounces accumulating)"
              % answer["accumulated_impacts"])
    print("end: %s at t = %.2f ms, %d impacts listed; followed in %.1f us"
          % (answer["end_reason"], answer["end_time"] * 1e3, len(impacts),
             answer["solve_time"] * 1e6))
    for body, outcome in zip(answer["bodies"], answer["outcomes"]):
        if masses.get(body["id"], 1.0) == 0.0:
            continue  # immovable
        twist = body["twist"]
        print("%s: %s, v = %s m/s, w = %s rad/s, at z = %.4f m"
              % (body["id"], outcome, vec(twist["linear"]), vec(twist["angular"]),
                 body["pose"]["position"]["z"]))
    for force in answer.get("resting_forces") or []:
        print("  resting contact: normal force %.4f N, friction force %s N%s"
              % (force["normal_force"], vec(force["friction_force"]),
                 ", sticking" if force["sticking"] else ""))
    for warning in answer.get("warnings") or []:
        print("warning: %s" % warning)
    return 0


if __name__ == "__main__":
    sys.exit(main())
