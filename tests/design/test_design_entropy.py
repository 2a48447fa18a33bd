"""Joint entropy and greedy placement (Rust) against the NumPy reference of
the definitions, on random and structured predictions with ties."""

import math

import numpy as np
import pytest
from edmf_rs import design
from edmf_rs.design import reference as ref
from hypothesis import given
from hypothesis import strategies as st


@st.composite
def problems(draw, max_n=40, max_l=7):
    """Predictions with many ties (few distinct values, repeated columns and
    rows), float32 or float64, with positive widths."""
    n = draw(st.integers(1, max_n))
    n_loc = draw(st.integers(1, max_l))
    seed = draw(st.integers(0, 2**32 - 1))
    rng = np.random.default_rng(seed)
    kind = draw(st.sampled_from(["levels", "normal", "duplicates", "constant"]))
    if kind == "levels":
        g = rng.integers(0, draw(st.integers(1, 5)), size=(n, n_loc)).astype(np.float64)
    elif kind == "normal":
        g = rng.normal(size=(n, n_loc)) * rng.uniform(0.1, 10, size=n_loc)
    elif kind == "duplicates":
        base = rng.integers(0, 3, size=(n, max(1, n_loc // 2))).astype(np.float64)
        g = base[:, rng.integers(0, base.shape[1], size=n_loc)]
        g = g[rng.integers(0, n, size=n)]  # repeated rows
    else:
        g = np.full((n, n_loc), 3.25)
        g[:, -1] = rng.integers(0, 2, size=n)
    dtype = draw(st.sampled_from([np.float64, np.float32]))
    g = g.astype(dtype)
    if draw(st.booleans()):
        g = np.asfortranarray(g)
    widths = rng.choice([0.3, 0.5, 1.0, 2.5], size=n_loc)
    return g, widths, rng


@given(problems(), st.data())
def test_joint_entropy_matches_reference(problem, data):
    g, w, rng = problem
    sensors = data.draw(st.lists(st.integers(0, g.shape[1] - 1), max_size=g.shape[1]))
    h = design.joint_entropy(g, w, sensors)
    assert h == pytest.approx(ref.joint_entropy(g, w, sensors), abs=1e-9)
    assert -1e-12 <= h <= math.log2(g.shape[0]) + 1e-12


@given(problems())
def test_greedy_placement_matches_reference(problem):
    g, w, rng = problem
    k = int(rng.integers(1, g.shape[1] + 1))
    d = design.place_sensors(g, w, k)
    order, h = ref.place_sensors(g, w, k)
    assert d.order.tolist() == order
    np.testing.assert_allclose(d.joint_entropy, h, atol=1e-9)
    assert np.all(np.diff(d.joint_entropy) >= -1e-12)  # monotone


@given(problems())
def test_fixed_sensors_costs_budget_and_tolerance_match_reference(problem):
    g, w, rng = problem
    n_loc = g.shape[1]
    fixed = rng.permutation(n_loc)[: rng.integers(0, min(2, n_loc) + 1)].tolist()
    k = int(rng.integers(max(1, len(fixed)), n_loc + 1))
    costs = rng.choice([1.0, 2.0, 3.5], size=n_loc)
    budget = float(costs[np.asarray(fixed, dtype=int)].sum() + rng.choice([0.0, 1.0, 4.0])) if rng.random() < 0.5 else None
    if budget is not None:
        budget = max(budget, float(costs.min()))
    tolerance = float(rng.choice([0.0, 0.1, 0.5])) if rng.random() < 0.5 else None
    use_costs = rng.random() < 0.7 or budget is not None
    d = design.place_sensors(g, w, k, fixed=fixed, costs=costs if use_costs else None, budget=budget,
                             tolerance=tolerance)
    order, h = ref.place_sensors(g, w, k, fixed=fixed, costs=costs if use_costs else None, budget=budget,
                                 tolerance=tolerance)
    assert d.order.tolist() == order
    assert d.order[: len(fixed)].tolist() == fixed
    np.testing.assert_allclose(d.joint_entropy, h, atol=1e-9)
    if budget is not None:
        assert len(d) == 0 or d.cost[-1] <= budget + 1e-12


def test_a_zero_tolerance_keeps_adding_locations_that_gain_nothing():
    """Columns 0-4 split the instances alike: after location 1, each adds 0 bits,
    which the Rust sums gave as a gain of about -4e-16, so tolerance = 0 stopped
    the design after three sensors (found by the property test above)."""
    rows = ["0000011", "0000022", "0000022", "2222202", "0000021", "1111102", "0000022", "0000002",
            "1111110", "2222200", "0000022", "0000021", "2222202", "0000022", "0000001", "0000011",
            "0000021", "2222200", "0000021", "2222200", "2222221", "1111102"]
    g = np.array([[float(c) for c in r] for r in rows])
    w = np.array([0.3, 0.5, 0.3, 0.3, 1.0, 0.3, 2.5])
    for dtype in (np.float64, np.float32):
        d = design.place_sensors(g.astype(dtype), w, 7, fixed=[1, 3], tolerance=0.0)
        # Locations 0, 2 and 4 repeat 1's split and 6 adds nothing after 5: ties to the lowest index.
        assert d.order.tolist() == [1, 3, 5, 0, 2, 4, 6]
        assert len(set(np.round(d.joint_entropy[2:], 12))) == 1
    # A tolerance above 0 stops where the gains fall to 0.
    assert design.place_sensors(g, w, 7, fixed=[1, 3], tolerance=0.01).order.tolist() == [1, 3, 5]


def test_ties_go_to_the_lowest_index():
    # Columns 1 and 3 are the same split, column 2 is its mirror: all tie.
    g = np.array([[0, 0, 1, 0], [0, 1, 0, 1], [0, 0, 1, 0], [0, 1, 0, 1]], dtype=float)
    d = design.place_sensors(g, np.ones(4) * 0.5, k=4)
    assert d.order.tolist() == [1, 0, 2, 3]
    assert d.joint_entropy.tolist() == [1.0, 1.0, 1.0, 1.0]


def test_known_entropies():
    g = np.array([[0.0, 0.0], [0.4, 1.0], [1.0, 2.0], [1.2, 3.0]])
    # Location 0 with width 0.5: bins 0, 0, 2, 2 -> one bit; location 1: all distinct -> 2 bits.
    assert design.joint_entropy(g, [0.5, 1.0], [0]) == pytest.approx(1.0)
    assert design.joint_entropy(g, [0.5, 1.0], [1]) == pytest.approx(2.0)
    assert design.joint_entropy(g, [0.5, 1.0], []) == 0.0


def test_nan_is_refused_or_its_own_bin():
    g = np.array([[0.0], [np.nan], [0.0], [np.nan]])
    with pytest.raises(ValueError, match="predictions"):
        design.joint_entropy(g, [1.0])
    assert design.joint_entropy(g, [1.0], nan_policy="bin") == pytest.approx(1.0)
    assert design.joint_entropy(g, [1.0], nan_policy="bin") == pytest.approx(ref.joint_entropy(g, [1.0], nan_bin=True))


def test_memory_map_is_read_in_place(tmp_path):
    g = np.random.default_rng(0).normal(size=(200, 6)).astype(np.float32)
    np.save(tmp_path / "g.npy", g)
    mm = np.load(tmp_path / "g.npy", mmap_mode="r")
    d = design.place_sensors(mm, np.full(6, 0.5), k=3)
    assert d.order.tolist() == ref.place_sensors(g, np.full(6, 0.5), 3)[0]


@pytest.mark.parametrize(
    ("kwargs", "name"),
    [
        ({"widths": [0.0, 1.0, 1.0]}, "widths"),
        ({"widths": [np.nan, 1.0, 1.0]}, "widths"),
        ({"widths": [1.0, 1.0]}, "widths"),
        ({"k": 4}, "k"),
        ({"k": 1, "fixed": [0, 1]}, "k"),
        ({"fixed": [3]}, "fixed"),
        ({"fixed": [1, 1]}, "fixed"),
        ({"costs": [1.0, 0.0, 1.0]}, "costs"),
        ({"costs": [1.0, 2.0, 3.0], "budget": 0.5}, "budget"),
        ({"budget": 3.0}, "budget"),
        ({"tolerance": -1.0}, "tolerance"),
        ({"nan_policy": "skip"}, "nan_policy"),
    ],
)
def test_bad_input_names_the_argument(kwargs, name):
    args = {"widths": [1.0, 1.0, 1.0], "k": 2}
    args.update(kwargs)
    g = np.arange(12.0).reshape(4, 3)
    with pytest.raises(ValueError, match=f"^{name}:"):
        design.place_sensors(g, args.pop("widths"), args.pop("k"), **args)


@given(problems(), st.data())
def test_quotas_per_type_match_reference(problem, data):
    g, w, rng = problem
    n_loc = g.shape[1]
    types = [["deflection", "strain", "rotation"][t] for t in rng.integers(0, 3, size=n_loc)]
    present = sorted(set(types))
    quota = {t: int(rng.integers(0, 3)) for t in present if rng.random() < 0.7}
    k = int(rng.integers(1, n_loc + 1))
    lazy = data.draw(st.booleans())
    d = design.place_sensors(g, w, k, types=types, max_per_type=quota, lazy=lazy)
    order, h = ref.place_sensors(g, w, k, types=types, max_per_type=quota)
    assert d.order.tolist() == order
    np.testing.assert_allclose(d.joint_entropy, h, atol=1e-9)
    for t, q in quota.items():
        assert sum(types[i] == t for i in d.order) <= q


@given(problems())
def test_lazy_and_plain_greedy_choose_the_same(problem):
    g, w, rng = problem
    k = int(rng.integers(1, g.shape[1] + 1))
    lazy = design.place_sensors(g, w, k)
    plain = design.place_sensors(g, w, k, lazy=False)
    assert lazy.order.tolist() == plain.order.tolist()
    assert lazy.joint_entropy.tolist() == plain.joint_entropy.tolist()
    assert lazy.evaluations <= plain.evaluations


@pytest.mark.parametrize("seed", range(4))
def test_many_ties_repeated_and_mirrored_columns(seed):
    # Every location is one of three splits, repeated and mirrored: at each
    # step many locations tie exactly, and the lowest index must win.
    rng = np.random.default_rng(seed)
    base = rng.integers(0, 2, size=(64, 3)).astype(float)
    pick = rng.integers(0, 3, size=30)
    g = np.where(rng.random(30) < 0.5, base[:, pick], 1.0 - base[:, pick])
    w = np.full(30, 0.5)
    for lazy in (True, False):
        d = design.place_sensors(g, w, 10, lazy=lazy)
        order, h = ref.place_sensors(g, w, 10)
        assert d.order.tolist() == order
        np.testing.assert_allclose(d.joint_entropy, h, atol=1e-12)


@pytest.mark.parametrize(("n", "levels"), [(3000, 300), (3000, 2000), (20_000, 70_000)])
def test_more_bins_than_a_byte_or_two_hold(n, levels):
    # 300 and 2000 bins: labels stored as u16; 70,000 bins (<= 4N): u32.
    rng = np.random.default_rng(levels)
    g = rng.integers(0, levels, size=(n, 5)).astype(np.float64)
    g[:, 1] = g[:, 0] // 7  # a coarser copy of location 0
    g[:, 3] = g[:, 2]  # a repeat: ties
    w = np.ones(5)
    d = design.place_sensors(g, w, 4)
    order, h = ref.place_sensors(g, w, 4)
    assert d.order.tolist() == order
    np.testing.assert_allclose(d.joint_entropy, h, atol=1e-9)
    assert design.place_sensors(g, w, 4, lazy=False).order.tolist() == order


@pytest.mark.parametrize(
    ("kwargs", "err"),
    [
        ({"max_per_type": {"a": 1}}, ValueError),  # no types
        ({"types": ["a", "b", "b"], "max_per_type": {"c": 1}}, ValueError),
        ({"types": ["a", "b", "b"], "max_per_type": {"a": -1}}, ValueError),
        ({"types": ["a", "b", "b"], "max_per_type": {"a": 0}, "fixed": [0]}, ValueError),
        ({"types": ["a", "b", "b"], "max_per_type": [1]}, TypeError),
    ],
)
def test_bad_quotas_name_max_per_type(kwargs, err):
    g = np.arange(12.0).reshape(4, 3)
    with pytest.raises(err, match="^max_per_type:"):
        design.place_sensors(g, [1.0, 1.0, 1.0], 2, **kwargs)
