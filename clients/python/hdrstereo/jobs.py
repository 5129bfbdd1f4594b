# SPDX-License-Identifier: GPL-3.0-or-later
"""A job on the daemon: watched as events, waited for with a progress bar."""

from __future__ import annotations

import time
from typing import TYPE_CHECKING, Iterator, Optional

from .errors import DeadlineExceeded, JobFailed, Unavailable
from .v1 import jobs_pb2

if TYPE_CHECKING:
    from .client import Client

State = jobs_pb2.JobState
_ENDED = frozenset({State.JOB_STATE_SUCCEEDED, State.JOB_STATE_FAILED,
                    State.JOB_STATE_CANCELLED, State.JOB_STATE_INTERRUPTED})


def state_name(state: int) -> str:
    """'succeeded' for JOB_STATE_SUCCEEDED, as the CLI prints it."""
    return State.Name(state).removeprefix("JOB_STATE_").lower()


class Job:
    """A capture or processing job. `message` is the last Job seen."""

    def __init__(self, client: "Client", message: jobs_pb2.Job):
        self._client = client
        self.message = message

    id = property(lambda self: self.message.id)
    session = property(lambda self: self.message.session)

    @property
    def state(self) -> str:
        """'queued', 'running', 'paused', 'succeeded', 'failed', ..."""
        return state_name(self.message.state)

    @property
    def done(self) -> bool:
        return self.message.state in _ENDED

    @property
    def suspension_reason(self) -> str:
        """Why a condition holds the job suspended (state 'paused'), e.g.
        'the camera battery is at 12%, below --min-battery-percent 20%';
        '' when none does. As last read: refresh() reads it again."""
        return self.message.suspension_reason

    @property
    def instruction(self) -> str:
        """What a waiting job (state 'waiting') waits for, e.g. 'place the
        board in pose 3 of 8 and continue'; '' otherwise. As last read."""
        return self.message.instruction

    @property
    def auto_bracket(self) -> Optional[list]:
        """The exposures (s, longest first) automatic bracketing chose for
        this capture, None before it has (or without auto_bracket); the
        reason, range and coverage are in message.auto_bracket. As last
        read: refresh() reads it again."""
        chosen = self.message.auto_bracket.exposures_s
        return list(chosen) if chosen else None

    @property
    def projector_timing(self) -> Optional[dict]:
        """What a structured-light capture measured of its projector once it
        has started: {'latency_s': ..., 'refresh_hz': ...}, each None when
        not probed or unknown; None before the capture starts (or for other
        jobs). As last read: refresh() reads it again."""
        if not self.message.HasField("projector_timing"):
            return None
        t = self.message.projector_timing
        return {
            "latency_s": t.latency_s if t.HasField("latency_s") else None,
            "refresh_hz": t.refresh_hz if t.HasField("refresh_hz") else None,
        }

    def __repr__(self) -> str:
        p = self.message.progress
        suspended = (f", suspended={self.suspension_reason!r}"
                     if self.suspension_reason else "")
        return (f"Job(id={self.id}, session={self.session!r}, state="
                f"{self.state!r}, progress={p.done}/{p.total}{suspended})")

    def refresh(self) -> "Job":
        """Reads the job again from the daemon."""
        self.message = self._client._call(
            self._client._stubs.Jobs.Get, jobs_pb2.GetJobRequest(job_id=self.id))
        return self

    def pause(self) -> "Job":
        self.message = self._client._call(
            self._client._stubs.Jobs.Pause,
            jobs_pb2.PauseJobRequest(job_id=self.id))
        return self

    def resume(self) -> "Job":
        self.message = self._client._call(
            self._client._stubs.Jobs.Resume,
            jobs_pb2.ResumeJobRequest(job_id=self.id))
        return self

    def continue_(self) -> "Job":
        """Lets a waiting job go on (Jobs.Continue), e.g. once the
        calibration board is in the pose its instruction names; a job that
        is not waiting is refused (FAILED_PRECONDITION naming its state)."""
        self.message = self._client._call(
            self._client._stubs.Jobs.Continue,
            jobs_pb2.ContinueJobRequest(job_id=self.id))
        return self

    def cancel(self) -> "Job":
        self.message = self._client._call(
            self._client._stubs.Jobs.Cancel,
            jobs_pb2.CancelJobRequest(job_id=self.id))
        return self

    def watch(self, reconnects: int = 10) -> Iterator[jobs_pb2.JobEvent]:
        """Yields the job's events (JobEvent: sequence, state, progress,
        level, message) until it ends. A dropped stream is reopened after the
        last event seen (`after_sequence`), at most `reconnects` times in a
        row without a new event."""
        last = 0
        failures = 0
        while True:
            request = jobs_pb2.WatchJobRequest(job_id=self.id,
                                               after_sequence=last)
            try:
                for event in self._client._stream(
                        self._client._stubs.Jobs.Watch, request):
                    last = event.sequence
                    failures = 0
                    yield event
                    if event.state in _ENDED:
                        self.refresh()
                        return
            except (Unavailable, DeadlineExceeded):
                if failures >= reconnects:
                    raise
            failures += 1
            if self.refresh().done:
                return
            if failures > reconnects:
                raise Unavailable(f"the watch of job {self.id} kept ending "
                                  f"without news ({reconnects} reconnects)")
            time.sleep(min(0.1 * 2 ** failures, 2.0))

    def wait(self, progress: bool = False,
             timeout: Optional[float] = None) -> "Job":
        """Blocks until the job ends; returns it if it succeeded, else raises
        JobFailed with its state and error. `progress` shows a tqdm bar (in a
        terminal or in Jupyter). `timeout` (seconds) raises
        DeadlineExceeded; the job goes on."""
        deadline = None if timeout is None else time.monotonic() + timeout
        bar = None
        if progress:
            from tqdm.auto import tqdm
            bar = tqdm(total=max(self.message.progress.total, 1),
                       desc=f"job {self.id}", unit="step")
        try:
            for event in self.watch():
                if bar is not None:
                    bar.total = max(event.progress.total, 1)
                    bar.n = event.progress.done
                    bar.set_postfix_str(event.progress.step or event.message,
                                        refresh=False)
                    bar.refresh()
                if deadline is not None and time.monotonic() > deadline:
                    raise DeadlineExceeded(
                        f"job {self.id} did not end within {timeout} s "
                        f"(it is {self.refresh().state}; it goes on)")
        finally:
            if bar is not None:
                bar.close()
        if self.message.state != State.JOB_STATE_SUCCEEDED:
            raise JobFailed(f"job {self.id} {self.state}"
                            + (f": {self.message.error}"
                               if self.message.error else ""))
        return self
