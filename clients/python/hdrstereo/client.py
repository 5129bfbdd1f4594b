# SPDX-License-Identifier: GPL-3.0-or-later
"""`hdrstereo.Client`: the daemon's API in verbs that read like the lab."""

from __future__ import annotations

import os
import re
import tempfile
from typing import (Any, Callable, Iterable, Iterator, Optional, Sequence,
                    Union)

import grpc
from google.protobuf import descriptor_pb2

from . import config, errors
from .artifacts import Artifact
from .jobs import Job
from .v1 import (admin_pb2, admin_pb2_grpc, common_pb2, hardware_pb2,
                 hardware_pb2_grpc, jobs_pb2, jobs_pb2_grpc, schedules_pb2,
                 schedules_pb2_grpc, server_pb2, server_pb2_grpc, sessions_pb2,
                 sessions_pb2_grpc)

# The daemon's rule for names that become folders (daemon/store/names.h).
_NAME = re.compile(r"[A-Za-z0-9][A-Za-z0-9_-]{0,63}")
_PAGE = 500
# How long the check behind "cannot reach hdrstereod" waits for an answer.
_PROBE_S = 2.0

_SERVICES = {
    "Sessions": (sessions_pb2, sessions_pb2_grpc.SessionsStub),
    "Jobs": (jobs_pb2, jobs_pb2_grpc.JobsStub),
    "Hardware": (hardware_pb2, hardware_pb2_grpc.HardwareStub),
    "Schedules": (schedules_pb2, schedules_pb2_grpc.SchedulesStub),
    "Server": (server_pb2, server_pb2_grpc.ServerStub),
    "Admin": (admin_pb2, admin_pb2_grpc.AdminStub),
}


def check_name(name: str, what: str = "session name") -> None:
    """Raises InvalidArgument unless `name` is 1-64 of [A-Za-z0-9_-]
    starting with a letter or digit (the daemon's rule), before any call."""
    if not isinstance(name, str) or not name:
        raise errors.InvalidArgument(f"{what} is empty")
    if len(name) > 64:
        raise errors.InvalidArgument(
            f"{what} has {len(name)} characters; at most 64 are allowed")
    if not _NAME.fullmatch(name):
        raise errors.InvalidArgument(
            f"{what} {name!r} must start with a letter or digit and use only "
            "letters, digits, '-' and '_'")


class _Stubs:
    """The generated stubs, one per service, sharing one channel."""

    def __init__(self, channel: grpc.Channel):
        for name, (_, stub) in _SERVICES.items():
            setattr(self, name, stub(channel))


class _RawService:
    """`client.raw.Sessions.Create(request)`: any RPC of a service, with
    the client's timeout and error mapping."""

    def __init__(self, client: "Client", name: str, stub: Any):
        self._client = client
        self._name = name
        self._stub = stub
        self._streaming = _streaming_methods(name)

    def __getattr__(self, method: str) -> Callable[..., Any]:
        if method.startswith("_"):
            raise AttributeError(method)
        rpc = getattr(self._stub, method)
        if method in self._streaming:
            return lambda request: self._client._stream(rpc, request)
        return lambda request, timeout=None: self._client._call(
            rpc, request, timeout)

    def __dir__(self) -> list[str]:
        return method_names(self._name)


def _service_descriptor(name: str) -> Any:
    return _SERVICES[name][0].DESCRIPTOR.services_by_name[name]


def method_names(service: str) -> list[str]:
    """The RPCs of a hdrstereo.v1 service the client was built with."""
    return [m.name for m in _service_descriptor(service).methods]


def _streaming_methods(service: str) -> set[str]:
    proto = descriptor_pb2.ServiceDescriptorProto()
    _service_descriptor(service).CopyToProto(proto)
    return {m.name for m in proto.method if m.server_streaming}


class _Raw:
    def __init__(self, client: "Client"):
        for name in _SERVICES:
            setattr(self, name,
                    _RawService(client, name, getattr(client._stubs, name)))


class Sessions:
    """`client.sessions`: create, list, get, delete, frames."""

    def __init__(self, client: "Client"):
        self._c = client

    def create(self, name: str, note: str = "") -> sessions_pb2.Session:
        """Creates a session (a slug name; InvalidArgument otherwise)."""
        check_name(name)
        return self._c._call(self._c._stubs.Sessions.Create,
                             sessions_pb2.CreateSessionRequest(name=name,
                                                               note=note))

    def get(self, name: str) -> sessions_pb2.Session:
        check_name(name)
        return self._c._call(self._c._stubs.Sessions.Get,
                             sessions_pb2.GetSessionRequest(name=name))

    def list(self) -> list[sessions_pb2.Session]:
        """Every session (all pages)."""
        return list(self._c._pages(
            self._c._stubs.Sessions.List,
            lambda page: sessions_pb2.ListSessionsRequest(page=page),
            "sessions"))

    def delete(self, name: str) -> sessions_pb2.DeleteSessionResponse:
        """Deletes a session with its frames and artifacts (admin)."""
        check_name(name)
        return self._c._call(self._c._stubs.Sessions.Delete,
                             sessions_pb2.DeleteSessionRequest(name=name))

    def frames(self, name: str, capture_id: int = 0
               ) -> list[sessions_pb2.Frame]:
        """The session's frames (of one capture, or all)."""
        check_name(name)
        return list(self._c._pages(
            self._c._stubs.Sessions.ListFrames,
            lambda page: sessions_pb2.ListFramesRequest(
                session=name, capture_id=capture_id, page=page), "frames"))


def _set(message: Any, **fields: Any) -> Any:
    for key, value in fields.items():
        if value is not None:
            setattr(message, key, value)
    return message


class Capture:
    """`client.capture`: stereo, structured_light, calibration."""

    def __init__(self, client: "Client"):
        self._c = client

    def _submit(self, session: str, plan: jobs_pb2.CapturePlan, wait: bool,
                progress: bool) -> Job:
        check_name(session)
        job = Job(self._c, self._c._call(
            self._c._stubs.Jobs.SubmitCapture,
            jobs_pb2.SubmitCaptureRequest(session=session, plan=plan)))
        return job.wait(progress=progress) if wait else job

    def stereo(self, session: str,
               exposures_s: Optional[Sequence[float]] = None,
               baseline_mm: Optional[float] = None,
               views: Optional[int] = None, iso: Optional[int] = None,
               aperture_f: Optional[float] = None,
               settle_s: Optional[float] = None, skip_ambient: bool = False,
               auto_bracket: bool = False, min_snr: Optional[float] = None,
               max_step_stops: Optional[float] = None,
               exclude_emitters_above: Optional[float] = None,
               max_uncovered_fraction: Optional[float] = None,
               max_exposure_s: Optional[float] = None,
               wait: bool = False, progress: bool = False) -> Job:
        """Queues a bracketed stereo capture (unset values: the daemon's
        defaults) and returns its Job; `wait=True` returns once it ended
        (JobFailed if it did not succeed). `auto_bracket=True` (instead of
        `exposures_s`) meters the scene first and chooses the exposures at
        the rig (min_snr, max_step_stops, exclude_emitters_above,
        max_uncovered_fraction, max_exposure_s tune it; `job.auto_bracket`
        says what it chose)."""
        plan = jobs_pb2.CapturePlan()
        _set(plan.bracketed_stereo, baseline_mm=baseline_mm, views=views,
             iso=iso, aperture_f=aperture_f, settle_s=settle_s,
             skip_ambient=skip_ambient)
        plan.bracketed_stereo.exposures_s.extend(exposures_s or [])
        if auto_bracket:
            plan.bracketed_stereo.auto_bracket.SetInParent()
            _set(plan.bracketed_stereo.auto_bracket, min_snr=min_snr,
                 max_step_stops=max_step_stops,
                 exclude_emitters_above=exclude_emitters_above,
                 max_uncovered_fraction=max_uncovered_fraction,
                 max_exposure_s=max_exposure_s)
        return self._submit(session, plan, wait, progress)

    def structured_light(self, session: str,
                         exposures_s: Optional[Sequence[float]] = None,
                         baseline_mm: Optional[float] = None,
                         views: Optional[int] = None,
                         settle_s: Optional[float] = None,
                         probe_projector: bool = False,
                         round_to_refresh: bool = False,
                         wait: bool = False, progress: bool = False) -> Job:
        """Queues a Gray-code structured-light capture; see `stereo`.
        `probe_projector=True` measures the projector's latency first and
        waits that long after each pattern; `round_to_refresh=True` rounds
        the exposures to whole refresh periods of its display."""
        plan = jobs_pb2.CapturePlan()
        _set(plan.structured_light, baseline_mm=baseline_mm, views=views,
             settle_s=settle_s,
             round_exposures_to_refresh=round_to_refresh)
        plan.structured_light.exposures_s.extend(exposures_s or [])
        if probe_projector:
            plan.structured_light.projector_probe.SetInParent()
        return self._submit(session, plan, wait, progress)

    def calibration(self, session: str, poses: int,
                    exposure_s: Optional[float] = None,
                    baseline_mm: Optional[float] = None,
                    board: Optional[tuple[int, int]] = None,
                    board_square_mm: Optional[float] = None,
                    wait: bool = False, progress: bool = False) -> Job:
        """Queues a checkerboard calibration capture of `poses` poses. Before
        each pose it waits (state 'waiting', `job.instruction` says which
        pose) until `job.continue_()`; `wait=True` would wait forever.
        `board`: inner corners (columns, rows), default (9, 6);
        `board_square_mm`: a square's edge, default 25, the scale of the
        calibrated baseline."""
        plan = jobs_pb2.CapturePlan()
        columns, rows = board if board is not None else (None, None)
        _set(plan.calibration, poses=poses, exposure_s=exposure_s,
             baseline_mm=baseline_mm, board_columns=columns, board_rows=rows,
             board_square_mm=board_square_mm)
        return self._submit(session, plan, wait, progress)


class Jobs:
    """`client.jobs`: get and list jobs."""

    def __init__(self, client: "Client"):
        self._c = client

    def get(self, job_id: int) -> Job:
        return Job(self._c, self._c._call(self._c._stubs.Jobs.Get,
                                          jobs_pb2.GetJobRequest(job_id=job_id)))

    def list(self, session: str = "",
             states: Iterable[str] = ()) -> list[Job]:
        """Jobs, of one session or all, in the given states ('running',
        'failed', ...) or all."""
        if session:
            check_name(session)
        wanted = []
        for state in states:
            name = "JOB_STATE_" + state.upper()
            if name not in jobs_pb2.JobState.keys():
                raise errors.InvalidArgument(
                    f"unknown job state {state!r}; known: " + ", ".join(
                        k.removeprefix("JOB_STATE_").lower()
                        for k in jobs_pb2.JobState.keys()[1:]))
            wanted.append(jobs_pb2.JobState.Value(name))
        return [Job(self._c, j) for j in self._c._pages(
            self._c._stubs.Jobs.List,
            lambda page: jobs_pb2.ListJobsRequest(session=session,
                                                  states=wanted, page=page),
            "jobs")]


def _write_atomically(path: Union[str, os.PathLike], data: bytes) -> None:
    """Writes `data` to a temporary file beside `path`, fsyncs it and
    renames it over `path`: a reader sees the old file or the new one."""
    folder = os.path.dirname(os.path.abspath(path))
    fd, temp = tempfile.mkstemp(dir=folder,
                                prefix=os.path.basename(path) + ".tmp-")
    try:
        with os.fdopen(fd, "wb") as out:
            out.write(data)
            out.flush()
            os.fsync(out.fileno())
        os.replace(temp, path)
    except BaseException:
        if os.path.exists(temp):
            os.unlink(temp)
        raise
    dir_fd = os.open(folder, os.O_RDONLY)
    try:
        os.fsync(dir_fd)
    finally:
        os.close(dir_fd)


class Preview:
    """Live view (`client.hardware.preview(...)`): iterate for
    `hardware_pb2.PreviewFrame`s (`jpeg`, `width_px`, `height_px`,
    `exposure_s`, `fps_cap`, and per channel `histogram` (256 bins),
    `clipped_low`, `clipped_high`, `mean`, `p1`, `p50`, `p99`; while a
    calibration waits for a pose, `calibration`: `board_found`,
    `board_missing`, `pose`, `poses`, `poses_kept`, `coverage_left`,
    `coverage_right`, `coverage_with_this_pose`). Stopping the
    iteration ends the stream. When the daemon ends it (the frames asked
    for were sent, or a capture job started: live view never holds up a
    capture), iteration stops and `ended` says why (`reason`,
    `capture_job_id`, `frames`); it is None while streaming or after you
    stopped."""

    def __init__(self, client: "Client",
                 request: hardware_pb2.StreamPreviewRequest,
                 out: Optional[Union[str, os.PathLike]]):
        self._c = client
        self._request = request
        self._out = out
        self.ended: Optional[hardware_pb2.PreviewEnded] = None

    def __iter__(self) -> Iterator[hardware_pb2.PreviewFrame]:
        for message in self._c._stream(self._c._stubs.Hardware.StreamPreview,
                                       self._request):
            if message.HasField("ended"):
                self.ended = message.ended
                return
            if self._out is not None:
                _write_atomically(self._out, message.frame.jpeg)
            yield message.frame

    def __repr__(self) -> str:
        return (f"Preview(max_fps={self._request.max_fps}, "
                f"max_frames={self._request.max_frames}, out={self._out!r})")


class Hardware:
    """`client.hardware`: status, stage, camera, live view, projector and
    its probe, rig lock."""

    def __init__(self, client: "Client"):
        self._c = client
        self._hw = client._stubs.Hardware

    def status(self) -> hardware_pb2.HardwareStatus:
        return self._c._call(self._hw.GetStatus,
                             hardware_pb2.GetHardwareStatusRequest())

    def move_stage(self, position_mm: float) -> hardware_pb2.StageStatus:
        """Moves the stage to an absolute position in [0, travel_mm]."""
        return self._c._call(self._hw.MoveStage, hardware_pb2.MoveStageRequest(
            position_mm=position_mm))

    def home_stage(self) -> hardware_pb2.StageStatus:
        return self._c._call(self._hw.HomeStage,
                             hardware_pb2.HomeStageRequest())

    def camera_settings(self) -> hardware_pb2.CameraSettings:
        return self._c._call(self._hw.GetCameraSettings,
                             hardware_pb2.GetCameraSettingsRequest())

    def set_camera_settings(self, exposure_s: float, iso: int = 0,
                            aperture_f: float = 0.0
                            ) -> hardware_pb2.CameraSettings:
        """Sets the camera (0 leaves ISO or aperture unchanged)."""
        return self._c._call(self._hw.SetCameraSettings,
                             hardware_pb2.SetCameraSettingsRequest(
                                 settings=hardware_pb2.CameraSettings(
                                     exposure_s=exposure_s, iso=iso,
                                     aperture_f=aperture_f)))

    def show_pattern(self, solid_level: Optional[int] = None,
                     png: Optional[bytes] = None
                     ) -> hardware_pb2.ProjectorStatus:
        """Shows a uniform gray level (0..255) or an 8-bit PNG."""
        request = hardware_pb2.ShowPatternRequest()
        if png is not None:
            request.png = png
        elif solid_level is not None:
            request.solid_level = solid_level
        else:
            raise errors.InvalidArgument("give solid_level or png")
        return self._c._call(self._hw.ShowPattern, request)

    def blank_projector(self) -> hardware_pb2.ProjectorStatus:
        return self._c._call(self._hw.BlankProjector,
                             hardware_pb2.BlankProjectorRequest())

    def preview(self, max_fps: float = 0, max_frames: int = 0,
                out: Optional[Union[str, os.PathLike]] = None) -> Preview:
        """Live view: at most `max_fps` frames a second (0: the daemon's
        default of 5; it sends at most 10), `max_frames` of them (0: until
        you stop iterating or a capture starts); with `out`, each frame is
        also written there (JPEG), replaced atomically. FailedPrecondition
        (naming the job) while a capture holds the rig."""
        if max_fps < 0 or max_frames < 0:
            raise errors.InvalidArgument(
                "max_fps and max_frames must not be negative")
        return Preview(self._c, hardware_pb2.StreamPreviewRequest(
            max_fps=max_fps, max_frames=max_frames), out)

    def probe_projector(self, step_s: float = 0, max_delay_s: float = 0,
                        exposure_s: float = 0,
                        timeout: Optional[float] = None
                        ) -> hardware_pb2.ProjectorProbe:
        """Measures the projector's latency (frames at increasing delays
        after black turns white; 0 takes the daemon's defaults: steps of
        0.02 s up to 0.5 s at 1/125 s) and reads the display's refresh rate:
        `latency_s`, `refresh_hz` (0: unknown, `refresh_error` says why),
        `frames`. It takes a while: `timeout` defaults to the client's plus
        what the frames need."""
        options = hardware_pb2.ProjectorProbeOptions(
            step_s=step_s, max_delay_s=max_delay_s, exposure_s=exposure_s)
        if timeout is None:
            # Every step waits up to the longest delay twice.
            steps = (max_delay_s or 0.5) / (step_s or 0.02) + 3
            timeout = self._c.timeout + steps * 2 * (max_delay_s or 0.5)
        return self._c._call(self._hw.ProbeProjector,
                             hardware_pb2.ProbeProjectorRequest(
                                 options=options), timeout=timeout)

    def lock(self, note: str, ttl_s: int) -> hardware_pb2.RigLock:
        """Locks the rig for `ttl_s` seconds; others are refused."""
        return self._c._call(self._hw.Lock,
                             hardware_pb2.LockRequest(note=note, ttl_s=ttl_s))

    def unlock(self, force: bool = False) -> hardware_pb2.RigLock:
        return self._c._call(self._hw.Unlock,
                             hardware_pb2.UnlockRequest(force=force))

    def get_lock(self) -> hardware_pb2.RigLock:
        return self._c._call(self._hw.GetLock, hardware_pb2.GetLockRequest())


class Admin:
    """`client.admin`: API keys, the audit log and webhooks (admin role)."""

    def __init__(self, client: "Client"):
        self._c = client

    def create_api_key(self, user: str, role: str, ttl_s: int,
                       note: str = "") -> admin_pb2.CreateApiKeyResponse:
        """A new key (`.api_key` is shown once: store it, mode 0600)."""
        role_value = _role(role)
        return self._c._call(self._c._stubs.Admin.CreateApiKey,
                             admin_pb2.CreateApiKeyRequest(
                                 user=user, role=role_value, ttl_s=ttl_s,
                                 note=note))

    def list_api_keys(self, user: str = "", include_revoked: bool = False
                      ) -> list[admin_pb2.ApiKey]:
        return list(self._c._pages(
            self._c._stubs.Admin.ListApiKeys,
            lambda page: admin_pb2.ListApiKeysRequest(
                user=user, include_revoked=include_revoked, page=page),
            "keys"))

    def revoke_api_key(self, key_id: str) -> admin_pb2.ApiKey:
        return self._c._call(self._c._stubs.Admin.RevokeApiKey,
                             admin_pb2.RevokeApiKeyRequest(id=key_id))

    def audit_log(self, principal: str = "", method: str = ""
                  ) -> list[admin_pb2.AuditEntry]:
        return list(self._c._pages(
            self._c._stubs.Admin.ListAuditLog,
            lambda page: admin_pb2.ListAuditLogRequest(
                principal=principal, method=method, page=page), "entries"))

    def create_webhook(self, url: str, events: list[str] | None = None,
                       note: str = "") -> admin_pb2.CreateWebhookResponse:
        """A hook POSTing events to `url` (`.secret` is shown once: the
        receiver checks X-Hdrstereo-Signature with it)."""
        return self._c._call(self._c._stubs.Admin.CreateWebhook,
                             admin_pb2.CreateWebhookRequest(
                                 url=url, events=events or [], note=note))

    def list_webhooks(self) -> list[admin_pb2.Webhook]:
        return list(self._c._call(self._c._stubs.Admin.ListWebhooks,
                                  admin_pb2.ListWebhooksRequest()).webhooks)

    def delete_webhook(self, webhook_id: int) -> admin_pb2.Webhook:
        return self._c._call(self._c._stubs.Admin.DeleteWebhook,
                             admin_pb2.DeleteWebhookRequest(id=webhook_id))

    def webhook_deliveries(self, webhook_id: int
                           ) -> list[admin_pb2.WebhookDelivery]:
        """Every attempt at the hook's events, newest first."""
        return list(self._c._pages(
            self._c._stubs.Admin.ListWebhookDeliveries,
            lambda page: admin_pb2.ListWebhookDeliveriesRequest(
                webhook_id=webhook_id, page=page), "deliveries"))


def _role(role: str) -> int:
    name = "ROLE_" + role.upper()
    if role.upper() == "UNSPECIFIED" or name not in common_pb2.Role.keys():
        raise errors.InvalidArgument(
            f"unknown role {role!r}; known: viewer, operator, admin")
    return common_pb2.Role.Value(name)


class Client:
    """A connection to hdrstereod.

    Settings come from the arguments, else the environment
    (HDRSTEREO_SERVER, HDRSTEREO_PROFILE, HDRSTEREO_TLS_CA,
    HDRSTEREO_TLS_CERT, HDRSTEREO_TLS_KEY, HDRSTEREO_API_KEY_FILE), else the
    profile in ~/.config/hdrstereo/client.toml ($HDRSTEREO_CLIENT_CONFIG),
    else localhost:50051 without TLS: the CLI's rules. `api_key` is the key
    itself (hs_<id>_<secret>); `api_key_file` a file holding it (0600).
    `timeout` (seconds) bounds every call but streams. Use it as a context
    manager, or call close().

        with hdrstereo.Client("labpc:50052", profile="lab") as client:
            client.sessions.create("lamp-1")
            client.capture.stereo("lamp-1", wait=True, progress=True)
            client.process("lamp-1", wait=True)
            print(client.metrics("lamp-1"))

    Errors are subclasses of hdrstereo.Error named for the gRPC code
    (NotFound, InvalidArgument, PermissionDenied, Unauthenticated,
    Unavailable, ...) carrying the server's message.
    """

    def __init__(self, server: Optional[str] = None, *,
                 profile: Optional[str] = None,
                 tls_ca: Optional[str] = None,
                 tls_cert: Optional[str] = None,
                 tls_key: Optional[str] = None,
                 api_key: Optional[str] = None,
                 api_key_file: Optional[str] = None,
                 timeout: float = 30.0):
        self.connection = config.resolve(
            server=server, profile=profile, tls_ca=tls_ca, tls_cert=tls_cert,
            tls_key=tls_key, api_key=api_key, api_key_file=api_key_file)
        self.timeout = timeout
        self._channel = self._open(self.connection)
        self._stubs = _Stubs(self._channel)
        self.raw = _Raw(self)
        self.sessions = Sessions(self)
        self.capture = Capture(self)
        self.jobs = Jobs(self)
        self.hardware = Hardware(self)
        self.admin = Admin(self)

    @staticmethod
    def _open(c: config.Connection) -> grpc.Channel:
        target = c.server
        if not c.tls:
            return grpc.insecure_channel(target)
        credentials = grpc.ssl_channel_credentials(
            root_certificates=c.ca_pem, private_key=c.key_pem,
            certificate_chain=c.cert_pem)
        if c.api_key:
            credentials = grpc.composite_channel_credentials(
                credentials, grpc.access_token_call_credentials(c.api_key))
        return grpc.secure_channel(target, credentials)

    def __enter__(self) -> "Client":
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def close(self) -> None:
        """Closes the channel; streams still open end."""
        self._channel.close()

    def __repr__(self) -> str:
        return f"Client({self.connection!r})"

    def _answers(self) -> bool:
        """Whether the daemon answers now: a fail-fast WhoAmI, where any
        reply but UNAVAILABLE or a deadline counts. (Not a connectivity
        subscription: in grpcio 1.51 its polling thread can hang the
        interpreter's exit after close.)"""
        try:
            self._stubs.Server.WhoAmI(server_pb2.WhoAmIRequest(),
                                      timeout=_PROBE_S, wait_for_ready=False)
        except grpc.RpcError as e:
            return e.code() not in (grpc.StatusCode.UNAVAILABLE,
                                    grpc.StatusCode.DEADLINE_EXCEEDED)
        return True

    # The two ways a call goes out; every verb uses them.
    def _error(self, error: grpc.RpcError, timeout: Optional[float]
               ) -> errors.Error:
        mapped = errors.from_rpc_error(error, self.connection.server)
        if (isinstance(mapped, errors.DeadlineExceeded) and
                not self._answers()):
            return errors.Unavailable(
                f"cannot reach hdrstereod at {self.connection.server} within "
                f"{timeout} s: {mapped.message}", grpc.StatusCode.UNAVAILABLE)
        return mapped

    def _call(self, rpc: Callable[..., Any], request: Any,
              timeout: Optional[float] = None) -> Any:
        timeout = self.timeout if timeout is None else timeout
        try:
            return rpc(request, timeout=timeout, wait_for_ready=True)
        except grpc.RpcError as e:
            raise self._error(e, timeout) from None

    def _stream(self, rpc: Callable[..., Any], request: Any) -> Iterator[Any]:
        stream = None
        try:
            stream = rpc(request, wait_for_ready=False)
            yield from stream
        except grpc.RpcError as e:
            raise self._error(e, None) from None
        finally:
            # A caller that stops iterating ends the call (a no-op once it
            # is over).
            if stream is not None:
                stream.cancel()

    def _pages(self, rpc: Callable[..., Any],
               make: Callable[[common_pb2.PageRequest], Any],
               field: str) -> Iterator[Any]:
        token = ""
        while True:
            response = self._call(rpc, make(common_pb2.PageRequest(
                page_size=_PAGE, page_token=token)))
            yield from getattr(response, field)
            token = response.next_page_token
            if not token:
                return

    # Verbs on a session.
    def process(self, session: str, steps: Sequence[str] = (),
                force: bool = False, wait: bool = False,
                progress: bool = False) -> Job:
        """Queues processing of `session` (`steps`, plus what they need;
        all by default) and returns the Job; `wait=True` returns once it
        ended (JobFailed if it did not succeed)."""
        check_name(session)
        job = Job(self, self._call(
            self._stubs.Jobs.SubmitProcessing,
            jobs_pb2.SubmitProcessingRequest(session=session, steps=steps,
                                             force=force)))
        return job.wait(progress=progress) if wait else job

    def process_sessions(self, sessions: Sequence[str] = (),
                         all_sessions: bool = False,
                         steps: Sequence[str] = (), force: bool = False,
                         wait: bool = False) -> tuple[list[Job], dict[str, str]]:
        """Queues processing of many sessions, one job each: `sessions` are
        names or globs ('nightly-2026-*'), or `all_sessions=True`. Returns
        the jobs (in session name order) and the sessions skipped, with why
        (e.g. no complete stereo capture). `wait=True` returns once every job
        ended (JobFailed for the first that did not succeed)."""
        response = self._call(
            self._stubs.Jobs.SubmitProcessingBatch,
            jobs_pb2.SubmitProcessingBatchRequest(
                sessions=list(sessions), all_sessions=all_sessions,
                steps=steps, force=force))
        jobs = [Job(self, j) for j in response.jobs]
        if wait:
            jobs = [job.wait() for job in jobs]
        return jobs, {s.session: s.reason for s in response.skipped}

    def metrics(self, session: str, as_frame: bool = False) -> Any:
        """The session's disparity metrics, one dict per method and ground
        truth (method, ground_truth, rmse_px, mae_px, bad_0_5, bad_1, bad_2,
        bad_4, coverage, job_id, worse_than_ldr), by ground truth then RMSE;
        method "structured_light" against "simulation" is the
        structured-light ground truth itself. `as_frame=True`
        returns a pandas DataFrame (ImportError if pandas is not
        installed)."""
        check_name(session)
        response = self._call(self._stubs.Sessions.ListMetrics,
                              sessions_pb2.ListMetricsRequest(session=session))
        rows = [{f.name: getattr(m, f.name)
                 for f in sessions_pb2.Metric.DESCRIPTOR.fields}
                for m in response.metrics]
        if not as_frame:
            return rows
        try:
            import pandas
        except ImportError:
            raise ImportError("metrics(as_frame=True) needs pandas (Debian: "
                              "python3-pandas); without it, use the list of "
                              "dicts") from None
        return pandas.DataFrame(rows)

    def artifacts(self, session: str, kind: str = "") -> list[Artifact]:
        """The session's artifacts (of one kind: 'hdr', 'disparity', ...)."""
        check_name(session)
        return [Artifact(self, session, a) for a in self._pages(
            self._stubs.Sessions.ListArtifacts,
            lambda page: sessions_pb2.ListArtifactsRequest(
                session=session, kind=kind, page=page), "artifacts")]

    def info(self) -> server_pb2.ServerInfo:
        """The daemon's version, data root, hardware mode, uptime."""
        return self._call(self._stubs.Server.GetInfo,
                          server_pb2.GetServerInfoRequest())

    def whoami(self) -> server_pb2.Identity:
        """Who the daemon takes this client for (principal, role, auth)."""
        return self._call(self._stubs.Server.WhoAmI,
                          server_pb2.WhoAmIRequest())


# Every RPC of hdrstereo.v1 and the verb that calls it; the parity test
# (tests/test_parity.py) fails when an RPC has neither a verb here nor an
# entry in RAW_ONLY.
VERBS: dict[str, str] = {
    "Sessions.Create": "sessions.create",
    "Sessions.Get": "sessions.get",
    "Sessions.List": "sessions.list",
    "Sessions.Delete": "sessions.delete",
    "Sessions.ListFrames": "sessions.frames",
    "Sessions.ListArtifacts": "artifacts",
    "Sessions.DownloadArtifact": "artifacts",  # Artifact.download / .load
    "Sessions.ListMetrics": "metrics",
    "Jobs.SubmitCapture": "capture.stereo",
    "Jobs.SubmitProcessing": "process",
    "Jobs.SubmitProcessingBatch": "process_sessions",
    "Jobs.Get": "jobs.get",
    "Jobs.List": "jobs.list",
    "Jobs.Watch": "jobs.get",  # Job.watch / .wait
    "Jobs.Pause": "jobs.get",  # Job.pause
    "Jobs.Resume": "jobs.get",  # Job.resume
    "Jobs.Cancel": "jobs.get",  # Job.cancel
    "Jobs.Continue": "jobs.get",  # Job.continue_
    "Hardware.GetStatus": "hardware.status",
    "Hardware.GetCameraSettings": "hardware.camera_settings",
    "Hardware.SetCameraSettings": "hardware.set_camera_settings",
    "Hardware.HomeStage": "hardware.home_stage",
    "Hardware.MoveStage": "hardware.move_stage",
    "Hardware.ShowPattern": "hardware.show_pattern",
    "Hardware.BlankProjector": "hardware.blank_projector",
    "Hardware.StreamPreview": "hardware.preview",
    "Hardware.ProbeProjector": "hardware.probe_projector",
    "Hardware.Lock": "hardware.lock",
    "Hardware.Unlock": "hardware.unlock",
    "Hardware.GetLock": "hardware.get_lock",
    "Server.GetInfo": "info",
    "Server.WhoAmI": "whoami",
    "Admin.CreateApiKey": "admin.create_api_key",
    "Admin.ListApiKeys": "admin.list_api_keys",
    "Admin.RevokeApiKey": "admin.revoke_api_key",
    "Admin.ListAuditLog": "admin.audit_log",
    "Admin.CreateWebhook": "admin.create_webhook",
    "Admin.ListWebhooks": "admin.list_webhooks",
    "Admin.DeleteWebhook": "admin.delete_webhook",
    "Admin.ListWebhookDeliveries": "admin.webhook_deliveries",
}
# RPCs offered only as client.raw.<Service>.<Method>(request).
RAW_ONLY: frozenset[str] = frozenset({
    "Schedules.Create", "Schedules.List", "Schedules.Delete",
    "Schedules.SetEnabled", "Schedules.ListRuns",
    # A recorded frame's bytes (what the HTTP edge serves frames from).
    "Sessions.DownloadFrame",
    # The console's capture form asks while the operator types.
    "Jobs.EstimateCapture",
})
