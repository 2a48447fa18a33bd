import os

from hypothesis import HealthCheck, settings

# Property tests run many examples on CI-sized machines; no per-example deadline
# because the first call pays for thread-pool start-up.
settings.register_profile(
    "default", deadline=None, max_examples=int(os.environ.get("EDMF_RS_EXAMPLES", "150")),
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large],
)
settings.load_profile("default")
