# SPDX-License-Identifier: GPL-3.0-or-later
"""Every verb against the real hdrstereod on simulated hardware (local
caller on loopback), checked against the daemon's files, the real CLI and
the simulator's truth."""

from __future__ import annotations

import hashlib
import hmac
import http.server
import json
import threading
import time
from pathlib import Path

import cv2
import grpc
import numpy as np
import pytest

import hdrstereo
from hdrstereo.v1 import jobs_pb2, sessions_pb2

from conftest import SOURCE_DIR, Daemon, free_port
from tcp_proxy import TcpProxy

EXPOSURES = [0.25, 0.06, 0.015]


@pytest.fixture(scope="module")
def client(daemon: Daemon):
    with hdrstereo.Client(daemon.address, timeout=30) as c:
        yield c


@pytest.fixture(scope="module")
def processed(client: hdrstereo.Client) -> str:
    """A session captured (stereo and structured light) and processed."""
    client.sessions.create("processed", note="python client test")
    client.capture.stereo("processed", exposures_s=EXPOSURES, wait=True)
    client.capture.structured_light("processed", wait=True)
    client.process("processed", wait=True)
    return "processed"


def test_info_and_whoami(client, daemon) -> None:
    info = client.info()
    assert info.hardware_mode == "sim"
    assert Path(info.data_root) == daemon.data_root.resolve()
    me = client.whoami()
    assert (me.auth_method, hdrstereo.v1.common_pb2.Role.Name(me.role)) == (
        "local", "ROLE_ADMIN")


def test_sessions_create_get_list_delete(client, daemon) -> None:
    made = client.sessions.create("s-crud", note="n")
    assert (made.name, made.note) == ("s-crud", "n")
    assert client.sessions.get("s-crud").create_time == made.create_time
    assert "s-crud" in [s.name for s in client.sessions.list()]
    # The CLI sees what the client made.
    shown = json.loads(daemon.cli("--json", "session", "show", "s-crud").stdout)
    assert shown["name"] == "s-crud"
    with pytest.raises(hdrstereo.AlreadyExists, match="s-crud"):
        client.sessions.create("s-crud")
    client.sessions.delete("s-crud")
    with pytest.raises(hdrstereo.NotFound, match="s-crud") as e:
        client.sessions.get("s-crud")
    assert e.value.code == grpc.StatusCode.NOT_FOUND


def test_server_message_carried(client) -> None:
    # A rule only the server knows: the note's length.
    with pytest.raises(hdrstereo.InvalidArgument, match="4096") as e:
        client.sessions.create("long-note", note="x" * 5000)
    assert e.value.code == grpc.StatusCode.INVALID_ARGUMENT
    assert "long-note" not in [s.name for s in client.sessions.list()]


def test_wrong_address_is_unavailable_after_the_timeout() -> None:
    address = f"127.0.0.1:{free_port()}"
    with hdrstereo.Client(address, timeout=1.5) as c:
        start = time.monotonic()
        with pytest.raises(hdrstereo.Unavailable, match=address) as e:
            c.sessions.list()
        assert time.monotonic() - start >= 1.4  # it waited as asked
    assert "within 1.5 s" in str(e.value)


def test_capture_watch_and_frames(client, daemon) -> None:
    client.sessions.create("cap")
    job = client.capture.stereo("cap", exposures_s=EXPOSURES)
    assert job.session == "cap" and job.id > 0
    events = list(job.watch())
    sequences = [e.sequence for e in events]
    assert sequences == sorted(set(sequences)) and sequences[0] == 1
    assert events[-1].state == jobs_pb2.JOB_STATE_SUCCEEDED
    assert job.state == "succeeded"
    frames = client.sessions.frames("cap")
    # Each exposure in both views, and one ambient frame.
    views = {(f.view_index, round(f.exposure_s, 6)) for f in frames}
    assert {(v, e) for v in (0, 1) for e in EXPOSURES} <= views
    assert len(frames) == 2 * len(EXPOSURES) + 1
    assert client.sessions.get("cap").frame_count == len(frames)
    for f in frames:  # the files the daemon wrote, by their sha256
        path = Path(client.sessions.get("cap").path) / f.path
        assert hashlib.sha256(path.read_bytes()).hexdigest() == f.sha256
    assert job.id in [j.id for j in client.jobs.list(session="cap")]
    assert job.id in [j.id for j in client.jobs.list(states=["succeeded"])]
    with pytest.raises(hdrstereo.InvalidArgument, match="unknown job state"):
        client.jobs.list(states=["done"])


def test_wait_shows_progress(client, capsys) -> None:
    client.sessions.create("bar")
    job = client.capture.stereo("bar", exposures_s=EXPOSURES, wait=True,
                                progress=True)
    assert job.state == "succeeded"
    assert f"job {job.id}" in capsys.readouterr().err


def test_failed_job_raises(client) -> None:
    client.sessions.create("nothing-captured")
    with pytest.raises(hdrstereo.FailedPrecondition,
                       match="bracketed-stereo"):
        client.process("nothing-captured", wait=True)


def test_process_sessions_one_job_each_and_the_skipped_named(client) -> None:
    client.sessions.create("batch-a")
    client.capture.stereo("batch-a", exposures_s=EXPOSURES, wait=True)
    client.sessions.create("batch-b")  # nothing captured
    jobs, skipped = client.process_sessions(["batch-*"], steps=["hdr"],
                                            wait=True)
    assert [j.session for j in jobs] == ["batch-a"]
    assert jobs[0].state == "succeeded"
    assert list(skipped) == ["batch-b"]
    assert "bracketed-stereo" in skipped["batch-b"]
    with pytest.raises(hdrstereo.NotFound, match="no session matches"):
        client.process_sessions(["nobody-*"])
    with pytest.raises(hdrstereo.InvalidArgument, match="not both"):
        client.process_sessions(["batch-a"], all_sessions=True)


class _Receiver(http.server.BaseHTTPRequestHandler):
    """Records each POST; answers 200."""
    received: list[tuple[dict, bytes]] = []

    def do_POST(self) -> None:  # noqa: N802 (the stdlib's name)
        body = self.rfile.read(int(self.headers["Content-Length"]))
        _Receiver.received.append(({k.lower(): v for k, v in
                                    self.headers.items()}, body))
        self.send_response(200)
        self.send_header("Content-Length", "0")
        self.end_headers()

    def log_message(self, *args) -> None:
        pass


def test_webhook_gets_a_signed_job_outcome(client) -> None:
    with pytest.raises(hdrstereo.InvalidArgument, match="http:// or https://"):
        client.admin.create_webhook("gopher://example.org/")
    server = http.server.ThreadingHTTPServer(("127.0.0.1", 0), _Receiver)
    thread = threading.Thread(target=server.serve_forever, daemon=True)
    thread.start()
    try:
        url = f"http://127.0.0.1:{server.server_address[1]}/hook"
        made = client.admin.create_webhook(
            url, events=["job.succeeded", "job.failed"], note="python")
        assert made.secret.startswith("whsec_")
        assert made.webhook.id in [h.id for h in client.admin.list_webhooks()]
        client.sessions.create("hooked")
        job = client.capture.stereo("hooked", exposures_s=EXPOSURES, wait=True)
        deadline = time.monotonic() + 30
        mine = []
        while not mine and time.monotonic() < deadline:
            mine = [(h, b) for h, b in _Receiver.received
                    if json.loads(b)["job"]["session"] == "hooked"]
            time.sleep(0.05)
        assert len(mine) == 1, _Receiver.received
        headers, body = mine[0]
        assert headers["x-hdrstereo-event"] == "job.succeeded"
        expected = "sha256=" + hmac.new(made.secret.encode(), body,
                                        hashlib.sha256).hexdigest()
        assert hmac.compare_digest(headers["x-hdrstereo-signature"], expected)
        assert json.loads(body)["job"]["id"] == job.id
        # Jobs of other tests in this daemon may end while the hook exists:
        # only this event's attempts are this test's. The daemon records an
        # attempt after the receiver has answered it.
        event_id = headers["x-hdrstereo-event-id"]
        attempts = []
        while not attempts and time.monotonic() < deadline:
            attempts = [d.http_status
                        for d in client.admin.webhook_deliveries(made.webhook.id)
                        if d.event_id == event_id]
            time.sleep(0.05)
        assert attempts == [200]
        client.admin.delete_webhook(made.webhook.id)
        with pytest.raises(hdrstereo.NotFound, match="no webhook"):
            client.admin.delete_webhook(made.webhook.id)
    finally:
        server.shutdown()
        server.server_close()


def test_metrics_match_the_cli_and_the_truth(client, daemon, processed) -> None:
    rows = client.metrics(processed)
    assert rows and all(isinstance(r, dict) for r in rows)
    by_key = {(r["method"], r["ground_truth"]): r for r in rows}
    assert ("fused", "simulation") in by_key
    assert ("fused", "structured_light") in by_key
    # The same rows, field for field, as the real CLI prints (its JSON keeps
    # the proto's field names and writes int64 as a string).
    cli = json.loads(daemon.cli("--json", "metrics", processed).stdout)
    cli_rows = cli["metrics"] if isinstance(cli, dict) else cli
    assert len(cli_rows) == len(rows)
    for c in cli_rows:
        r = by_key[(c["method"], c["ground_truth"])]
        for field, value in c.items():
            expected = int(value) if field == "job_id" else value
            assert r[field] == pytest.approx(expected, rel=1e-12), field
    try:
        import pandas  # noqa: F401
    except ImportError:
        with pytest.raises(ImportError, match="python3-pandas"):
            client.metrics(processed, as_frame=True)
    else:
        assert len(client.metrics(processed, as_frame=True)) == len(rows)


def test_artifact_load_matches_the_file_and_the_simulator(client,
                                                          processed) -> None:
    folder = Path(client.sessions.get(processed).path)
    fused = [a for a in client.artifacts(processed, kind="disparity")
             if a.path.endswith("fused.pfm")]
    assert len(fused) == 1, client.artifacts(processed, kind="disparity")
    disparity = fused[0].load()
    assert disparity.dtype == np.float32 and disparity.shape == (180, 240)
    on_disk = hdrstereo.images.cv2.imread(str(folder / fused[0].path),
                                          hdrstereo.images.cv2.IMREAD_UNCHANGED)
    np.testing.assert_array_equal(disparity, on_disk)
    # Scored against the simulator's exact disparity (the capture's truth):
    # the fused map is within 2 px on 80% of the pixels where both exist.
    truth_file = sorted(folder.glob("captures/*/truth/disp0.pfm"))
    assert truth_file, sorted(p.relative_to(folder) for p in folder.rglob("*")
                              if "truth" in str(p))
    truth = hdrstereo.decode_pfm(truth_file[-1].read_bytes())
    both = np.isfinite(truth) & np.isfinite(disparity) & (truth > 0)
    assert both.mean() > 0.5
    assert (np.abs(disparity - truth)[both] < 2).mean() > 0.8
    hdr = [a for a in client.artifacts(processed, kind="hdr")
           if a.path.endswith("im0.pfm")][0].load()
    assert hdr.dtype == np.float32 and hdr.shape == (180, 240, 3)
    png = [a for a in client.artifacts(processed) if a.path.endswith(".png")]
    assert png and png[0].load().dtype in (np.uint8, np.uint16)


def test_download_refuses_existing_resumes_and_checks(client, processed,
                                                      tmp_path) -> None:
    artifact = [a for a in client.artifacts(processed, kind="disparity")
                if a.path.endswith("fused.pfm")][0]
    path = artifact.download(tmp_path)
    assert path == tmp_path / "fused.pfm"
    data = path.read_bytes()
    assert hashlib.sha256(data).hexdigest() == artifact.sha256
    assert len(data) == artifact.size_bytes
    with pytest.raises(FileExistsError, match="overwrite=True"):
        artifact.download(path)
    assert artifact.download(path, overwrite=True) == path

    # Interrupted: the first half is there as .part; the rest is fetched.
    resumed = tmp_path / "resumed.pfm"
    Path(str(resumed) + ".part").write_bytes(data[: len(data) // 2])
    assert artifact.download(resumed).read_bytes() == data
    assert not Path(str(resumed) + ".part").exists()

    # A damaged partial file: only the rest is fetched, so the sha256 does
    # not match; the file is removed and not given its name.
    damaged = tmp_path / "damaged.pfm"
    Path(str(damaged) + ".part").write_bytes(b"\xff" * (len(data) // 2))
    with pytest.raises(hdrstereo.DataLoss, match="sha256 does not match"):
        artifact.download(damaged)
    assert not damaged.exists() and not Path(str(damaged) + ".part").exists()


def test_missing_artifact_is_not_found(client, processed) -> None:
    ghost = hdrstereo.Artifact(client, processed, sessions_pb2.Artifact(
        id=987654, path="ghost.pfm", sha256="0" * 64))
    with pytest.raises(hdrstereo.NotFound, match="987654"):
        ghost.load()


def test_hardware(client) -> None:
    status = client.hardware.status()
    assert status.hardware_mode == "sim"
    travel = status.stage.travel_mm
    assert client.hardware.move_stage(travel / 2).position_mm == pytest.approx(
        travel / 2)
    assert client.hardware.status().stage.position_mm == pytest.approx(
        travel / 2)
    with pytest.raises(hdrstereo.InvalidArgument, match="travel|range|0"):
        client.hardware.move_stage(travel + 10)
    assert client.hardware.camera_settings().exposure_s > 0
    lock = client.hardware.lock("python test", ttl_s=60)
    assert lock.locked and client.hardware.get_lock().note == "python test"
    assert not client.hardware.unlock().locked


def test_live_view_writes_frames_and_says_why_it_ended(client,
                                                     tmp_path) -> None:
    out = tmp_path / "live.jpg"
    preview = client.hardware.preview(max_fps=10, max_frames=2, out=out)
    frames = list(preview)
    assert [f.sequence for f in frames] == [1, 2]
    assert preview.ended.reason == "sent the 2 frames asked for"
    assert preview.ended.capture_job_id == 0
    # The file is the last frame; the statistics are of its pixels.
    assert out.read_bytes() == frames[-1].jpeg
    image = cv2.imdecode(np.frombuffer(out.read_bytes(), np.uint8),
                         cv2.IMREAD_COLOR)
    assert image.shape[:2] == (frames[-1].height_px, frames[-1].width_px)
    red = frames[-1].channels[0]
    assert red.channel == "red" and len(red.histogram) == 256
    assert sum(red.histogram) == image.shape[0] * image.shape[1]
    assert red.p1 <= red.p50 <= red.p99
    assert red.mean == pytest.approx(image[:, :, 2].mean(), abs=1e-6)
    assert not list(tmp_path.glob("*.tmp-*"))
    # Stopping early ends the stream; a bad rate never leaves the client.
    for frame in client.hardware.preview(max_fps=10):
        break
    with pytest.raises(hdrstereo.InvalidArgument, match="negative"):
        client.hardware.preview(max_fps=-1)


def test_auto_bracket_chooses_records_and_says_why(client, daemon) -> None:
    client.sessions.create("py-auto")
    # Asking for both is refused before anything is queued.
    with pytest.raises(hdrstereo.InvalidArgument, match="not both"):
        client.capture.stereo("py-auto", exposures_s=EXPOSURES,
                              auto_bracket=True)
    with pytest.raises(hdrstereo.InvalidArgument,
                       match=r"auto_bracket\.min_snr is 5"):
        client.capture.stereo("py-auto", auto_bracket=True, min_snr=5)
    with pytest.raises(hdrstereo.InvalidArgument,
                       match=r"auto_bracket\.max_step_stops is 0\.1"):
        client.capture.stereo("py-auto", auto_bracket=True,
                              max_step_stops=0.1)
    job = client.capture.stereo("py-auto", auto_bracket=True,
                                exclude_emitters_above=100, wait=True)
    chosen = job.auto_bracket
    assert chosen and len(chosen) >= 2
    assert chosen == sorted(chosen, reverse=True)
    choice = job.message.auto_bracket
    assert choice.coverage == 1.0 and choice.emitter_pixels > 0
    assert "covered" in choice.reason
    # The frames are the chosen exposures at both views, plus the ambient.
    frames = client.sessions.frames("py-auto")
    stereo = sorted({round(f.exposure_s, 12) for f in frames
                     if "/stereo/" in f.path})
    assert stereo == sorted(round(e, 12) for e in chosen)
    assert len(frames) == 2 * len(chosen) + 1


def test_structured_light_job_says_its_projector_timing(client) -> None:
    client.sessions.create("py-sl")
    job = client.capture.structured_light("py-sl", wait=True)
    # The simulated display refreshes at 60 Hz; the plan did not probe.
    assert job.projector_timing == {"latency_s": None, "refresh_hz": 60.0}
    stereo = client.capture.stereo("py-sl", exposures_s=EXPOSURES, wait=True)
    assert stereo.projector_timing is None


def test_raw_calls_map_errors(client) -> None:
    listed = client.raw.Schedules.List(
        hdrstereo.v1.schedules_pb2.ListSchedulesRequest())
    assert list(listed.schedules) == []
    with pytest.raises(hdrstereo.NotFound):
        client.raw.Jobs.Get(jobs_pb2.GetJobRequest(job_id=424242))


@pytest.fixture(scope="module")
def low_battery_daemon(tmp_path_factory):
    """The camera's battery reads 12% for six readings from the 30th (one
    reading per frame, then one a second while a capture waits), below
    --min-battery-percent 20."""
    d = Daemon(tmp_path_factory.mktemp("battery"),
               ["--min-battery-percent", "20"],
               scene={"faults": {"camera": {"low_battery": {
                   "calls": [30], "lasts": 6, "percent": 12}}}})
    yield d
    assert d.stop() == 0, d.log.read_text(errors="replace")


def test_a_suspended_job_says_why_until_it_resumes(low_battery_daemon) -> None:
    with hdrstereo.Client(low_battery_daemon.address, timeout=30) as c:
        c.sessions.create("battery")
        job = c.capture.structured_light("battery")
        seen = []
        for event in job.watch():
            if event.message.startswith("suspended: "):
                job.refresh()
                seen.append((job.state, job.suspension_reason))
                assert "suspended='the camera battery" in repr(job)
        reason = "the camera battery is at 12%, below --min-battery-percent 20%"
        assert seen == [("paused", reason)]
        assert job.state == "succeeded"
        assert job.suspension_reason == ""
        assert "suspended=" not in repr(job)


@pytest.fixture(scope="module")
def slow_daemon(tmp_path_factory):
    """Simulated hardware in real time, so a capture lasts a few seconds."""
    d = Daemon(tmp_path_factory.mktemp("slow"), ["--sim-time-scale", "1"])
    yield d
    assert d.stop() == 0, d.log.read_text(errors="replace")


def test_watch_survives_a_dropped_stream(slow_daemon) -> None:
    proxy = TcpProxy(slow_daemon.address)
    try:
        with hdrstereo.Client(proxy.address, timeout=30) as c:
            c.sessions.create("dropped")
            job = c.capture.stereo("dropped", exposures_s=[0.2, 0.1])
            events = []
            for event in job.watch():
                events.append(event)
                if len(events) == 1:
                    proxy.drop()  # mid-stream
            sequences = [e.sequence for e in events]
            # Every event once, in order, despite the reconnect.
            assert sequences == list(range(1, len(sequences) + 1))
            assert events[-1].state == jobs_pb2.JOB_STATE_SUCCEEDED
            assert len(events) > 2
            assert proxy.accepted >= 2  # the watch did reconnect
    finally:
        proxy.close()


@pytest.fixture(scope="module")
def board_daemon(tmp_path_factory):
    """The bundled checkerboard scene's board (eight poses) and light in
    place of the small lab-lamp's objects and lights."""
    board = json.loads((SOURCE_DIR / "hardware/sim/scenes/checkerboard.json")
                       .read_text())
    scene = {key: board[key] for key in
             ("objects", "lights", "ambient_lux", "calibration_board")}
    scene["camera"] = {"width": 600, "height": 450, "fx": 800, "fy": 800,
                       "cx": 299.5, "cy": 224.5}
    d = Daemon(tmp_path_factory.mktemp("board"), [], scene=scene)
    yield d
    assert d.stop() == 0, d.log.read_text(errors="replace")


def test_a_calibration_waits_for_continue(board_daemon) -> None:
    with hdrstereo.Client(board_daemon.address, timeout=30) as c:
        c.sessions.create("cal")
        job = c.capture.calibration("cal", poses=3)
        for pose in range(1, 4):
            want = f"place the board in pose {pose} of 3 and continue"
            deadline = time.monotonic() + 60
            while job.refresh().instruction != want:
                assert time.monotonic() < deadline, repr(job)
                time.sleep(0.05)
            assert job.state == "waiting"
            if pose == 1:
                # Live view guides the board: found, nothing kept yet.
                frame = next(iter(c.hardware.preview(max_frames=1)))
                guide = frame.calibration
                assert (guide.job_id, guide.pose, guide.poses) == (job.id, 1, 3)
                assert guide.board_found, guide.board_missing
                assert guide.poses_kept == 0 and guide.coverage_left == 0
                assert guide.coverage_with_this_pose > 0
            # The answer is the job as it goes on.
            assert job.continue_().state == "running"
        deadline = time.monotonic() + 60
        while not job.refresh().done:
            assert time.monotonic() < deadline, repr(job)
            time.sleep(0.05)
        assert job.state == "succeeded"
        with pytest.raises(hdrstereo.FailedPrecondition,
                           match="is succeeded; only a waiting job"):
            job.continue_()
