"""Keep DDS on loopback and give every test process its own ROS domain."""

import os

os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
if "ROS_DOMAIN_ID" not in os.environ or os.environ.get("PYTEST_XDIST_WORKER"):
    # Domain ids 0..101 are valid for Fast DDS on one host; spread processes over 10..99.
    os.environ["ROS_DOMAIN_ID"] = str(10 + os.getpid() % 90)


def pytest_addoption(parser):
    parser.addoption("--reverse-modules", action="store_true",
                     help="run the test modules in reverse order (each module's tests in their own order): a module "
                          "that passes only after another has run fails then")


def pytest_collection_modifyitems(config, items):
    if config.getoption("--reverse-modules"):
        modules = list(dict.fromkeys(item.module.__name__ for item in items))
        rank = {name: -index for index, name in enumerate(modules)}
        items.sort(key=lambda item: rank[item.module.__name__])     # stable: a module's own order stays
