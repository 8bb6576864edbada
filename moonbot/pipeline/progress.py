"""Progress lines for people watching a long command: one line per stage as it starts, with the
seconds since the command started, so a run of a minute or more is never silent."""

from __future__ import annotations

import time
from collections.abc import Callable


class StageClock:
    """Called with a stage's name as the stage starts (run_views's `on_stage`), it says
    "[  12.3 s] render view 4" through `say`: seconds since the clock was made, from the
    monotonic clock."""

    def __init__(self, say: Callable[[str], None]) -> None:
        self.say = say
        self.started = time.monotonic()

    def __call__(self, stage: str) -> None:
        self.say(f"[{time.monotonic() - self.started:6.1f} s] {stage}")
