#!/usr/bin/python3
"""Runs the README's example clients (Python and C++) against the nodelet of embedding.test."""
import os
import subprocess
import unittest

import rospkg
import rostest

SERVER = "/nodelet/collision_response"
EXPECTED = [
    "single: left -1.000000 m/s, right 0.500000 m/s, impulse 3.000000 N s",
    "batch v1=1.0: left -1.000000 m/s, right 0.000000 m/s",
    "batch v1=2.0: left -1.000000 m/s, right 0.500000 m/s",
    "batch v1=3.0: left -1.000000 m/s, right 1.000000 m/s",
    "closed form: OK",
]


def run(command):
    result = subprocess.run(command + [SERVER], stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                            universal_newlines=True, timeout=100)
    lines = [line for line in result.stdout.splitlines()
             if line.startswith(("single", "batch", "closed"))]
    return result.returncode, lines, result.stdout


class ExampleClients(unittest.TestCase):
    def test_python_client(self):
        script = os.path.join(rospkg.RosPack().get_path("collision_response"), "scripts",
                              "example_client.py")
        code, lines, output = run(["/usr/bin/python3", script])
        self.assertEqual(lines, EXPECTED, "output of the client:\n" + output)
        self.assertEqual(code, 0, output)

    def test_cpp_client(self):
        binary = os.environ.get("COLLISION_RESPONSE_EXAMPLE_CLIENT")
        if not binary:
            # catkin devel space: lib/collision_response/example_client next to this test's binaries
            for prefix in os.environ.get("CMAKE_PREFIX_PATH", "").split(":"):
                candidate = os.path.join(prefix, "lib", "collision_response", "example_client")
                if os.path.exists(candidate):
                    binary = candidate
                    break
        self.assertTrue(binary, "example_client binary not found")
        code, lines, output = run([binary])
        self.assertEqual(lines, EXPECTED, "output of the client:\n" + output)
        self.assertEqual(code, 0, output)


if __name__ == "__main__":
    rostest.rosrun("collision_response", "test_example_clients", ExampleClients)
