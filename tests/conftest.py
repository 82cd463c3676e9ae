import os

os.environ.setdefault("OMP_NUM_THREADS", "1")


def pytest_runtest_setup(item):
    """A test marked ``@pytest.mark.realdata(name)`` is skipped, naming the path looked at, when
    the real data set is not there (`helpers.realdata`)."""
    import pytest

    from helpers import realdata_skip_reason

    for mark in item.iter_markers("realdata"):
        reason = realdata_skip_reason(*mark.args)
        if reason:
            pytest.skip(reason)
