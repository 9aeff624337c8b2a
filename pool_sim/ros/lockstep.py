"""Lockstep: after each publish instant, the physics waits for the inputs that must answer it.

The protocol. The node publishes the state of instant t (every state topic, /clock when
asked for). Each input listed in `lockstep_inputs` answers t with a message stamped t (a
stamp later than the newest instant answers nothing; unstamped messages answer the instant
published last before they arrived, see inputs.py). Once every listed input has answered, the next publish period's steps run, with
every answer applied at their start; then t + period is published, and so on. Answering
twice causes no extra step: a period is stepped once per instant, not once per message.

A controller that subscribes after an instant was published gets it again: while an instant
waits for stamped inputs only, its state is sent again after 0.5 s, 1.5 s, 4.5 s, ... of
waiting (a stamped answer to a copy is the same answer; an unstamped one would answer the
next instant, so inputs that answer unstamped are never sent copies).

A dead controller never wedges the simulation: an input that has not answered within
`lockstep_timeout` wall seconds is counted as a miss, logged, and not waited for again until
it answers some instant (a controller that starts late joins when it first answers; one that
died costs one timeout, not one per instant).

Reproducibility follows: the physics core is deterministic, the steps between two instants
are fixed, and what is applied at the start of a period is exactly the answers to the
instant before, whatever the machine's speed or load.
"""
import time

from pool_sim.physics.spheres import named_few
from pool_sim.ros.services import THROTTLE_S
# Wall s an instant waits before its state is sent again (then after three times the wait
# so far each time): a controller that subscribed after the publish gets it. Never while an
# unstamped input is waited for: a copy it answers again would answer the next instant.
REPUBLISH_FIRST_S = 0.5


class Lockstep:
    """What the node waits for: `awaited_ns`, the instant published last and not yet
    answered (None while nothing is awaited, and always with lockstep off)."""

    def __init__(self, logger):
        self.logger = logger
        self.enabled, self.inputs, self.timeout_s = False, (), 5.0
        self.awaited_ns = None
        self.awaited_since = 0.0  # wall s (monotonic) the instant was published
        self.next_republish = 0.0
        self.absent = {}  # input -> the instant it had answered when it missed one
        self.misses = 0  # instants that went on without an input's answer
        self.waiting = []  # the inputs the awaited instant waited for when last looked at

    def configure(self, enabled: bool, inputs, timeout_s: float):
        self.enabled, self.inputs, self.timeout_s = enabled, tuple(inputs), timeout_s
        self.absent = {name: at for name, at in self.absent.items() if name in self.inputs}
        if not enabled:
            self.awaited_ns = None

    def forget(self):
        """After a reset: every input is waited for again, time 0 (published next) anew."""
        self.absent = {}
        self.awaited_ns = None

    def restart_wait(self):
        """After a pause: the awaited instant's timeout counts from now."""
        if self.awaited_ns is not None:
            self.awaited_since = time.monotonic()
            self.next_republish = self.awaited_since + REPUBLISH_FIRST_S

    def published(self, instant_ns: int):
        """The state of instant_ns is out (again, when it is the one awaited)."""
        if self.enabled and instant_ns != self.awaited_ns:
            self.awaited_ns = instant_ns
            self.awaited_since = time.monotonic()
            self.next_republish = self.awaited_since + REPUBLISH_FIRST_S

    def republish_due(self) -> bool:
        """True now and then while an instant waits: then its state goes out again, for a
        controller that started (or subscribed) after it was published."""
        now = time.monotonic()
        if self.awaited_ns is None or now < self.next_republish:
            return False
        self.next_republish = now + 2.0 * (now - self.awaited_since)  # 0.5, 1.5, 4.5 s, ...
        return True

    def ready(self, inputs) -> bool:
        """True when the awaited instant is answered (or nothing is awaited, or it timed
        out: then the misses are counted and logged). inputs: the ForceInputs."""
        if self.awaited_ns is None:
            return True
        for name, at in list(self.absent.items()):
            if inputs.answered(name) > at:
                del self.absent[name]  # it answers again: waited for from now on
        waiting = [name for name in inputs.unanswered(self.inputs, self.awaited_ns)
                   if name not in self.absent]
        self.waiting = waiting
        if waiting and time.monotonic() - self.awaited_since < self.timeout_s:
            return False
        if waiting:
            self.misses += 1
            for name in waiting:
                self.absent[name] = inputs.answered(name)
            self.logger.warning(
                f'lockstep: no answer from {named_few(waiting)} to t='
                f'{self.awaited_ns * 1e-9:.6f} s within {self.timeout_s:g} s (wall): going on '
                'without waiting for it until it answers again', throttle_duration_sec=THROTTLE_S)
        self.awaited_ns = None
        return True

    def wall_left(self) -> float:
        """Wall seconds until the awaited instant times out (0 when nothing is awaited)."""
        if self.awaited_ns is None:
            return 0.0
        return max(self.awaited_since + self.timeout_s - time.monotonic(), 0.0)

    def report(self) -> str:
        if not self.enabled and not self.misses:
            return ''
        return (f', lockstep {"on" if self.enabled else "off"} ({self.misses} instants went '
                'on without an answer, after lockstep_timeout)')
