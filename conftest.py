"""Keep DDS on loopback and give every test process its own ROS domain."""

import os

os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
if "ROS_DOMAIN_ID" not in os.environ or os.environ.get("PYTEST_XDIST_WORKER"):
    # Domain ids 0..101 are valid for Fast DDS on one host; spread processes over 10..99.
    os.environ["ROS_DOMAIN_ID"] = str(10 + os.getpid() % 90)
