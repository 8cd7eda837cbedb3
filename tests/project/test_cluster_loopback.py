"""A local cluster listens on loopback only, its dashboard included (docs/security.md)."""

from __future__ import annotations

import os

import psutil

from viscoforce.fitting.maps import cluster


def test_the_local_cluster_and_its_dashboard_listen_on_loopback_only():
    with cluster(None, 1) as client:
        info = client.scheduler_info()
        dashboard = int(info["services"]["dashboard"])
        listening = {c.laddr.port: c.laddr.ip
                     for c in psutil.Process(os.getpid()).net_connections(kind="inet")
                     if c.status == psutil.CONN_LISTEN}
    assert info["address"].startswith("tcp://127.0.0.1:")
    assert listening[dashboard] == "127.0.0.1"  # was 0.0.0.0 with dashboard_address=":0"
    assert set(listening.values()) <= {"127.0.0.1", "::1"}
