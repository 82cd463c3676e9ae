"""The local Dask cluster of `vibupdate.study.engine.open_client`."""

import socket
import warnings

from vibupdate.study.engine import open_client


def test_a_busy_dashboard_port_gives_no_warning():
    """Another Dask cluster (a second sweep, a notebook) holds the default dashboard port 8787:
    the local cluster takes a free port and says nothing, so an interrupted command still ends
    with its one line on stderr."""
    busy = socket.socket()
    try:
        try:
            busy.bind(("127.0.0.1", 8787))
            busy.listen()
        except OSError:   # already held by something else: the situation the test is about
            pass
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            with open_client(1) as client:
                assert client.submit(sum, [1, 2]).result() == 3
        assert not [w for w in caught if "already in use" in str(w.message)], [str(w.message) for w in caught]
    finally:
        busy.close()
