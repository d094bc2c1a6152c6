"""The simulator's pacing against the wall clock, on a fake clock (no ROS)."""

from __future__ import annotations

import pytest

from servicesim_sim.process.pacing import MAX_LAG_WALL_S, MIN_LAG_SIM_S, Pacer


class FakeClock:
    def __init__(self) -> None:
        self.now = 100.0

    def __call__(self) -> float:
        return self.now


def test_on_schedule_it_waits_until_the_sim_time_is_due() -> None:
    clock = FakeClock()
    pacer = Pacer(clock=clock)
    assert pacer.wait_s(sim_time=0.0, speed=20.0) == 0.0
    clock.now += 0.001  # a step of 0.1 sim s took 1 ms; it is due at 5 ms
    assert pacer.wait_s(sim_time=0.1, speed=20.0) == pytest.approx(0.004)


def test_a_little_behind_it_catches_up_by_not_waiting() -> None:
    clock = FakeClock()
    pacer = Pacer(clock=clock)
    pacer.wait_s(sim_time=0.0, speed=20.0)
    clock.now += 0.009  # 0.1 sim s was due at 5 ms: 4 ms (0.08 sim s) behind, within the lag
    assert pacer.wait_s(sim_time=0.1, speed=20.0) == 0.0
    clock.now += 0.0005
    assert pacer.wait_s(sim_time=0.2, speed=20.0) == pytest.approx(0.0005)  # schedule kept
    assert pacer.slips == 0


def test_far_behind_it_slips_instead_of_racing_to_catch_up() -> None:
    clock = FakeClock()
    pacer = Pacer(clock=clock)
    pacer.wait_s(sim_time=0.0, speed=20.0)
    clock.now += 0.5  # a slow step: 0.1 sim s took 0.5 s wall, 9.9 sim s behind
    assert pacer.wait_s(sim_time=0.1, speed=20.0) == 0.0
    assert pacer.slips == 1
    clock.now += 0.001
    # the next 0.1 sim s is due 5 ms after the slip, not at once as the old schedule had it
    assert pacer.wait_s(sim_time=0.2, speed=20.0) == pytest.approx(0.004)


@pytest.mark.parametrize(("speed", "lag_sim_s"), [(50.0, 2.0), (20.0, 0.8), (1.0, 0.2)])
def test_the_lag_allowed_is_a_little_wall_time_and_at_least_two_periods(
        speed: float, lag_sim_s: float) -> None:
    clock = FakeClock()
    pacer = Pacer(clock=clock)
    assert pacer.max_lag_sim_s(speed) == pytest.approx(lag_sim_s)
    assert max(MAX_LAG_WALL_S * speed, MIN_LAG_SIM_S) == pytest.approx(lag_sim_s)
    pacer.wait_s(sim_time=0.0, speed=speed)
    clock.now += (0.1 + 0.99 * lag_sim_s) / speed  # just within the lag
    pacer.wait_s(sim_time=0.1, speed=speed)
    assert pacer.slips == 0
    clock.now += 0.02 * lag_sim_s / speed + 0.001
    pacer.wait_s(sim_time=0.1, speed=speed)
    assert pacer.slips == 1


def test_speed_0_never_waits_and_a_new_speed_starts_a_new_schedule() -> None:
    clock = FakeClock()
    pacer = Pacer(clock=clock)
    assert pacer.wait_s(sim_time=0.0, speed=0.0) == 0.0
    clock.now += 5.0
    assert pacer.wait_s(sim_time=50.0, speed=0.0) == 0.0
    assert pacer.wait_s(sim_time=50.0, speed=1.0) == 0.0  # anchored now
    assert pacer.wait_s(sim_time=50.1, speed=1.0) == pytest.approx(0.1)
    assert pacer.slips == 0
