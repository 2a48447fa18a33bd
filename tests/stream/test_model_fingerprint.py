"""The checkpoint fingerprint of falsify_model covers the model itself, not
only its qualified name (two lambdas ``scale * t`` with scale 1 and 2 share it)."""

from __future__ import annotations

import functools
import threading

import edmf_rs
import numpy as np
import pytest
from edmf_rs import Thresholds
from edmf_rs.stream.identity import model_fingerprint

N_M = 2
THETA = np.linspace(-1.0, 1.0, 201)[:, None]
Y = np.zeros(N_M)
T = Thresholds(np.full(N_M, -0.5), np.full(N_M, 0.5))


def make(scale):
    return lambda t: scale * np.repeat(t, N_M, axis=1)


def test_two_lambdas_with_other_closure_values_are_other_models(tmp_path):
    one, two = make(1.0), make(2.0)
    assert one.__qualname__ == two.__qualname__
    first = edmf_rs.falsify_model(one, THETA, Y, T, checkpoint=tmp_path / "run", progress=False)
    want = edmf_rs.falsify_model(two, THETA, Y, T, progress=False)
    assert len(first.candidate_indices) != len(want.candidate_indices)
    with pytest.raises(ValueError, match="holds a run with other model"):
        edmf_rs.falsify_model(two, THETA, Y, T, checkpoint=tmp_path / "run", progress=False)
    # The same model made again is recognised: the finished run is returned.
    again = edmf_rs.falsify_model(make(1.0), THETA, Y, T, checkpoint=tmp_path / "run", progress=False)
    np.testing.assert_array_equal(again.candidate_indices, first.candidate_indices)


def scaled(t, scale=1.0, *, shift=0.0):
    return scale * np.repeat(t, N_M, axis=1) + shift


class Scaled:
    def __init__(self, scale):
        self.scale = scale

    def __call__(self, t):
        return self.scale * np.repeat(t, N_M, axis=1)

    def predict(self, t):
        return self(t)


def test_what_decides_the_predictions_is_in_the_fingerprint():
    fp = model_fingerprint
    assert fp(functools.partial(scaled, scale=1.0)) != fp(functools.partial(scaled, scale=2.0))
    assert fp(functools.partial(scaled, 1.0)) != fp(functools.partial(scaled, 2.0))
    assert fp(functools.partial(scaled, 1.0)) == fp(functools.partial(scaled, 1.0))
    assert fp(Scaled(1.0)) != fp(Scaled(2.0)) and fp(Scaled(1.0)) == fp(Scaled(1.0))
    assert fp(Scaled(1.0).predict) != fp(Scaled(2.0).predict)
    arrays = [np.arange(3.0), np.arange(3.0) + 1e-12]
    assert fp(make(arrays[0])) != fp(make(arrays[1]))
    # Defaults, and module-level values the code reads.
    namespace: dict = {"np": np, "GAIN": 1.0}
    exec("def g(t, k=1.0):\n    return GAIN * k * t", namespace)
    before = fp(namespace["g"])
    namespace["GAIN"] = 3.0
    assert fp(namespace["g"]) != before
    namespace["g"].__defaults__ = (2.0,)
    assert fp(namespace["g"]) != before
    # Bytecode, not the name: the same name computing something else.
    exec("def g(t, k=1.0):\n    return GAIN * k * t * t", namespace)
    assert fp(namespace["g"])["name"] == before["name"] and fp(namespace["g"]) != before
    assert "unhashable" not in fp(np.sin) and fp(np.sin) != fp(np.cos)


def test_objects_may_say_what_identifies_them():
    class External:
        def __init__(self, command):
            self.command = command

        def __call__(self, t):
            return np.repeat(t, N_M, axis=1)

        def __edmf_fingerprint__(self):
            return {"command": self.command}

    assert model_fingerprint(External(["a"])) != model_fingerprint(External(["b"]))
    assert model_fingerprint(External(["a"])) == model_fingerprint(External(["a"]))


def test_a_model_that_cannot_be_hashed_is_not_silently_reused(tmp_path):
    lock = threading.Lock()  # neither attributes nor a pickle

    def model(t):
        with lock:
            return np.repeat(t, N_M, axis=1)

    fp = model_fingerprint(model)
    assert "unhashable" in fp and "lock" in fp["unhashable"]
    edmf_rs.falsify_model(model, THETA, Y, T, checkpoint=tmp_path / "run", progress=False)
    with pytest.raises(ValueError, match="model cannot be fingerprinted .*__edmf_fingerprint__"):
        edmf_rs.falsify_model(model, THETA, Y, T, checkpoint=tmp_path / "run", progress=False)
