"""Where alerts go: the log/terminal, a sound on the audio output, a command hook (alert JSON on stdin), and
optionally phones or mail through apprise (``apprise_urls``: ntfy, Telegram, e-mail, ...; the ``notify`` extra).

The hook's JSON (one object, one line) is the alert (``t_s`` capture time, ``kind``, ``state``, ``value``,
``threshold``, ``message``) plus ``session_id``, ``person`` (or null) and ``time_local``: the wall-clock time of
delivery in ISO 8601 with the local UTC offset (e.g. ``2026-11-23T07:41:05.120+01:00``).

Sinks never block the processing loop for long and never raise: a failing sink logs a warning and the
session goes on. Child processes are started without waiting, each in its own process group, and
killed with everything they started once ``hook_timeout_s`` has passed (a timer per child), reaped on later
calls and on :meth:`AlertSinks.close`.
Apprise notifications (network) are sent by one worker thread from a bounded queue; whatever is still queued
at close gets ``hook_timeout_s``. Configuring ``apprise_urls`` sends alert texts to the services named there:
off the device, by the operator's choice (the dashboard and everything else stay local).
"""

from __future__ import annotations

import contextlib
import datetime as _dt
import io
import json
import logging
import math
import os
import queue
import shutil
import signal
import struct
import subprocess
import tempfile
import threading
import time
import wave
from dataclasses import dataclass
from pathlib import Path
from typing import TextIO

from walkmon.errors import ConfigError
from walkmon.live.alerts import AlertEvent

__all__ = ["DEFAULT_SINK_SETTINGS", "AlertSinks", "SinkSettings", "beep_wav_bytes", "check_sinks"]

_log = logging.getLogger(__name__)

_PLAYERS = (("paplay",), ("aplay", "-q"))


@dataclass(frozen=True, slots=True)
class SinkSettings:
    """Alert sinks. ``sound_command``/``hook_command`` are argv lists; empty = off (sound: auto player)."""

    #: Write raised/cleared alerts to the terminal stream and the log.
    terminal: bool = True
    #: Play a beep when an alert is raised.
    sound: bool = False
    #: Player argv; the WAV path is appended. Empty: paplay or aplay, whichever is installed.
    sound_command: tuple[str, ...] = ()
    #: Sound file to play; empty: a generated 0.3 s 880 Hz beep.
    sound_file: str = ""
    #: Program run for every alert event with its JSON on stdin, e.g. ("/usr/local/bin/buzz", "--pin", "17").
    hook_command: tuple[str, ...] = ()
    #: Also run the hook when an alert is cleared.
    hook_on_clear: bool = False
    #: A hook or player still running after this long is killed, s.
    hook_timeout_s: float = 10.0
    #: Apprise notification URLs (e.g. "ntfys://ntfy.sh/my-topic", "tgram://BOT/CHAT", "mailtos://..."); they get
    #: the same events as the hook (raised; cleared too with hook_on_clear). Needs the notify extra (apprise).
    apprise_urls: tuple[str, ...] = ()

    def __post_init__(self) -> None:
        if self.hook_timeout_s <= 0:
            msg = f"sinks.hook_timeout_s must be > 0, got {self.hook_timeout_s}"
            raise ValueError(msg)


DEFAULT_SINK_SETTINGS = SinkSettings()


def check_sinks(settings: SinkSettings) -> None:
    """ConfigError (one line) naming the first configured sink that cannot work: a hook or player that is not an
    executable program, a sound file that cannot be read, sound with no player, an apprise URL apprise does not
    take (or apprise missing). ``walkmon config --check`` and ``walkmon live`` run it before anything starts
    (user review: a missing, empty or non-executable hook, a missing sound file and a malformed URL all read 'ok',
    and the alert they were for was lost at its first raising)."""
    if settings.hook_command:
        _check_program(settings.hook_command[0], "sinks.hook_command")
    if settings.sound:
        if settings.sound_command:
            _check_program(settings.sound_command[0], "sinks.sound_command")
        elif not any(shutil.which(p[0]) for p in _PLAYERS):
            msg = "sinks.sound is on but neither paplay nor aplay is installed: install one or set sinks.sound_command"
            raise ConfigError(msg)
        if settings.sound_file and not (os.path.isfile(settings.sound_file) and os.access(settings.sound_file, os.R_OK)):
            msg = f"sinks.sound_file {settings.sound_file!r}: no readable file there"
            raise ConfigError(msg)
    if settings.apprise_urls:
        try:
            import apprise  # noqa: PLC0415
        except ImportError:
            msg = "sinks.apprise_urls is set but apprise is not installed (pip install 'walkmon[notify]')"
            raise ConfigError(msg) from None
        for url in settings.apprise_urls:
            if not apprise.Apprise().add(url):
                scheme = url.split("://", 1)[0] + "://..." if "://" in url else "(no scheme://)"
                msg = f"sinks.apprise_urls: apprise does not accept the URL {scheme} (its keys are not shown)"
                raise ConfigError(msg)


def _check_program(program: str, where: str) -> None:
    """An executable file (a path), or a name on PATH."""
    if not program.strip():
        msg = f"{where}: the program is empty"
        raise ConfigError(msg)
    found = program if os.sep in program else shutil.which(program)
    if found is None or not os.path.isfile(found):
        msg = f"{where}: no program {program!r} there" + ("" if os.sep in program else " (not on PATH)")
        raise ConfigError(msg)
    if not os.access(found, os.X_OK):
        msg = f"{where}: {program!r} is not executable (chmod +x it)"
        raise ConfigError(msg)


def beep_wav_bytes(freq_hz: float = 880.0, duration_s: float = 0.3, rate_hz: int = 16000) -> bytes:
    """A mono 16-bit WAV of a sine beep with short fades."""
    n = int(duration_s * rate_hz)
    fade = max(1, int(0.01 * rate_hz))
    frames = bytearray()
    for i in range(n):
        env = min(1.0, i / fade, (n - 1 - i) / fade)
        frames += struct.pack("<h", int(0.5 * 32767 * env * math.sin(2 * math.pi * freq_hz * i / rate_hz)))
    buf = io.BytesIO()
    with wave.open(buf, "wb") as w:
        w.setnchannels(1)
        w.setsampwidth(2)
        w.setframerate(rate_hz)
        w.writeframes(bytes(frames))
    return buf.getvalue()


def _running(proc: subprocess.Popen[bytes]) -> bool:
    """The child has not exited yet; an exited one is left unreaped (waitid WNOWAIT), so its process id, its group's
    id, cannot be reused by another process before the group is killed (see AlertSinks._finish)."""
    if proc.returncode is not None:
        return False
    try:
        return os.waitid(os.P_PID, proc.pid, os.WEXITED | os.WNOHANG | os.WNOWAIT) is None
    except ChildProcessError:
        return False


def _child_env() -> dict[str, str]:
    """The environment of a hook or player: ours, with no empty entry in LD_LIBRARY_PATH (OpenCV's import leaves
    one, 'lib64:', and an empty entry makes the loader search the current folder; user review)."""
    env = dict(os.environ)
    paths = env.get("LD_LIBRARY_PATH")
    if paths is not None:
        kept = [p for p in paths.split(os.pathsep) if p]
        if kept:
            env["LD_LIBRARY_PATH"] = os.pathsep.join(kept)
        else:
            del env["LD_LIBRARY_PATH"]
    return env


def _feed(proc: subprocess.Popen[bytes], data: bytes, what: str, program: str) -> None:
    """Write a hook's input and close it (a thread of its own: see AlertSinks._spawn)."""
    assert proc.stdin is not None
    try:
        proc.stdin.write(data)
    except OSError as exc:
        _log.warning("alert %s %s did not read its input: %s", what, program, exc)
    finally:
        with contextlib.suppress(OSError):
            proc.stdin.close()


class AlertSinks:
    """Deliver :class:`AlertEvent` objects to the configured sinks. ``deliver(events)``, ``close()``."""

    def __init__(self, settings: SinkSettings = DEFAULT_SINK_SETTINGS, stream: TextIO | None = None, *,
                 session_id: int | None = None, person: str = "") -> None:
        self.settings = settings
        self._stream = stream
        self.session_id, self.person = session_id, person
        self._apprise: _AppriseWorker | None = None
        if settings.apprise_urls:
            self._apprise = _AppriseWorker.create(settings.apprise_urls, settings.hook_timeout_s)
        self._children: list[tuple[subprocess.Popen[bytes], float, str]] = []
        self._lock = threading.Lock()  # _finish runs from the timers and the loop
        self._timers: list[threading.Timer] = []
        self._tmpdir: tempfile.TemporaryDirectory[str] | None = None
        self._sound_argv: list[str] | None = None
        if settings.sound:
            self._sound_argv = self._prepare_sound()

    def _prepare_sound(self) -> list[str] | None:
        s = self.settings
        if s.sound_file:
            wav = s.sound_file
        else:
            self._tmpdir = tempfile.TemporaryDirectory(prefix="walkmon-sound-")
            wav = str(Path(self._tmpdir.name) / "beep.wav")
            Path(wav).write_bytes(beep_wav_bytes())
        if s.sound_command:
            return [*s.sound_command, wav]
        for player in _PLAYERS:
            if shutil.which(player[0]):
                return [*player, wav]
        _log.warning("sound alerts enabled but neither paplay nor aplay is installed; sound is off")
        return None

    def deliver(self, events: list[AlertEvent]) -> None:
        self._reap()
        for ev in events:
            if self.settings.terminal:
                line = f"[t={ev.t_s:7.1f}s] ALERT {ev.state}: {ev.message}"
                _log.info("%s", line)
                if self._stream is not None:
                    try:
                        self._stream.write("\n" + line + "\n")
                        self._stream.flush()
                    except (OSError, ValueError) as exc:
                        _log.warning("cannot write alert to terminal: %s", exc)
            if ev.state == "raised" and self._sound_argv:
                self._spawn(self._sound_argv, None, "sound")
            wanted = ev.state == "raised" or self.settings.hook_on_clear
            if wanted and (self.settings.hook_command or self._apprise is not None):
                payload = self.payload(ev)
                if self.settings.hook_command:
                    self._spawn(list(self.settings.hook_command),
                                (json.dumps(payload, sort_keys=True) + "\n").encode(), "hook")
                if self._apprise is not None:
                    self._apprise.submit(payload)

    def payload(self, ev: AlertEvent) -> dict[str, object]:
        """The alert as the hook and apprise get it: the event plus session id, person and local time."""
        return {**ev.to_dict(), "session_id": self.session_id, "person": self.person or None,
                "time_local": _dt.datetime.now().astimezone().isoformat(timespec="milliseconds")}

    def _spawn(self, argv: list[str], stdin_bytes: bytes | None, what: str) -> None:
        try:
            proc = subprocess.Popen(  # noqa: S603 - argv comes from the operator's config
                argv,
                stdin=subprocess.PIPE if stdin_bytes is not None else subprocess.DEVNULL,
                stdout=subprocess.DEVNULL,
                stderr=subprocess.DEVNULL,
                start_new_session=True,  # its own process group: the timeout kills the hook's children too
                env=_child_env(),
            )
        except OSError as exc:
            _log.warning("alert %s %s failed to start: %s", what, argv[0], exc)
            return
        self._children.append((proc, time.monotonic(), what))
        # its group (start_new_session: the hook's own id) is killed on time even when no further alert (and so
        # no _reap) comes
        timer = threading.Timer(self.settings.hook_timeout_s, self._finish, (proc, what))
        timer.daemon = True
        timer.start()
        self._timers.append(timer)
        if stdin_bytes is not None and proc.stdin is not None:
            # from a thread: a hook that does not read its input would block the write once the event is beyond
            # the pipe's 64 KiB (a long wearer's name), and with it the processing loop (user review: 60 s per alert)
            threading.Thread(target=_feed, args=(proc, stdin_bytes, what, argv[0]), name="walkmon-hook-input",
                             daemon=True).start()

    def _finish(self, proc: subprocess.Popen[bytes], what: str) -> None:
        """At its timeout (or the session's close): kill the child's process group, whatever runs in it (the hook
        itself if still running, or what it left behind, 'sleep 300 &', which outlived the session: user review),
        then reap the child. The child stays unreaped until here, so the group id cannot belong to anybody else
        (killing groups by remembered ids did hit an unrelated process that reused one: review)."""
        with self._lock:
            if proc.returncode is not None:
                return
            if _running(proc):
                _log.warning("alert %s (pid %d) still running after %g s: killed", what, proc.pid,
                             self.settings.hook_timeout_s)
            with contextlib.suppress(OSError):
                os.killpg(proc.pid, signal.SIGKILL)
            try:
                rc = proc.wait(timeout=2)
            except subprocess.TimeoutExpired:
                _log.error("alert child pid %d did not die after SIGKILL", proc.pid)
                return
            if rc not in (0, -signal.SIGKILL):
                _log.warning("alert %s exited with status %d", what, rc)

    def _reap(self) -> None:
        """Finish the children past their timeout (the others, even when exited, wait for it: see _finish)."""
        now = time.monotonic()
        self._timers = [t for t in self._timers if t.is_alive()]
        due = [(p, w) for p, started, w in self._children if now - started > self.settings.hook_timeout_s]
        for proc, what in due:
            self._finish(proc, what)
        self._children = [c for c in self._children if c[0].returncode is None]

    def close(self, wait_s: float = 2.0) -> None:
        """Wait briefly for running hooks/players, then kill every child's group (the stragglers and what finished
        hooks left behind), remove the generated sound."""
        deadline = time.monotonic() + wait_s
        while any(_running(p) for p, _, _ in self._children) and time.monotonic() < deadline:
            time.sleep(0.01)
        for timer in self._timers:
            timer.cancel()
        self._timers = []
        for proc, _, what in self._children:
            self._finish(proc, what)
        self._children = []
        if self._apprise is not None:
            self._apprise.close()
            self._apprise = None
        if self._tmpdir is not None:
            self._tmpdir.cleanup()
            self._tmpdir = None


class _AppriseWorker:
    """Sends notifications through apprise from one daemon thread (network calls never touch the loop)."""

    MAX_QUEUED = 100

    def __init__(self, apobj: object, timeout_s: float) -> None:
        self._apobj, self._timeout_s = apobj, timeout_s
        self._queue: queue.Queue[dict[str, object] | None] = queue.Queue(self.MAX_QUEUED)
        self.sent = self.failed = self.dropped = 0
        self._thread = threading.Thread(target=self._run, name="walkmon-apprise", daemon=True)
        self._thread.start()

    @classmethod
    def create(cls, urls: tuple[str, ...], timeout_s: float) -> _AppriseWorker | None:
        try:
            import apprise  # noqa: PLC0415
        except ImportError:
            _log.warning("sinks.apprise_urls is set but apprise is not installed (pip install 'walkmon[notify]'); "
                         "phone/mail notifications are off")
            return None
        apobj = apprise.Apprise()
        for url in urls:
            if not apobj.add(url):
                _log.warning("sinks.apprise_urls: apprise does not accept %r; skipped", url.split("://", 1)[0] + "://...")
        if len(apobj) == 0:
            _log.warning("sinks.apprise_urls: no usable URL; phone/mail notifications are off")
            return None
        return cls(apobj, timeout_s)

    def submit(self, payload: dict[str, object]) -> None:
        try:
            self._queue.put_nowait(payload)
        except queue.Full:
            self.dropped += 1
            _log.warning("apprise notifications are backed up: one dropped (%d so far)", self.dropped)

    def _run(self) -> None:
        while True:
            payload = self._queue.get()
            if payload is None:
                return
            who = f" ({payload['person']})" if payload.get("person") else ""
            title = f"walkmon{who}: {str(payload['kind']).replace('_', ' ')} {payload['state']}"
            body = f"{payload['message']} (session {payload['session_id']}, {payload['time_local']})"
            try:
                ok = self._apobj.notify(title=title, body=body)  # type: ignore[attr-defined]
            except Exception as exc:  # noqa: BLE001 - a notification service failing must not end the session
                ok = False
                _log.warning("apprise notification failed: %s", exc)
            if ok:
                self.sent += 1
            else:
                self.failed += 1
                _log.warning("apprise notification not delivered: %s", title)

    def close(self) -> None:
        try:
            self._queue.put(None, timeout=self._timeout_s)
        except queue.Full:
            pass
        self._thread.join(self._timeout_s)
        if self._thread.is_alive():
            _log.warning("apprise notifications still being sent after %.0f s; left behind", self._timeout_s)
