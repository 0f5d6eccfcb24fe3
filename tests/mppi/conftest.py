import pytest

from simplebot_navigation.mppi import warm_up


@pytest.fixture(scope="session", autouse=True)
def compiled_kernels():
    """Load the compiled kernels before the first cycle, as the node does."""
    warm_up()
