#!/usr/bin/python3
"""Example client of collision_response: two spheres meet head on, first alone through ~compute,
then as a batch of scenes through ~compute_batch.

Usage: example_client.py [SERVER_NAMESPACE]   (default /collision_response)
Prints the post-impact velocities; exits 1 if the service fails or disagrees with the closed form.
"""
import sys

import rospy
from collision_response.msg import BodyState, Contact, Scene
from collision_response.srv import ComputeBatch, ComputeBatchRequest, ComputeResponse, ComputeResponseRequest


def sphere(body_id, mass, x, vx):
    body = BodyState(id=body_id)
    body.inertia.m = mass
    body.inertia.ixx = body.inertia.iyy = body.inertia.izz = 0.4 * mass * 0.1 ** 2  # R = 0.1 m
    body.pose.position.x = x
    body.pose.orientation.w = 1.0
    body.twist.linear.x = vx
    return body


def shown(x):
    """x for printing: rounded to 6 decimals, without a negative zero."""
    return round(x, 6) + 0.0


def head_on(v1):
    """1 kg at v1 against 2 kg at -1 m/s, e = 0.5, contact at the origin, normal +x."""
    contact = Contact(body_a="left", body_b="right", restitution=0.5)
    contact.normal.x = 1.0
    return [sphere("left", 1.0, -0.1, v1), sphere("right", 2.0, 0.1, -1.0)], [contact]


def main():
    server = sys.argv[1] if len(sys.argv) > 1 else "/collision_response"
    rospy.init_node("collision_response_example_client", anonymous=True)
    rospy.wait_for_service(server + "/compute", timeout=30.0)
    compute = rospy.ServiceProxy(server + "/compute", ComputeResponse)
    compute_batch = rospy.ServiceProxy(server + "/compute_batch", ComputeBatch)

    request = ComputeResponseRequest()
    request.header.frame_id = "world"
    request.bodies, request.contacts = head_on(2.0)
    response = compute(request)
    if not response.success:
        print("compute failed: " + response.message)
        return 1
    left, right = (b.twist.linear.x for b in response.bodies)
    print("single: left %.6f m/s, right %.6f m/s, impulse %.6f N s"
          % (shown(left), shown(right), shown(response.impulses[0].normal_impulse)))
    ok = abs(left + 1.0) < 1e-9 and abs(right - 0.5) < 1e-9  # closed form: -1 and 0.5 m/s

    batch = ComputeBatchRequest()
    batch.header.frame_id = "world"  # scenes with an empty frame take it
    for v1 in (1.0, 2.0, 3.0):
        scene = Scene()
        scene.bodies, scene.contacts = head_on(v1)
        batch.scenes.append(scene)
    answer = compute_batch(batch)
    if not answer.success:
        print("compute_batch failed: " + answer.message)
        return 1
    for v1, result in zip((1.0, 2.0, 3.0), answer.results):
        left, right = (b.twist.linear.x for b in result.bodies)
        # momentum p = v1 - 2, separation 0.5 (v1 + 1): v1' = (p - 1 (v1 + 1)) / 3
        expected = ((v1 - 2.0) - (v1 + 1.0)) / 3.0
        print("batch v1=%.1f: left %.6f m/s, right %.6f m/s" % (v1, shown(left), shown(right)))
        ok = ok and result.success and abs(left - expected) < 1e-9
    print("closed form: " + ("OK" if ok else "MISMATCH"))
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
