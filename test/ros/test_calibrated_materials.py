#!/usr/bin/python3
"""The launch argument `materials` (calibrated_materials.test), as the README's calibration section
uses it: the file's ~materials replace the shipped table while the other parameters of
config/collision_response.yaml stay, and a detected contact between the two materials gets the
file's coefficients (read here from the file itself), in the node and in the nodelet."""
import os
import unittest

import genpy
import rospkg
import rospy
import rostest
import yaml
from collision_response.srv import ComputeResponse, ComputeResponseRequest

PACKAGE = rospkg.RosPack().get_path("collision_response")
SERVERS = ["/node/collision_response", "/nodelet/collision_response"]


def load(path):
    with open(os.path.join(PACKAGE, path)) as f:
        return yaml.safe_load(f)


def drop(material_a, material_b):
    """A 1 kg cube of side 0.1 m falling flat at 1 m/s onto a plane: four detected contacts."""
    request = ComputeResponseRequest()
    genpy.message.fill_message_args(request, [{
        "header": {"frame_id": "world"},
        "bodies": [
            {"id": "floor", "material": material_b, "pose": {"orientation": {"w": 1.0}},
             "planes": [{"coef": [0.0, 0.0, 1.0, 0.0]}], "plane_poses": [{"orientation": {"w": 1.0}}]},
            {"id": "cube", "material": material_a,
             "inertia": {"m": 1.0, "ixx": 0.00167, "iyy": 0.00167, "izz": 0.00167},
             "pose": {"position": {"z": 0.05}, "orientation": {"w": 1.0}},
             "twist": {"linear": {"z": -1.0}},
             "primitives": [{"type": 1, "dimensions": [0.1, 0.1, 0.1]}],
             "primitive_poses": [{"orientation": {"w": 1.0}}]}]}])
    return request


class CalibratedMaterials(unittest.TestCase):
    def test_materials_replace_the_table_and_the_rest_stays(self):
        shipped = load("config/collision_response.yaml")
        calibrated = load("test/ros/calibrated_materials.yaml")
        for server in SERVERS:
            self.assertEqual(rospy.get_param(server + "/materials"), calibrated["materials"], server)
            self.assertEqual(rospy.get_param(server + "/law"), shipped["law"], server)
            self.assertEqual(rospy.get_param(server + "/max_bodies"), shipped["max_bodies"], server)

    def test_detected_contacts_take_the_calibrated_coefficients(self):
        entry = load("test/ros/calibrated_materials.yaml")["materials"][0]
        for server in SERVERS:
            rospy.wait_for_service(server + "/compute", timeout=60.0)
            compute = rospy.ServiceProxy(server + "/compute", ComputeResponse)
            answer = compute(drop(entry["a"], entry["b"]))
            self.assertTrue(answer.success, "%s: %s" % (server, answer.message))
            self.assertEqual(len(answer.detected_contacts), 4, server)
            for contact in answer.detected_contacts:
                self.assertEqual(contact.restitution, entry["restitution"], server)
                self.assertEqual(contact.static_friction, entry["static_friction"], server)
                self.assertEqual(contact.dynamic_friction, entry["dynamic_friction"], server)
            # The shipped pairs are gone: steel is a material of no entry now.
            answer = compute(drop("steel", "steel"))
            self.assertFalse(answer.success, server)
            self.assertIn("material", answer.message, server)


if __name__ == "__main__":
    rospy.init_node("test_calibrated_materials")
    rostest.rosrun("collision_response", "test_calibrated_materials", CalibratedMaterials)
