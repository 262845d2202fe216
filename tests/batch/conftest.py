"""Fixtures of the batch tests: ten small recordings (rendered once per session) and one LocalCluster."""

from __future__ import annotations

import shutil
from pathlib import Path
from types import SimpleNamespace

import pytest

#: IMU-only walks (12 s: 2 s standing, 8 s walking, 2 s standing), cheap to simulate and to analyse.
IMU_WALKS = (("normal", 11), ("bend", 12), ("left_shoulder_down", 13), ("right_foot_drag", 14), ("normal", 15),
             ("bend", 16))
#: The recordings the batch must analyse (8) and the corrupt ones (2), by the names the pairing rule gives them.
OK_NAMES = ("walk_a", "walk_b", *(f"s{i}_imu" for i in range(len(IMU_WALKS))))
FAILED_NAMES = ("bad_imu", "broken")


@pytest.fixture(scope="session")
def recordings(tmp_path_factory: pytest.TempPathFactory) -> SimpleNamespace:
    """A folder (``.root``) of 10 recordings: 2 videos (one with its IMU file, one camera-only with a camera.yaml
    beside it), 6 IMU-only walks (``.imu_walks``: walk type and seed of ``s0_imu`` ...), a truncated video and
    an IMU file with a broken header; ``.ok_names`` and ``.failed_names`` by the names the pairing rule gives."""
    pytest.importorskip("distributed")
    pytest.importorskip("pandas")
    from walkmon.simulate import simulate  # noqa: PLC0415

    root = tmp_path_factory.mktemp("batch_inputs")
    sim = tmp_path_factory.mktemp("batch_sim")
    video = simulate(sim / "v", walk="normal", seconds=5, seed=4, width=96, height=72, fps=15)
    inputs = root / "in"
    (inputs / "cam_only").mkdir(parents=True)
    shutil.copy(video.video_path, inputs / "walk_a.mp4")
    shutil.copy(sim / "v" / "imu.csv", inputs / "walk_a_imu.csv")  # paired by the {stem}_imu.csv pattern
    shutil.copy(video.video_path, inputs / "cam_only" / "walk_b.mp4")
    shutil.copy(sim / "v" / "camera.yaml", inputs / "cam_only" / "camera.yaml")  # the folder's calibration
    for i, (walk, seed) in enumerate(IMU_WALKS):
        simulate(sim / f"i{i}", walk=walk, seconds=12, seed=seed, video=False)
        shutil.copy(sim / f"i{i}" / "imu.csv", inputs / f"s{i}_imu.csv")
    data = Path(video.video_path).read_bytes()
    (inputs / "broken.mp4").write_bytes(data[: len(data) // 20])  # header cut: no decodable frame
    (inputs / "bad_imu.csv").write_text("time,a,b\n1,2,3\n", encoding="utf-8")
    return SimpleNamespace(root=inputs, ok_names=OK_NAMES, failed_names=FAILED_NAMES, imu_walks=IMU_WALKS)


@pytest.fixture(scope="session")
def dask_client(recordings: SimpleNamespace):  # noqa: ANN201, ARG001 - the inputs exist before the workers start
    """A LocalCluster of 2 single-threaded worker processes (as ``walkmon batch --workers 2`` starts), shared by
    the tests of a session."""
    distributed = pytest.importorskip("distributed")
    import dask  # noqa: PLC0415

    with dask.config.set({"logging.distributed": "error"}):
        cluster = distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                           dashboard_address="127.0.0.1:0", host="127.0.0.1")
    client = distributed.Client(cluster)
    yield client
    client.close()
    cluster.close()
