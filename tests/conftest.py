import os

import pytest
from hypothesis import HealthCheck, settings

# Property tests run many examples on CI-sized machines; no per-example deadline
# because the first call pays for thread-pool start-up.
settings.register_profile(
    "default", deadline=None, max_examples=int(os.environ.get("EDMF_RS_EXAMPLES", "150")),
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large],
)
settings.load_profile("default")


@pytest.fixture(autouse=True)
def _stream_saves_after_every_chunk(request, monkeypatch):
    """The tests in tests/stream count on ``checkpoint_every=0`` saving after
    every chunk (they interrupt or kill a run at a given save, or change the
    folder between two), which a run does only while its chunks take longer
    than ~19 saves: there chunks take microseconds. So for them the share of a
    run's time saves may take is lifted to all of it (the child scripts of the
    SIGKILL tests do the same); tests/stream/test_save_share.py checks the
    default. Here, not in a tests/stream/conftest.py: two conftest modules
    would shadow each other for the tests that import from ``conftest``."""
    if request.node.path.parent.name == "stream" and request.node.path.parent.parent.name == "tests":
        from edmf_rs.stream import checkpoint

        monkeypatch.setattr(checkpoint, "MAX_SAVE_SHARE", 1.0)


@pytest.fixture
def full_disk(monkeypatch):
    """``full_disk(writer, failing=1)``: call number ``failing`` of the checkpoint's
    ``writer`` (``save_npy`` or ``save_state``, module-level in
    ``edmf_rs.stream.checkpoint`` for this) fails as on a full disk (ENOSPC); the
    other calls write."""
    import errno

    from edmf_rs.stream import checkpoint

    def arm(writer: str, failing: int = 1) -> None:
        original, calls = getattr(checkpoint, writer), [0]

        def full(*args):
            calls[0] += 1
            if calls[0] == failing:
                raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
            return original(*args)

        monkeypatch.setattr(checkpoint, writer, full)

    return arm
