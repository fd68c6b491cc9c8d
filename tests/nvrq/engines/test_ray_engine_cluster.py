"""``nvrq score --engine ray --address ADDR`` on a two-node cluster simulated on this machine
(``ray.cluster_utils.Cluster``): the CLI joins it and gives the local engine's numbers."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from data_schema import datasets as ds

ray = pytest.importorskip("ray")
sys.path.insert(0, str(Path(__file__).parent))
from fleet_data import METRICS, local_scores, write_fleet  # noqa: E402


def test_two_node_cluster_equals_local_engine(tmp_path):
    from ray.cluster_utils import Cluster

    os.environ.setdefault("RAY_AUTH_MODE", "disabled")
    root, pairs_ds = write_fleet(tmp_path, n_frames=2)
    cluster = Cluster(initialize_head=True, head_node_args={"num_cpus": 1, "include_dashboard": False})
    try:
        cluster.add_node(num_cpus=1)
        cluster.wait_for_nodes()
        cmd = [sys.executable, "-m", "nvrq", "score", str(pairs_ds), "--out", str(tmp_path / "m"),
               "--metrics", ",".join(METRICS), "--tau", "0.6", "--engine", "ray", "--address", cluster.address,
               "--shard-pairs", "9", "--quiet"]
        proc = subprocess.run(cmd, capture_output=True, text=True, timeout=300)
        assert proc.returncode == 0, proc.stderr[-2000:]
        ray.init(address=cluster.address)
        assert len([n for n in ray.nodes() if n["Alive"]]) == 2
        ray.shutdown()
    finally:
        cluster.shutdown()
    got, want = ds.read_dataset(tmp_path / "m"), local_scores(root, pairs_ds)
    assert got.pair_id.tolist() == want.pair_id.tolist()
    for c in METRICS:
        np.testing.assert_allclose(got[c].to_numpy(), want[c].to_numpy(), atol=1e-6 if ":" in c else 0, rtol=0)
