"""Bad input is a ValueError naming it; degenerate-but-legal input gives a valid empty result."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from modeling.model.build import build_model
from modeling.model.gaps import gap_passable_probability, gap_passable_probability_batch
from modeling.observation import AmbiguousSegment, FloorObservation, FloorSegment

C = np.eye(2) * 1e-4


def good_seg() -> FloorSegment:
    return FloorSegment(endpoints=np.array([[0.0, 0.0], [1.0, 0.0]]), cov=np.stack([C, C]))


def test_nan_coordinates() -> None:
    with pytest.raises(ValueError, match="endpoints"):
        FloorSegment(endpoints=np.array([[0.0, np.nan], [1.0, 0.0]]), cov=np.stack([C, C]))
    with pytest.raises(ValueError, match="mean_a"):
        gap_passable_probability([np.nan, 0], C, [1, 0], C, 0.5)
    with pytest.raises(ValueError, match="mean_b"):
        gap_passable_probability_batch([[0, 0]], [C], [[np.inf, 0]], [C], 0.5)


def test_nan_covariance_and_width() -> None:
    with pytest.raises(ValueError, match="cov_a"):
        gap_passable_probability([0, 0], [[np.nan, 0], [0, 1e-4]], [1, 0], C, 0.5)
    with pytest.raises(ValueError, match="cov"):
        FloorSegment(endpoints=np.array([[0.0, 0.0], [1.0, 0.0]]), cov=np.stack([C, C * np.nan]))
    with pytest.raises(ValueError, match="robot_width_m"):
        build_model(FloorObservation(), float("nan"))
    with pytest.raises(ValueError, match="width_m"):
        gap_passable_probability([0, 0], C, [1, 0], C, float("inf"))


def test_non_symmetric_covariance() -> None:
    bad = np.array([[1e-4, 5e-5], [0.0, 1e-4]])
    with pytest.raises(ValueError, match=r"cov.*symmetric"):
        FloorSegment(endpoints=np.array([[0.0, 0.0], [1.0, 0.0]]), cov=np.stack([bad, C]))
    with pytest.raises(ValueError, match="cov_a must be symmetric"):
        gap_passable_probability([0, 0], bad, [1, 0], C, 0.5)


def test_non_positive_definite_covariance() -> None:
    bad = np.array([[1e-4, 2e-4], [2e-4, 1e-4]])
    with pytest.raises(ValueError, match=r"cov.*positive definite"):
        FloorSegment(endpoints=np.array([[0.0, 0.0], [1.0, 0.0]]), cov=np.stack([C, bad]))
    with pytest.raises(ValueError, match="cov_b must be positive definite"):
        gap_passable_probability([0, 0], C, [1, 0], bad, 0.5)
    with pytest.raises(ValueError, match="cov_b"):
        gap_passable_probability([0, 0], C, [1, 0], -C, 0.5)


def test_probabilities_summing_above_one_or_a_certain_single_candidate() -> None:
    with pytest.raises(ValueError, match="probabilities must sum to at most 1"):
        AmbiguousSegment(candidates=(good_seg(), good_seg()), probabilities=(0.7, 0.4))
    with pytest.raises(ValueError, match="probabilities must lie in"):
        AmbiguousSegment(candidates=(good_seg(), good_seg()), probabilities=(-0.1, 0.4))
    with pytest.raises(ValueError, match="probabilities has 1 entries for 2 candidates"):
        AmbiguousSegment(candidates=(good_seg(), good_seg()), probabilities=(0.4,))
    with pytest.raises(ValueError, match="candidates must hold at least 2"):
        AmbiguousSegment(candidates=(good_seg(),), probabilities=(1.0,))
    with pytest.raises(ValueError, match="candidates must hold at least 1"):
        AmbiguousSegment(candidates=(), probabilities=())


def test_probabilities_below_one_leave_the_rest_as_no_obstacle() -> None:
    two = AmbiguousSegment(candidates=(good_seg(), good_seg()), probabilities=(0.5, 0.4))
    assert two.p_none == pytest.approx(0.1)
    one = AmbiguousSegment(candidates=(good_seg(),), probabilities=(0.4,))
    assert one.p_none == pytest.approx(0.6)
    full = AmbiguousSegment(candidates=(good_seg(), good_seg()), probabilities=(0.6, 0.4))
    assert full.p_none == 0.0


def test_negative_width() -> None:
    with pytest.raises(ValueError, match="width_m"):
        gap_passable_probability([0, 0], C, [1, 0], C, -0.1)
    with pytest.raises(ValueError, match="width_m"):
        gap_passable_probability_batch([[0, 0]], [C], [[1, 0]], [C], -0.1)
    with pytest.raises(ValueError, match="robot_width_m"):
        build_model(FloorObservation(), -0.5)


def test_bad_model_arguments() -> None:
    obs = FloorObservation(segments=(good_seg(),))
    with pytest.raises(ValueError, match="eps"):
        build_model(obs, 0.5, eps=0.6)
    with pytest.raises(ValueError, match="max_situations"):
        build_model(obs, 0.5, max_situations=0)
    with pytest.raises(ValueError, match="min_isolated_3d_length_m"):
        build_model(obs, 0.5, min_isolated_3d_length_m=-1.0)
    with pytest.raises(ValueError, match="observation"):
        build_model([good_seg()], 0.5)  # type: ignore[arg-type]


def test_empty_observation_gives_one_certain_empty_situation() -> None:
    m = build_model(FloorObservation(), 0.5)
    (s,) = m.situations
    assert s.probability == 1.0
    assert s.obstacles == () and s.critical_regions == ()
    assert m.residual_probability == 0.0
    assert m.occluded == ()
    assert len(m.relations) == 0
    g = s.path_graph([0, 0], [3, 0])
    assert g.has_edge("start", "goal")


def test_single_segment_is_one_obstacle() -> None:
    m = build_model(FloorObservation(segments=(good_seg(),)), 0.5)
    (s,) = m.situations
    assert len(s.obstacles) == 1
    assert s.obstacles[0].polygon.shape[1] == 2 and s.obstacles[0].polygon.shape[0] >= 3


# ------------------------------------------------------------------ scalar validators and options
@dataclasses.dataclass(frozen=True, kw_only=True)
class _Leaf:
    x: int = 1
    y: float = 2.0


@dataclasses.dataclass(frozen=True, kw_only=True)
class _Tree:
    leaf: _Leaf = dataclasses.field(default_factory=_Leaf)
    z: str = "q"


def test_scalar_validators_accept_and_name_bad_values() -> None:
    from modeling.validation import boolean, integer, number

    assert number(3, "a", low=0.0) == 3.0
    assert number(0.0, "a", low=0.0, strict=False) == 0.0
    assert integer(np.int64(4), "n", low=1) == 4
    assert boolean(False, "flag") is False
    for bad in (True, float("nan"), float("inf"), "1", None):
        with pytest.raises(ValueError, match=r"^a must be a finite number"):
            number(bad, "a")
    with pytest.raises(ValueError, match="a must be > 0"):
        number(0.0, "a", low=0.0)
    with pytest.raises(ValueError, match="a must be <= 1"):
        number(1.5, "a", high=1.0, strict=False)
    with pytest.raises(ValueError, match="n must be an integer >= 1"):
        integer(0, "n", low=1)
    with pytest.raises(ValueError, match="n must be an integer"):
        integer(True, "n")
    with pytest.raises(ValueError, match="flag must be True or False"):
        boolean(1, "flag")


def test_from_flat_maps_flat_and_nested_keys() -> None:
    from modeling.validation import from_flat

    assert from_flat(_Tree, {"x": 5, "z": "w"}) == _Tree(leaf=_Leaf(x=5), z="w")
    assert from_flat(_Tree, {"leaf": {"y": 3.0}, "x": 7}) == _Tree(leaf=_Leaf(x=7, y=3.0))
    assert from_flat(_Tree, {"leaf": _Leaf(x=9), "y": 1.5}) == _Tree(leaf=_Leaf(x=9, y=1.5))
    assert from_flat(_Tree, {}) == _Tree()
    with pytest.raises(ValueError, match=r"unknown _Tree option\(s\) \['bad'\]; known: \['leaf'"):
        from_flat(_Tree, {"bad": 1})
    with pytest.raises(ValueError, match=r"unknown _Tree\.leaf option"):
        from_flat(_Tree, {"leaf": {"w": 1}})
    with pytest.raises(ValueError, match="leaf must be a _Leaf or a dict, got int"):
        from_flat(_Tree, {"leaf": 3})


def test_reject_unknown_names_the_key_and_suggests_a_close_known_one() -> None:
    from modeling.validation import from_flat, reject_unknown

    known = ["robot_width_m", "robot_height_m", "tilt_rad"]
    reject_unknown(["tilt_rad", "robot_width_m"], known, "X")  # all known: nothing
    with pytest.raises(ValueError) as err:
        reject_unknown(["robot_widht_m"], known, "X")
    assert str(err.value) == (
        "unknown X option(s) ['robot_widht_m'] (did you mean 'robot_width_m'?); "
        "known: ['robot_height_m', 'robot_width_m', 'tilt_rad']"
    )
    with pytest.raises(ValueError) as err:  # no close match: no suggestion
        reject_unknown(["colour"], known)
    assert str(err.value) == (
        "unknown option(s) ['colour']; known: ['robot_height_m', 'robot_width_m', 'tilt_rad']"
    )
    with pytest.raises(ValueError, match=r"\['colour', 'tilt_rd'\] \(did you mean 'tilt_rad' for"):
        reject_unknown(["tilt_rd", "colour"], known, "X")
    with pytest.raises(
        ValueError, match=r"_Tree\.leaf option\(s\) \['xx'\] \(did you mean 'x'\?\)"
    ):
        from_flat(_Tree, {"leaf": {"xx": 1}})


def test_settings_of_reads_json_values_and_names_a_bad_word() -> None:
    from modeling.validation import settings_of

    words = ["replan_every=1", "policy=greedy", "eps=0.1", "flag=true", "text=a=b"]
    assert settings_of(words) == {
        "replan_every": 1,
        "policy": "greedy",
        "eps": 0.1,
        "flag": True,
        "text": "a=b",
    }
    assert settings_of([]) == {}
    for bad in ("replan_every", "=1"):
        with pytest.raises(ValueError, match=repr(bad)):
            settings_of([bad])


def test_with_overrides_replaces_named_fields_only() -> None:
    from modeling.validation import with_overrides

    assert with_overrides(None, _Leaf, {}) == _Leaf()
    assert with_overrides(_Leaf(x=2), _Leaf, {"y": 0.5}) == _Leaf(x=2, y=0.5)
    with pytest.raises(ValueError, match=r"unknown _Leaf option\(s\) \['q'\]"):
        with_overrides(None, _Leaf, {"q": 1})
    with pytest.raises(ValueError, match="options must be a _Leaf, got _Tree"):
        with_overrides(_Tree(), _Leaf, {})


def test_with_overrides_keeps_results_without_hiding_what_was_passed() -> None:
    """Equal arguments give the kept options again; a value of another type is a new key (its
    check still sees it); a bad value fails on every call; unhashable values are made afresh."""
    from modeling.model.build import ModelOptions
    from modeling.validation import with_overrides

    first = with_overrides(None, ModelOptions, {"eps": 0.1, "max_situations": 8})
    assert with_overrides(None, ModelOptions, {"max_situations": 8, "eps": 0.1}) is first
    assert first == ModelOptions(eps=0.1, max_situations=8)
    for _ in range(2):  # an int where an int is expected, then a float: the float is refused
        assert with_overrides(None, ModelOptions, {"max_situations": 8}).max_situations == 8
        with pytest.raises(ValueError, match="max_situations"):
            with_overrides(None, ModelOptions, {"max_situations": 8.0})
    unhashable = with_overrides(_Tree(), _Tree, {"leaf": _Leaf(x=3), "z": ["list"]})
    assert unhashable.z == ["list"] and unhashable.leaf.x == 3
