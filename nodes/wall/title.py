"""The preview window's title: its frame and the frames it shows per second, said a few
times a second (a title changed every frame would cost the window system more than it
tells)."""

from __future__ import annotations

TITLE_EVERY = 0.5  # s between two titles


class FrameRate:
    def __init__(self, name: str, every: float = TITLE_EVERY) -> None:
        self.name = name
        self.every = every
        self._since: tuple[float, int] | None = None  # when the last title was made, frame

    def title(self, k: int, now: float, paused: bool) -> str | None:
        """The title after frame `k` was shown at monotonic time `now`, when one is due."""
        if self._since is None:
            self._since = (now, k)
            return f"{self.name} - frame {k}"
        then, frame = self._since
        if now - then < self.every:
            return None
        self._since = (now, k)
        rate = (k - frame) / (now - then)
        return f"{self.name} - frame {k} - {rate:.1f} frames/s" + (" - paused" if paused else "")
