"""Safety limits: nothing outside the limits (or not finite) passes, everything inside does."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from pydantic import ValidationError

from hardware.safety import SafetyLimits
from twin.core.errors import SafetyError
from twin.core.poses import Pose

LIMITS = SafetyLimits(
    x_mm=(-80.0, 80.0),
    y_mm=(-50.0, 70.0),
    z_mm=(-60.0, 8.0),
    max_depth_mm=5.0,
    alpha_deg=(-20.0, 15.0),
    beta_deg=(-10.0, 25.0),
    max_linear_speed_mm_s=50.0,
    max_angular_speed_deg_s=30.0,
)
FIELDS = ("x", "y", "z", "alpha", "beta", "gamma")
#: the largest finite float32: the robot's wire carries nothing larger
F32_MAX = (2 - 2**-23) * 2.0**127


def oracle(limits: SafetyLimits, pose: Pose) -> bool:
    """Independent statement of the rule the checker must implement."""
    v = pose.as_array()
    if not all(math.isfinite(a) and abs(a) <= F32_MAX for a in v):
        return False
    boxes = [
        limits.x_mm,
        limits.y_mm,
        (limits.z_mm[0], min(limits.z_mm[1], limits.max_depth_mm)),
        limits.alpha_deg,
        limits.beta_deg,
    ]
    return all(lo <= a <= hi for a, (lo, hi) in zip(v[:5], boxes))


def bounds_of(limits: SafetyLimits) -> list[float]:
    return [
        *limits.x_mm,
        *limits.y_mm,
        *limits.z_mm,
        limits.max_depth_mm,
        *limits.alpha_deg,
        *limits.beta_deg,
    ]


def near(values: list[float]) -> st.SearchStrategy[float]:
    """Values on, and just either side of, the given bounds."""
    base = st.sampled_from(values)
    offsets = st.sampled_from([0.0, -0.0, 1e-9, -1e-9, 1e-12, -1e-12, 1e-6, -1e-6, 0.5, -0.5])
    nudged = st.builds(lambda b, d: b + d, base, offsets)
    ulp = st.builds(lambda b, up: math.nextafter(b, math.inf if up else -math.inf), base, st.booleans())
    return st.one_of(base, nudged, ulp)


adversarial = st.one_of(
    st.floats(allow_nan=True, allow_infinity=True),
    st.sampled_from([math.nan, math.inf, -math.inf, 0.0, -0.0, 1e308, -1e308, 5e-324, -5e-324, 1e20]),
    near(bounds_of(LIMITS)),
    st.floats(-200, 200),
)


@settings(max_examples=1500, deadline=None)
@given(st.tuples(*[adversarial] * 6))
def test_only_poses_inside_the_limits_pass(values):
    pose = Pose(*values)
    expected = oracle(LIMITS, pose)
    if expected:
        LIMITS.check_pose(pose)
    else:
        with pytest.raises(SafetyError):
            LIMITS.check_pose(pose)


@settings(max_examples=300, deadline=None)
@given(
    st.floats(-80, 80),
    st.floats(-50, 70),
    st.floats(-60, 5),
    st.floats(-20, 15),
    st.floats(-10, 25),
    st.floats(allow_nan=False, allow_infinity=False, min_value=-1e6, max_value=1e6),
)
def test_every_pose_inside_passes(x, y, z, a, b, g):
    LIMITS.check_pose(Pose(x, y, z, a, b, g))


@st.composite
def random_limits(draw):
    def rng(lo, hi):
        a, b = sorted([draw(st.floats(lo, hi)), draw(st.floats(lo, hi))])
        return (a, b)

    z = rng(-100, 20)
    depth = draw(st.floats(max(0.0, z[0]), 20.0))
    return SafetyLimits(
        x_mm=rng(-300, 300),
        y_mm=rng(-300, 300),
        z_mm=z,
        max_depth_mm=depth,
        alpha_deg=rng(-90, 90),
        beta_deg=rng(-90, 90),
    )


@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.data())
def test_random_limits_with_poses_at_their_faces(data):
    limits = data.draw(random_limits())
    values = near(bounds_of(limits))
    pose = Pose(*[data.draw(st.one_of(values, adversarial)) for _ in FIELDS])
    assert limits.allows(pose) == oracle(limits, pose)


@pytest.mark.parametrize("field", FIELDS)
@pytest.mark.parametrize("bad", [math.nan, math.inf, -math.inf])
def test_non_finite_values_are_named(field, bad):
    pose = Pose(**{field: bad})
    with pytest.raises(SafetyError, match=rf"{field} = {bad!r} (mm|deg) is not a finite number"):
        LIMITS.check_pose(pose)


@pytest.mark.parametrize(
    "field, bound, outside",
    [
        ("x", -80.0, -1),
        ("x", 80.0, 1),
        ("y", -50.0, -1),
        ("y", 70.0, 1),
        ("z", -60.0, -1),
        ("alpha", -20.0, -1),
        ("alpha", 15.0, 1),
        ("beta", -10.0, -1),
        ("beta", 25.0, 1),
    ],
)
def test_each_face_inclusive_and_one_nanometre_beyond_refused(field, bound, outside):
    LIMITS.check_pose(Pose(**{field: bound}))
    for delta in (1e-9, math.nextafter(abs(bound), math.inf) - abs(bound)):
        value = bound + outside * delta
        with pytest.raises(SafetyError) as err:
            LIMITS.check_pose(Pose(**{field: value}))
        text = str(err.value)
        assert f"{field} = {value!r}" in text and f"{bound}" in text and "safety." in text


@pytest.mark.parametrize(
    "value, match",
    [
        (None, r"x = None is not a number \(NoneType\)"),
        (True, r"x = True is not a number \(bool\)"),
        (np.bool_(False), r"x = (np\.)?False_? is not a number \(bool_?\)"),
        ("5", r"x = '5' is not a number \(str\)"),
        (10**400, r"x = ~1e\+400 mm is beyond the robot's float32 range"),
        (-3.5e38, r"x = -3\.5e\+38 mm is beyond the robot's float32 range"),
    ],
)
def test_pose_fields_the_wire_cannot_carry_are_named_in_one_line(value, match):
    with pytest.raises(SafetyError, match=r"^pose \(.*\): " + match) as err:
        LIMITS.check_pose(Pose(x=value))
    assert "\n" not in str(err.value) and len(str(err.value)) < 200


def test_a_coordinate_below_float32_normals_passes_as_the_zero_it_is():
    LIMITS.check_pose(Pose(x=1e-40, gamma=-5e-324))  # arrives as a denormal or 0: off by < 1.2e-38 mm/deg


@pytest.mark.parametrize(
    "value, match",
    [
        (1e-300, r"linear speed = 1e-300 mm/s is too small to send: the robot's float32 carries it as 0 "),
        (1e-40, r"linear speed = 1e-40 mm/s is too small to send: the robot's float32 carries it as 9\.99995e-41 "),
        ("5", r"linear speed = '5' is not a number \(str\)"),
        (10**400, r"linear speed = ~1e\+400 mm/s is beyond the robot's float32 range"),
        (True, r"linear speed = True is not a number \(bool\)"),
    ],
)
def test_speeds_the_wire_cannot_carry_are_named(value, match):
    with pytest.raises(SafetyError, match="^" + match):
        LIMITS.check_speed(value)


def test_depth_limit_is_max_z_into_the_object():
    LIMITS.check_pose(Pose(z=5.0))
    with pytest.raises(SafetyError, match=r"deeper than the max indentation depth 5.0 mm"):
        LIMITS.check_pose(Pose(z=5.0 + 1e-9))
    LIMITS.check_pose(Pose(z=-0.0))


def test_speeds():
    LIMITS.check_speed(50.0, 30.0)
    LIMITS.check_speed(1e-9)
    for bad, match in [
        (math.nan, "not a finite"),
        (math.inf, "not a finite"),
        (0.0, "must be > 0"),
        (-0.0, "must be > 0"),
        (-5.0, "must be > 0"),
        (50.000001, r"exceeds the limit 50.0 mm/s \(safety.max_linear_speed_mm_s\)"),
    ]:
        with pytest.raises(SafetyError, match=match):
            LIMITS.check_speed(bad)
    with pytest.raises(SafetyError, match="max_angular_speed_deg_s"):
        LIMITS.check_speed(10.0, 30.5)


@pytest.mark.parametrize(
    "fields",
    [
        {"x_mm": (10, -10)},
        {"alpha_deg": (-100, 10)},
        {"max_depth_mm": math.nan},
        {"z_mm": (-10, math.inf)},
        {"z_mm": (8, 10), "max_depth_mm": 5},
        {"max_linear_speed_mm_s": 0},
        {"unknown": 1},
    ],
)
def test_bad_limits_are_refused(fields):
    with pytest.raises(ValidationError):
        SafetyLimits(**fields)
