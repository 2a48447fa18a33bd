"""These tests count on ``checkpoint_every=0`` saving after every chunk (they
interrupt or kill a run at a given save, or change the folder between two),
which a run does only while its chunks take longer than ~19 saves: here
chunks take microseconds. So the share of a run's time saves may take is
lifted to all of it (the child scripts of the SIGKILL tests do the same);
tests/stream/test_save_share.py checks the default."""

import pytest
from edmf_rs.stream import checkpoint


@pytest.fixture(autouse=True)
def _save_after_every_chunk(monkeypatch):
    monkeypatch.setattr(checkpoint, "MAX_SAVE_SHARE", 1.0)
