"""Progress bars for long streams (tqdm). A bar only appears once a run has
lasted a few seconds, so short calls stay quiet."""

from __future__ import annotations

from tqdm.auto import tqdm

#: Seconds before a bar shows up.
DELAY = 3.0


def bar(total: int | None, enabled: bool, desc: str = "falsifying", initial: int = 0):
    """A bar counting instances; ``initial`` is where a resumed run starts."""
    return tqdm(total=total, initial=initial, disable=not enabled, delay=DELAY, unit=" instances",
                unit_scale=True, desc=desc, dynamic_ncols=True, smoothing=0.1)
