import pytest

from simplebot_navigation.teb import warm_up


@pytest.fixture(scope="session", autouse=True)
def compiled_kernels():
    """Load the compiled kernels before the first cycle, as the node does: loading them takes
    longer than a cycle's budget, which would otherwise postpone the first cycle's alternatives."""
    warm_up()
