"""SafetyResponder: what the server does to the mounts when the safety monitor turns unsafe (``on_unsafe``).

Rules (docs/guide/observatory.md), per unsafe *episode* (from the verdict turning unsafe to it turning
anything else) and per telescope:

- ``park``: stop everything (a running GOTO, MoveAxis, pulses, timed moves; rate offsets zeroed), then
  park; the park ends with tracking off (and tracking is turned off if it is not). ``stop``: the same
  stop, then tracking off. ``nothing``: motion is refused, nothing is stopped.
- A park already running (a client's, or this responder's) is left to finish: it is the safe outcome;
  it is not aborted and restarted. A mount already parked only gets tracking off (if it was on).
- A mount no client holds connected is connected by the responder itself (as the client
  ``safety-interlock#0``) and let go once it is safe; the link then lingers and closes as usual.
- A mount that cannot be reached (link down, USB unplugged) is tried again every ``max(poll_s, 2 s)``
  for as long as the episode lasts: the reaction is carried out when it answers again, if the monitor
  still says unsafe then. An episode that ends first (safe again) owes nothing: motion is allowed then.
- It never unparks or restarts tracking by itself: after an episode the mount stays as it was left.
- A server that starts while the monitor says unsafe (or gets no answer for ``unreachable_s``) counts
  that as turning unsafe: the mount is parked (a mount already at its park position just confirms it).

Runs on its own thread (``safety-response``), woken by the watch; a park's start may wait for the axes
to brake, which must never hold up the polling.
"""

from __future__ import annotations

import logging
import threading
import time
from collections.abc import Callable, Sequence

from .._exceptions import AlpacaError
from ..clients import ClientKey
from ..config.settings import Settings
from ..motion import MotionKind
from ..motion.interlock import Interlock, SafetyState, Verdict
from ..telescope.device import Telescope

__all__ = ["INTERLOCK_CLIENT", "SafetyResponder"]

log = logging.getLogger(__name__)

#: The client the responder connects a mount as, when no one holds it.
INTERLOCK_CLIENT = ClientKey("safety-interlock", 0)
RETRY_MIN_S = 2.0
TICK_S = 1.0


class SafetyResponder:
    """Carries out ``on_unsafe`` on every telescope (see the module docstring); ``record(kind, text)``
    reports each step for the page."""

    def __init__(self, telescopes: Sequence[Telescope], interlock: Interlock, settings: Callable[[], Settings],
                 record: Callable[[str, str], None]) -> None:
        self.telescopes = telescopes
        self.interlock = interlock
        self._settings = settings
        self._record = record
        self._episode = 0
        self._handled: dict[int, int] = {}  # telescope index -> the episode it was made safe in
        self._next_send: dict[int, float] = {}  # telescope index -> no new stop/park sent before (monotonic)
        self._attached: set[int] = set()
        self._failed: dict[int, str] = {}  # why the last try failed (logged once per reason)
        self._wake = threading.Event()
        self._stopped = threading.Event()
        self._thread = threading.Thread(target=self._run, name="safety-response", daemon=True)

    def start(self) -> None:
        self._thread.start()

    def stop(self) -> None:
        self._stopped.set()
        self._wake.set()
        if self._thread.is_alive():
            self._thread.join(timeout=10)

    def verdict_changed(self, previous: Verdict, verdict: Verdict) -> None:
        """Called by the watch after it wrote ``verdict`` into the gate."""
        if verdict.state is SafetyState.UNSAFE and previous.state is not SafetyState.UNSAFE:
            self._episode += 1
        self._wake.set()

    def _run(self) -> None:
        while not self._stopped.is_set():
            try:
                self.tick()
            except Exception:  # must outlive any bug: the next tick tries again
                log.exception("safety response failed")
            self._wake.wait(TICK_S)  # a tick with nothing owed costs no I/O; on_unsafe may change any time
            self._wake.clear()

    def tick(self) -> None:
        """One pass over the telescopes: act where the episode is owed, let go where it is done."""
        verdict = self.interlock.verdict
        action = self._settings().safety.on_unsafe
        owed = verdict.state is SafetyState.UNSAFE and action != "nothing"
        for index, telescope in enumerate(self.telescopes):
            if owed and self._handled.get(index) != self._episode:
                self._try(index, telescope, action, verdict)
            done = not owed or self._handled.get(index) == self._episode
            if done and index in self._attached:
                self._attached.discard(index)
                telescope.connection.release(INTERLOCK_CLIENT)

    def _try(self, index: int, telescope: Telescope, action: str, verdict: Verdict) -> None:
        try:
            safe = self._make_safe(index, telescope, action, verdict)
        except AlpacaError as exc:
            if self._failed.get(index) != exc.message:
                self._failed[index] = exc.message
                text = f"telescope {index}: cannot {action} yet ({exc.message}); trying again while unsafe"
                log.error("safety monitor: %s", text)
                self._record("error", text)
            return
        if safe:
            self._handled[index] = self._episode
            self._failed.pop(index, None)
            text = (f"telescope {index}: parked, tracking off" if action == "park"
                    else f"telescope {index}: stopped, tracking off")
            log.warning("safety monitor: %s", text)
            self._record("action", text)

    def _make_safe(self, index: int, telescope: Telescope, action: str, verdict: Verdict) -> bool:
        """One step towards the safe state; True once there. Raises AlpacaError when the mount is away."""
        if not telescope.mount.running or not telescope.connection.clients():
            now = time.monotonic()
            if now < self._next_send.get(index, 0.0):
                return False
            self._next_send[index] = now + max(self._settings().safety.poll_s, RETRY_MIN_S)
            telescope.connection.attach(INTERLOCK_CLIENT)  # raises DriverError if the mount cannot be reached
            self._attached.add(index)
            self._next_send.pop(index, None)
        supervisor = telescope.motion
        running = supervisor.motion
        if running is not None and running.kind is MotionKind.PARK:
            return False  # a park under way is the safe outcome: let it finish
        if supervisor.parked:
            self._tracking_off(telescope)
            return True
        now = time.monotonic()
        if now < self._next_send.get(index, 0.0):
            return False  # a park this responder started ended short (stopped, refused): again, but paced
        self._next_send[index] = now + max(self._settings().safety.poll_s, RETRY_MIN_S)
        why = f"the safety monitor reports unsafe ({verdict.reason})"
        self._record("action", f"telescope {index}: {why}: stopping{' and parking' if action == 'park' else ''}")
        supervisor.abort(why)  # every motion, pulse and timed move
        telescope.capabilities.zero_offsets()
        if action == "stop":
            self._tracking_off(telescope)
            return True
        telescope.park()  # runs on; the next ticks see it running, then parked
        return False

    @staticmethod
    def _tracking_off(telescope: Telescope) -> None:
        tracking = telescope.mount.state.tracking
        if tracking is None or tracking.on:
            telescope.set_tracking(False)
